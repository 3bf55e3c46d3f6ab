#include "bdis_stereo/error_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace bdis {
namespace {

void requireSameSize(const cv::Mat& disparity, const cv::Mat& gt, const cv::Mat& other, const char* what) {
  if (disparity.type() != CV_32FC1 || gt.type() != CV_32FC1 || disparity.size() != gt.size() ||
      other.size() != gt.size()) {
    throw std::invalid_argument(std::string(what) +
                                ": disparity and ground truth must be CV_32FC1 and all inputs of one size");
  }
}

/// Non-black pixels (some channel above 0) of an 8-bit image.
cv::Mat1b validMask(const cv::Mat& left) {
  if (left.depth() != CV_8U) throw std::invalid_argument("the left image must be 8-bit");
  const int ch = left.channels();
  cv::Mat1b valid(left.size());
  for (int y = 0; y < left.rows; ++y) {
    const uchar* p = left.ptr<uchar>(y);
    for (int x = 0; x < left.cols; ++x) {
      bool any = false;
      for (int c = 0; c < ch; ++c) any = any || p[x * ch + c] != 0;
      valid(y, x) = any ? 1 : 0;
    }
  }
  return valid;
}

cv::Mat1b greyOf(const cv::Mat& left) {
  if (left.channels() == 1) return left;
  cv::Mat1b grey;
  cv::cvtColor(left, grey, left.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return grey;
}

/// Left pixels whose match in the right view is covered by a nearer surface:
/// each row's ground truth projected into the right image keeps the largest
/// disparity per right column (a z-buffer); a pixel whose disparity lies
/// `margin` below that of the column its match falls in is hidden there.
cv::Mat1b occludedPixels(const cv::Mat1f& gt, float margin) {
  cv::Mat1b occluded(gt.size(), uchar{0});
  std::vector<float> nearest(static_cast<size_t>(gt.cols));
  for (int y = 0; y < gt.rows; ++y) {
    const float* g = gt[y];
    std::fill(nearest.begin(), nearest.end(), 0.f);
    for (int x = 0; x < gt.cols; ++x) {
      if (!(g[x] > 0.f)) continue;
      const float xr = static_cast<float>(x) - g[x];
      const int lo = static_cast<int>(std::floor(xr));
      for (int c : {lo, lo + 1}) {
        if (c >= 0 && c < gt.cols) nearest[static_cast<size_t>(c)] = std::max(nearest[static_cast<size_t>(c)], g[x]);
      }
    }
    for (int x = 0; x < gt.cols; ++x) {
      if (!(g[x] > 0.f)) continue;
      const int c = static_cast<int>(std::lround(static_cast<float>(x) - g[x]));
      if (c >= 0 && c < gt.cols && g[x] < nearest[static_cast<size_t>(c)] - margin) occluded(y, x) = 1;
    }
  }
  return occluded;
}

/// Pixels within `band` of a jump larger than `jump` between 4-neighbours
/// that both have ground truth.
cv::Mat1b depthEdgeBand(const cv::Mat1f& gt, float jump, int band) {
  cv::Mat1b edges(gt.size(), uchar{0});
  for (int y = 0; y < gt.rows; ++y) {
    for (int x = 0; x < gt.cols; ++x) {
      const float g = gt(y, x);
      if (!(g > 0.f)) continue;
      if (x + 1 < gt.cols && gt(y, x + 1) > 0.f && std::fabs(gt(y, x + 1) - g) > jump) {
        edges(y, x) = edges(y, x + 1) = 255;
      }
      if (y + 1 < gt.rows && gt(y + 1, x) > 0.f && std::fabs(gt(y + 1, x) - g) > jump) {
        edges(y, x) = edges(y + 1, x) = 255;
      }
    }
  }
  if (band > 0) {
    cv::dilate(edges, edges, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * band + 1, 2 * band + 1)));
  }
  return edges;
}

/// bad2 of the first k estimates, from the running count of bad ones.
double bad2OfFirst(const std::vector<size_t>& bad_prefix, size_t k) {
  return k ? static_cast<double>(bad_prefix[k]) / static_cast<double>(k) : 0.0;
}

}  // namespace

