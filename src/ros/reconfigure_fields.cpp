#include "stereo_safety_map/ros/reconfigure_fields.h"

namespace stereo_safety_map {

namespace {

template <typename Parameters>
auto* findParameter(Parameters& params, const std::string& name) {
  for (auto& p : params)
    if (p.name == name) return &p;
  return static_cast<decltype(&params[0])>(nullptr);
}

}  // namespace

bool reconfigureValue(const dynamic_reconfigure::Config& msg, const std::string& name,
                      ParamType type, ParamValue* value) {
  switch (type) {
    case ParamType::kBool:
      if (const auto* p = findParameter(msg.bools, name)) {
        *value = static_cast<bool>(p->value);
        return true;
      }
      return false;
    case ParamType::kInt:
      if (const auto* p = findParameter(msg.ints, name)) {
        *value = static_cast<int>(p->value);
        return true;
      }
      return false;
    case ParamType::kDouble:
      if (const auto* p = findParameter(msg.doubles, name)) {
        *value = static_cast<double>(p->value);
        return true;
      }
      return false;
    case ParamType::kString:
      if (const auto* p = findParameter(msg.strs, name)) {
        *value = std::string(p->value);
        return true;
      }
      return false;
  }
  return false;
}

bool setReconfigureValue(dynamic_reconfigure::Config* msg, const std::string& name,
                         const ParamValue& value) {
  switch (paramTypeOf(value)) {
    case ParamType::kBool:
      if (auto* p = findParameter(msg->bools, name)) {
        p->value = std::get<bool>(value);
        return true;
      }
      return false;
    case ParamType::kInt:
      if (auto* p = findParameter(msg->ints, name)) {
        p->value = std::get<int>(value);
        return true;
      }
      return false;
    case ParamType::kDouble:
      if (auto* p = findParameter(msg->doubles, name)) {
        p->value = std::get<double>(value);
        return true;
      }
      return false;
    case ParamType::kString:
      if (auto* p = findParameter(msg->strs, name)) {
        p->value = std::get<std::string>(value);
        return true;
      }
      return false;
  }
  return false;
}

}  // namespace stereo_safety_map
