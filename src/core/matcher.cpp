// BDIS: coarse-to-fine 1-D inverse search per patch, a Bayesian posterior per
// patch from a window of costs around its optimum, and posterior x spatial
// Gaussian weighted fusion. See METHOD.md sections 1-3.
#include "bdis_stereo/matcher.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "patch_kernels.hpp"
#include "pyramid.hpp"

namespace bdis {

using detail::PyramidLevel;
using detail::ResidualSums;
using detail::SampleSpan;

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
/// A patch's residual at its optimum must stay below this share of its
/// template's variance (see patchPosterior). Measured on the colon sequences
/// (balanced): 1.5 lowers the mean error 1.74 -> 1.71 / 1.77 -> 1.71 px at
/// 0.1-0.4 points of density; 1.0 cuts deeper (1.64 / 1.71 px) but costs
/// specular 1.3 points of density.
constexpr float kMaxResidualShareOfTemplate = 1.5f;

// Patch origins along one axis: a regular stride plus one patch flush with
// the far border, so every pixel is covered. clear() keeps capacity.
void patchAxis(int extent, int p, int stride, std::vector<int>& out) {
  out.clear();
  for (int x = 0; x + p <= extent; x += stride) out.push_back(x);
  if (out.empty() || out.back() != extent - p) out.push_back(extent - p);
}

/// Row-wise fill: cv::Mat::setTo allocates an iterator on ROIs, and the
/// steady state must not allocate.
void fill(cv::Mat1f& m, float value) {
  for (int y = 0; y < m.rows; ++y) std::fill(m[y], m[y] + m.cols, value);
}

size_t rowStride(const cv::Mat1f& m) { return m.step1(); }

/// Patch grid spacing at a level searched with the given overlap.
int patchStride(int p, double overlap) {
  return std::max(1, static_cast<int>(std::lround(p * (1.0 - overlap))));
}

/// Rows of fuseLevel's accumulator band: one patch and four more patch rows,
/// so the rows carried over when the band moves (fewer than p) are copied once
/// per four patch rows. 28 rows at the defaults: at 1920x1080 the five sums
/// take 0.5 MB, where whole-level sums took 10 MB and ran from memory.
int fuseBandRows(const MatcherParams& P) {
  const int p = P.patch_size;
  return p + 4 * std::max(patchStride(p, P.overlap), patchStride(p, P.coarse_overlap));
}

/// Level rows that a band of search_band_rows patch rows spans on the finest
/// level (the whole level when it is searched at once).
int searchBandLevelRows(const MatcherParams& P, int level_height) {
  if (P.search_band_rows <= 0) return level_height;
  const int stride = patchStride(P.patch_size, P.overlap);
  return std::min(level_height, (P.search_band_rows - 1) * stride + P.patch_size);
}

std::string describe(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " type " +
         cv::typeToString(m.type());
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
                                  ": both sides must be at least " +
                                  std::to_string(kMinImageSide) + " px");
    }
  }
  if (left.size() != right.size()) {
    throw std::invalid_argument("left image is " + describe(left) + " but right is " +
                                describe(right) + ": a rectified pair has equal sizes");
  }
  if (left.type() != right.type()) {
    throw std::invalid_argument("left image is " + describe(left) + " but right is " +
                                describe(right) + ": both must have the same type");
  }
}

}  // namespace

/// Result of one patch at one level.
struct PatchEstimate {
  float disparity = 0.f;  ///< at the level's scale
  float posterior = 0.f;  ///< 0 when discarded
  /// Posterior above chance: 0 for a flat window (posterior 1/(2n+1)), 1 for a
  /// single peak. A flat cost must never look confident.
  float evidence = 0.f;
  float variance = 0.f;   ///< px^2 at the level's scale
};

/// One direction of the search: the pyramid of a (reference, other) pair and
/// every buffer of the coarse-to-fine patch search. The matcher runs one with
/// the left image as reference and, for the left-right check, one on the
/// mirrored pair (right as reference).
struct SearchPass {
  MatcherParams params;  ///< effective settings of the current frame
  detail::StereoPyramid pyramid;
  const detail::KernelSet* kernels = nullptr;  ///< inner loops for this patch size and CPU

  // Per-level state, sized on the first frame of a given size.
  /// Dense coarse-to-fine initialisation per level, above the finest (which
  /// initialises nothing: its fused rows pass through fused_row).
  std::vector<cv::Mat1f> init_disparity;
  std::vector<float> fused_row;
  /// Whether level_confidence is kept: the check's pass needs only its
  /// disparity, so it writes its confidence into one reused row.
  bool keeps_confidence = true;
  /// fuseLevel's accumulators: a band of fuseBandRows() level rows slides down
  /// the level, so they stay in cache at any image size.
  cv::Mat1f fused_num, fused_den, conf_sum, var_num, var_den;
  cv::Mat1f level_disparity, level_confidence, level_variance;  ///< finest level, floored
  std::vector<int> xs, ys;
  std::vector<float> cover_x, cover_y;  ///< patches covering each column / row of the level
  // upsampleToFull: the level columns and weight of each output column, and
  // the level rows blended vertically for the current output row.
  std::vector<int> up_x0, up_x1;
  std::vector<float> up_ax, up_weight, up_disparity, up_confidence, up_variance;
  std::vector<float> up_row_weight, up_row_disparity, up_row_confidence;  ///< full width
  std::vector<PatchEstimate> patches;

  // Per-patch scratch, p*p or row-sized.
  std::vector<float> spatial, row_buf, costs, likelihood, window_sum, window_sq;