const char* regionName(PixelRegion region) {
  switch (region) {
    case PixelRegion::OutOfView: return "out_of_view";
    case PixelRegion::Occluded: return "occluded";
    case PixelRegion::Dark: return "dark";
    case PixelRegion::DepthEdge: return "depth_edge";
    case PixelRegion::Rest: return "rest";
  }
  return "?";
}

cv::Mat classifyPixels(const cv::Mat& gt_in, const cv::Mat& left, const RegionOptions& options) {
  if (gt_in.type() != CV_32FC1 || left.size() != gt_in.size()) {
    throw std::invalid_argument("classifyPixels: ground truth must be CV_32FC1, the left image of its size");
  }
  const cv::Mat1f gt = gt_in;
  const cv::Mat1b valid = validMask(left);
  const cv::Mat1b grey = greyOf(left);
  const cv::Mat1b occluded = occludedPixels(gt, options.occlusion_margin_px);
  const cv::Mat1b edges = depthEdgeBand(gt, options.edge_jump_px, options.edge_band_px);
  cv::Mat1b labels(gt.size(), kNotScorable);
  for (int y = 0; y < gt.rows; ++y) {
    for (int x = 0; x < gt.cols; ++x) {
      const float g = gt(y, x);
      if (!(g > 0.f) || !valid(y, x)) continue;
      PixelRegion r = PixelRegion::Rest;
      if (static_cast<float>(x) - g < 0.f) {
        r = PixelRegion::OutOfView;
      } else if (occluded(y, x)) {
        r = PixelRegion::Occluded;
      } else if (grey(y, x) < options.dark_grey) {
        r = PixelRegion::Dark;
      } else if (edges(y, x)) {
        r = PixelRegion::DepthEdge;
      }
      labels(y, x) = static_cast<uchar>(r);
    }
  }
  return std::move(labels);
}

double RegionScore::scorable() const {
  double n = 0;
  for (const Counts& c : regions) n += c.scorable;
  return n;
}

double RegionScore::share(PixelRegion r) const {
  const double all = scorable();
  return all > 0 ? (*this)[r].scorable / all : 0.0;
}

void RegionScore::add(const RegionScore& o) {
  for (size_t i = 0; i < regions.size(); ++i) {
    regions[i].scorable += o.regions[i].scorable;
    regions[i].estimated += o.regions[i].estimated;
    regions[i].bad2 += o.regions[i].bad2;
  }
}

RegionScore scoreRegions(const cv::Mat& disparity, const cv::Mat& gt, const cv::Mat& labels) {
  requireSameSize(disparity, gt, labels, "scoreRegions");
  RegionScore s;
  for (int y = 0; y < gt.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const float* g = gt.ptr<float>(y);
    const uchar* l = labels.ptr<uchar>(y);
    for (int x = 0; x < gt.cols; ++x) {
      if (l[x] == kNotScorable) continue;
      RegionScore::Counts& c = s.regions[l[x]];
      c.scorable += 1;
      if (!(d[x] >= 0.f)) continue;
      c.estimated += 1;
      if (std::fabs(d[x] - g[x]) > 2.f) c.bad2 += 1;
    }
  }
  return s;
}

void InstrumentBandScore::add(const InstrumentBandScore& o) {
  for (auto [to, from] : {std::pair<Band*, const Band*>{&tissue, &o.tissue}, {&rim, &o.rim}}) {
    to->scorable += from->scorable;
    to->estimated += from->estimated;
    to->bad2 += from->bad2;
    to->confident_bad2 += from->confident_bad2;
    to->confidence_sum += from->confidence_sum;
  }
}

