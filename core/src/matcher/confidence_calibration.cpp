#include "confidence_calibration.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>

#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

constexpr int kOctaves = 40;
using OctaveTable = std::array<float, kOctaves + 1>;

/// A fitted table and each octave's rise to the next knot (0 for the
/// last), so that a pixel reads two tables at one index.
struct Calibration {
  OctaveTable within_two_px, rise;
};

constexpr Calibration calibrationOf(const OctaveTable& within_two_px) {
  Calibration c{within_two_px, {}};
  for (size_t k = 0; k + 1 < within_two_px.size(); ++k) c.rise[k] = within_two_px[k + 1] - within_two_px[k];
  return c;
}

// Per finest level 1, 2 and 3 (what finest_level -1 picks for frames about
// 640, 1280 and 1920 px wide: the product of the cues and the error in input
// px both depend on it), the share of estimates within 2 px at a raw
// confidence of 2^(k - 40), k = 0..40. Fitted on the generated scenes at
// seeds 7 and 11 (16 sequences, each weighted alike) at 640x480, 1280x720
// and 1920x1080 by scripts/fit_confidence_calibration.py, whose docstring
// holds the commands; made increasing there.
constexpr std::array<Calibration, 3> kByFinestLevel = {
    calibrationOf({
        0.313391f, 0.473388f, 0.473488f, 0.473588f, 0.473688f, 0.473788f,
        0.473888f, 0.473988f, 0.474088f, 0.474188f, 0.474288f, 0.474388f,
        0.474488f, 0.474588f, 0.474688f, 0.474788f, 0.488252f, 0.503224f,
        0.518419f, 0.538364f, 0.561921f, 0.587880f, 0.619461f, 0.657239f,
        0.708923f, 0.760903f, 0.813530f, 0.861782f, 0.907550f, 0.941758f,
        0.965568f, 0.981345f, 0.990044f, 0.994691f, 0.997883f, 0.999359f,
        0.999802f, 0.999849f, 0.999863f, 0.999875f, 0.999887f,
    }),
    calibrationOf({
        0.344740f, 0.392222f, 0.392322f, 0.392422f, 0.392522f, 0.398653f,
        0.398753f, 0.411172f, 0.417509f, 0.424120f, 0.438171f, 0.451997f,
        0.463184f, 0.481682f, 0.507995f, 0.528979f, 0.556096f, 0.583507f,
        0.611150f, 0.644455f, 0.693103f, 0.735727f, 0.776104f, 0.814497f,
        0.847022f, 0.880798f, 0.909909f, 0.936746f, 0.960122f, 0.977731f,
        0.988300f, 0.994843f, 0.998366f, 0.999350f, 0.999660f, 0.999691f,
        0.999719f, 0.999744f, 0.999768f, 0.999789f, 0.999808f,
    }),
    calibrationOf({
        0.284083f, 0.367798f, 0.367898f, 0.367998f, 0.368098f, 0.372775f,
        0.383091f, 0.400692f, 0.405483f, 0.444012f, 0.466928f, 0.494112f,
        0.527000f, 0.574371f, 0.609675f, 0.635596f, 0.669679f, 0.709994f,
        0.740145f, 0.774346f, 0.806747f, 0.844676f, 0.875412f, 0.905722f,
        0.930364f, 0.952292f, 0.971813f, 0.982141f, 0.989719f, 0.994211f,
        0.997434f, 0.998820f, 0.998920f, 0.999018f, 0.999107f, 0.999188f,
        0.999262f, 0.999329f, 0.999390f, 0.999446f, 0.999496f,
    }),
};

const Calibration& calibrationFor(int finest_level) {
  return kByFinestLevel[static_cast<size_t>(std::clamp(finest_level, 1, 3) - 1)];
}

// Linear in the mantissa between the knots at powers of two: the exponent
// picks the knots, so no logarithm is taken. Without branches, so that the
// row loop vectorises (a gather per table).
inline float calibrated(float raw, const float* __restrict within_two_px, const float* __restrict rise) {
  std::uint32_t bits;
  std::memcpy(&bits, &raw, sizeof bits);
  // Octave index: the exponent (the sign bit set for negatives puts them
  // above the table, and raw <= 0 gives 0 below anyway).
  const int octave = static_cast<int>(bits >> 23) - 127 + kOctaves;
  const int k = std::min(std::max(octave, 0), kOctaves);
  const std::uint32_t mantissa_bits = (bits & 0x007FFFFFu) | 0x3F800000u;  // the mantissa as a float in [1, 2)
  float mantissa;
  std::memcpy(&mantissa, &mantissa_bits, sizeof mantissa);
  // Below the table the knot's value alone (the mantissa's share dropped).
  const float share = octave >= 0 ? mantissa - 1.f : 0.f;
  const float p = within_two_px[k] + rise[k] * share;
  return raw > 0.f ? p : 0.f;
}

BDIS_ROW_LOOP
void calibrateRow(int w, const float* __restrict within_two_px, const float* __restrict rise,
                  float* __restrict confidence) {
  for (int x = 0; x < w; ++x) confidence[x] = calibrated(confidence[x], within_two_px, rise);
}

}  // namespace

float calibratedConfidence(float raw, int finest_level) {
  const Calibration& c = calibrationFor(finest_level);
  return calibrated(raw, c.within_two_px.data(), c.rise.data());
}

void calibrateConfidence(cv::Mat1f& confidence, int finest_level) {
  const Calibration& c = calibrationFor(finest_level);
  for (int y = 0; y < confidence.rows; ++y) {
    calibrateRow(confidence.cols, c.within_two_px.data(), c.rise.data(), confidence[y]);
  }
}

}  // namespace detail
}  // namespace bdis