  /// What depends only on the parameters (kernels, spatial Gaussian): done
  /// when they are set, not per frame.
  void configure(const MatcherParams& p);
  void allocate(cv::Size size, int levels);
  /// Matches the levels above the finest of `pyramid` (built by the caller),
  /// coarsest first; each only initialises the next. The finest level is the
  /// caller's, through beginLevel, searchBand and fuseLevel, so that the two
  /// passes can search theirs in step (Matcher::Impl::matchFinestLevel).
  void matchLevelsAboveFinest(int levels);
  /// The patch grid of level s; returns its number of patch rows.
  int beginLevel(int s, bool finest);
  /// Patch rows per search band of the finest level (after its beginLevel):
  /// search_band_rows, as the level (about 7 MB at 1920x1080) no longer stays
  /// in cache between the forward and the backward pass; 0 is the whole
  /// level. A coarser level is searched whole.
  int finestBandRows() const {
    return params.search_band_rows > 0 ? params.search_band_rows : static_cast<int>(ys.size());
  }
  /// Forward and backward pass over patch rows [top, bottom) of level s.
  void searchBand(int s, int top, int bottom);
  /// DIS's two passes over patch rows [top, bottom) of the level's grid (xs, ys).
  void forwardPass(const PyramidLevel& L, const cv::Mat1f& coarse, int top, int bottom);
  void backwardPass(const PyramidLevel& L, int top, int bottom);
  // The patch being searched: template, gradient and validity read in place
  // from the level, plus the template's constant sums the fast path needs.
  struct CurrentPatch {
    const PyramidLevel* level = nullptr;
    int x0 = 0, y0 = 0;
    detail::PatchView view{};
    const uchar* valid = nullptr;  ///< left validity at (x0, y0), rows level->left_valid.step apart
    bool left_all_valid = false;
    /// Every left pixel of the patch and every right pixel of its patch
    /// row's band valid: an in-image match needs no validity lookup.
    bool no_invalid_pixels = false;
    const float* right_rows = nullptr;  ///< right image, column 0 of row y0
    size_t right_stride = 0;
    int width = 0;  ///< of the level
    /// Sums of gx and gx^2 and the template variance; only when left_all_valid.
    detail::TemplateSums constants{};
  } cur;
  /// What the backward pass cannot re-derive cheaply from a patch's position:
  /// 16 bytes a patch, not a whole CurrentPatch (96), so that at 1920x1080 the
  /// records of a pass take 0.9 MB, not 5.4, beside the level in cache.
  struct LoadedPatch {
    detail::TemplateSums constants;
    bool loaded = false;  ///< enough valid pixels to be searched
    bool left_all_valid = false;
  };
  std::vector<LoadedPatch> loaded_patches;  ///< as the forward pass loaded them, for the backward one
  /// Loads the left patch at (x0, y0); false when too few of its pixels are valid.
  bool loadPatch(const PyramidLevel& L, int x0, int y0);
  /// Makes the patch at (x0, y0) current with what loadPatch found out about it.
  void setCurrent(const PyramidLevel& L, int x0, int y0, bool left_all_valid);
  /// The invalid pixels of the current patch row's band (level rows y0 ..
  /// y0 + p - 1) per column, summed along the row (level width + 1 entries):
  /// the count over columns [lo, hi) of the band is prefix[hi] - prefix[lo].
  /// Made for each patch row from the validity masks: that answers every
  /// query of the search, which asks only about the rows of its patch row,
  /// and writes no level-sized integral images (4 MB per pair at 1920x1080).
  struct ValidityBand {
    std::vector<int> left_prefix, right_prefix;
    std::vector<uchar> column_count;  ///< scratch: invalid pixels of each column of the band
    bool left_all_valid = false, right_all_valid = false;
    int leftInvalid(int lo, int hi) const {
      return left_all_valid ? 0 : left_prefix[hi] - left_prefix[lo];
    }
    int rightInvalid(int lo, int hi) const {
      return right_all_valid ? 0 : right_prefix[hi] - right_prefix[lo];
    }
  } band;
  /// Makes `band` describe level rows y0 .. y0 + p - 1 of L.
  void loadBand(const PyramidLevel& L, int y0);
  /// Whether the all-valid kernels may read right-image columns [lo, hi) on
  /// the current patch's rows: every template pixel valid, the columns inside
  /// the image and none of them invalid (one count where the band has any).
  bool allValidColumns(int lo, int hi) const {
    return cur.left_all_valid && lo >= 0 && hi <= cur.width &&
           (cur.no_invalid_pixels || band.rightInvalid(lo, hi) == 0);
  }
  /// The residual sums at disparity u; g_diff only `with_gradient` (a cost alone needs none).
  void patchSums(float u, ResidualSums& r, bool with_gradient = true);
  /// patchSums where the all-valid kernels may not run: near the image edge or invalid pixels.
  void patchSumsNearInvalidOrEdge(SampleSpan span, ResidualSums& r);
  /// Mean squared residual at disparity u (mean-normalised if enabled); +inf without pixels.
  float patchCost(float u, float* valid_count = nullptr);
  /// patchCost at n <= kMaxBatchSpans disparities, in one pass over the
  /// template when all of them take the fast path.
  void patchCosts(const float* u, int n, float* costs);
  float meanSquaredResidual(const ResidualSums& r) const;
  /// Grey-level variance of the current patch's valid template pixels.
  float templateVariance() const;
  float refinePatch(float u_start);
  /// Costs of the window samples around u into `costs`, through one shared
  /// interpolation when they allow it; returns the valid pixels at u.
  float windowCosts(float u);
  PatchEstimate patchPosterior(float u);
  /// Variance of a failed fit: a Gaussian twice as wide as the window, px^2 at the level.
  float maxVariance() const {
    const float half_span = static_cast<float>(params.window_half_width) * params.window_step;
    return 4.f * half_span * half_span;
  }
  /// The propagation candidates of patch k: the disparities of its loaded
  /// neighbours k + row_offset (in the same patch row, if `in_row`) and
  /// k + column_offset (in the same column, if `in_column`), in that order.
  int neighbourCandidates(size_t k, bool in_row, std::ptrdiff_t row_offset, bool in_column,
                          std::ptrdiff_t column_offset, float* out) const {
    int n = 0;
    auto add = [&](bool present, std::ptrdiff_t offset) {
      const size_t neighbour = static_cast<size_t>(static_cast<std::ptrdiff_t>(k) + offset);
      if (present && loaded_patches[neighbour].loaded) out[n++] = patches[neighbour].disparity;
    };
    add(in_row, row_offset);
    add(in_column, column_offset);
    return n;
  }
  /// Spatial propagation (DIS): in order, each of the n <= 2 candidates (the
  /// neighbours' disparities) replaces u when its cost is lower. True when u changed.
  bool propagate(float& u, const float* candidates, int n);
  /// Fuses the patches of level s into init_disparity[s] (and, on the finest
  /// level, level_disparity / level_confidence / level_variance).
  void fuseLevel(int s, bool finest);
  /// fuseLevel's per-pixel results for level rows [band_top, end), all final,
  /// from the band of accumulators that starts at level row band_top.
  void finishFusedRows(int s, bool finest, int band_top, int end);
  void upsampleToFull(int s, MatchResult& out);
};

struct Matcher::Impl {
  MatcherParams params;
  SearchPass left_pass;   ///< left image as reference: the result
  SearchPass right_pass;  ///< mirrored pair, right image as reference: the check

  /// Searches and fuses the finest level of the left pass and, with the
  /// check, of the right pass: band by band, in step down the level.
  void matchFinestLevel(int finest, bool check);
  /// Removes left estimates that the right-reference pass does not confirm.
  void leftRightCheck(float tolerance);
};

