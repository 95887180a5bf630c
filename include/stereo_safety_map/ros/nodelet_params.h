// Every nodelet's parameters, put together from the field lists (core/param_fields.h) in the
// order the README lists them: the unknown-parameter warnings, the README's Parameters lists
// (src/tools/param_table.cpp) and test_nodelet_params (YAML, .cfg, README) all read this.
#pragma once

#include "stereo_safety_map/core/param_fields.h"

#include <string>
#include <vector>

namespace stereo_safety_map {

struct NodeletParams {
  std::string name;  ///< "safety_map": the README's marker and config/<name>.yaml
  std::string yaml;  ///< its parameter file, relative to the package: config/safety_map.yaml
  std::string cfg;   ///< its dynamic_reconfigure file (cfg/SafetyMap.cfg), empty when none
  std::vector<ParamInfo> params;  ///< every field of its lists, README order, with defaults
  /// Names read by libraries that are neither in the YAML file nor in the Parameters list
  /// (image_transport's transport hint, documented with the topics).
  std::vector<std::string> other_names;
};

/// safety_map, disparity, obstacle_detection, occupancy_grid_2d, hybrid_safety_map.
const std::vector<NodeletParams>& allNodeletParams();
/// One of them by name; throws std::out_of_range for another name.
const NodeletParams& nodeletParams(const std::string& name);
/// Every name the nodelet reads from its private namespace (params and other_names).
std::vector<std::string> nodeletParameterNames(const std::string& name);

/// The README's generated block of a nodelet: begin marker, markdownList(params), end marker.
std::string readmeParameterBlock(const NodeletParams& nodelet);
/// The README's markers of the block (HTML comments, invisible when rendered).
std::string readmeBeginMarker(const std::string& nodelet);
std::string readmeEndMarker(const std::string& nodelet);
/// `readme` with every nodelet's block replaced by the generated one; `error` names a nodelet
/// whose markers are missing.
std::string updateReadmeParameterBlocks(const std::string& readme, std::string* error);

}  // namespace stereo_safety_map
