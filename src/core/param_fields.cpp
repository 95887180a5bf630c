#include "stereo_safety_map/core/param_fields.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace stereo_safety_map {

const char* paramTypeName(ParamType type) {
  switch (type) {
    case ParamType::kBool:
      return "bool";
    case ParamType::kInt:
      return "int";
    case ParamType::kDouble:
      return "double";
    case ParamType::kString:
      return "string";
  }
  return "?";
}

ParamType paramTypeOf(const ParamValue& value) {
  switch (value.index()) {
    case 0:
      return ParamType::kBool;
    case 1:
      return ParamType::kInt;
    case 2:
      return ParamType::kDouble;
    default:
      return ParamType::kString;
  }
}

std::string formatParamNumber(double value) {
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  std::ostringstream os;
  if (value == std::floor(value) && std::fabs(value) < 1e15) {
    os << std::fixed << std::setprecision(0) << value;  // 1000000, not 1e+06
  } else {
    os << value;  // %g, 6 significant digits: 0.1, 11.345, 0.00025
  }
  return os.str();
}

std::string formatParamValue(const ParamValue& value) {
  switch (paramTypeOf(value)) {
    case ParamType::kBool:
      return std::get<bool>(value) ? "true" : "false";
    case ParamType::kInt:
      return std::to_string(std::get<int>(value));
    case ParamType::kDouble:
      return formatParamNumber(std::get<double>(value));
    case ParamType::kString:
      return std::get<std::string>(value);
  }
  return "";
}

std::string ParamRange::describe(ParamType type) const {
  if (!text.empty()) return text;
  if (!choices.empty()) {
    std::string s;
    for (const std::string& c : choices) {
      if (!s.empty()) s += " | ";
      s += type == ParamType::kString ? "`" + c + "`" : c;
    }
    return s;
  }
  if (hasMin() && hasMax()) {
    return std::string(min_open ? "(" : "[") + formatParamNumber(min) + ", " +
           formatParamNumber(max) + (max_open ? ")" : "]");
  }
  if (hasMin()) return std::string(min_open ? "> " : ">= ") + formatParamNumber(min);
  if (hasMax()) return std::string(max_open ? "< " : "<= ") + formatParamNumber(max);
  return "";
}

std::string markdownLine(const ParamInfo& info) {
  std::string value = formatParamValue(info.default_value);
  if (info.type == ParamType::kString) value = "`" + value + "`";
  if (!info.unit.empty()) {
    // "1 voxel", "2 voxels"; units of one or two letters (s, px) have no plural.
    const bool one = formatParamValue(info.default_value) == "1";
    const std::string& u = info.unit;
    value += " " + (one && u.size() > 2 && u.back() == 's' ? u.substr(0, u.size() - 1) : u);
  }
  std::string line = "- `~" + info.name + "` (" + paramTypeName(info.type) + ", " + value;
  const std::string range = info.range.describe(info.type);
  if (!range.empty()) line += ", " + range;
  line += ")";
  if (info.live()) line += " [live]";
  line += ": " + info.doc;
  return line;
}

std::string markdownList(const std::vector<ParamInfo>& infos) {
  std::string out;
  bool first = true;
  std::string section;
  for (const ParamInfo& info : infos) {
    if (first || info.section != section) {
      if (!first) out += "\n";
      if (!info.section.empty()) out += info.section + ":\n";
      section = info.section;
      first = false;
    }
    out += markdownLine(info) + "\n";
  }
  return out;
}

}  // namespace stereo_safety_map
