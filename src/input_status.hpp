// What the input side of the nodelet reports to the statistics: message
// counts per input topic and how long ago the last synchronised pair formed.
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace bdis_stereo {

/// Cumulative counts of the inputs (since the nodelet started).
struct InputCounts {
  uint64_t left_images = 0;
  uint64_t left_images_lost = 0;  ///< gaps in the left image's header.seq: lost before the nodelet
  uint64_t right_images = 0;
  uint64_t left_infos = 0;
  uint64_t right_infos = 0;
  uint64_t time_jumps = 0;  ///< input stamps went back: synchroniser reset
};

/// A snapshot of the inputs, for the watchdog and the diagnostics.
struct InputStatus {
  bool subscribed = false;
  double seconds_since_pair = 0.0;  ///< since the last synchronised pair (or the subscription)
  InputCounts total;
  InputCounts since_pair;  ///< what arrived after the last pair formed
  /// Resolved topics: left image, right image, left camera_info, right camera_info.
  std::array<std::string, 4> topics;
};

}  // namespace bdis_stereo
