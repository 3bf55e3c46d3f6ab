// The photometric cost of one patch at a disparity (docs/method.md, "Patch
// search"): sums of the residual between the right image, sampled at x - u,
// and the left template, over the pixels valid in both views. Chooses per
// call the cheapest kernel the validity of the pixels involved allows.
#pragma once

#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

#include "patch_kernels.hpp"
#include "pyramid.hpp"

namespace bdis {
namespace detail {

/// A patch whose centre's surface covers less than this share of it (its
/// support weights' sum over p^2) is centred on a thin structure, such as a
/// highlight's stripe or a vessel, not on one side of an edge: weighted, it
/// would match that structure's few pixels alone, which a moving highlight
/// puts elsewhere in the other view. It keeps the plain search.
constexpr float kMinSupportShare = 0.5f;

/// The support weights' grey levels (`support_grey`, `support_edge_grey`)
/// hold for a patch whose centre is at least this bright. Below it they
/// scale with the centre's grey level: the same contrast between two
/// surfaces, an instrument and the tissue behind it, spans fewer grey levels
/// in the dark (the lit tissue they were set on lies mostly above it).
constexpr float kSupportFullContrastGrey = 64.f;
/// ... down to this share of them (2 and 6 grey levels at the defaults),
/// about the noise of a dark pixel: a finer grey step is noise, not an edge.
constexpr float kSupportMinContrastShare = 0.25f;

/// The square of the share of such grey levels that holds at grey level
/// `grey` (a patch centre's; the variational refinement's link, its two
/// pixels' mean).
inline float supportContrastShareSq(float grey) {
  const float share = std::clamp(grey * (1.f / kSupportFullContrastGrey), kSupportMinContrastShare, 1.f);
  return share * share;
}

/// Whether a patch's search sums weigh its pixels by their support weights.
enum class SupportWeighting : unsigned char {
  Unknown,   ///< not decided yet (decided when a sum is first asked for)
  Plain,     ///< every pixel weighs 1 (no edge, a thin structure, no valid centre, or the weights off)
  Weighted,  ///< the support weights
};

/// The most validity bands a PatchCost keeps: a search band of more patch
/// rows (or the whole level) reuses the last this many in its backward pass.
constexpr int kMaxKeptBands = 32;

class PatchCost {
 public:
  /// What depends only on the parameters.
  /// `band_rows`: the patch rows a search band holds (0: the whole level),
  /// whose validity bands are kept for its backward pass.
  void configure(const KernelSet& kernels, int patch_size, bool mean_normalization,
                 int window_half_width, float window_step, int band_rows);
  /// Scratch for levels up to `max_width` wide.
  void allocate(int max_width);
  /// Support weights for the patches set from now on (docs/method.md,
  /// "Support weights"): each template pixel weighs 1 / (1 + (g - c)^2 /
  /// grey^2) in the search's costs and Gauss-Newton sums and in the
  /// template's constants, g its grey level and c the patch centre's, so a
  /// patch matches the surface of its centre. 0: every pixel weighs 1. Only
  /// a patch with a pixel more than `edge_grey` from c (an edge) takes them;
  /// the others keep the plain search, bit for bit, and pay only that test
  /// (0: every patch). The posterior's window costs stay plain either way.
  void useSupportWeights(float grey, float edge_grey = 0.f);

  /// Makes the validity band describe level rows y0 .. y0 + p - 1 of L: the
  /// patch row that the following patches lie in. The bands of the last
  /// rows loaded since forgetBands() (a search band's) are kept and reused:
  /// the backward pass revisits the patch rows its forward pass loaded.
  void loadBand(const PyramidLevel& L, int y0);
  /// Drops the kept bands: call before loading bands of another level or
  /// frame (the masks behind them may have changed).
  void forgetBands();
  /// Invalid left pixels of the band's patch at column x0.
  int leftInvalid(int x0) const { return band_.leftInvalid(x0, x0 + p_); }
  /// Makes the patch at (x0, y0) of L current. `constants` are its template
  /// sums when `left_all_valid` (see templateSums), else unused.
  void setPatch(const PyramidLevel& L, int x0, int y0, bool left_all_valid, const TemplateSums& constants);
  /// After setPatch for a patch that was current before: its
  /// supportWeighting() then, which spares the test for an edge.
  void recallSupportWeighting(SupportWeighting weighting) {
    if (support_inv_grey_sq_ > 0.f && weighting != SupportWeighting::Unknown) resolveSupportWeights(weighting);
  }
  /// setPatch for a patch first seen: computes its template sums.
  void loadPatch(const PyramidLevel& L, int x0, int y0, bool left_all_valid);
  bool leftAllValid() const { return cur_.left_all_valid; }
  /// How the current patch's search sums weigh its pixels: Unknown until a
  /// sum (or loadPatch, for a fully valid template) has decided it.
  SupportWeighting supportWeighting() const {
    if (support_inv_grey_sq_ <= 0.f) return SupportWeighting::Plain;
    if (!support_resolved_) return SupportWeighting::Unknown;
    return search_view_ == &weighted_view_ ? SupportWeighting::Weighted : SupportWeighting::Plain;
  }
  const TemplateSums& constants() const { return cur_.constants; }
  int levelWidth() const { return cur_.width; }

