// What a pixel's confidence is made of (docs/method.md, "Confidence"): the
// mean evidence of the patches covering it, lowered where those patches
// disagree on its disparity (the pixel mixes surfaces: a depth edge, an
// occluder's rim, a guess in a flat region), where the search from the
// right image lands elsewhere (left-right check), where the surface is too
// slanted for a patch of one disparity or, on strong texture, misfits it,
// or where one edge is most of the texture (slant_cue.hpp), where most of
// its neighbourhood got no estimate (support_cue.hpp), where it stands
// apart from the estimates of its wider neighbourhood (consensus_cue.hpp)
// and where the images, warped by the estimates, still show a slant they
// miss or pin their shift only loosely against their own noise
// (residual_fit_cue.hpp), and the nearer it lies to a jump between
// neighbouring estimates (edge_distance_cue.hpp) or on a ramp the patches
// blurred a small step into (blurred_step_cue.hpp), and, on block-coded
// views, where the codec's grid may have pulled it (block_grid_cue.hpp),
// and where a clipped highlight's lobe outweighs the texture around it
// (specular_lobe_cue.hpp). Measured on generated scenes and the colon
// sequences, each cue ranks the wrong estimates better than the evidence
// alone; see docs/method.md for the figures.
#pragma once

namespace bdis {
namespace detail {

/// Full-resolution px of disagreement at which a cue halves the confidence.
constexpr float kSpreadHalvingPx = 1.0f;      ///< weighted std of the covering patches' disparities
constexpr float kLeftRightHalvingPx = 0.75f;  ///< |left-right difference|
/// Disparity change across a patch (surface slope x patch side): at the 2 px
/// outlier threshold a patch of one disparity no longer fits its footprint
/// within it.
constexpr float kSlantHalvingPx = 2.0f;
/// Grey levels by which a patch of one disparity misfits a slanted, textured
/// surface (its disparity change times the gradient RMS of its texture) at
/// which the confidence halves: the slant cue's 2 px on texture with a
/// gradient RMS of 2 grey levels per px, where, at the same confidence, the
/// outlier rate rises again as a strong edge (a fold rim, an instrument's
/// outline) dominates the patch and pulls its disparity to the edge's own.
constexpr float kStrongTextureGreyPerPx = 2.0f;
constexpr float kMisfitHalvingGrey = kSlantHalvingPx * kStrongTextureGreyPerPx;
/// How far the texture's peakedness in a patch-sized box, mean(g^2) /
/// mean(|g|)^2 of the left image's horizontal gradient, may exceed a
/// Gaussian texture's pi / 2 before the confidence halves (slant_cue.hpp).
/// One edge covering a share s of the box and nothing else gives about 1 /
/// s: a patch-wide box crossed by one edge, 5-10.
constexpr float kLoneEdgeHalving = 1.0f;
/// Bend of the surface across a patch (the Laplacian of the patch-box means
/// at half a patch's step) at which the confidence halves: that of the
/// spread, as the patches around a pixel miss the bend by about that much.
constexpr float kBendHalvingPx = kSpreadHalvingPx;
/// Share of a pixel's neighbourhood without an estimate at which the
/// confidence halves: a quarter of what its covering patches reach.
constexpr float kSupportHalvingShare = 0.25f;
/// Distance of an estimate from the mean of the estimates around it (two
/// patch sides each way) at which the confidence halves: half the spread's,
/// as that mean pools many patches, so a smaller step from it already marks
/// an estimate its surroundings do not share (docs/method.md, "Confidence").
constexpr float kConsensusHalvingPx = 0.5f * kSpreadHalvingPx;
/// Disparity change across a patch that the photometric residual of the
/// estimates still asks for at which the confidence halves: that of the spread.
constexpr float kResidualSlantHalvingPx = kSpreadHalvingPx;
/// Standard error of the disparity that a patch's footprint would give,
/// with the texture and the residual's noise around it, at which the
/// confidence halves: that of the spread.
constexpr float kShiftErrorHalvingPx = kSpreadHalvingPx;
/// A jump between neighbouring estimates, for the edge distance cue: more
/// than the outlier threshold (full-resolution px).
constexpr float kEdgeJumpPx = 2.0f;
/// Distance from the nearest jump at which the edge distance cue halves the
/// confidence, in patch sides: the consensus cue's reach.
constexpr float kEdgeHalvingPatches = 2.0f;
/// A blurred step (blurred_step_cue.hpp): a slope across a patch counts as
/// the ramp of one where it exceeds this many times the flattest slope a
/// little further out, and the excess halves the confidence at the slant
/// cue's 2 px: a patch of one disparity no longer fits the ramp within the
/// outlier threshold.
constexpr float kBlurredStepSlopeRatio = 2.0f;
constexpr float kBlurredStepHalvingPx = kSlantHalvingPx;

/// Shortfall of an estimate carried out to the image's edge (the slope there
/// times the distance carried) at which the confidence halves: that of the spread.
constexpr float kImageBorderHalvingPx = kSpreadHalvingPx;
/// Share of its confidence an estimate keeps at the image's edge itself for
/// the start carried there, rising linearly to all of it two patch sides in.
/// Measured on the generated scenes and the colon sequences (0.1-0.5; one
/// patch side to four): the most confident half's wrong estimates crowd the
/// outer two patch sides on all of them, however the surface slopes.
constexpr float kImageBorderKeptAtEdge = 0.25f;
/// On views whose block codec grids align at some disparity: how far from it
/// (input px) an estimate may have been pulled there, that of the spread,
/// and the share of its confidence taken where it sits exactly on it.
constexpr float kBlockGridReachPx = kSpreadHalvingPx;
constexpr float kBlockGridDoubt = 0.75f;
/// Where the codec's seams are all of the texture around an estimate (its
/// blocks flattened, as in the dark), the grid alone pulls the match: a second
/// doubt, of the estimates within twice that reach, in proportion to the
/// seams' share of the texture above a gridless texture's.
constexpr float kBlockGridSeamReachPx = 2.f * kBlockGridReachPx;
constexpr float kBlockGridSeamDoubt = 0.9f;
/// How far the smooth gradient's RMS may exceed the texture's, as a share of
/// the texture's, next to a clipped highlight before the confidence halves:
/// at 1.5 times the texture's the lobe outweighs it (specular_lobe_cue.hpp).
constexpr float kSpecularLobeHalving = 0.5f;

/// The variance of a pixel's disparity, as a standard deviation of its
/// error should be (docs/method.md, "Variance"): shares of the covering
/// patches' window fit, of the squared spread and of the squared left-right
/// difference (the inlier's error), plus an outlier's squared error times
/// the probability the cues' product gives the estimate of being one
/// (outlier_variance.hpp). Without that term the shares alone (0.015, 0.75,
/// 0.75) put 79 % of the colon's errors within 1 sigma but ranked them
/// poorly: sorted by sigma, the errors' sparsification area was 5.5 times
/// the oracle's, against 2.5-3.2 for the confidence. The shares are those
/// without the term times 0.05, fitted with the term on the generated colon
/// scene (bdis_synth --variant tube, seed 7), where they matter little; the
/// term's two values on the 16 generated sets the calibration is fitted on
/// (seeds 7 and 11): the shares within 1 and 2 sigma nearest, on average,
/// the middles of their bands, 70 % and 94 %.
constexpr float kWindowVarianceShare = 0.00075f;
constexpr float kSpreadVarianceShare = 0.0375f;
constexpr float kLeftRightVarianceShare = 0.0375f;
/// The confidence at which an estimate is as likely an outlier as not.
constexpr float kOutlierHalfConfidence = 5e-7f;
/// An outlier's squared error, full-resolution px^2.
constexpr float kOutlierVariancePx2 = 20.f;
/// The variance's shares and outlier term were fitted at finest level 1
/// (640 px frames). A finest level s >= 2 (wider frames, or a finest level
/// set) gives a variance too wide for its errors (the generated scenes at
/// 1280x720 and 1920x1080: 8 and 1 of 16 sets in the 60-80 / 90-98 % bands,
/// median |error| / sigma 0.54 and 0.39), so it is narrowed by this factor
/// per level above the first: 0.71 at level 2, 0.5 at level 3 (docs/method.md,
/// "The outlier term", at a coarser finest level).
constexpr float kVarianceScalePerLevel = 0.70710678f;
/// That narrowing at finest level `s`: 1 up to level 1.
inline float varianceNarrowingAt(int s) {
  float factor = 1.f;
  for (int level = 2; level <= s; ++level) factor *= kVarianceScalePerLevel;
  return factor;
}

/// 1 for agreement, 1/2 at `halving`, falling as 1 / (1 + (deviation / halving)^2):
/// no exp per pixel, and it vectorises.
inline float agreement(float deviation_squared, float inv_halving_squared) {
  return 1.f / (1.f + deviation_squared * inv_halving_squared);
}

}  // namespace detail
}  // namespace bdis
