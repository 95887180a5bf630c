#include "stereo_safety_map/ros/nodelet_params.h"

#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/ros/disparity_params.h"
#include "stereo_safety_map/ros/hybrid_safety_map_params.h"
#include "stereo_safety_map/ros/obstacle_params.h"
#include "stereo_safety_map/ros/occupancy_grid_2d_params.h"
#include "stereo_safety_map/ros/safety_map_params.h"

#include <stdexcept>

namespace stereo_safety_map {

namespace {

template <typename Config>
void append(const ParamFieldList<Config>& list, std::vector<ParamInfo>* out) {
  const std::vector<ParamInfo> infos = list.infos();
  out->insert(out->end(), infos.begin(), infos.end());
}

std::vector<NodeletParams> makeNodeletParams() {
  std::vector<NodeletParams> all;
  {
    NodeletParams n{"safety_map", "config/safety_map.yaml", "cfg/SafetyMap.cfg", {}, {}};
    append(safetyMapRosFields(), &n.params);
    append(obstacleCueFields(), &n.params);
    append(safetyMapperFields(), &n.params);
    append(landmarkStreamFields(), &n.params);
    all.push_back(n);
  }
  {
    NodeletParams n{"disparity", "config/disparity.yaml", "cfg/Disparity.cfg", {}, {}};
    append(disparityRosFields(), &n.params);
    append(disparityPipelineFields(), &n.params);
    n.other_names = {"image_transport"};  // the transport hint (README, subscribed topics)
    all.push_back(n);
  }
  {
    NodeletParams n{"obstacle_detection", "config/obstacle_detection.yaml", "", {}, {}};
    append(obstacleDetectionRosFields(), &n.params);
    append(obstacleDetectionFields(), &n.params);
    all.push_back(n);
  }
  {
    NodeletParams n{"occupancy_grid_2d", "config/occupancy_grid_2d.yaml", "", {}, {}};
    append(occupancyGrid2DRosFields(), &n.params);
    append(occupancyGrid2DFields(), &n.params);
    all.push_back(n);
  }
  {
    NodeletParams n{"hybrid_safety_map", "config/hybrid_safety_map.yaml", "", {}, {}};
    append(hybridSafetyMapParamsFields(), &n.params);
    all.push_back(n);
  }
  return all;
}

}  // namespace

const std::vector<NodeletParams>& allNodeletParams() {
  static const std::vector<NodeletParams> all = makeNodeletParams();
  return all;
}

const NodeletParams& nodeletParams(const std::string& name) {
  for (const NodeletParams& n : allNodeletParams())
    if (n.name == name) return n;
  throw std::out_of_range("no nodelet named " + name);
}

std::vector<std::string> nodeletParameterNames(const std::string& name) {
  const NodeletParams& n = nodeletParams(name);
  std::vector<std::string> names;
  for (const ParamInfo& p : n.params)
    names.push_back(p.name);
  names.insert(names.end(), n.other_names.begin(), n.other_names.end());
  return names;
}

std::string readmeBeginMarker(const std::string& nodelet) {
  return "<!-- parameters of " + nodelet +
         ": generated from the field lists by param_table --readme README.md; edit those -->";
}

std::string readmeEndMarker(const std::string& nodelet) {
  return "<!-- end of the parameters of " + nodelet + " -->";
}

std::string readmeParameterBlock(const NodeletParams& nodelet) {
  return readmeBeginMarker(nodelet.name) + "\n" + markdownList(nodelet.params) +
         readmeEndMarker(nodelet.name);
}

std::string updateReadmeParameterBlocks(const std::string& readme, std::string* error) {
  std::string out = readme;
  for (const NodeletParams& n : allNodeletParams()) {
    const std::string begin = readmeBeginMarker(n.name);
    const std::string end = readmeEndMarker(n.name);
    const std::size_t b = out.find(begin);
    const std::size_t e = b == std::string::npos ? b : out.find(end, b);
    if (e == std::string::npos) {
      if (error != nullptr) *error = "README has no block for " + n.name + ": " + begin;
      return readme;
    }
    out.replace(b, e + end.size() - b, readmeParameterBlock(n));
  }
  if (error != nullptr) error->clear();
  return out;
}

}  // namespace stereo_safety_map
