// BDIS as a pipeline of stages (docs/method.md): the pyramid, then per level
// patch search -> posterior -> fusion from coarse to fine, then the
// left-right check, the texture centroid correction, the refinement, the
// confidence's cues; with two_scales, the choice between it and the same
// search one level coarser; the upsampling to the input resolution.
#include "bdis_stereo/matcher.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "band_schedule.hpp"
#include "block_grid_cue.hpp"
#include "blurred_step_cue.hpp"
#include "confidence.hpp"
#include "confidence_calibration.hpp"
#include "consensus_cue.hpp"
#include "edge_distance_cue.hpp"
#include "image_border_cue.hpp"
#include "left_right_check.hpp"
#include "neighbourhood_cue.hpp"
#include "outlier_variance.hpp"
#include "patch_grid.hpp"
#include "pyramid.hpp"
#include "residual_fit_cue.hpp"
#include "scale_choice.hpp"
#include "search_pass.hpp"
#include "slant_cue.hpp"
#include "specular_lobe_cue.hpp"
#include "support_cue.hpp"
#include "texture_centroid_correction.hpp"
#include "upsampling.hpp"
#include "variational_refinement.hpp"
#include "view_gain.hpp"

namespace bdis {

namespace {

std::string describe(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " type " + cv::typeToString(m.type());
}

void validateInputs(const cv::Mat& left, const cv::Mat& right) {
  for (const auto& [name, img] : {std::pair<const char*, const cv::Mat&>{"left", left},
                                  std::pair<const char*, const cv::Mat&>{"right", right}}) {
    if (img.empty()) throw std::invalid_argument(std::string(name) + " image is empty");
    if (img.dims != 2) throw std::invalid_argument(std::string(name) + " image is not 2-D");
    if (img.depth() != CV_8U || (img.channels() != 1 && img.channels() != 3)) {
      throw std::invalid_argument(std::string(name) + " image is " + describe(img) +
                                  ": expected 8-bit mono (CV_8UC1) or BGR (CV_8UC3)");
    }
    if (img.cols < kMinImageSide || img.rows < kMinImageSide) {
      throw std::invalid_argument(std::string(name) + " image is " + describe(img) +
                                  ": both sides must be at least " + std::to_string(kMinImageSide) + " px");
    }
  }
  if (left.size() != right.size()) {
    throw std::invalid_argument("left image is " + describe(left) + " but right is " + describe(right) +
                                ": a rectified pair has equal sizes");
  }
  if (left.type() != right.type()) {
    throw std::invalid_argument("left image is " + describe(left) + " but right is " + describe(right) +
                                ": both must have the same type");
  }
}

/// Estimates whose confidence is below `min_confidence` get none (and
/// confidence 0, as every pixel without an estimate).
void dropLessConfident(float min_confidence, MatchResult& result) {
  const bool with_variance = !result.variance.empty();
  for (int y = 0; y < result.disparity.rows; ++y) {
    float* d = result.disparity.ptr<float>(y);
    float* c = result.confidence.ptr<float>(y);
    float* v = with_variance ? result.variance.ptr<float>(y) : nullptr;
    for (int x = 0; x < result.disparity.cols; ++x) {
      const bool drop = c[x] < min_confidence;
      d[x] = drop ? kNoDisparity : d[x];
      c[x] = drop ? 0.f : c[x];
      if (v && drop) v[x] = std::numeric_limits<float>::quiet_NaN();
    }
  }
}

/// The parameters of the two_scales search one level coarser: the same
/// search with its finest level at `finest` (resolved), alone, dropping nothing.
MatcherParams coarserScaleParams(const MatcherParams& P, int finest) {
  MatcherParams c = P;
  c.finest_level = finest;
  c.two_scales = false;
  c.min_confidence = 0.f;
  return c;
}

/// The left-right check's settings: the same search with the right image as
/// reference, on a sparser grid (it only confirms or refutes), where any
/// fused estimate may confirm.
MatcherParams checkParams(const MatcherParams& P) {
  MatcherParams c = P;
  c.compute_variance = false;
  c.confidence_floor = 0.f;
  c.overlap = P.lr_check_overlap;
  return c;
}

}  // namespace

struct Matcher::Impl {
  MatcherParams params;
  /// params as the searches run them for the current frame width (the
  /// patch size from patchSizeFor).
  MatcherParams resolved;
  detail::StereoPyramid pyramid;            ///< the pair: left image as reference
  detail::MirroredPyramid mirrored;         ///< the mirrored pair: right image as reference
  detail::SearchPass left;                  ///< the search whose result is published
  detail::SearchPass check;                 ///< the left-right check's search
  detail::ViewGainEstimator gain_estimator;
  std::vector<detail::SearchBand> bands;    ///< the finest level's search order
  detail::SlantCue slant;
  detail::SupportCue support;
  detail::BlockGridCue block_grid;
  detail::ConsensusCue consensus;
  detail::ResidualFitCue residual_fit;
  detail::EdgeDistanceCue edge_distance;
  detail::BlurredStepCue blurred_step;     ///< the blurred step cue
  detail::ImageBorderCue image_border;     ///< the image border cue
  detail::SpecularLobeCue specular_lobe;   ///< the specular lobe cue
  detail::NeighbourhoodCue neighbourhood;  ///< the neighbourhood cue
  detail::VariationalRefinement refinement;
  detail::TextureCentroidCorrection centroid_correction;
  detail::Upsampler upsampler;
  /// two_scales: the same search with its finest level one coarser, made on
  /// the first frame that needs it, and its result brought to this finest
  /// level (buffers reused).
  std::unique_ptr<Matcher> coarser_scale;
  detail::Upsampler coarser_upsampler;
  MatchResult coarser_here;
  detail::ScaleChoice scale_choice;

