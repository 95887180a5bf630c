// The field lists (core/param_fields.h) read from flat YAML maps: the parameter files
// config/*.yaml and `--set key=value` of the offline tools, so that they run what the nodelets
// run. The same rules as the ROS reader (param_reader.h): fields in the list's order, wrong
// types refused (an integer must be an integer literal), absent keys keep their values.
#pragma once

#include "stereo_safety_map/core/param_fields.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

namespace stereo_safety_map {

/// A YAML scalar as a value of `type`: booleans as yaml-cpp reads them (true, false, yes, no,
/// ...), integers only as integer literals (not 2.5, not 1e3), doubles also from integers and
/// .inf, strings as written. Empty when converted, else why not.
std::string yamlToParamValue(const YAML::Node& node, ParamType type, ParamValue* value);

/// Reads a YAML file that must be a map of parameters. Empty on success.
std::string loadYamlMap(const std::string& path, YAML::Node* root);

/// `key=value` as a one-key YAML map (the value parsed as YAML). Empty on success.
std::string parseAssignment(const std::string& assignment, YAML::Node* root);

/// Applies the keys of the map `root` that name fields of `list` to `config`, in the list's
/// order; the other keys go to `unknown` (when not null) in the map's order. External fields
/// are known but not applied. Does not validate. Empty on success, else
/// "<where>: bad value for <key>: <why>".
template <typename Config>
std::string applyYamlFields(const YAML::Node& root, const ParamFieldList<Config>& list,
                            Config* config, const std::string& where,
                            std::vector<std::string>* unknown = nullptr) {
  if (!root.IsMap()) return where + ": not a map of parameters";
  for (const ParamField<Config>& f : list.fields()) {
    if (!f.set) continue;
    const YAML::Node n = root[f.info.name];
    if (!n.IsDefined()) continue;
    ParamValue value;
    std::string why = yamlToParamValue(n, f.info.type, &value);
    if (why.empty()) why = f.set(config, value);
    if (!why.empty()) return where + ": bad value for " + f.info.name + ": " + why;
  }
  if (unknown != nullptr) {
    for (const auto& kv : root) {
      const std::string key = kv.first.as<std::string>();
      if (list.find(key) == nullptr) unknown->push_back(key);
    }
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// The core's configuration from the nodelets' flat keys, so that the offline tools (evaluators,
// bench, tests) run what the nodelets run.

/// Applies the keys of the YAML file that name core parameters (the fields of
/// core/config_fields.h's stereoFrameProcessorFields(); others, the nodelets' own settings, are
/// ignored) and validates. Takes config/safety_map.yaml and config/disparity.yaml (the disparity
/// nodelet's matcher and post-filters). Empty on success.
std::string loadCoreParams(const std::string& path, StereoFrameProcessorConfig* c);
/// One `key=value` (same keys as the file; also the disparity stage's: matcher, block_size,
/// enable_texture, ...). Empty on success.
std::string setCoreParam(const std::string& assignment, StereoFrameProcessorConfig* c);
/// The tools' `--params FILE ...` then `--set key=value ...`: loadCoreParams for each file in
/// order, then setCoreParam for each assignment. Empty on success, else the first error.
std::string loadCoreParams(const std::vector<std::string>& files,
                           const std::vector<std::string>& assignments,
                           StereoFrameProcessorConfig* c);

}  // namespace stereo_safety_map