Matcher::Matcher(const MatcherParams& params) : impl_(std::make_unique<Impl>()) {
  impl_->right_pass.keeps_confidence = false;
  setParams(params);
}
Matcher::~Matcher() = default;
Matcher::Matcher(Matcher&&) noexcept = default;
Matcher& Matcher::operator=(Matcher&&) noexcept = default;

void Matcher::setParams(const MatcherParams& params) {
  params.validate();
  impl_->params = params;
  impl_->left_pass.configure(params);
  impl_->right_pass.configure(params);
}

void SearchPass::configure(const MatcherParams& p) {
  kernels = &detail::kernelsFor(p.patch_size, detail::bestKernelIsa());
  const int n = p.patch_size;
  const float c = 0.5f * static_cast<float>(n - 1);
  const float inv2s2 = 1.f / (2.f * p.sigma_s * p.sigma_s);
  spatial.resize(static_cast<size_t>(n) * static_cast<size_t>(n));
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const float dx = static_cast<float>(x) - c, dy = static_cast<float>(y) - c;
      spatial[static_cast<size_t>(y * n + x)] = std::exp(-(dx * dx + dy * dy) * inv2s2);
    }
  }
}

const MatcherParams& Matcher::params() const { return impl_->params; }

void SearchPass::allocate(cv::Size size, int levels) {
  const int p = params.patch_size;
  const int window = 2 * params.window_half_width + 1;
  // Every create()/resize() below is a no-op when the size is unchanged, so a
  // steady stream of equal frames allocates nothing.
  init_disparity.resize(static_cast<size_t>(levels) + 1);
  for (int s = params.finest_level + 1; s <= levels; ++s) {
    init_disparity[s].create(std::max(1, size.height >> s), std::max(1, size.width >> s));
  }
  // Level-sized buffers are allocated at the largest searched level (the finest).
  const cv::Size largest(size.width >> params.finest_level, size.height >> params.finest_level);
  level_disparity.create(largest);
  level_confidence.create(keeps_confidence ? largest.height : 1, largest.width);
  if (params.compute_variance) level_variance.create(largest);
  fused_row.resize(static_cast<size_t>(largest.width));
  const int band_rows = fuseBandRows(params);
  for (cv::Mat1f* m : {&fused_num, &fused_den, &conf_sum, &var_num, &var_den}) {
    m->create(band_rows, largest.width);
  }
  cover_x.resize(static_cast<size_t>(largest.width));
  cover_y.resize(static_cast<size_t>(largest.height));
  for (std::vector<float>* v : {&up_ax, &up_weight, &up_disparity, &up_confidence, &up_variance}) {
    v->resize(static_cast<size_t>(std::max(size.width, largest.width)));
  }
  for (std::vector<float>* v : {&up_row_weight, &up_row_disparity, &up_row_confidence}) {
    v->resize(static_cast<size_t>(size.width));
  }
  up_x0.resize(static_cast<size_t>(size.width));
  up_x1.resize(static_cast<size_t>(size.width));
  // xs, ys, patches and loaded_patches grow to the finest level's size on the
  // first frame and keep that capacity afterwards.
  const int max_window_span = static_cast<int>(
      std::ceil(2.f * static_cast<float>(params.window_half_width) * params.window_step));
  row_buf.resize(static_cast<size_t>(p + max_window_span + 2));
  band.left_prefix.resize(static_cast<size_t>(largest.width) + 1);
  band.right_prefix.resize(static_cast<size_t>(largest.width) + 1);
  band.column_count.resize(static_cast<size_t>(largest.width));
  costs.resize(static_cast<size_t>(window));
  likelihood.resize(static_cast<size_t>(window));
  window_sum.resize(static_cast<size_t>(window));
  window_sq.resize(static_cast<size_t>(window));
}

void Matcher::compute(const cv::Mat& left, const cv::Mat& right, MatchResult& result) {
  validateInputs(left, right);
  Impl& m = *impl_;
  const MatcherParams& P = m.params;

  // Levels that hold at least one patch; the finest level is clamped alike.
  const int levels = detail::levelsThatFit(left.cols, left.rows, P.patch_size, P.coarsest_level + 1);
  const int finest = std::min(P.finest_level, levels - 1);

  m.left_pass.params = P;
  m.left_pass.params.finest_level = finest;
  m.left_pass.pyramid.build(left, right, levels, finest);
  const bool check = P.lr_check_tolerance > 0.f;
  m.left_pass.matchLevelsAboveFinest(levels);
  if (check) {
    m.right_pass.params = m.left_pass.params;
    m.right_pass.params.compute_variance = false;
    m.right_pass.params.confidence_floor = 0.f;  // any fused estimate may confirm
    // The check only confirms or refutes: a sparser grid does.
    m.right_pass.params.overlap = P.lr_check_overlap;
    // Mirroring turns "right as reference" into the same left-reference search.
    // Its finest level is mirrored a search band at a time (see buildMirrored).
    m.right_pass.pyramid.buildMirrored(
        m.left_pass.pyramid, levels, finest,
        searchBandLevelRows(m.right_pass.params, m.left_pass.pyramid.level(finest).height));
    m.right_pass.matchLevelsAboveFinest(levels);
  }
  m.matchFinestLevel(finest, check);
  if (check) m.leftRightCheck(P.lr_check_tolerance / static_cast<float>(1 << finest));
  m.left_pass.upsampleToFull(finest, result);
}

namespace {

/// One row of the left-right check: a left estimate whose match column
/// (rounded) has no estimate in the mirrored right-reference row, or one
/// more than `tolerance` away, is dropped. Branch-free, so it vectorises.
BDIS_ROW_LOOP
void leftRightCheckRow(int w, const float* __restrict mirrored, float tolerance,
                       float* __restrict disparity, float* __restrict confidence) {
  for (int x = 0; x < w; ++x) {
    const float d = disparity[x];
    const float match = static_cast<float>(x) - d + 0.5f;
    // Truncation is floor for match >= 0; d < 0 (no estimate) reads column w - 1, unused.
    const int xr = std::min(static_cast<int>(std::max(match, 0.f)), w - 1);
    const float back = mirrored[w - 1 - xr];
    const bool refuted =
        (d >= 0.f) & ((match < 0.f) | (back < 0.f) | (std::fabs(back - d) > tolerance));
    disparity[x] = refuted ? kNoDisparity : d;
    confidence[x] = refuted ? 0.f : confidence[x];
  }
}

}  // namespace

