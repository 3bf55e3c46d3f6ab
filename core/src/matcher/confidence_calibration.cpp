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

// The share of estimates within 2 px at a raw confidence of 2^(k - 40),
// k = 0..40. Fitted on the generated scenes at seeds 7 and 11 (16
// sequences, each weighted alike) by scripts/fit_confidence_calibration.py,
// whose docstring holds the command; made increasing there.
constexpr std::array<float, kOctaves + 1> kWithinTwoPxByOctave = {
    0.285473f, 0.445349f, 0.445350f, 0.445351f, 0.445352f, 0.445353f,
    0.445354f, 0.445355f, 0.445356f, 0.445357f, 0.445358f, 0.445359f,
    0.445360f, 0.445361f, 0.445362f, 0.446965f, 0.462531f, 0.486057f,
    0.507753f, 0.529323f, 0.554658f, 0.581496f, 0.609169f, 0.648261f,
    0.698113f, 0.745199f, 0.795773f, 0.845945f, 0.892935f, 0.930890f,
    0.958636f, 0.976584f, 0.987277f, 0.992971f, 0.997071f, 0.999150f,
    0.999753f, 0.999883f, 0.999884f, 0.999885f, 0.999886f,
};

// Each octave's rise to the next knot (0 for the last), so that a pixel
// reads two tables at one index.
constexpr std::array<float, kOctaves + 1> kRiseByOctave = [] {
  std::array<float, kOctaves + 1> rise{};
  for (int k = 0; k < kOctaves; ++k) rise[k] = kWithinTwoPxByOctave[k + 1] - kWithinTwoPxByOctave[k];
  return rise;
}();

// Linear in the mantissa between the knots at powers of two: the exponent
// picks the knots, so no logarithm is taken. Without branches, so that the
// row loop vectorises (a gather per table).
inline float calibrated(float raw) {
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
  const float p = kWithinTwoPxByOctave[static_cast<size_t>(k)] + kRiseByOctave[static_cast<size_t>(k)] * share;
  return raw > 0.f ? p : 0.f;
}

BDIS_ROW_LOOP
void calibrateRow(int w, float* __restrict confidence) {
  for (int x = 0; x < w; ++x) confidence[x] = calibrated(confidence[x]);
}

}  // namespace

float calibratedConfidence(float raw) { return calibrated(raw); }

void calibrateConfidence(cv::Mat1f& confidence) {
  for (int y = 0; y < confidence.rows; ++y) calibrateRow(confidence.cols, confidence[y]);
}

}  // namespace detail
}  // namespace bdis
