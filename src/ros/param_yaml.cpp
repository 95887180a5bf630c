#include "stereo_safety_map/ros/param_yaml.h"

#include "stereo_safety_map/core/config_fields.h"

#include <climits>
#include <exception>

namespace stereo_safety_map {

std::string yamlToParamValue(const YAML::Node& node, ParamType type, ParamValue* value) {
  if (!node.IsScalar()) return "not a single value";
  const std::string& text = node.Scalar();
  try {
    switch (type) {
      case ParamType::kBool:
        *value = node.as<bool>();
        return "";
      case ParamType::kInt: {
        // as<int>() reads 010 as octal; an integer parameter is a decimal integer literal.
        std::size_t used = 0;
        const long v = std::stol(text, &used, 10);
        if (used != text.size() || v < INT_MIN || v > INT_MAX) break;
        *value = static_cast<int>(v);
        return "";
      }
      case ParamType::kDouble:
        *value = node.as<double>();
        return "";
      case ParamType::kString:
        *value = node.as<std::string>();
        return "";
    }
  } catch (const std::exception&) {
  }
  const char* expected = type == ParamType::kBool  ? "true or false"
                         : type == ParamType::kInt ? "an integer"
                                                   : "a number";
  return "'" + text + "' is not " + expected;
}

std::string loadYamlMap(const std::string& path, YAML::Node* root) {
  try {
    *root = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    return "cannot read " + path + ": " + e.what();
  }
  if (!root->IsMap()) return path + " is not a YAML map of parameters";
  return "";
}

std::string parseAssignment(const std::string& assignment, YAML::Node* root) {
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) return "--set needs key=value, got " + assignment;
  try {
    *root = YAML::Node(YAML::NodeType::Map);
    (*root)[assignment.substr(0, eq)] = YAML::Load(assignment.substr(eq + 1));
  } catch (const std::exception& e) {
    return "--set " + assignment + ": " + e.what();
  }
  return "";
}

std::string loadCoreParams(const std::string& path, StereoFrameProcessorConfig* c) {
  YAML::Node root;
  std::string e = loadYamlMap(path, &root);
  // Keys of the nodelets' own settings (frames, queues, ...) are not the core's: ignored.
  if (e.empty()) e = applyYamlFields(root, stereoFrameProcessorFields(), c, path);
  return e.empty() ? stereoFrameProcessorFields().validate(*c) : e;
}

std::string setCoreParam(const std::string& assignment, StereoFrameProcessorConfig* c) {
  YAML::Node root;
  std::string e = parseAssignment(assignment, &root);
  if (!e.empty()) return e;
  std::vector<std::string> unknown;
  e = applyYamlFields(root, stereoFrameProcessorFields(), c, "--set", &unknown);
  if (!e.empty()) return e;
  if (!unknown.empty()) return "--set: unknown core parameter " + unknown.front();
  return stereoFrameProcessorFields().validate(*c);
}

std::string loadCoreParams(const std::vector<std::string>& files,
                           const std::vector<std::string>& assignments,
                           StereoFrameProcessorConfig* c) {
  for (const std::string& f : files) {
    const std::string e = loadCoreParams(f, c);
    if (!e.empty()) return e;
  }
  for (const std::string& a : assignments) {
    const std::string e = setCoreParam(a, c);
    if (!e.empty()) return e;
  }
  return "";
}

}  // namespace stereo_safety_map