void Matcher::Impl::matchFinestLevel(int finest, bool check) {
  SearchPass& left = left_pass;
  SearchPass& right = right_pass;
  const int p = params.patch_size;
  const int left_rows = left.beginLevel(finest, true);
  const int right_rows = check ? right.beginLevel(finest, true) : 0;
  const int left_band = left.finestBandRows();
  const int right_band = check ? right.finestBandRows() : 0;
  // The right pass mirrors the left pass's level rows a band at a time: its
  // next band waits until the left pass has searched every row that band
  // reads, and no longer, so that it mirrors rows still in cache instead of
  // reading the level back from memory once the left pass is done with it.
  // The order changes no result: the right pass only reads the left pass's
  // pyramid, which neither pass writes.
  int left_top = 0, right_top = 0;
  int left_done = 0;  // level rows the left pass has searched
  while (left_top < left_rows || right_top < right_rows) {
    const int right_bottom = std::min(right_rows, right_top + right_band);
    const bool right_waits =
        right_top < right_rows && left_done < right.ys[static_cast<size_t>(right_bottom - 1)] + p;
    if (left_top < left_rows && (right_top >= right_rows || right_waits)) {
      const int bottom = std::min(left_rows, left_top + left_band);
      left.searchBand(finest, left_top, bottom);
      left_top = bottom;
      left_done = left.ys[static_cast<size_t>(bottom - 1)] + p;
    } else {
      right.searchBand(finest, right_top, right_bottom);
      right_top = right_bottom;
    }
  }
  left.fuseLevel(finest, true);
  if (check) right.fuseLevel(finest, true);
}

void Matcher::Impl::leftRightCheck(float tolerance) {
  const int w = left_pass.pyramid.level(left_pass.params.finest_level).width;
  const int h = left_pass.pyramid.level(left_pass.params.finest_level).height;
  for (int y = 0; y < h; ++y) {
    leftRightCheckRow(w, right_pass.level_disparity[y], tolerance, left_pass.level_disparity[y],
                      left_pass.level_confidence[y]);
  }
}

void SearchPass::matchLevelsAboveFinest(int levels) {
  const int finest = params.finest_level;
  allocate(pyramid.size(), levels);

  // Start from zero disparity above the coarsest level.
  fill(init_disparity[levels], 0.f);
  for (int s = levels - 1; s > finest; --s) {
    searchBand(s, 0, beginLevel(s, false));
    fuseLevel(s, false);
  }
}

int SearchPass::beginLevel(int s, bool finest) {
  const PyramidLevel& L = pyramid.level(s);
  const int p = params.patch_size;
  // Coarser levels only initialise the next one: they get by with fewer patches.
  const double overlap = finest ? params.overlap : params.coarse_overlap;
  const int stride = patchStride(p, overlap);
  patchAxis(L.width, p, stride, xs);
  patchAxis(L.height, p, stride, ys);
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size());
  // Only grown: the finer level has more patches than the coarser one before
  // it, and resizing down and up again would construct them anew every level.
  // Every entry below nx * ny is written by the forward pass before it is read.
  const size_t num_patches = static_cast<size_t>(nx) * static_cast<size_t>(ny);
  if (patches.size() < num_patches) {
    patches.resize(num_patches);
    loaded_patches.resize(num_patches);
  }
  return ny;
}

void SearchPass::searchBand(int s, int top, int bottom) {
  const PyramidLevel& L = pyramid.level(s);
  // The backward pass takes no lower neighbour across a band's bottom edge;
  // the next band's forward pass starts from the final results of its upper
  // neighbours. The check's pass mirrors each band's rows just before it
  // searches them (StereoPyramid::loadRows).
  const int p = params.patch_size;
  pyramid.loadRows(s, ys[static_cast<size_t>(top)], ys[static_cast<size_t>(bottom - 1)] + p);
  forwardPass(L, init_disparity[s + 1], top, bottom);
  backwardPass(L, top, bottom);
}

void SearchPass::forwardPass(const PyramidLevel& L, const cv::Mat1f& coarse, int top, int bottom) {
  const int p = params.patch_size;
  const int nx = static_cast<int>(xs.size());
  const float half = 0.5f * static_cast<float>(p - 1);
  // Forward pass (raster order): start from the coarser level's disparity at
  // the patch centre, times 2, or from the left or upper neighbour's result
  // when that fits this patch better (spatial propagation, as in DIS).
  for (int iy = top; iy < bottom; ++iy) {
    loadBand(L, ys[static_cast<size_t>(iy)]);
    for (int ix = 0; ix < nx; ++ix) {
      const size_t k = static_cast<size_t>(iy * nx + ix);
      const int x0 = xs[static_cast<size_t>(ix)], y0 = ys[static_cast<size_t>(iy)];
      const float cx = (static_cast<float>(x0) + half + 0.5f) * 0.5f - 0.5f;
      const float cy = (static_cast<float>(y0) + half + 0.5f) * 0.5f - 0.5f;
      // cx, cy > 0: adding 0.5 and truncating rounds them (lround is a libm call).
      const int ccx = std::min(static_cast<int>(cx + 0.5f), coarse.cols - 1);
      const int ccy = std::min(static_cast<int>(cy + 0.5f), coarse.rows - 1);
      float u = 2.f * coarse(ccy, ccx);
      patches[k] = PatchEstimate{u, 0.f, 0.f};
      LoadedPatch& record = loaded_patches[k];
      record.loaded = loadPatch(L, x0, y0);
      if (!record.loaded) continue;
      record.constants = cur.constants;
      record.left_all_valid = cur.left_all_valid;
      if (params.propagation) {
        float candidates[2];
        propagate(u, candidates, neighbourCandidates(k, ix > 0, -1, iy > 0, -nx, candidates));
      }
      patches[k].disparity = refinePatch(u);
    }
  }
}

void SearchPass::backwardPass(const PyramidLevel& L, int top, int bottom) {
  const int nx = static_cast<int>(xs.size());
  // Backward pass: the right and lower neighbours get their say, then the
  // patch's posterior is taken at its final disparity.
  for (int iy = bottom - 1; iy >= top; --iy) {
    loadBand(L, ys[static_cast<size_t>(iy)]);
    for (int ix = nx - 1; ix >= 0; --ix) {
      const size_t k = static_cast<size_t>(iy * nx + ix);
      const LoadedPatch& record = loaded_patches[k];
      if (!record.loaded) continue;
      setCurrent(L, xs[static_cast<size_t>(ix)], ys[static_cast<size_t>(iy)], record.left_all_valid);
      cur.constants = record.constants;
      float u = patches[k].disparity;
      if (params.propagation) {
        float candidates[2];
        const int n = neighbourCandidates(k, ix + 1 < nx, 1, iy + 1 < bottom, nx, candidates);
        if (propagate(u, candidates, n)) u = refinePatch(u);
      }
      patches[k] = patchPosterior(u);
    }
  }
}