  /// What matchToFinestLevel decided for the frame.
  struct FinestLevel {
    int index = 0;                    ///< the finest level searched
    bool with_variance = false;       ///< the variance is computed
    bool publish_confidence = false;  ///< the confidence is calibrated and published
    bool two_scales = false;          ///< the coarser scale is matched and chosen from
  };
  /// Steps 1-8 of compute(): the pair matched down to the finest level, its
  /// maps (left.finest()) checked, refined, with their confidence and
  /// variance. `pyramid_built`: `pyramid` already holds this pair's levels
  /// (levelsFor them, searchable from the finest level down to it or finer,
  /// the block grid probed), built with the same saturation and floor.
  /// `levels_from`: a matcher of the same search settings that matched this
  /// pyramid to a finer level without gain compensation; both searches take
  /// the levels above this finest level from its searches.
  FinestLevel matchToFinestLevel(const cv::Mat& left, const cv::Mat& right, const MatchOutputs& outputs,
                                 bool pyramid_built = false, const Impl* levels_from = nullptr);
  /// Levels that hold at least one patch, for frames of `size` (after configureFor).
  int levelsFor(cv::Size size) const;
  /// Step 9 of compute(), after matchToFinestLevel decided `level` with
  /// two_scales: the same search one level coarser, on this pyramid where it
  /// has as many levels, brought to this finest level; where it is the more
  /// confident away from depth edges, its estimates replace left.finest()'s.
  void keepMoreConfidentOfCoarserScale(const cv::Mat& left, const cv::Mat& right, const FinestLevel& level);

  /// Configures the searches for frames `width` px wide; a no-op while the
  /// resolved patch size stays the same.
  void configureFor(int width);
  /// Both searches from `resolved`.
  void configureSearches();

  /// The published search's levels above the finest, coarsest first. The
  /// last kGainLevelsAboveFinest of them each estimate the views' gain
  /// that remains; every right view is divided by the gain known when it
  /// is searched, and at the end by all of it (the check's search and the
  /// finest level come after).
  void matchLevelsAboveFinest(cv::Size size, int levels, int finest);