  /// The residual sums at disparity u, weighted by the support weights when
  /// in use; g_diff only `with_gradient` (a cost alone needs none).
  void sums(float u, ResidualSums& r, bool with_gradient = true);
  /// Mean squared residual at disparity u (mean-normalised if enabled), as
  /// sums() weighs it; +inf without pixels.
  float cost(float u);
  /// cost() at n <= kMaxBatchSpans disparities (the propagation's
  /// candidates), in one pass over the template when all of them take the
  /// fast path.
  void costs(const float* u, int n, float* out);
  /// The 2n+1 costs of the posterior window around u (u + j * delta, j = -n..n)
  /// into `out`, through one shared interpolation when they allow it;
  /// returns the valid pixels at u. Plain costs: every pixel weighs 1.
  float windowCosts(float u, float* out);
  /// Grey-level variance of the current patch's valid template pixels (weighted
  /// by the support weights when in use).
  float templateVariance();
  float meanSquaredResidual(const ResidualSums& r) const {
    if (r.count <= 0.f) return std::numeric_limits<float>::infinity();
    // One division, not two: the propagation compares costs as soon as they
    // are known, so a division's latency is on its path.
    const float inv_count = 1.f / r.count;
    const float mean = r.diff * inv_count;
    return r.diff_sq * inv_count - (mean_normalization_ ? mean * mean : 0.f);
  }

 private:
  /// The patch being searched: template, gradient and validity read in place
  /// from the level, plus the template's constant sums the fast path needs.
  struct CurrentPatch {
    const PyramidLevel* level = nullptr;
    int x0 = 0, y0 = 0;
    PatchView view{};  ///< without support weights (see weighted_view_)
    const uchar* valid = nullptr;  ///< left validity at (x0, y0), rows level->left_valid.step apart
    bool left_all_valid = false;
    /// Every left pixel of the patch and every right pixel of its patch
    /// row's band valid: an in-image match needs no validity lookup.
    bool no_invalid_pixels = false;
    const float* right_rows = nullptr;  ///< right image, column 0 of row y0
    size_t right_stride = 0;
    int width = 0;  ///< of the level
    /// Sums of gx and gx^2 and the template variance; only when left_all_valid.
    TemplateSums constants{};
  };
  /// The invalid pixels of the current patch row's band (level rows y0 ..
  /// y0 + p - 1) per column, summed along the row (level width + 1 entries):
  /// the count over columns [lo, hi) of the band is prefix[hi] - prefix[lo].
  /// Made for each patch row from the validity masks: that answers every
  /// query of the search, which asks only about the rows of its patch row,
  /// and writes no level-sized integral images (4 MB per pair at 1920x1080).
  struct ValidityBand {
    int y0 = -1;  ///< the band's first level row; -1: none
    int* left_prefix = nullptr;
    int* right_prefix = nullptr;
    bool left_all_valid = false, right_all_valid = false;
    int leftInvalid(int lo, int hi) const { return left_all_valid ? 0 : left_prefix[hi] - left_prefix[lo]; }
    int rightInvalid(int lo, int hi) const { return right_all_valid ? 0 : right_prefix[hi] - right_prefix[lo]; }
  };

