#include "tool_common.hpp"

#include <algorithm>
#include <cstdio>
#include <exception>
#include <iostream>

namespace bdis {
namespace tools {

int runGuarded(const char* tool, const std::function<int()>& body) {
  try {
    return body();
  } catch (const UsageError& e) {
    std::cerr << tool << ": " << e.what() << "\n(see " << tool << " --help)\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return 1;
  } catch (...) {
    std::cerr << tool << ": error: unknown exception\n";
    return 1;
  }
}

MatcherParams resolveParams(const std::string& preset, const std::string& params_file) {
  MatcherParams p = MatcherParams::preset(preset.empty() ? "balanced" : preset);
  if (!params_file.empty()) p = loadParams(params_file, p);
  return p;
}

MatcherParams applyOverride(MatcherParams params, const std::string& assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos) throw UsageError("expected NAME=VALUE, got '" + assignment + "'");
  const std::string name = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  const ParamField* f = findParamField(name);
  if (!f) throw UsageError("unknown parameter '" + name + "'");
  double v = 0;
  if (text == "true") {
    v = 1;
  } else if (text == "false") {
    v = 0;
  } else {
    size_t used = 0;
    try {
      v = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text.size() || text.empty()) {
      throw UsageError("parameter " + name + " needs a number, got '" + text + "'");
    }
  }
  if (v < f->min_value || v > f->max_value) {
    throw UsageError("parameter " + name + " = " + text + " is out of range [" +
                     std::to_string(f->min_value) + ", " + std::to_string(f->max_value) + "]");
  }
  f->set(params, v);
  return params;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

ProgressBar::ProgressBar(size_t total, std::string label) : total_(total), label_(std::move(label)) {
  update(0);
}

void ProgressBar::update(size_t done) {
  constexpr int kWidth = 30;
  const double frac = total_ ? static_cast<double>(done) / static_cast<double>(total_) : 1.0;
  const int filled = static_cast<int>(frac * kWidth);
  std::fprintf(stderr, "\r%s [%s%s] %zu/%zu", label_.c_str(), std::string(filled, '#').c_str(),
               std::string(kWidth - filled, '.').c_str(), done, total_);
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (finished_) return;
  finished_ = true;
  std::fprintf(stderr, "\n");
}

}  // namespace tools
}  // namespace bdis