  /// The finest level of both searches, band by band in the order of
  /// scheduleFinestBands; the check's rows are mirrored just before their band.
  void searchFinestLevel(int finest, bool with_check);

  /// The confidence's cues on the finest level's estimates `out`: each but
  /// the last lowers the confidence where the estimates are in doubt for a
  /// reason the posteriors cannot see (confidence.hpp); the last pools each
  /// confidence with its neighbours'.
  void applyConfidenceCues(int finest, detail::LevelMaps& out);
};

Matcher::Matcher(const MatcherParams& params) : impl_(std::make_unique<Impl>()) { setParams(params); }
Matcher::~Matcher() = default;
Matcher::Matcher(Matcher&&) noexcept = default;
Matcher& Matcher::operator=(Matcher&&) noexcept = default;

void Matcher::setParams(const MatcherParams& params) {
  params.validate();
  impl_->params = params;
  impl_->resolved = params;
  impl_->configureSearches();
  impl_->refinement.configure(params.refinement_iterations, params.refinement_smoothness);
  impl_->coarser_scale.reset();
}

const MatcherParams& Matcher::params() const { return impl_->params; }

void Matcher::compute(const cv::Mat& left, const cv::Mat& right, MatchResult& result, const MatchOutputs& outputs) {
  validateInputs(left, right);
  Impl& m = *impl_;
  const Impl::FinestLevel level = m.matchToFinestLevel(left, right, outputs);
  const MatcherParams& P = m.resolved;
  const int finest = level.index;
  detail::LevelMaps& out = m.left.finest();
  // 9. With two_scales, the same search one level coarser, brought to this
  //    level, and per pixel the estimate more likely right.
  if (level.two_scales) m.keepMoreConfidentOfCoarserScale(left, right, level);
  // 10. Upsampling to the input resolution. The variance is narrowed where
  //     this search's finest level is coarser than the level it was fitted
  //     at (by this level: at level 1 the coarser scale's chosen estimates
  //     keep the variance that fits them).
  m.upsampler.upsample(out, finest, m.pyramid.level(0).left_valid, level.publish_confidence, result);
  if (level.with_variance) {
    m.upsampler.upsampleVariance(out, finest, result, detail::varianceNarrowingAt(finest));
  } else {
    result.variance.release();
  }
  // 11. The estimates less confident than min_confidence dropped, at the
  //     resolution the confidence is published at (and their variance).
  if (P.min_confidence > 0.f) dropLessConfident(P.min_confidence, result);
}

void Matcher::Impl::keepMoreConfidentOfCoarserScale(const cv::Mat& left, const cv::Mat& right,
                                                    const FinestLevel& level) {
  const int finest = level.index;
  detail::LevelMaps& out = this->left.finest();
  if (!coarser_scale || coarser_scale->params().finest_level != finest + 1) {
    coarser_scale = std::make_unique<Matcher>(coarserScaleParams(params, finest + 1));
  }
  Impl& coarser = *coarser_scale->impl_;
  // The coarser search runs on this pyramid of the same pair (its levels
  // from finest + 1 are what it would build) where it has as many levels.
  coarser.configureFor(left.cols);
  const bool share = coarser.levelsFor(left.size()) == pyramid.numLevels();
  // Its levels above its finest are then this search's too, unless the gain
  // compensation divided the right views as the levels went (each search
  // measures the gain on levels of its own) or a patch size that changes
  // with the width made the two searches differ.
  const bool same_levels_above =
      share && !resolved.gain_compensation && coarser.resolved.patch_size == resolved.patch_size;
  if (share) std::swap(pyramid, coarser.pyramid);
  const int coarser_finest =
      coarser
          .matchToFinestLevel(left, right, MatchOutputs{true, level.with_variance}, /*pyramid_built=*/share,
                              same_levels_above ? this : nullptr)
          .index;
  if (share) std::swap(pyramid, coarser.pyramid);
  // Levels between the two (1, unless a patch size that changes with the
  // width left the coarser search fewer levels).
  const int step = coarser_finest - finest;
  if (step > 0) {
    const detail::PyramidLevel& here = pyramid.level(finest);
    coarser_upsampler.upsample(coarser.left.finest(), step, here.left_valid, true, coarser_here);
    if (level.with_variance) coarser_upsampler.upsampleVariance(coarser.left.finest(), step, coarser_here);
    MatchResult chosen;  // headers on this level's maps
    chosen.disparity = out.disparity;
    chosen.confidence = out.confidence;
    if (level.with_variance) chosen.variance = out.variance;
    // The reach: one coarser patch side, in this level's px.
    scale_choice.keepMoreConfident(coarser_here, detail::kScaleChoiceJumpPx, coarser.resolved.patch_size << step,
                                   chosen);
  }
}

int Matcher::Impl::levelsFor(cv::Size size) const {
  return detail::levelsThatFit(size.width, size.height, resolved.patch_size, resolved.coarsest_level + 1);
}

Matcher::Impl::FinestLevel Matcher::Impl::matchToFinestLevel(const cv::Mat& left, const cv::Mat& right,
                                                             const MatchOutputs& outputs, bool pyramid_built,
                                                             const Impl* levels_from) {
  configureFor(left.cols);
  const MatcherParams& P = resolved;
  FinestLevel r;
  const int levels = levelsFor(left.size());
  const int finest = std::min(P.finestLevelFor(left.cols), levels - 1);
  r.index = finest;
  const bool with_check = P.lr_check_tolerance > 0.f;
  // The confidence is published when asked for or when it decides which
  // estimates are published; it is computed for the variance's outlier term too.
  r.with_variance = P.compute_variance && outputs.variance;
  // two_scales keeps, per pixel, the estimate more confident of the two
  // scales: that takes both calibrated confidences and a coarser level.
  r.two_scales = P.two_scales && P.calibrated_confidence && finest + 1 < levels;
  r.publish_confidence = outputs.confidence || P.min_confidence > 0.f || r.two_scales;
  const bool with_confidence = r.publish_confidence || r.with_variance;

  // 1. Pyramid: grey levels, gradients and validity of the pair.
  if (!pyramid_built) {
    pyramid.build(left, right, levels, finest, P.saturation_grey, P.dark_floor_grey,
                  /*probe_block_grid=*/with_confidence);
  }
  // 2. Coarse to fine above the finest level; each level initialises the next.
  if (levels_from) {
    this->left.adoptLevelsAboveFinest(levels_from->left, left.size(), levels, finest);
  } else {
    matchLevelsAboveFinest(left.size(), levels, finest);
  }
  if (with_check) {
    const MatcherParams& C = check.params();
    const int band_rows = detail::bandLevelRows(C.search_band_rows, detail::patchStride(C.patch_size, C.overlap),
                                                C.patch_size, pyramid.level(finest).height);
    mirrored.build(pyramid, levels, finest, band_rows);
    if (levels_from) {
      check.adoptLevelsAboveFinest(levels_from->check, left.size(), levels, finest);
    } else {
      check.matchLevelsAboveFinest(mirrored, left.size(), levels, finest);
    }
  }
  // 3. The finest level, band by band, then fused.
  searchFinestLevel(finest, with_check);
  this->left.fuseFinestLevel();
  if (with_check) check.fuseFinestLevel();
  // 4. The left-right check, at the finest level's scale.
  detail::LevelMaps& out = this->left.finest();
  const float level_px = 1.f / static_cast<float>(1 << finest);
  if (with_check) {
    detail::leftRightCheck(check.finest().disparity, P.checkToleranceFor(left.cols) * level_px,
                           detail::kLeftRightHalvingPx * level_px, out.disparity, out.confidence,
                           P.compute_variance ? &out.variance : nullptr);
  }
  // 5. Each estimate moved from where its patches' texture is centred to
  //    its pixel, along the surface's slope; then the variational
  //    refinement of the estimates the check kept, which pins them to the
  //    images where their texture can.
  centroid_correction.apply(pyramid.level(finest), P.patch_size, detail::kCentroidShiftLimitPx * level_px,
                            out.disparity);
  refinement.apply(pyramid.level(finest), this->left.aboveFinest(), out.disparity);
  // 6. The confidence's cues, only when the confidence is computed: they
  //    change no disparity.
  if (with_confidence) applyConfidenceCues(finest, out);
  // 7. The variance's outlier term: the outlier's squared error times the
  //    probability the cues' product (the confidence, not yet calibrated)
  //    gives the estimate of being one.
  if (r.with_variance) {
    detail::addOutlierVariance(out.disparity, out.confidence, detail::kOutlierVariancePx2 * level_px * level_px,
                               detail::kOutlierHalfConfidence, out.variance);
  }
  // 8. The published confidence as the probability of being within 2 px.
  if (r.publish_confidence && P.calibrated_confidence) detail::calibrateConfidence(out.confidence, finest);
  return r;
}

void Matcher::Impl::applyConfidenceCues(int finest, detail::LevelMaps& out) {
  const detail::PyramidLevel& level = pyramid.level(finest);
  const int p = resolved.patch_size;
  const float level_px = 1.f / static_cast<float>(1 << finest);
  // The slant cue: surfaces too slanted or bent for a patch of one
  // disparity, or slanted and so strongly textured that the patch misfits
  // them, and patches whose texture is one edge.
  slant.apply(out.disparity, level.left_gx, p, detail::kSlantHalvingPx * level_px, detail::kMisfitHalvingGrey,
              detail::kBendHalvingPx * level_px, detail::kLoneEdgeHalving, out.confidence);
  // The support cue: estimates among holes.
  support.apply(out.disparity, level.left_valid, level.left, p, detail::kSupportHalvingShare, out.confidence);
  // The consensus cue: estimates that stand apart from their neighbourhood.
  consensus.apply(out.disparity, p, detail::kConsensusHalvingPx * level_px, out.confidence);
  // The residual fit cues: a slant the estimates miss that the images still
  // show, and a shift their texture pins only loosely.
  if (finest + 1 < pyramid.numLevels()) {
    residual_fit.apply(out.disparity, pyramid.level(finest + 1), p, detail::kResidualSlantHalvingPx * level_px,
                       detail::kShiftErrorHalvingPx * level_px, out.confidence);
  }
  // The edge distance cue: estimates near a jump between neighbours.
  edge_distance.apply(out.disparity, detail::kEdgeJumpPx * level_px,
                      detail::kEdgeHalvingPatches * static_cast<float>(p), out.confidence);
  // The blurred step cue: estimates on a ramp the patches made of a small
  // step, steep beside flat tissue with no jump for the edge cue to see.
  blurred_step.apply(out.disparity, slant.blockSlopesSquared(), edge_distance.blockDistances(), p,
                     detail::kBlurredStepSlopeRatio, detail::kBlurredStepHalvingPx * level_px, out.confidence);
  // The image border cue: estimates the patches carry out to the image's edge.
  image_border.apply(out.disparity, p, detail::kImageBorderHalvingPx * level_px, out.confidence);
  // The block grid cue: on block-coded views, estimates the codec's grid may
  // have pulled to where the views' grids align, more so where its seams are
  // the texture left.
  const detail::BlockGridLayout grid{
      detail::alignedGridDisparity(pyramid.columnSteps(true), pyramid.columnSteps(false)),
      pyramid.columnSteps(true).strongestPhase()};
  const detail::BlockGridDoubts grid_doubts{detail::kBlockGridReachPx, detail::kBlockGridDoubt,
                                            detail::kBlockGridSeamReachPx, detail::kBlockGridSeamDoubt};
  block_grid.apply(out.disparity, 1 << finest, grid, level.left, level.left_valid, p, grid_doubts, out.confidence);
  // The specular lobe cue: estimates a clipped highlight's lobe, not the
  // tissue's texture, has placed.
  specular_lobe.apply(out.disparity, level.left, level.left_valid, level.left_gx, resolved.saturation_grey, p,
                      detail::kSpecularLobeHalving, out.confidence);
  // The neighbourhood cue, last: each confidence pooled with its neighbours'
  // as the cues above left them.
  neighbourhood.apply(out.disparity, p, out.confidence);
}

void Matcher::Impl::configureFor(int width) {
  const int patch_size = params.patchSizeFor(width);
  if (patch_size == resolved.patch_size) return;
  resolved = params;
  if (patch_size != params.patch_size) {
    resolved.patch_size = patch_size;
    // The finest level's grid stays as set (its stride in level px): the
    // smaller patch changes what each patch sees, not how many there are.
    const int stride = detail::patchStride(params.patch_size, params.overlap);
    resolved.overlap = 1.f - static_cast<float>(stride) / static_cast<float>(patch_size);
  }
  configureSearches();
}

void Matcher::Impl::configureSearches() {
  left.configure(resolved, /*keep_confidence=*/true);
  check.configure(checkParams(resolved), /*keep_confidence=*/false);
}

void Matcher::Impl::matchLevelsAboveFinest(cv::Size size, int levels, int finest) {
  CV_Assert(levels <= detail::kMaxPyramidLevels);
  left.beginLevelsAboveFinest(size, levels, finest);
  const int first_gain_level = resolved.gain_compensation ? finest + detail::kGainLevelsAboveFinest : -1;
  float gain = 1.f;  // right view over left: what the levels matched so far measured
  std::array<float, detail::kMaxPyramidLevels> divided{};  // the gain each right view is divided by
  divided.fill(1.f);
  auto divide = [&](int s) {
    if (divided[static_cast<size_t>(s)] == gain) return;
    pyramid.scaleRightView(s, divided[static_cast<size_t>(s)] / gain);
    divided[static_cast<size_t>(s)] = gain;
  };
  for (int s = levels - 1; s > finest; --s) {
    divide(s);
    left.matchCoarseLevel(pyramid.level(s), s);
    if (s > first_gain_level) continue;
    const float remaining = gain_estimator.estimate(pyramid.level(s), left.levelDisparity(s));
    if (std::fabs(remaining - 1.f) > detail::kGainTolerance) gain *= remaining;
  }
  for (int s = finest; s < levels; ++s) divide(s);
}

void Matcher::Impl::searchFinestLevel(int finest, bool with_check) {
  const detail::PyramidLevel& level = pyramid.level(finest);
  // The second look one level coarser is the published search's only: in
  // the check's search it lets more of the left's guesses on dark tissue
  // through, wrong ones among them, at twice the cost (docs/method.md).
  const bool coarser_look = params.coarser_look && finest + 1 < pyramid.numLevels();
  left.beginFinestLevel(level, finest, coarser_look ? &pyramid.level(finest + 1) : nullptr);
  if (with_check) check.beginFinestLevel(mirrored.level(finest), finest, nullptr);
  detail::scheduleFinestBands(left.grid(), params.search_band_rows, with_check ? &check.grid() : nullptr,
                              params.search_band_rows, bands);
  for (const detail::SearchBand& band : bands) {
    if (band.pass == detail::SearchBand::Pass::Left) {
      left.searchFinestBand(level, band.top, band.bottom);
    } else {
      mirrored.loadFinestRows(level, band.first_row, band.end_row);
      check.searchFinestBand(mirrored.level(finest), band.top, band.bottom);
    }
  }
}

}  // namespace bdis
