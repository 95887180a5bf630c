#include "stereo_safety_map/ros/safety_map_export.h"

#include "stereo_safety_map/ros/conversions.h"

#include <octomap/OcTree.h>

#include <opencv2/imgcodecs.hpp>

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace stereo_safety_map {

namespace {

// A temporary name next to `path` that no other save (of this or another nodelet in this
// process, or another process) uses at the same time.
std::string temporaryName(const std::string& path) {
  static std::atomic<std::uint64_t> counter{0};
  return path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
}

// The 3D model as an OctoMap: occupied voxels occupied, voxels with negative log-odds free.
// OctoMap's voxels span [k l, (k + 1) l), ours are centred on k l (Eq. (1)): voxel (u, v, w)
// is stored as OctoMap's voxel (u, v, w), i.e. shifted by l / 2 along each axis.
bool octomapBytes(const VoxelGrid& grid, std::string* bytes) {
  const double l = grid.config().voxel_size;
  octomap::OcTree tree(l);
  const VoxelIndex gmin = grid.minIndex();
  for (int w = gmin.w; w < gmin.w + grid.sizeW(); ++w) {
    for (int v = gmin.v; v < gmin.v + grid.sizeV(); ++v) {
      for (int u = gmin.u; u < gmin.u + grid.sizeU(); ++u) {
        const VoxelIndex i{u, v, w};
        const bool occupied = grid.isOccupied(i);
        if (!occupied && grid.logOdds(i) >= 0) continue;  // unknown
        const octomap::point3d p(static_cast<float>((u + 0.5) * l),
                                 static_cast<float>((v + 0.5) * l),
                                 static_cast<float>((w + 0.5) * l));
        tree.setNodeValue(
            p, occupied ? tree.getClampingThresMaxLog() : tree.getClampingThresMinLog(), true);
      }
    }
  }
  tree.updateInnerOccupancy();
  std::ostringstream os;
  if (!tree.writeBinary(os)) return false;
  *bytes = os.str();
  return true;
}

// The colour picture with 000 Fig. 4(a)'s colours; row 0 is the map's top (largest y).
cv::Mat labelsPicture(const SafetyMap& map) {
  cv::Mat colour(map.height, map.width, CV_8UC3);
  for (int r = 0; r < map.height; ++r) {
    const int v = map.min_v + map.height - 1 - r;
    for (int c = 0; c < map.width; ++c) {
      const int u = map.min_u + c;
      const int k = map.index(u, v);
      const SafetyLabel label = map.labels[k];
      const bool drop = map.drop_off[k] != 0;
      cv::Vec3b bgr(80, 80, 80);  // Unexamined: dark grey
      if (drop && isSafe(label)) {
        bgr = cv::Vec3b(255, 0, 0);  // blue
      } else if (label == SafetyLabel::kLevel) {
        bgr = cv::Vec3b(255, 255, 255);
      } else if (label == SafetyLabel::kInclined) {
        bgr = cv::Vec3b(0, 255, 255);  // yellow
      } else if (label == SafetyLabel::kNonGround) {
        bgr = cv::Vec3b(0, 0, 0);
      } else if (label == SafetyLabel::kUnknown) {
        bgr = cv::Vec3b(200, 200, 200);
      }
      colour.at<cv::Vec3b>(r, c) = bgr;
    }
  }
  return colour;
}

}  // namespace

std::string prepareSavePrefix(const std::string& directory, const std::string& requested,
                              std::string* prefix) {
  // Only under save_directory: a prefix that leaves it (absolute elsewhere, "..", a symlink out)
  // is refused. Checked again once the directories exist, so that a symlink made in between is
  // seen.
  std::string err = resolveSavePrefix(directory, requested, prefix);
  std::error_code ec;
  if (err.empty()) {
    const std::filesystem::path parent = std::filesystem::path(*prefix).parent_path();
    std::filesystem::create_directories(parent, ec);
    if (ec) err = "cannot create " + parent.string() + ": " + ec.message();
  }
  if (err.empty()) err = resolveSavePrefix(directory, requested, prefix);
  return err;
}

std::string makeSaveFiles(const SafetyMapper& mapper, const CostTable& costs_table,
                          const std::string& fixed_frame, const std::string& prefix,
                          std::vector<SaveFile>* files) {
  const SafetyMap& map = mapper.safetyMap();
  if (map.width <= 0 || map.height <= 0) {
    return "no map yet: no frame has been integrated since the start or the last reset";
  }

  std::string octomap;
  if (!octomapBytes(mapper.grid(), &octomap)) return "OctoMap could not serialise the 3D model";
  files->push_back({prefix + ".bt", "", octomap});

  // The safety map for map_server in `mode: raw`: each pixel is the live OccupancyGrid's value
  // (the same cost table, core/map_costs.h; 255 = -1 unknown), so map_server serves exactly the
  // map that was published. Row 0 of the image is the map's top (largest y). Plus a colour
  // picture with 000 Fig. 4(a)'s colours.
  std::vector<std::int8_t> costs;
  const SafetyLabellingConfig& labelling = mapper.config().labelling;
  safetyMapCosts(map, costs_table, labelling.level_slope_deg, labelling.max_slope_deg, &costs);
  files->push_back({prefix + ".pgm", "", costsToRawPgm(costs, map.width, map.height)});

  const nav_msgs::MapMetaData info = mapMetaData(map, ros::Time());
  std::ostringstream yaml;
  yaml << "# Safety map of stereo_safety_map (paper 000 Sec. VI) in map_server's format.\n"
       << "# mode: raw: every pixel is the published OccupancyGrid's value (cost table of the\n"
       << "# README; 255 = -1 unknown). Frame: " << fixed_frame << ".\n"
       << "image: " << std::filesystem::path(prefix).filename().string() << ".pgm\n"
       << "resolution: " << info.resolution << "\n"
       << "origin: [" << info.origin.position.x << ", " << info.origin.position.y << ", 0.0]\n"
       << "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: raw\n";
  files->push_back({prefix + ".yaml", "", yaml.str()});

  std::vector<unsigned char> png;
  if (cv::imencode(".png", labelsPicture(map), png)) {
    files->push_back({prefix + "_labels.png", "", std::string(png.begin(), png.end())});
  }
  return "";
}

std::string writeFilesAtomically(std::vector<SaveFile>* files) {
  std::string err;
  for (SaveFile& f : *files) {
    f.tmp = temporaryName(f.path);
    std::ofstream out(f.tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      err = "cannot open " + f.tmp + " for writing";
      break;
    }
    out.write(f.bytes.data(), static_cast<std::streamsize>(f.bytes.size()));
    out.close();
    if (!out) {
      err = "cannot write " + f.tmp;
      break;
    }
  }
  for (const SaveFile& f : *files) {
    if (!err.empty()) break;
    if (std::rename(f.tmp.c_str(), f.path.c_str()) != 0) {
      err = "cannot rename " + f.tmp + " to " + f.path;
    }
  }
  if (!err.empty()) {
    // Temporary names are unique: removing one that was renamed already fails harmlessly.
    for (const SaveFile& f : *files)
      if (!f.tmp.empty()) std::remove(f.tmp.c_str());
  }
  return err;
}

}  // namespace stereo_safety_map
