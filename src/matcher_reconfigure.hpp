// The matcher parameters of a running nodelet: fixed at start-up, changed by
// dynamic_reconfigure requests (bound here with the core's rules, on the
// server's thread), handed to the worker between two frames.
#pragma once

#include <mutex>
#include <string>

#include "bdis_stereo/BdisStereoConfig.h"
#include "bdis_stereo/params.hpp"

namespace bdis_stereo {

/// Every matcher field of `config` bound into MatcherParams (source
/// "dynamic_reconfigure"); throws bdis::ParamError for a value the core
/// refuses (NaN passes dynamic_reconfigure's range clamp).
bdis::MatcherParams paramsFromConfig(const BdisStereoConfig& config);

/// Writes every matcher field of `params` into `config`.
void paramsToConfig(const bdis::MatcherParams& params, BdisStereoConfig& config);

class MatcherReconfigure {
 public:
  MatcherReconfigure(std::string log_name, std::string preset, const bdis::MatcherParams& params);

  /// The dynamic_reconfigure callback. A new preset sets every field; a
  /// refused value or combination keeps the previous parameters (and puts them
  /// back into `config`); a field that lands on an end of its range is
  /// reported, as the server clamps requests outside the range to it. Never throws.
  void reconfigure(BdisStereoConfig& config);

  /// For the worker, before a frame: the accepted parameters when they
  /// changed since the last call.
  bool takeChange(bdis::MatcherParams& params);

  std::string preset() const;

 private:
  void apply(BdisStereoConfig& config);
  void warnAboutRangeEnds(const bdis::MatcherParams& requested) const;

  const std::string log_name_;
  // Written by reconfigure() only, which the server calls one at a time.
  std::string preset_;
  bdis::MatcherParams params_;
  mutable std::mutex mutex_;  // the pending change and the preset's name for readers
  std::string preset_shown_;
  bdis::MatcherParams pending_;
  bool changed_ = false;
};

}  // namespace bdis_stereo