InstrumentBandScore scoreInstrumentBands(const cv::Mat& disparity, const cv::Mat& gt, const cv::Mat& regions,
                                         const cv::Mat& surfaces, const cv::Mat& confidence, int band_px,
                                         float confident) {
  requireSameSize(disparity, gt, regions, "scoreInstrumentBands");
  if (surfaces.type() != CV_8UC1 || surfaces.size() != gt.size() ||
      (!confidence.empty() && (confidence.type() != CV_32FC1 || confidence.size() != gt.size()))) {
    throw std::invalid_argument("scoreInstrumentBands: surfaces must be CV_8UC1 and the confidence CV_32FC1 or "
                                "empty, of the ground truth's size");
  }
  if (band_px < 1) throw std::invalid_argument("scoreInstrumentBands: band_px must be >= 1");
  const cv::Mat1b instrument = surfaces == kInstrumentSurface;
  cv::Mat1b grown, shrunk;
  cv::dilate(instrument, grown, cv::Mat(), cv::Point(-1, -1), band_px);
  cv::erode(instrument, shrunk, cv::Mat(), cv::Point(-1, -1), band_px);
  InstrumentBandScore s;
  for (int y = 0; y < gt.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const float* g = gt.ptr<float>(y);
    const uchar* r = regions.ptr<uchar>(y);
    const float* c = confidence.empty() ? nullptr : confidence.ptr<float>(y);
    for (int x = 0; x < gt.cols; ++x) {
      if (r[x] == kNotScorable) continue;
      InstrumentBandScore::Band* band = nullptr;
      if (instrument(y, x)) {
        if (!shrunk(y, x)) band = &s.rim;
      } else if (grown(y, x)) {
        band = &s.tissue;
      }
      if (!band) continue;
      band->scorable += 1;
      if (!(d[x] >= 0.f)) continue;
      band->estimated += 1;
      const bool wrong = std::fabs(d[x] - g[x]) > 2.f;
      if (wrong) band->bad2 += 1;
      if (c) {
        band->confidence_sum += c[x];
        if (wrong && c[x] >= confident) band->confident_bad2 += 1;
      }
    }
  }
  return s;
}

void EstimateSamples::add(const cv::Mat& disparity, const cv::Mat& gt, const cv::Mat& labels,
                          const cv::Mat& confidence_map, const cv::Mat& variance_map) {
  requireSameSize(disparity, gt, labels, "EstimateSamples::add");
  const bool with_confidence = !confidence_map.empty();
  const bool with_variance = !variance_map.empty();
  for (int y = 0; y < gt.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const float* g = gt.ptr<float>(y);
    const uchar* l = labels.ptr<uchar>(y);
    const float* c = with_confidence ? confidence_map.ptr<float>(y) : nullptr;
    const float* v = with_variance ? variance_map.ptr<float>(y) : nullptr;
    for (int x = 0; x < gt.cols; ++x) {
      if (l[x] == kNotScorable) continue;
      scorable += 1;
      if (!(d[x] >= 0.f)) continue;
      abs_error.push_back(std::fabs(d[x] - g[x]));
      confidence.push_back(c ? c[x] : 0.f);
      if (v) sigma.push_back(std::sqrt(std::max(0.f, v[x])));
    }
  }
}

bool Sparsification::monotone(double tolerance) const {
  for (size_t i = 1; i < decile_bad2.size(); ++i) {
    if (decile_bad2[i] > decile_bad2[i - 1] + tolerance) return false;
  }
  return true;
}

Sparsification sparsify(const EstimateSamples& samples) { return sparsifyBy(samples.confidence, samples.abs_error); }