  /// Whether the all-valid kernels may read right-image columns [lo, hi) on
  /// the current patch's rows: every template pixel valid, the columns inside
  /// the image and none of them invalid (one count where the band has any).
  bool allValidColumns(int lo, int hi) const {
    return cur_.left_all_valid && lo >= 0 && hi <= cur_.width &&
           (cur_.no_invalid_pixels || band_.rightInvalid(lo, hi) == 0);
  }
  /// The sums of `view` at disparity u by the kernels `k` (the weighted ones
  /// for the weighted view, the plain ones for the plain view).
  [[gnu::always_inline]] inline void sumsOf(const KernelSet& k, const PatchView& view, float u, ResidualSums& r,
                                            bool with_gradient);
  /// sums() where the all-valid kernels may not run: near the image edge or invalid pixels.
  void sumsNearInvalidOrEdge(const KernelSet& k, const PatchView& view, SampleSpan span, bool with_gradient,
                             ResidualSums& r);
  /// The view the search's sums of the current patch read, with
  /// search_kernels_ the kernels for it: with support weights and an edge in
  /// the patch, the weighted view (the weights computed once per patch, when
  /// first asked for) and the weighted twin; else the plain ones.
  const PatchView& searchView() {
    if (support_inv_grey_sq_ <= 0.f) return cur_.view;
    if (!support_resolved_) resolveSupportWeights(SupportWeighting::Unknown);
    return *search_view_;
  }
  /// Whether the current patch takes support weights (`known`, or Unknown:
  /// whether it spans an edge), and if so its weights into support_weights_.
  void resolveSupportWeights(SupportWeighting known);
  /// The grey level the support weights compare with: the mean of the
  /// patch's (up to) four valid centre pixels; false when none is valid.
  bool supportCentre(float& centre) const {
    if (!cur_.left_all_valid) return supportCentreOfValid(centre);
    const float* t = cur_.view.tmpl;
    const size_t s = cur_.view.stride, c0 = centre_index_[0], c1 = centre_index_[1];
    centre = 0.25f * (t[c0 * s + c0] + t[c0 * s + c1] + t[c1 * s + c0] + t[c1 * s + c1]);
    return true;
  }
  bool supportCentreOfValid(float& centre) const;
  /// loadPatch's template constants with support weights. Out of line, so
  /// that the plain path's call carries none of its register saves.
  [[gnu::noinline]] void loadSupportWeighted();
  /// The current patch's search: plain, or with its support weights around
  /// `centre` (and with `sums` the template's constants under them) unless
  /// they cover less than kMinSupportShare of it (then plain, `sums`
  /// untouched, and false).
  void searchPlain() {
    search_view_ = &cur_.view;
    search_kernels_ = kernels_;
  }
  bool searchWeighted(float centre, TemplateSums* sums);

  const KernelSet* kernels_ = nullptr;
  /// kernels_, or their weighted twin for a patch with support weights (see searchView)
  const KernelSet* search_kernels_ = nullptr;
  int p_ = 0;
  bool mean_normalization_ = true;
  int window_half_width_ = 2;
  float window_step_ = 1.f;
  CurrentPatch cur_;
  int kept_bands_ = 1;               ///< the bands allocate() gives kept_ (from configure())
  std::vector<ValidityBand> kept_;  ///< the kept bands, each with its own prefix rows
  std::vector<int> kept_prefix_;    ///< storage of the kept bands' prefix rows
  std::vector<uchar> column_count_; ///< scratch: invalid pixels of each column of a band
  int next_kept_ = 0;               ///< the slot the next band not kept goes to
  ValidityBand band_;               ///< the current band (a copy of its slot)
  std::vector<float> row_buf_, window_sum_, window_sq_;  ///< window_costs kernel scratch
  std::vector<ResidualSums> window_sums_;                ///< window_sums_masked's output
  float support_inv_grey_sq_ = 0.f;     ///< 1 / grey^2 of useSupportWeights; 0: off
  float support_edge_sq_ = 0.f;         ///< edge_grey^2 of useSupportWeights
  size_t centre_index_[2] = {0, 0};     ///< the rows and columns of the patch's four centre pixels
  std::vector<float> support_weights_;  ///< the current patch's, p x p
  bool support_resolved_ = false;       ///< search_view_ and search_kernels_ are the current patch's
  PatchView weighted_view_{};           ///< the current patch's view with support_weights_
  const PatchView* search_view_ = nullptr;  ///< &cur_.view or &weighted_view_
};

}  // namespace detail
}  // namespace bdis