bool SearchPass::propagate(float& u, const float* candidates, int n) {
  // A candidate this close to the current choice is not worth a cost: the
  // refinement would end where it ends from there (the scores on the colon
  // and generated sequences do not change).
  constexpr float kMinCandidateDistance = 0.1f;
  auto far = [](float a, float b) { return std::fabs(a - b) >= kMinCandidateDistance; };
  // The costs the rule below may compare, in one batch: u's, and each
  // candidate's that is far from u or from an earlier candidate (which may
  // have replaced u by then).
  float values[detail::kMaxBatchSpans] = {u};
  int slot[detail::kMaxBatchSpans - 1] = {-1, -1};  // candidate i's index in values
  int m = 1;
  for (int i = 0; i < n; ++i) {
    bool may_be_tried = far(candidates[i], u);
    for (int j = 0; j < i; ++j) may_be_tried |= slot[j] >= 0 && far(candidates[i], candidates[j]);
    if (may_be_tried) {
      slot[i] = m;
      values[m++] = candidates[i];
    }
  }
  if (m == 1) return false;
  float costs[detail::kMaxBatchSpans];
  patchCosts(values, m, costs);
  float best = costs[0];
  bool moved = false;
  for (int i = 0; i < n; ++i) {
    if (!far(candidates[i], u)) continue;  // else slot[i] >= 0
    const float c = costs[slot[i]];
    if (!(c < best)) continue;
    u = candidates[i];
    best = c;
    moved = true;
  }
  return moved;
}

namespace {

/// Adds each column's invalid pixels (valid is 0 or 1) of one mask row to `count`.
BDIS_ROW_LOOP
void countInvalidRow(int w, const uchar* __restrict valid, uchar* __restrict count) {
  for (int x = 0; x < w; ++x) count[x] = static_cast<uchar>(count[x] + 1 - valid[x]);
}

/// The invalid pixels of rows y0 .. y0 + p - 1 of `valid` per column, as
/// prefix sums along the row; false when there are none.
bool bandPrefix(const uchar* valid, size_t stride, int w, int p, uchar* count, int* prefix) {
  std::fill(count, count + w, uchar{0});
  for (int y = 0; y < p; ++y) countInvalidRow(w, valid + static_cast<size_t>(y) * stride, count);
  int sum = 0;
  prefix[0] = 0;
  for (int x = 0; x < w; ++x) {
    sum += count[x];
    prefix[x + 1] = sum;
  }
  return sum > 0;
}

}  // namespace

void SearchPass::loadBand(const PyramidLevel& L, int y0) {
  const int p = params.patch_size;
  band.left_all_valid = L.left_all_valid ||
      !bandPrefix(L.leftValidRow(y0), L.left_valid.step1(), L.width, p, band.column_count.data(),
                  band.left_prefix.data());
  band.right_all_valid = L.right_all_valid ||
      !bandPrefix(L.rightValidRow(y0), L.right_valid.step1(), L.width, p, band.column_count.data(),
                  band.right_prefix.data());
}

bool SearchPass::loadPatch(const PyramidLevel& L, int x0, int y0) {
  const int p = params.patch_size;
  const int pp = p * p;
  const int left_invalid = band.leftInvalid(x0, x0 + p);
  if (static_cast<float>(pp - left_invalid) < params.min_valid_share * static_cast<float>(pp)) {
    return false;  // mostly outside the rectified view
  }
  setCurrent(L, x0, y0, left_invalid == 0);
  if (cur.left_all_valid) kernels->template_sums(p, cur.view, cur.constants);
  return true;
}

void SearchPass::setCurrent(const PyramidLevel& L, int x0, int y0, bool left_all_valid) {
  cur.level = &L;
  cur.x0 = x0;
  cur.y0 = y0;
  cur.view = {L.leftRow(y0) + x0, L.gradientRow(y0) + x0, rowStride(L.left)};
  cur.valid = L.leftValidRow(y0) + x0;
  cur.left_all_valid = left_all_valid;
  cur.no_invalid_pixels = left_all_valid && band.right_all_valid;
  cur.right_rows = L.rightRow(y0);
  cur.right_stride = rowStride(L.right);
  cur.width = L.width;
}

void SearchPass::patchSums(float u, ResidualSums& r, bool with_gradient) {
  const int p = params.patch_size;
  const SampleSpan span = detail::sampleSpan(cur.x0, u);
  // Fast path: the span and its right neighbour column inside the image and valid.
  if (allValidColumns(span.base, span.base + p + 1)) {
    (with_gradient ? kernels->sums_all_valid : kernels->sums_all_valid_no_gradient)(
        cur.right_rows, cur.right_stride, p, span, cur.view, r);
    r.g = cur.constants.g;
    r.g_sq = cur.constants.g_sq;
    return;
  }
  patchSumsNearInvalidOrEdge(span, r);
}

void SearchPass::patchSumsNearInvalidOrEdge(SampleSpan span, ResidualSums& r) {
  const PyramidLevel& L = *cur.level;
  const int p = params.patch_size;
  // Near or past the image edge with a fully valid template: sum over the
  // columns inside the image, if those are valid.
  if (cur.left_all_valid) {
    const detail::ColumnRange cols = detail::columnsInside(L.width, p, span);
    const int taps = span.frac > 0.f ? 1 : 0;
    const int lo = span.base + cols.begin, hi = span.base + cols.end + taps;
    if (cols.empty() || band.rightInvalid(lo, hi) == 0) {
      kernels->sums_clipped(cur.right_rows, cur.right_stride, p, span, cols, cur.view, r);
      return;
    }
  }
  // Invalid pixels in the template or under the span: every pixel weighted by both validities.
  kernels->sums_masked(cur.right_rows, cur.right_stride, L.rightValidRow(cur.y0),
                       L.right_valid.step1(), L.width, p, span, cur.view, cur.valid,
                       L.left_valid.step1(), r);
}