Sparsification sparsifyBy(const std::vector<float>& trust, const std::vector<float>& abs_error) {
  Sparsification s;
  const size_t n = abs_error.size();
  if (n == 0 || trust.size() != n) return s;
  std::vector<size_t> by_confidence(n), by_error(n);
  std::iota(by_confidence.begin(), by_confidence.end(), size_t{0});
  std::iota(by_error.begin(), by_error.end(), size_t{0});
  // Most confident first; ties keep a fixed order (by error, worst first, so
  // that a constant confidence ranks no better than chance would).
  std::stable_sort(by_error.begin(), by_error.end(),
                   [&](size_t a, size_t b) { return abs_error[a] > abs_error[b]; });
  by_confidence = by_error;
  std::stable_sort(by_confidence.begin(), by_confidence.end(),
                   [&](size_t a, size_t b) { return trust[a] > trust[b]; });
  std::reverse(by_error.begin(), by_error.end());  // the oracle: smallest error first
  auto prefixBad = [&](const std::vector<size_t>& order) {
    std::vector<size_t> prefix(n + 1, 0);
    for (size_t i = 0; i < n; ++i) prefix[i + 1] = prefix[i] + (abs_error[order[i]] > 2.f ? 1 : 0);
    return prefix;
  };
  const std::vector<size_t> bad_confident = prefixBad(by_confidence), bad_oracle = prefixBad(by_error);
  // The most confident `parts` twentieths of the estimates (at least one), in whole numbers.
  auto firstK = [&](size_t parts) { return std::max<size_t>(1, (parts * n + 19) / 20); };
  double prev = -1, prev_oracle = -1;
  for (int i = 1; i <= 20; ++i) {
    const size_t k = firstK(static_cast<size_t>(i));
    const double b = bad2OfFirst(bad_confident, k), o = bad2OfFirst(bad_oracle, k);
    if (prev >= 0) {
      s.area += 0.05 * 0.5 * (prev + b);
      s.oracle_area += 0.05 * 0.5 * (prev_oracle + o);
    }
    prev = b;
    prev_oracle = o;
  }
  s.bad2_top25 = bad2OfFirst(bad_confident, firstK(5));
  s.bad2_top50 = bad2OfFirst(bad_confident, firstK(10));
  // Deciles, least confident first: the most confident tenth is the first of by_confidence.
  for (size_t d = 0; d < 10; ++d) {
    const size_t hi = n - (n * d) / 10, lo = n - (n * (d + 1)) / 10;  // [lo, hi) of by_confidence
    const size_t bad = bad_confident[hi] - bad_confident[lo];
    s.decile_bad2[d] = hi > lo ? static_cast<double>(bad) / static_cast<double>(hi - lo) : 0.0;
  }
  return s;
}

std::vector<ThresholdRow> confidenceThresholds(const EstimateSamples& samples, const std::vector<float>& thresholds) {
  std::vector<ThresholdRow> rows;
  for (float t : thresholds) {
    double kept = 0, bad = 0;
    for (size_t i = 0; i < samples.size(); ++i) {
      if (!(samples.confidence[i] >= t)) continue;
      kept += 1;
      bad += samples.abs_error[i] > 2.f ? 1 : 0;
    }
    rows.push_back({t, samples.scorable > 0 ? kept / samples.scorable : 0.0, kept > 0 ? bad / kept : 0.0});
  }
  return rows;
}

double Reliability::mostClaimedOver(float from_confidence, double min_share) const {
  double most = -1;
  for (const ReliabilityBin& b : bins) {
    if (b.lower >= from_confidence && b.share >= min_share) most = std::max(most, b.mean_confidence - b.within2);
  }
  return most;
}

const std::vector<float>& reliabilityEdges() {
  static const std::vector<float> edges = {0.f, 0.5f, 0.6f, 0.7f, 0.8f, 0.9f, 0.95f, 0.98f, 1.f};
  return edges;
}

Reliability reliability(const EstimateSamples& samples, const std::vector<float>& edges) {
  Reliability r;
  if (edges.size() < 2 || samples.confidence.size() != samples.abs_error.size()) return r;
  const size_t bins = edges.size() - 1;
  std::vector<double> count(bins, 0.0), confidence_sum(bins, 0.0), within(bins, 0.0);
  double total = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const float c = samples.confidence[i];
    if (!(c >= edges.front() && c <= edges.back())) continue;
    // The bin whose lower edge is the last one at or below c; c == back() in the last.
    const auto upper = std::upper_bound(edges.begin(), edges.end(), c);
    const size_t b = std::min(static_cast<size_t>(upper - edges.begin()) - 1, bins - 1);
    count[b] += 1;
    confidence_sum[b] += c;
    within[b] += samples.abs_error[i] <= 2.f ? 1 : 0;
    total += 1;
  }
  if (total > 0) {
    r.mean_confidence = std::accumulate(confidence_sum.begin(), confidence_sum.end(), 0.0) / total;
    r.within2 = std::accumulate(within.begin(), within.end(), 0.0) / total;
  }
  for (size_t b = 0; b < bins; ++b) {
    ReliabilityBin bin;
    bin.lower = edges[b];
    bin.upper = edges[b + 1];
    if (count[b] > 0) {
      bin.share = count[b] / total;
      bin.mean_confidence = confidence_sum[b] / count[b];
      bin.within2 = within[b] / count[b];
      r.expected_error += bin.share * std::fabs(bin.mean_confidence - bin.within2);
    }
    r.bins.push_back(bin);
  }
  return r;
}

