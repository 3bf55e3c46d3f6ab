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
        0.285473f, 0.444062f, 0.444162f, 0.444262f, 0.444362f, 0.444462f,
        0.444562f, 0.444662f, 0.444762f, 0.444862f, 0.444962f, 0.445062f,
        0.445162f, 0.445262f, 0.445362f, 0.446965f, 0.462531f, 0.486057f,
        0.507753f, 0.529323f, 0.554658f, 0.581496f, 0.609169f, 0.648261f,
        0.698113f, 0.745199f, 0.795773f, 0.845945f, 0.892935f, 0.930890f,
        0.958636f, 0.976584f, 0.987277f, 0.992971f, 0.997071f, 0.999150f,
        0.999753f, 0.999849f, 0.999862f, 0.999875f, 0.999886f,
    }),
    calibrationOf({
        0.298748f, 0.362379f, 0.362479f, 0.362579f, 0.367880f, 0.377724f,
        0.383450f, 0.393059f, 0.400359f, 0.414247f, 0.425762f, 0.448642f,
        0.466296f, 0.481399f, 0.501613f, 0.513298f, 0.541624f, 0.577048f,
        0.608758f, 0.635385f, 0.676433f, 0.721160f, 0.762422f, 0.800037f,
        0.837184f, 0.869037f, 0.898568f, 0.926762f, 0.952891f, 0.971465f,
        0.984577f, 0.992217f, 0.996852f, 0.998234f, 0.998711f, 0.999400f,
        0.999706f, 0.999732f, 0.999757f, 0.999779f, 0.999799f,
    }),
    calibrationOf({
        0.253310f, 0.341096f, 0.354497f, 0.357699f, 0.361283f, 0.366561f,
        0.369352f, 0.381700f, 0.397489f, 0.433995f, 0.460186f, 0.488398f,
        0.520425f, 0.567316f, 0.602658f, 0.627621f, 0.660684f, 0.700271f,
        0.728657f, 0.762205f, 0.798205f, 0.836637f, 0.869537f, 0.899681f,
        0.924021f, 0.944984f, 0.965516f, 0.977470f, 0.985035f, 0.991140f,
        0.995040f, 0.998060f, 0.998842f, 0.998942f, 0.999038f, 0.999126f,
        0.999205f, 0.999277f, 0.999343f, 0.999403f, 0.999457f,
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