float SearchPass::templateVariance() const {
  const int p = params.patch_size;
  if (cur.left_all_valid) return cur.constants.variance;
  const float ref = cur.view.tmpl[0];  // sums of t - t[0]: see detail::templateSums
  const size_t valid_stride = cur.level->left_valid.step1();
  float sum = 0.f, sum_sq = 0.f, count = 0.f;
  for (int y = 0; y < p; ++y) {
    const float* t = cur.view.tmpl + static_cast<size_t>(y) * cur.view.stride;
    const uchar* valid = cur.valid + static_cast<size_t>(y) * valid_stride;
    for (int x = 0; x < p; ++x) {
      const float w = valid[x] ? 1.f : 0.f;
      const float v = t[x] - ref;
      sum += w * v;
      sum_sq += w * v * v;
      count += w;
    }
  }
  if (count <= 0.f) return 0.f;
  const float mean = sum / count;
  return std::max(0.f, sum_sq / count - mean * mean);
}

float SearchPass::meanSquaredResidual(const ResidualSums& r) const {
  if (r.count <= 0.f) return std::numeric_limits<float>::infinity();
  const float mean = r.diff / r.count;
  return r.diff_sq / r.count - (params.mean_normalization ? mean * mean : 0.f);
}

float SearchPass::patchCost(float u, float* valid_count) {
  ResidualSums r;
  patchSums(u, r, /*with_gradient=*/false);
  if (valid_count) *valid_count = r.count;
  return meanSquaredResidual(r);
}

void SearchPass::patchCosts(const float* u, int n, float* costs) {
  const int p = params.patch_size;
  SampleSpan spans[detail::kMaxBatchSpans] = {};
  // All spans' columns valid: patchSums would take the all-valid kernel for each.
  int lo = cur.width, hi = 0;
  for (int i = 0; i < n; ++i) {
    spans[i] = detail::sampleSpan(cur.x0, u[i]);
    lo = std::min(lo, spans[i].base);
    hi = std::max(hi, spans[i].base + p + 1);
  }
  if (!allValidColumns(lo, hi)) {
    for (int i = 0; i < n; ++i) costs[i] = patchCost(u[i]);
    return;
  }
  ResidualSums r[detail::kMaxBatchSpans];
  kernels->sums_no_gradient_batch(cur.right_rows, cur.right_stride, p, spans, n, cur.view, r);
  for (int i = 0; i < n; ++i) costs[i] = meanSquaredResidual(r[i]);
}

float SearchPass::refinePatch(float u_start) {
  // Inverse-compositional Gauss-Newton along x, d >= 0.
  const float max_u = static_cast<float>(cur.level->width);
  float u = u_start;
  ResidualSums r;
  for (int it = 0; it < params.iterations; ++it) {
    patchSums(u, r);
    if (r.count <= 0.f) break;
    float b = r.g_diff, H = r.g_sq;
    if (params.mean_normalization) {
      b -= r.diff * r.g / r.count;
      H -= r.g * r.g / r.count;
    }
    if (H <= 1e-6f) break;  // no texture: nothing to align on
    const float step = b / H;
    u = std::clamp(u + step, 0.f, max_u);
    if (std::fabs(step) < 0.01f) break;  // converged: far below what a match resolves
  }
  // Outlier guard: wandered more than a patch from its start.
  if (std::fabs(u - u_start) > static_cast<float>(params.patch_size)) u = u_start;
  return u;
}

float SearchPass::windowCosts(float u) {
  const int n = params.window_half_width;
  const float delta = params.window_step;
  const int p = params.patch_size;
  const int step = static_cast<int>(delta);
  if (static_cast<float>(step) == delta) {
    // Samples whole pixels apart: one interpolated row serves them all.
    const SampleSpan lo = detail::sampleSpan(cur.x0, u + static_cast<float>(n) * delta);
    const int last = lo.base + p + 2 * n * step;  // rightmost column read
    if (allValidColumns(lo.base, last + 1)) {
      kernels->window_costs(cur.right_rows, cur.right_stride, p, lo.base, lo.frac, 2 * n + 1,
                            step, cur.view, params.mean_normalization, row_buf.data(),
                            window_sum.data(), window_sq.data(), costs.data());
      return static_cast<float>(p * p);
    }
  }
  float valid_at_optimum = 0.f;
  for (int j = -n; j <= n; ++j) {
    costs[static_cast<size_t>(j + n)] =
        patchCost(u + static_cast<float>(j) * delta, j == 0 ? &valid_at_optimum : nullptr);
  }
  return valid_at_optimum;
}

PatchEstimate SearchPass::patchPosterior(float u) {
  const int pp = params.patch_size * params.patch_size;
  PatchEstimate est;
  est.disparity = u;
  // Posterior over the window u + k*delta, k = -n..n.
  const int n = params.window_half_width;
  const float delta = params.window_step;
  const float valid_at_optimum = windowCosts(u);
  if (valid_at_optimum < params.min_valid_share * static_cast<float>(pp)) return est;
  const float e0 = costs[static_cast<size_t>(n)];
  if (!std::isfinite(e0)) return est;
  // Local-minimum test: a neighbour as good as the optimum means a flat or
  // saddle cost, not a converged match.
  for (int j = 0; j < 2 * n + 1; ++j) {
    if (j != n && costs[static_cast<size_t>(j)] <= e0) return est;
  }
  // The match must explain the template: a residual as large as the
  // template's own variance means the cost measured the right image's texture,
  // not agreement (a flat or saturated left patch against texture: a highlight
  // or an occluder seen by one camera only).
  if (!(e0 < kMaxResidualShareOfTemplate * templateVariance())) return est;
  const float sigma2 = params.sigma_r * params.sigma_r + params.contrast_share * e0;
  const float inv = 1.f / (2.f * sigma2);
  float sum = 0.f;
  for (int j = 0; j < 2 * n + 1; ++j) {
    const float e = costs[static_cast<size_t>(j)];
    // exp(0) = 1 at the optimum, without the call.
    likelihood[static_cast<size_t>(j)] =
        j == n ? 1.f : std::isfinite(e) ? std::exp(-(e - e0) * inv) : 0.f;
    sum += likelihood[static_cast<size_t>(j)];
  }
  est.posterior = 1.f / sum;
  const float chance = 1.f / static_cast<float>(2 * n + 1);
  est.evidence = std::max(0.f, (est.posterior - chance) / (1.f - chance));

  if (params.compute_variance) {
    // Zero-mean Gaussian with free scale through the window posteriors:
    // least squares of log p_j = a - x_j / (2 v), x_j = (j delta)^2.
    float sx = 0, sy = 0, sxx = 0, sxy = 0, cnt = 0;
    for (int j = -n; j <= n; ++j) {
      const float l = likelihood[static_cast<size_t>(j + n)];
      if (l <= 0.f) continue;
      const float x = static_cast<float>(j * j) * delta * delta;
      const float yv = std::log(l / sum);
      sx += x, sy += yv, sxx += x * x, sxy += x * yv, cnt += 1;
    }
    const float denom = cnt * sxx - sx * sx;
    const float slope = denom > 0.f ? (cnt * sxy - sx * sy) / denom : 0.f;
    est.variance = slope < 0.f ? std::min(maxVariance(), -0.5f / slope) : maxVariance();
  }
  return est;
}