VarianceCalibration calibrateVariance(const EstimateSamples& samples) {
  VarianceCalibration c;
  if (samples.sigma.size() != samples.abs_error.size() || samples.sigma.empty()) return c;
  std::vector<float> ratio;
  ratio.reserve(samples.sigma.size());
  double one = 0, two = 0;
  for (size_t i = 0; i < samples.sigma.size(); ++i) {
    const float e = samples.abs_error[i], s = samples.sigma[i];
    one += e <= s ? 1 : 0;
    two += e <= 2.f * s ? 1 : 0;
    ratio.push_back(s > 0.f ? e / s : (e > 0.f ? std::numeric_limits<float>::infinity() : 0.f));
  }
  c.samples = ratio.size();
  c.within1 = one / static_cast<double>(c.samples);
  c.within2 = two / static_cast<double>(c.samples);
  std::nth_element(ratio.begin(), ratio.begin() + static_cast<long>(ratio.size() / 2), ratio.end());
  c.median_ratio = ratio[ratio.size() / 2];
  // Ranked as a confidence: the smallest sigma first.
  std::vector<float> trust(samples.sigma.size());
  std::transform(samples.sigma.begin(), samples.sigma.end(), trust.begin(), [](float s) { return -s; });
  c.ranking_ratio = sparsifyBy(trust, samples.abs_error).ratio();
  return c;
}

BorderStripScore scoreBorderStrips(const cv::Mat& disparity, const cv::Mat& left, int strip_px, int reference_from,
                                   int reference_to, float tolerance_px) {
  if (disparity.type() != CV_32FC1 || disparity.size() != left.size()) {
    throw std::invalid_argument("scoreBorderStrips: disparity must be CV_32FC1 of the left image's size");
  }
  const cv::Mat1b valid = validMask(left);
  BorderStripScore s;
  std::vector<float> reference;
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const uchar* v = valid[y];
    int first = 0, last = disparity.cols - 1;
    while (first < disparity.cols && !v[first]) ++first;
    while (last >= 0 && !v[last]) --last;
    if (last - first + 1 < 2 * reference_to) continue;  // too short a span for a strip and its reference
    for (const int side : {+1, -1}) {
      const int end = side > 0 ? first : last;  // the span's end, and inwards is `side`
      reference.clear();
      for (int i = reference_from; i < reference_to; ++i) {
        const float r = d[end + side * i];
        if (r >= 0.f) reference.push_back(r);
      }
      if (reference.empty()) continue;
      std::nth_element(reference.begin(), reference.begin() + static_cast<long>(reference.size() / 2), reference.end());
      const float median = reference[reference.size() / 2];
      for (int i = 0; i < strip_px; ++i) {
        const float e = d[end + side * i];
        if (!(e >= 0.f)) continue;
        s.estimates += 1;
        s.outliers += std::fabs(e - median) > tolerance_px ? 1 : 0;
      }
    }
  }
  return s;
}

double validPixelDensity(const cv::Mat& disparity, const cv::Mat& left) {
  const cv::Mat1b valid = validMask(left);
  double n = 0, with = 0;
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (!valid(y, x)) continue;
      n += 1;
      with += d[x] >= 0.f ? 1 : 0;
    }
  }
  return n > 0 ? with / n : 0.0;
}

}  // namespace bdis
