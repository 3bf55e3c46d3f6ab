#include "matcher_reconfigure.hpp"

#include <utility>

#include <dynamic_reconfigure/Config.h>
#include <ros/console.h>

#include "node_params.hpp"

namespace bdis_stereo {

namespace {
const char* const kSource = "dynamic_reconfigure";
}  // namespace

// Generically through the config message, so that every bdis::paramFields()
// entry maps by name.
bdis::MatcherParams paramsFromConfig(const BdisStereoConfig& config) {
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  bdis::MatcherParams p;
  for (const auto& v : msg.ints) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) {
      bdis::bindParam(p, *f, bdis::ParamValue::ofInteger(v.value), kSource);
    }
  }
  for (const auto& v : msg.doubles) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) {
      bdis::bindParam(p, *f, bdis::ParamValue::ofReal(v.value), kSource);
    }
  }
  for (const auto& v : msg.bools) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) {
      bdis::bindParam(p, *f, bdis::ParamValue::ofBool(v.value), kSource);
    }
  }
  return p;
}

void paramsToConfig(const bdis::MatcherParams& p, BdisStereoConfig& config) {
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  for (auto& v : msg.ints) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) v.value = static_cast<int>(f->get(p));
  }
  for (auto& v : msg.doubles) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) v.value = displayedFloat(f->get(p));
  }
  for (auto& v : msg.bools) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) v.value = f->get(p) != 0.0;
  }
  config.__fromMessage__(msg);
}

MatcherReconfigure::MatcherReconfigure(std::string log_name, std::string preset,
                                       const bdis::MatcherParams& params)
    : log_name_(std::move(log_name)), preset_(preset), params_(params), preset_shown_(std::move(preset)) {}

void MatcherReconfigure::reconfigure(BdisStereoConfig& config) {
  try {
    apply(config);
  } catch (const std::exception& e) {
    ROS_ERROR_NAMED(log_name_, "dynamic_reconfigure: %s", e.what());
  }
}

void MatcherReconfigure::apply(BdisStereoConfig& config) {
  const bool preset_changed = config.preset != preset_;
  if (preset_changed) {
    bdis::MatcherParams preset_params;
    try {
      preset_params = bdis::bindPreset(bdis::ParamValue::ofString(config.preset), kSource);
    } catch (const bdis::ParamError& e) {
      ROS_ERROR_NAMED(log_name_, "%s; keeping preset %s", e.what(), preset_.c_str());
      config.preset = preset_;
      paramsToConfig(params_, config);
      return;
    }
    ROS_INFO_NAMED(log_name_, "dynamic_reconfigure: preset %s", config.preset.c_str());
    preset_ = config.preset;
    paramsToConfig(preset_params, config);
  }
  bdis::MatcherParams requested;
  try {
    requested = paramsFromConfig(config);
    requested.validate();
  } catch (const std::invalid_argument& e) {
    const bdis::ParamError* bound = dynamic_cast<const bdis::ParamError*>(&e);
    ROS_ERROR_NAMED(log_name_, "dynamic_reconfigure: rejected (%s); keeping the previous parameters",
                    bound ? bound->detail().c_str() : e.what());
    paramsToConfig(params_, config);
    return;
  }
  if (!preset_changed) warnAboutRangeEnds(requested);
  params_ = requested;
  std::lock_guard<std::mutex> lock(mutex_);
  preset_shown_ = preset_;
  pending_ = requested;
  changed_ = true;
}

// dynamic_reconfigure clamps a request outside a field's range to the range's
// end before the callback sees it: a field that moved onto an end may have
// been clamped, so say so. Compared as the core stores them (float): 0.1 is
// not 0.1f.
void MatcherReconfigure::warnAboutRangeEnds(const bdis::MatcherParams& requested) const {
  auto same = [](double a, double b) { return static_cast<float>(a) == static_cast<float>(b); };
  for (const bdis::ParamField& f : bdis::paramFields()) {
    const double v = f.get(requested);
    if (f.type == bdis::ParamField::Type::Bool || same(v, f.get(params_))) continue;
    if (same(v, f.min_value) || same(v, f.max_value)) {
      ROS_WARN_NAMED(log_name_,
                     "dynamic_reconfigure: %s = %g, the %s end of its range [%g, %g] (requests outside the "
                     "range are clamped to it)",
                     f.name, v, same(v, f.min_value) ? "lower" : "upper", f.min_value, f.max_value);
    }
  }
}

bool MatcherReconfigure::takeChange(bdis::MatcherParams& params) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!changed_) return false;
  params = pending_;
  changed_ = false;
  return true;
}

std::string MatcherReconfigure::preset() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return preset_shown_;
}

}  // namespace bdis_stereo