namespace {

// Per-row loops of fusion and upsampling. Their rows are __restrict
// parameters: without them GCC gives up vectorising for the many possible
// aliases between the outputs and the inputs.

/// Fused disparity where any patch survived; 0 elsewhere (the caller fills those).
BDIS_ROW_LOOP
void fusedRow(int n, const float* __restrict num, const float* __restrict den,
              float* __restrict out) {
  for (int x = 0; x < n; ++x) {
    const float d = num[x] / std::max(den[x], std::numeric_limits<float>::min());
    const float value = den[x] > 0.f ? d : 0.f;
    out[x] = value;
  }
}

/// The finest level's output row: fused disparity and confidence where some
/// patch survived and the confidence reaches the floor.
BDIS_ROW_LOOP
void floorRow(int n, const float* __restrict fused, const float* __restrict den,
              const float* __restrict conf_sum, const float* __restrict cover_x, float cover_y,
              float confidence_floor, float* __restrict disparity, float* __restrict confidence) {
  for (int x = 0; x < n; ++x) {
    const float conf = conf_sum[x] / (cover_y * cover_x[x]), f = fused[x];
    const bool keep = (den[x] > 0.f) & (conf >= confidence_floor);  // & : no branch
    const float d = keep ? f : kNoDisparity, c = keep ? conf : 0.f;
    disparity[x] = d;
    confidence[x] = c;
  }
}

/// Blends two level rows with weights (1 - a, a), counting only pixels with
/// an estimate: the weight, weighted disparity and weighted confidence.
BDIS_ROW_LOOP
void blendRows(int n, const float* __restrict d0, const float* __restrict d1,
               const float* __restrict c0, const float* __restrict c1, float a,
               float* __restrict weight, float* __restrict disparity,
               float* __restrict confidence) {
  for (int x = 0; x < n; ++x) {
    const float w0 = d0[x] >= 0.f ? 1.f - a : 0.f;
    const float w1 = d1[x] >= 0.f ? a : 0.f;
    weight[x] = w0 + w1;
    disparity[x] = w0 * d0[x] + w1 * d1[x];
    confidence[x] = w0 * c0[x] + w1 * c1[x];
  }
}

/// dst[x] = (1 - ax[x]) src[x0[x]] + ax[x] src[x1[x]]: one level row
/// interpolated to the output columns.
void interpolateColumns(int n, const int* x0, const int* x1, const float* ax,
                        const float* __restrict src, float* __restrict dst) {
  for (int x = 0; x < n; ++x) dst[x] = (1.f - ax[x]) * src[x0[x]] + ax[x] * src[x1[x]];
}

/// The same for exactly twice the level width (finest level 1, the usual
/// case), where the taps repeat: output columns 2i+1 and 2i+2 lie a quarter
/// and three quarters of the way from level column i to i+1, and the two
/// outermost columns copy the outermost level columns. Same arithmetic, so
/// the same values, but a loop that vectorises.
BDIS_ROW_LOOP
void interpolateColumnsTwice(int level_width, const float* __restrict src, float* __restrict dst) {
  dst[0] = src[0];
  for (int i = 0; i + 1 < level_width; ++i) {
    const float a = src[i], b = src[i + 1];
    dst[2 * i + 1] = 0.75f * a + 0.25f * b;
    dst[2 * i + 2] = 0.25f * a + 0.75f * b;
  }
  dst[2 * level_width - 1] = src[level_width - 1];
}

/// Final output row: weighted means where the input pixel is valid and the
/// estimates around it carry more than a quarter of the weight.
BDIS_ROW_LOOP
void upsampledRow(int n, const uchar* __restrict valid, const float* __restrict weight,
                  const float* __restrict disparity, const float* __restrict confidence,
                  float scale, float* __restrict d_out, float* __restrict c_out) {
  for (int x = 0; x < n; ++x) {
    const bool keep = (valid[x] != 0) & (weight[x] > 0.25f);  // & : no branch
    const float w = std::max(weight[x], 0.25f);
    const float d = scale * disparity[x] / w, c = confidence[x] / w;
    const float d_kept = keep ? d : kNoDisparity, c_kept = keep ? c : 0.f;
    d_out[x] = d_kept;
    c_out[x] = c_kept;
  }
}

/// Patches covering each pixel along one axis of a level.
void coverAlongAxis(const std::vector<int>& origins, int p, std::vector<float>& cover, int extent) {
  std::fill(cover.begin(), cover.begin() + extent, 0.f);
  for (int o : origins) {
    for (int i = o; i < o + p; ++i) cover[static_cast<size_t>(i)] += 1.f;
  }
}

}  // namespace

void SearchPass::fuseLevel(int s, bool finest) {
  const PyramidLevel& L = pyramid.level(s);
  const int p = params.patch_size;
  const int w = L.width;
  const bool variance = params.compute_variance && finest;
  // The band holds level rows [band_top, band_top + band_rows). Patch rows
  // come top to bottom, so when the next one does not fit, the rows above it
  // are final: they are finished, the rest moves up and the band follows.
  // Every pixel sums its patches in the same order as over a whole-level buffer.
  const int band_rows = fused_num.rows;
  cv::Mat1f* const sums[] = {&fused_num, &fused_den, &conf_sum, &var_num, &var_den};
  const int num_sums = variance ? 5 : 3;
  auto clearRows = [&](int from) {
    for (int i = 0; i < num_sums; ++i) {
      for (int y = from; y < band_rows; ++y) std::fill((*sums[i])[y], (*sums[i])[y] + w, 0.f);
    }
  };
  int band_top = 0;
  clearRows(0);
  // The grid is regular: the patches covering a pixel are those covering its
  // column times those covering its row.
  coverAlongAxis(xs, p, cover_x, L.width);
  coverAlongAxis(ys, p, cover_y, L.height);

  const size_t stride = rowStride(fused_num);
  size_t k = 0;
  for (int y0 : ys) {
    if (y0 + p > band_top + band_rows) {
      finishFusedRows(s, finest, band_top, y0);
      const int kept = band_top + band_rows - y0;  // < p: rows the next patches add to
      for (int i = 0; i < num_sums; ++i) {
        for (int y = 0; y < kept; ++y) {
          std::copy((*sums[i])[y0 - band_top + y], (*sums[i])[y0 - band_top + y] + w, (*sums[i])[y]);
        }
      }
      clearRows(kept);
      band_top = y0;
    }
    const int by = y0 - band_top;
    for (int x0 : xs) {
      const PatchEstimate& e = patches[k++];
      if (e.posterior <= 0.f) continue;
      kernels->accumulate_patch(p, spatial.data(), e.posterior, e.disparity, e.evidence,
                                fused_num[by] + x0, fused_den[by] + x0, conf_sum[by] + x0, stride);
      if (variance) {
        for (int y = 0; y < p; ++y) {
          const float* g = spatial.data() + y * p;
          float* vn = var_num[by + y] + x0;
          float* vd = var_den[by + y] + x0;
          for (int x = 0; x < p; ++x) {
            const float wt = e.posterior * g[x];
            vn[x] += wt * wt * e.variance;
            vd[x] += wt * wt;
          }
        }
      }
    }
  }
  finishFusedRows(s, finest, band_top, L.height);
}

