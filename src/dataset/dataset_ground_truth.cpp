#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/scene_loader.h"

#include <yaml-cpp/yaml.h>

#include <sys/stat.h>

namespace stereo_safety_map {
namespace dataset {

namespace {
bool exists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}
}  // namespace

std::string recomputeDatasetGroundTruth(const std::string& gt_dir, const std::string& scenes_dir,
                                        const GroundTruthConfig& config, GroundTruthMap* gt,
                                        std::string* scene_path) {
  const std::string meta = gt_dir + "/dataset.yaml";
  if (!exists(meta)) return "no " + meta;
  std::string scene_file, variant;
  try {
    const YAML::Node y = YAML::LoadFile(meta);
    scene_file = y["scene_file"] ? y["scene_file"].as<std::string>() : "";
    variant = y["variant"] ? y["variant"].as<std::string>() : "";
  } catch (const std::exception& e) {
    return "bad " + meta + ": " + e.what();
  }
  if (scene_file.empty()) return meta + " names no scene_file";
  if (!exists(scene_file)) {
    // The path is the one make_dataset was given: try the file's name in scenes_dir.
    const std::string alt = scenes_dir + "/" + scene_file.substr(scene_file.find_last_of('/') + 1);
    if (!exists(alt)) return "scene file " + scene_file + " not found (nor " + alt + ")";
    scene_file = alt;
  }
  SceneFile sf;
  std::string e = loadSceneFromFile(scene_file, variant, &sf);
  if (!e.empty()) return "scene " + scene_file + ": " + e;
  e = computeGroundTruth(sf.scene, config,
                         Eigen::Vector2d(sf.trajectory.start_x, sf.trajectory.start_y), gt);
  if (!e.empty()) return "ground truth of " + scene_file + ": " + e;
  if (scene_path != nullptr) *scene_path = scene_file;
  return "";
}

}  // namespace dataset
}  // namespace stereo_safety_map
