// One direction of the coarse-to-fine search (docs/method.md, "Coarse to
// fine"): per level, patch search -> posterior -> fusion, each level above
// the finest initialising the next. The matcher runs one with the left image
// as reference and, for the left-right check, one on the mirrored pair.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "bdis_stereo/params.hpp"
#include "fusion.hpp"
#include "inverse_search.hpp"
#include "pyramid.hpp"

namespace bdis {
namespace detail {

class SearchPass {
 public:
  /// The pass's settings. `keep_confidence` false: the finest level's
  /// confidence is not kept (the check needs only its disparity).
  void configure(const MatcherParams& params, bool keep_confidence);
  const MatcherParams& params() const { return params_; }

  /// Levels levels-1 down to finest+1 of `pyramid` (a StereoPyramid or a
  /// MirroredPyramid), coarsest first, starting from disparity 0: each
  /// level's fused disparity initialises the next finer one. Sizes the
  /// pass's buffers for a pyramid of that many levels over an input of `size`.
  template <class Pyramid>
  void matchLevelsAboveFinest(const Pyramid& pyramid, cv::Size size, int levels, int finest) {
    beginLevelsAboveFinest(size, levels, finest);
    for (int s = levels - 1; s > finest; --s) matchCoarseLevel(pyramid.level(s), s);
  }
  /// matchLevelsAboveFinest a level at a time: beginLevelsAboveFinest, then
  /// matchCoarseLevel for s = levels-1 down to finest+1.
  void beginLevelsAboveFinest(cv::Size size, int levels, int finest) { allocate(size, levels, finest); }
  void matchCoarseLevel(const PyramidLevel& L, int s);
  /// The dense disparity of level s > finest (level px), once it is matched.
  const cv::Mat1f& levelDisparity(int s) const { return initialisation_[static_cast<size_t>(s)]; }
  /// In place of matchLevelsAboveFinest: the level above the finest as
  /// `finer` matched it on the way to a finer level. The same result where
  /// `finer` ran the same settings on the same pyramid levels with the same
  /// right views (no gain compensation), since the finest level and the
  /// refinement read no other level's disparity.
  void adoptLevelsAboveFinest(const SearchPass& finer, cv::Size size, int levels, int finest);

  /// The finest level, s: beginFinestLevel, then searchFinestBand for
  /// every band of patch rows of grid() from the top, then fuseFinestLevel.
  /// `coarser`: level s + 1 of the same pyramid, for the second look of
  /// patches without evidence (null: none, as when s is the coarsest level).
  void beginFinestLevel(const PyramidLevel& L, int s, const PyramidLevel* coarser);
  const PatchGrid& grid() const { return search_.grid(); }
  void searchFinestBand(const PyramidLevel& L, int top, int bottom);
  void fuseFinestLevel();
  /// The finest level's results (after fuseFinestLevel).
  LevelMaps& finest() { return finest_; }
  /// The dense disparity of the level above the finest, which started it.
  const cv::Mat1f& aboveFinest() const { return initialisation_[static_cast<size_t>(finest_level_) + 1]; }
  const LevelMaps& finest() const { return finest_; }

 private:
  void allocate(cv::Size size, int levels, int finest);

  MatcherParams params_;
  bool keep_confidence_ = true;
  PatchSearch search_;
  Fusion fusion_;
  /// Dense disparity of each level above the finest (index s), which starts
  /// the search of level s - 1; index `levels` is all 0.
  std::vector<cv::Mat1f> initialisation_;
  int finest_level_ = 0;
  LevelMaps finest_;
};

}  // namespace detail
}  // namespace bdis