void SearchPass::finishFusedRows(int s, bool finest, int band_top, int end) {
  // Dense initialisation for the next finer level: the fused value where any
  // patch survived, otherwise this level's own initialisation.
  const int w = pyramid.level(s).width;
  const bool variance = params.compute_variance && finest;
  const cv::Mat1f& coarse = init_disparity[s + 1];
  for (int y = band_top; y < end; ++y) {
    const int by = y - band_top;
    const float* nr = fused_num[by];
    const float* dr = fused_den[by];
    const float* cr = conf_sum[by];
    const float* coarse_row = coarse[std::min(y / 2, coarse.rows - 1)];
    float* ir = finest ? fused_row.data() : init_disparity[s][y];
    fusedRow(w, nr, dr, ir);
    for (int x = 0; x < w; ++x) {
      if (!(dr[x] > 0.f)) ir[x] = 2.f * coarse_row[std::min(x / 2, coarse.cols - 1)];  // rare
    }
    if (!finest) continue;
    float* dout = level_disparity[y];
    floorRow(w, ir, dr, cr, cover_x.data(), cover_y[static_cast<size_t>(y)],
             params.confidence_floor, dout, level_confidence[keeps_confidence ? y : 0]);
    if (!variance) continue;
    float* vout = level_variance[y];
    const float* vn = var_num[by];
    const float* vd = var_den[by];
    for (int x = 0; x < w; ++x) {
      // Squared weights can underflow for a tiny sigma_s: report the maximal
      // variance then rather than 0/0.
      vout[x] = dout[x] < 0.f ? kNaN : vd[x] > 0.f ? vn[x] / vd[x] : maxVariance();
    }
  }
}

void SearchPass::upsampleToFull(int s, MatchResult& out) {
  const cv::Size full_size = pyramid.size();
  const int W = full_size.width, H = full_size.height;
  const PyramidLevel& L = pyramid.level(s);
  const bool variance = params.compute_variance;
  out.disparity.create(H, W, CV_32FC1);
  out.confidence.create(H, W, CV_32FC1);
  if (variance) {
    out.variance.create(H, W, CV_32FC1);
  } else {
    out.variance.release();
  }
  const PyramidLevel& full = pyramid.level(0);
  const float scale = static_cast<float>(1 << s);
  const float inv = 1.f / scale;
  const float var_scale = scale * scale;
  const int level_width = L.width;
  const bool twice = s == 1 && W == 2 * level_width;
  // Bilinear among the neighbours that have an estimate. The taps of a
  // column are the same on every row: computed once per frame.
  for (int x = 0; x < W; ++x) {
    const float fx = std::clamp((static_cast<float>(x) + 0.5f) * inv - 0.5f, 0.f,
                                static_cast<float>(L.width - 1));
    up_x0[static_cast<size_t>(x)] = static_cast<int>(fx);
    up_x1[static_cast<size_t>(x)] = std::min(static_cast<int>(fx) + 1, L.width - 1);
    up_ax[static_cast<size_t>(x)] = fx - static_cast<float>(static_cast<int>(fx));
  }
  float* vw = up_weight.data();
  float* vd = up_disparity.data();
  float* vc = up_confidence.data();
  float* vv = up_variance.data();
  for (int y = 0; y < H; ++y) {
    // Blend the two level rows first (weights of rows with an estimate, and
    // weighted values), then the two columns of each output pixel.
    const float fy = std::clamp((static_cast<float>(y) + 0.5f) * inv - 0.5f, 0.f,
                                static_cast<float>(L.height - 1));
    const int y0 = static_cast<int>(fy);
    const int y1 = std::min(y0 + 1, L.height - 1);
    const float ay = fy - static_cast<float>(y0);
    const float *d0 = level_disparity[y0], *d1 = level_disparity[y1];
    blendRows(level_width, d0, d1, level_confidence[y0], level_confidence[y1], ay, vw, vd, vc);
    if (variance) {
      const float *v0 = level_variance[y0], *v1 = level_variance[y1];
      for (int x = 0; x < level_width; ++x) {
        // NaN where there is no estimate: only weighted where there is one.
        vv[x] = (d0[x] >= 0.f ? (1.f - ay) * v0[x] : 0.f) + (d1[x] >= 0.f ? ay * v1[x] : 0.f);
      }
    }
    float* hw = up_row_weight.data();
    float* hd = up_row_disparity.data();
    float* hc = up_row_confidence.data();
    for (const auto& [level_row, out_row] : {std::pair<float*, float*>{vw, hw}, {vd, hd}, {vc, hc}}) {
      if (twice) {
        interpolateColumnsTwice(level_width, level_row, out_row);
      } else {
        interpolateColumns(W, up_x0.data(), up_x1.data(), up_ax.data(), level_row, out_row);
      }
    }
    float* dout = out.disparity.ptr<float>(y);
    upsampledRow(W, full.left_valid[y], hw, hd, hc, scale, dout, out.confidence.ptr<float>(y));
    if (!variance) continue;
    float* vout = out.variance.ptr<float>(y);
    for (int x = 0; x < W; ++x) {
      const size_t i0 = static_cast<size_t>(up_x0[static_cast<size_t>(x)]);
      const size_t i1 = static_cast<size_t>(up_x1[static_cast<size_t>(x)]);
      const float ax = up_ax[static_cast<size_t>(x)];
      const float wsum = (1.f - ax) * vw[i0] + ax * vw[i1];
      const float vsum = (1.f - ax) * vv[i0] + ax * vv[i1];
      vout[x] = dout[x] >= 0.f ? var_scale * vsum / wsum : kNaN;
    }
  }
}

}  // namespace bdis
