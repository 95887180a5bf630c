// evaluate_safety_map: the evaluation framework of paper 000 Sec. VII on rosbags, without a
// roscore. Reads each dataset bag directly (rosbag::View), runs the core pipeline the nodelets run
// (StereoFrameProcessor: disparity -> reprojection -> SafetyMapper) on every stereo pair with the
// camera pose from the bag's tf, compares each safety map with the dataset's ground truth and
// writes metrics.json, report.md, per-frame CSVs and PNGs.
//
//   evaluate_safety_map --bag A.bag [--bag B.bag ...] [--latency-bag L.bag ...] [--out DIR]
//                       [--decr 1,3,5] [--every N] [--max-frames N] [--images N]
//                       [--plane-frames N] [--seed S] [--params config/safety_map.yaml]
//                       [--recorded REC.bag] [--fixed-frame odom] [--base-frame base_link]
//                       [--camera stereo] [--no-model] [--quiet]
//
// Measures (docs/evaluation.md):
//  - FN / FP / TP / TN rates of 000 Sec. VII-A per frame and per dataset (from sums over the
//    dataset's maps), averaged over datasets with standard deviations; stationary frames are
//    skipped by the mapper and not evaluated;
//  - safe-class precision / recall / F1 of 001 Sec. 5;
//  - plane accuracy of 000 Sec. VII-C (normal angle, mean distance) of all safe planes in
//    --plane-frames randomly chosen frames per dataset (the paper's protocol) and in all frames;
//  - frame latency of 000 Sec. VII-B on the --latency-bag datasets: frames until 50 % / 90 % of the
//    board's width is occupied in the 3D grid;
//  - wall time per stage and per frame.
// --decr 1,3,5 runs one mapper per value on the same disparity images (Table II, Fig. 6(a)).
// --recorded REC.bag evaluates the SafetyMap messages recorded from the nodelets (topic
// safety_map_labels) against the ground truth of the single --bag instead of running the core.
#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/map_image.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/ros/msgs.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/tools/boards.h"
#include "stereo_safety_map/tools/dataset_reader.h"
#include "stereo_safety_map/tools/json.h"

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/TransformStamped.h>
#include <image_geometry/stereo_camera_model.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>
#include <yaml-cpp/yaml.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace ssm = stereo_safety_map;
namespace sdata = stereo_safety_map::dataset;
using ssm::SafetyLabel;

namespace {

using Clock = std::chrono::steady_clock;
using ssm::fileExists;
using ssm::labelColour;
using ssm::makeDirs;
using ssm::mapBesideGroundTruth;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// Options

struct Options {
  std::vector<std::string> bags;
  std::vector<std::string> latency_bags;
  std::string out = "out/evaluation";
  std::vector<int> decr = {1};
  int every = 1;
  long max_frames = -1;
  int images = 3;
  int plane_frames = 5;
  unsigned seed = 1;
  std::vector<std::string> params;
  std::vector<std::string> sets;
  std::string recorded;
  std::string fixed_frame = "odom";
  std::string base_frame = "base_link";
  std::string camera = "stereo";
  bool model = true;
  bool quiet = false;
  int dump_frame = -1;
  std::string scenes = "scenes";  // where to look for scene files (local-horizon GT)  // print the
                                  // segments of this stereo pair's map (first dataset, first decr)
};

void usage() {
  std::fprintf(
      stderr,
      "usage: evaluate_safety_map --bag FILE [--bag FILE ...] [--latency-bag FILE ...] [--out "
      "DIR]\n"
      "         [--decr 1,3,5] [--every N] [--max-frames N] [--images N] [--plane-frames N]\n"
      "         [--seed S] [--params YAML] [--set key=value ...] [--recorded REC.bag]\n"
      "         [--fixed-frame F] [--base-frame F]\n"
      "         [--camera NS] [--no-model] [--quiet]\n"
      "  --bag          dataset bag made by make_dataset (ground truth in <bag>_gt/ and in the "
      "bag)\n"
      "  --latency-bag  dataset with a board (000 Sec. VII-B): frame latency only\n"
      "  --decr         one mapper per value on the same disparities (000 Table II)\n"
      "  --every N      process every N-th stereo pair only (faster, changes the maps)\n"
      "  --images N     safety map / GT / error PNGs of N frames per dataset (0 = none)\n"
      "  --plane-frames frames per dataset drawn at random (--seed) for plane accuracy (000 "
      "VII-C)\n"
      "  --params       YAML with the nodelets' flat parameters (config/safety_map.yaml,\n"
      "                 config/disparity.yaml); may be given more than once\n"
      "  --set k=v      one parameter (after --params), e.g. --set matcher=sgbm\n"
      "  --scenes DIR   scene files for the local-horizon GT, when not where make_dataset read\n"
      "                 them (default scenes)\n"
      "  --dump-frame N print the segments (label, size, height, plane, reachability) of pair N's\n"
      "                 map with the first --decr (debugging)\n"
      "  --recorded     evaluate SafetyMap messages recorded from the nodelets instead of running\n"
      "                 the core (one --bag: the dataset the recording was made from)\n");
}

bool parseIntList(const std::string& s, std::vector<int>* out) {
  out->clear();
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (end == item.c_str() || *end != '\0' || v < 0 || v > 10000) return false;
    out->push_back(static_cast<int>(v));
  }
  return !out->empty();
}

bool parseArgs(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    const char* v = nullptr;
    if (a == "--bag" && (v = next())) {
      o->bags.push_back(v);
    } else if (a == "--latency-bag" && (v = next())) {
      o->latency_bags.push_back(v);
    } else if (a == "--out" && (v = next())) {
      o->out = v;
    } else if (a == "--decr" && (v = next())) {
      if (!parseIntList(v, &o->decr)) return false;
    } else if (a == "--every" && (v = next())) {
      o->every = std::atoi(v);
      if (o->every < 1) return false;
    } else if (a == "--max-frames" && (v = next())) {
      o->max_frames = std::atol(v);
    } else if (a == "--images" && (v = next())) {
      o->images = std::max(0, std::atoi(v));
    } else if (a == "--plane-frames" && (v = next())) {
      o->plane_frames = std::max(0, std::atoi(v));
    } else if (a == "--seed" && (v = next())) {
      o->seed = static_cast<unsigned>(std::strtoul(v, nullptr, 10));
    } else if (a == "--params" && (v = next())) {
      o->params.push_back(v);
    } else if (a == "--set" && (v = next())) {
      o->sets.push_back(v);
    } else if (a == "--recorded" && (v = next())) {
      o->recorded = v;
    } else if (a == "--fixed-frame" && (v = next())) {
      o->fixed_frame = v;
    } else if (a == "--base-frame" && (v = next())) {
      o->base_frame = v;
    } else if (a == "--camera" && (v = next())) {
      o->camera = v;
    } else if (a == "--no-model") {
      o->model = false;
    } else if (a == "--quiet") {
      o->quiet = true;
    } else if (a == "--scenes" && (v = next())) {
      o->scenes = v;
    } else if (a == "--dump-frame" && (v = next())) {
      o->dump_frame = std::atoi(v);
    } else {
      std::fprintf(stderr, "bad or incomplete argument: %s\n", a.c_str());
      return false;
    }
  }
  if (o->bags.empty() && o->latency_bags.empty()) return false;
  if (!o->recorded.empty() && (o->bags.size() != 1 || !o->latency_bags.empty())) {
    std::fprintf(stderr, "--recorded needs exactly one --bag (the dataset it was recorded from)\n");
    return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Statistics

struct Series {
  std::vector<double> v;
  void add(double x) { v.push_back(x); }
  double mean() const {
    return v.empty() ? kNaN : std::accumulate(v.begin(), v.end(), 0.0) / v.size();
  }
  double quantile(double q) const {
    if (v.empty()) return kNaN;
    std::vector<double> s = v;
    std::sort(s.begin(), s.end());
    return s[std::min(s.size() - 1, static_cast<std::size_t>(q * (s.size() - 1) + 0.5))];
  }
  double max() const { return v.empty() ? kNaN : *std::max_element(v.begin(), v.end()); }
};

const char* kStageNames[] = {"disparity", "reproject", "update",       "height_map", "segmentation",
                             "plane_fit", "labelling", "mapper_total", "frame_total"};
constexpr int kStages = 9;

struct PlaneSample {
  int frame = 0;
  std::string reference;
  double angle_deg = 0.0;
  double distance = 0.0;
  int cells = 0;
  SafetyLabel label = SafetyLabel::kLevel;
};

struct LatencyResult {
  std::string board;
  double start_distance = kNaN;  // optical centre to the board's face at the first frame [m]
  int appear_frame = -1;         // first frame with the board in view (0-based)
  std::vector<double> coverage;  // per camera frame from the appearance
  int frames_to_50 = -1;
  int frames_to_90 = -1;
  int frames_available = 0;
};

struct FrameRecord {
  int index = 0;
  double stamp = 0.0;
  std::string status;
  bool robot_segment = false;
  ssm::ConfusionCounts counts;
  std::size_t points = 0;
  double ms[kStages] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
};

struct DatasetResult {
  std::string name;
  bool latency_only = false;
  int pairs = 0;       // stereo pairs read
  int integrated = 0;  // maps evaluated
  int stationary = 0;
  int rejected = 0;  // no tf, bad images, ...
  int without_robot_segment = 0;
  // Where the false positives are (diagnostics): cells of ground segments labelled Non-ground
  // (unreachable or too steep, Alg. 2), columns in no segment (heights unlike their neighbours),
  // and all FPs of maps without the robot's segment.
  std::uint64_t fp_in_segment = 0, fp_no_segment = 0, fp_without_robot_segment = 0;
  ssm::ConfusionCounts sum;
  ssm::ConfusionCounts seeded;  // maps in which the robot's segment was found
  // Against the local-horizon GT: the scene's GT relabelled at every frame with reachability
  // from the robot's position within R_max (what the robot could know), when the scene file
  // is found; `local_maps` counts the maps compared.
  ssm::ConfusionCounts local;
  int local_maps = 0;
  Series stage_ms[kStages];
  std::vector<PlaneSample> planes_all;
  std::vector<PlaneSample> planes_protocol;
  std::vector<int> protocol_frames;
  std::vector<LatencyResult> latency;
  std::vector<FrameRecord> frames;
  std::vector<std::string> images;
  double bag_seconds = 0.0;
  double wall_seconds = 0.0;
  std::map<std::string, int> problems;
};

struct Run {
  std::string label;  // "decr=1" or "recorded"
  int decr = 1;
  std::vector<DatasetResult> datasets;
};

// The hybrid 3D model of 000 Fig. 4(b): occupied voxels of Non-ground cells as grey cubes, safe
// segments as their planes over their cells (Level green, Inclined yellow), rendered with a
// painter's algorithm from behind and above the robot.
cv::Mat render3dModel(const ssm::SafetyMapper& mapper, const Eigen::Vector3d& robot, double yaw) {
  const ssm::SafetyMap& map = mapper.safetyMap();
  const ssm::VoxelGrid& grid = mapper.grid();
  const double l = grid.config().voxel_size;
  struct Face {
    std::array<Eigen::Vector3d, 4> p;
    cv::Vec3b colour;
    Eigen::Vector3d normal;
    double depth = 0.0;
  };
  std::vector<Face> faces;
  const Eigen::Vector3d fwd(std::cos(yaw), std::sin(yaw), 0.0);
  const Eigen::Vector3d eye = robot - 4.5 * fwd + Eigen::Vector3d(0, 0, 5.0);
  const Eigen::Vector3d target = robot + 2.5 * fwd;
  const Eigen::Vector3d zc = (target - eye).normalized();
  const Eigen::Vector3d xc = zc.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d yc = zc.cross(xc);
  const double top = robot.z() + mapper.config().height_map.robot_height;

  for (int k = 0; k < map.width * map.height; ++k) {
    const int u = map.min_u + k % map.width, v = map.min_v + k / map.width;
    const SafetyLabel lab = map.labels[k];
    const Eigen::Vector3d cc(u * l, v * l, 0.0);
    if (ssm::isSafe(lab) && map.segment[k] >= 0 &&
        map.segment[k] < static_cast<int>(map.segments.size())) {
      const ssm::GroundPlane& pl = map.segments[map.segment[k]].plane;
      if (!pl.valid) continue;
      Face f;
      const double h = 0.5 * l;
      const double dx[4] = {-h, h, h, -h}, dy[4] = {-h, -h, h, h};
      for (int i = 0; i < 4; ++i) {
        const double x = cc.x() + dx[i], y = cc.y() + dy[i];
        f.p[i] = Eigen::Vector3d(x, y, pl.heightAt(x, y));
      }
      f.normal = pl.normal;
      f.colour = lab == SafetyLabel::kLevel ? cv::Vec3b(60, 200, 60) : cv::Vec3b(0, 220, 240);
      faces.push_back(f);
    } else if (lab == SafetyLabel::kNonGround) {
      const ssm::VoxelIndex gmin = grid.minIndex();
      for (int w = gmin.w; w < gmin.w + grid.sizeW(); ++w) {
        const ssm::VoxelIndex i{u, v, w};
        if (!grid.isOccupied(i) || w * l > top) continue;
        const Eigen::Vector3d c(u * l, v * l, w * l);
        // Six faces; skip those between two occupied voxels and those facing away.
        const int du[6] = {1, -1, 0, 0, 0, 0}, dv[6] = {0, 0, 1, -1, 0, 0},
                  dw[6] = {0, 0, 0, 0, 1, -1};
        for (int fi = 0; fi < 6; ++fi) {
          const Eigen::Vector3d n(du[fi], dv[fi], dw[fi]);
          if (grid.isOccupied({u + du[fi], v + dv[fi], w + dw[fi]})) continue;
          const Eigen::Vector3d fc = c + 0.5 * l * n;
          if ((eye - fc).dot(n) <= 0.0) continue;
          Eigen::Vector3d a1, a2;
          if (fi < 2) {
            a1 = Eigen::Vector3d::UnitY();
            a2 = Eigen::Vector3d::UnitZ();
          } else if (fi < 4) {
            a1 = Eigen::Vector3d::UnitX();
            a2 = Eigen::Vector3d::UnitZ();
          } else {
            a1 = Eigen::Vector3d::UnitX();
            a2 = Eigen::Vector3d::UnitY();
          }
          Face f;
          const double h = 0.5 * l;
          f.p = {fc - h * a1 - h * a2, fc + h * a1 - h * a2, fc + h * a1 + h * a2,
                 fc - h * a1 + h * a2};
          f.normal = n;
          f.colour = cv::Vec3b(150, 150, 150);
          faces.push_back(f);
        }
      }
    }
  }
  const int W = 960, H = 720;
  const double focal = 700.0;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(250, 245, 240));
  for (Face& f : faces) {
    f.depth = 0.0;
    for (const auto& p : f.p)
      f.depth += 0.25 * (p - eye).dot(zc);
  }
  std::sort(faces.begin(), faces.end(),
            [](const Face& a, const Face& b) { return a.depth > b.depth; });
  const Eigen::Vector3d light = Eigen::Vector3d(-0.4, -0.3, 1.0).normalized();
  for (const Face& f : faces) {
    std::vector<cv::Point> poly;
    bool ok = true;
    for (const auto& p : f.p) {
      const Eigen::Vector3d q = p - eye;
      const double z = q.dot(zc);
      if (z < 0.2) {
        ok = false;
        break;
      }
      poly.emplace_back(static_cast<int>(W / 2 + focal * q.dot(xc) / z),
                        static_cast<int>(H / 2 + focal * q.dot(yc) / z));
    }
    if (!ok) continue;
    const double shade = 0.55 + 0.45 * std::abs(f.normal.dot(light));
    const cv::Scalar col(f.colour[0] * shade, f.colour[1] * shade, f.colour[2] * shade);
    cv::fillConvexPoly(img, poly, col, cv::LINE_AA);
    cv::polylines(img, poly, true, col * 0.8, 1, cv::LINE_AA);
  }
  // The robot: a red marker at its base.
  const Eigen::Vector3d q = robot - eye;
  if (q.dot(zc) > 0.2) {
    cv::circle(img,
               cv::Point(static_cast<int>(W / 2 + focal * q.dot(xc) / q.dot(zc)),
                         static_cast<int>(H / 2 + focal * q.dot(yc) / q.dot(zc))),
               8, cv::Scalar(0, 0, 255), cv::FILLED, cv::LINE_AA);
  }
  cv::putText(img,
              "hybrid 3D model (000 Fig. 4(b)): Level planes green, Inclined yellow, Non-ground "
              "voxels grey",
              cv::Point(10, 24), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  return img;
}

// ---------------------------------------------------------------------------------------------
// Bag reading

// ---------------------------------------------------------------------------------------------
// Offline evaluation: the core on each stereo pair of each dataset, one mapper per decr value.

struct MapperSlot {
  std::unique_ptr<ssm::StereoFrameProcessor> processor;
  DatasetResult* result = nullptr;
};

void evaluateFrameMap(const ssm::Dataset& ds, const ssm::SafetyMap& map, int frame, double stamp,
                      bool protocol_frame, FrameRecord* rec, DatasetResult* res,
                      std::vector<ssm::CellOutcome>* outcomes) {
  rec->robot_segment = map.robot_segment >= 0;
  const std::string e = ssm::countConfusion(map, ds.gt, &rec->counts, outcomes);
  if (!e.empty()) {
    ++res->problems["confusion: " + e];
    return;
  }
  res->sum += rec->counts;
  if (rec->robot_segment) {
    res->seeded += rec->counts;
    if (outcomes != nullptr && map.segment.size() == outcomes->size()) {
      for (std::size_t k = 0; k < outcomes->size(); ++k) {
        if ((*outcomes)[k] != ssm::CellOutcome::kFalsePositive) continue;
        ++(map.segment[k] >= 0 ? res->fp_in_segment : res->fp_no_segment);
      }
    }
  } else {
    ++res->without_robot_segment;
    res->fp_without_robot_segment += rec->counts.fp;
  }
  (void)stamp;
  for (const ssm::SegmentInfo& s : map.segments) {
    if (!ssm::isSafe(s.label) || !s.plane.valid) continue;
    const ssm::PlaneAccuracy a = ssm::comparePlane(s.plane, s.cells, map, ds.planes);
    if (!a.matched) continue;
    PlaneSample p;
    p.frame = frame;
    p.reference = ds.planes[a.reference].name;
    p.angle_deg = a.angle_deg;
    p.distance = a.mean_distance;
    p.cells = a.cells;
    p.label = s.label;
    res->planes_all.push_back(p);
    if (protocol_frame) res->planes_protocol.push_back(p);
  }
}

// --dump-frame: one line per segment of a map, and what the cells of each label are in the GT.
void dumpSegments(const ssm::Dataset& ds, const ssm::SafetyMap& map, int frame) {
  std::printf("%s pair %d: %zu segments, robot segment %d, robot cell (%d, %d)\n", ds.name.c_str(),
              frame, map.segments.size(), map.robot_segment, map.robot_u, map.robot_v);
  std::printf(
      "  id label      cells int bnd   w island reach slope_deg  rms_cm points  "
      "x_mean y_mean  gt: level incl nonground unknown\n");
  for (const ssm::SegmentInfo& s : map.segments) {
    int gt[5] = {0, 0, 0, 0, 0};
    double sx = 0.0, sy = 0.0;
    for (int c : s.cells) {
      const int u = map.min_u + c % map.width, v = map.min_v + c / map.width;
      ++gt[static_cast<int>(ds.gt.at(u, v))];
      sx += u * map.resolution;
      sy += v * map.resolution;
    }
    if (ssm::isSafe(s.label) && gt[4] > 0) {
      std::printf("  segment %d: safe cells the GT calls Non-ground (x, y):", s.id);
      for (int c : s.cells) {
        const int u = map.min_u + c % map.width, v = map.min_v + c / map.width;
        if (ds.gt.at(u, v) == SafetyLabel::kNonGround)
          std::printf(" (%.1f, %.1f)", u * map.resolution, v * map.resolution);
      }
      std::printf("\n");
    }
    const double n = std::max<std::size_t>(1, s.cells.size());
    std::printf(
        "  %2d %-10s %5zu %3d %3d %3d %6s %5s %9.2f %7.2f %6zu %7.2f %6.2f      %5d %4d %9d %7d\n",
        s.id, ssm::toString(s.label), s.cells.size(), s.num_interior, s.num_boundary,
        s.indexed_height, s.island ? "yes" : "no", s.reachable ? "yes" : "no",
        s.plane.valid ? s.plane.slope_deg : kNaN, s.plane.valid ? 100 * s.plane.residual_rms : kNaN,
        s.plane.num_points, sx / n, sy / n, gt[2], gt[3], gt[4], gt[1]);
  }
}

std::vector<int> chooseFrames(int total, int count, unsigned seed) {
  std::vector<int> all(total);
  std::iota(all.begin(), all.end(), 0);
  std::mt19937 rng(seed);
  std::shuffle(all.begin(), all.end(), rng);
  all.resize(std::min(total, count));
  std::sort(all.begin(), all.end());
  return all;
}

std::string writeFrameCsv(const std::string& path, const DatasetResult& r, const std::string& run) {
  std::ofstream f(path);
  if (!f) return "cannot write " + path;
  f << "# " << r.name << " " << run << ": one row per stereo pair\n";
  f << "frame,stamp,status,robot_segment,tp,fp,fn,tn,unclassified_in_map,unclassified_in_gt,points";
  for (const char* s : kStageNames)
    f << "," << s << "_ms";
  for (const auto& l : r.latency)
    f << ",coverage_" << l.board;
  f << "\n" << std::setprecision(10);
  for (std::size_t i = 0; i < r.frames.size(); ++i) {
    const FrameRecord& fr = r.frames[i];
    f << fr.index << "," << fr.stamp << "," << fr.status << "," << (fr.robot_segment ? 1 : 0) << ","
      << fr.counts.tp << "," << fr.counts.fp << "," << fr.counts.fn << "," << fr.counts.tn << ","
      << fr.counts.unclassified_in_map << "," << fr.counts.unclassified_in_gt << "," << fr.points;
    f << std::setprecision(4);
    for (double m : fr.ms)
      f << "," << m;
    for (const auto& l : r.latency) {
      const int k = static_cast<int>(i) - l.appear_frame;
      f << ",";
      if (l.appear_frame >= 0 && k >= 0 && k < static_cast<int>(l.coverage.size()))
        f << l.coverage[k];
    }
    f << std::setprecision(10) << "\n";
  }
  return "";
}

std::string evaluateOffline(const Options& opt, const ssm::StereoFrameProcessorConfig& base,
                            const std::vector<ssm::Dataset>& datasets, std::vector<Run>* runs) {
  runs->clear();
  for (int d : opt.decr) {
    Run r;
    r.decr = d;
    r.label = "decr=" + std::to_string(d);
    runs->push_back(r);
  }
  makeDirs(opt.out + "/maps");
  makeDirs(opt.out + "/frames");
  bool model_written = !opt.model;

  for (const ssm::Dataset& ds : datasets) {
    const Clock::time_point t_start = Clock::now();
    std::vector<MapperSlot> slots(opt.decr.size());
    for (std::size_t i = 0; i < opt.decr.size(); ++i) {
      ssm::StereoFrameProcessorConfig c = base;
      c.mapper.grid.decr = opt.decr[i];
      slots[i].processor = std::make_unique<ssm::StereoFrameProcessor>(c);
      (*runs)[i].datasets.emplace_back();
      slots[i].result = &(*runs)[i].datasets.back();
      slots[i].result->name = ds.name;
      slots[i].result->latency_only = ds.latency_only;
      for (const ssm::DatasetBoard& b : ds.boards) {
        LatencyResult l;
        l.board = b.name;
        slots[i].result->latency.push_back(l);
      }
    }

    // The local-horizon GT (see DatasetResult::local): the scene's GT map, relabelled per frame.
    sdata::GroundTruthConfig gtc;
    gtc.resolution = base.mapper.grid.voxel_size;
    gtc.h_t = base.mapper.labelling.max_step_height;
    gtc.theta_max_deg = base.mapper.labelling.max_slope_deg;
    gtc.theta_t_deg = base.mapper.labelling.level_slope_deg;
    gtc.robot_height = base.mapper.height_map.robot_height;
    sdata::GroundTruthMap scene_gt, local_gt;
    ssm::LabelGrid local_labels;
    bool have_local = false;
    if (!ds.latency_only) {
      const std::string e =
          sdata::recomputeDatasetGroundTruth(ds.gt_dir, opt.scenes, gtc, &scene_gt);
      have_local = e.empty() && scene_gt.labels.size() == ds.gt.labels.size();
      if (!have_local && !opt.quiet)
        std::fprintf(stderr, "  %s: no local-horizon GT (%s)\n", ds.name.c_str(),
                     e.empty() ? "GT map differs in size" : e.c_str());
    }
    ssm::StereoBagReaderOptions ro;
    ro.camera = opt.camera;
    ro.fixed_frame = opt.fixed_frame;
    ro.base_frame = opt.base_frame;
    ro.scan_topic.clear();
    ro.max_frames = opt.max_frames;
    ssm::StereoBagReader reader;
    std::string e = reader.open(ds.bag, ro);
    if (!e.empty()) return e;
    const double bag_seconds = reader.bagSeconds();
    const int pairs_total = reader.pairCount();

    // Frames whose planes enter the paper's protocol (000 Sec. VII-C: 5 random frames) and
    // frames whose maps are drawn.
    const std::vector<int> protocol = chooseFrames(pairs_total, opt.plane_frames, opt.seed);
    std::set<int> protocol_pending(protocol.begin(), protocol.end());
    std::set<int> image_pending;
    for (int k = 1; k <= opt.images; ++k)
      image_pending.insert(k * pairs_total / (opt.images + 1));

    bool any_protocol_due = false, any_image_due = false;
    std::vector<ssm::CellOutcome> outcomes;
    ssm::StereoBagFrame frame;

    while (reader.next(&frame)) {
      const int pair_index = frame.index;
      const ros::Time stamp = frame.stamp;
      if (protocol_pending.count(pair_index)) any_protocol_due = true;
      if (image_pending.count(pair_index)) any_image_due = true;
      if (pair_index % opt.every != 0) continue;
      for (auto& s : slots)
        ++s.result->pairs;
      if (!frame.error.empty()) {
        for (auto& s : slots) {
          ++s.result->rejected;
          ++s.result->problems[frame.error];
          FrameRecord rec;
          rec.index = pair_index;
          rec.stamp = stamp.toSec();
          rec.status = "rejected";
          s.result->frames.push_back(rec);
        }
        continue;
      }
      const ssm::StereoCameraModel& cam = frame.camera;
      const Eigen::Isometry3d& T_fixed_sensor = frame.T_fixed_sensor;
      const Eigen::Vector3d& robot = frame.robot;
      const cv::Mat& left = frame.left;
      const cv::Mat& right = frame.right;
      bool local_ok = false;
      if (have_local) {
        local_gt = scene_gt;
        local_ok = sdata::relabelGroundTruth(gtc, robot.head<2>(),
                                             base.mapper.segmentation.planning_radius, &local_gt)
                       .empty();
        if (local_ok) {
          local_labels = ds.gt;
          local_labels.labels = local_gt.labels;
        }
      }

      for (std::size_t i = 0; i < slots.size(); ++i) {
        MapperSlot& s = slots[i];
        DatasetResult& res = *s.result;
        ssm::StereoFrameResult fr;
        std::string err;
        bool ok;
        if (i == 0) {
          ok = s.processor->processImages(left, right, cam, T_fixed_sensor.cast<float>(),
                                          robot.cast<float>(), stamp.toSec(), &fr, &err);
        } else {
          // Same disparity image as the first mapper: only the grid's sensor model differs.
          const cv::Mat& disp = slots[0].processor->disparity();
          if (disp.empty()) {
            ok = false;
            err = "no disparity";
          } else {
            ok = s.processor->processDisparity(disp, slots[0].processor->disparityCamera(),
                                               T_fixed_sensor.cast<float>(), robot.cast<float>(),
                                               stamp.toSec(), &fr, &err);
          }
        }
        FrameRecord rec;
        rec.index = pair_index;
        rec.stamp = stamp.toSec();
        rec.points = fr.points;
        rec.status =
            ok ? "integrated"
               : (fr.mapper.status == ssm::FrameStatus::kStationary ? "stationary" : "rejected");
        if (ok) {
          ++res.integrated;
          const ssm::SafetyMap& map = s.processor->mapper().safetyMap();
          const bool protocol_frame = any_protocol_due;
          if (local_ok) {
            ssm::ConfusionCounts lc;
            if (ssm::countConfusion(map, local_labels, &lc).empty()) {
              res.local += lc;
              ++res.local_maps;
            }
          }
          evaluateFrameMap(ds, map, pair_index, rec.stamp, protocol_frame && !ds.latency_only, &rec,
                           &res, &outcomes);
          if (protocol_frame) res.protocol_frames.push_back(pair_index);
          if (pair_index == opt.dump_frame && i == 0) dumpSegments(ds, map, pair_index);
          const double disparity_ms =
              i == 0 ? fr.timings.disparity_ms : slots[0].result->frames.back().ms[0];
          const double values[kStages] = {
              disparity_ms,
              fr.timings.reproject_ms,
              fr.timings.mapper.integrate_ms,
              fr.timings.mapper.height_map_ms,
              fr.timings.mapper.segmentation_ms,
              fr.timings.mapper.plane_fit_ms,
              fr.timings.mapper.labelling_ms,
              fr.timings.mapper.total_ms,
              i == 0 ? fr.timings.total_ms : disparity_ms + fr.timings.total_ms};
          for (int k = 0; k < kStages; ++k) {
            rec.ms[k] = values[k];
            res.stage_ms[k].add(values[k]);
          }
          if (any_image_due && opt.images > 0) {
            const std::string name = ds.name + "_" + (*runs)[i].label.substr(0, 4) +
                                     std::to_string(opt.decr[i]) + "_frame" +
                                     std::to_string(pair_index) + ".png";
            char title[96];
            std::snprintf(title, sizeof(title), "%s frame %d, decr %d", ds.name.c_str(), pair_index,
                          opt.decr[i]);
            cv::imwrite(opt.out + "/maps/" + name,
                        mapBesideGroundTruth(map, ds.gt, outcomes, robot,
                                             ssm::yawOfOpticalAxis(T_fixed_sensor), title));
            res.images.push_back("maps/" + name);
          }
        } else {
          if (fr.mapper.status == ssm::FrameStatus::kStationary) {
            ++res.stationary;
          } else {
            ++res.rejected;
            ++res.problems[err];
          }
          if (i == 0) rec.ms[0] = fr.timings.disparity_ms;
        }
        // Frame latency (000 Sec. VII-B): counted in camera frames from the board's appearance;
        // a frame the mapper skipped keeps the previous grid.
        for (std::size_t b = 0; b < ds.boards.size(); ++b) {
          LatencyResult& l = res.latency[b];
          if (l.appear_frame < 0) {
            if (!ssm::boardInView(ds.boards[b].box, T_fixed_sensor, cam)) continue;
            l.appear_frame = static_cast<int>(res.frames.size());
            l.start_distance =
                ssm::distanceToBoardFace(ds.boards[b].box, T_fixed_sensor.translation());
          }
          l.coverage.push_back(
              ssm::boardWidthCoverage(s.processor->mapper().grid(), ds.boards[b].box).fraction());
        }
        res.frames.push_back(rec);
      }
      if (slots[0].result->frames.back().status == "integrated") {
        any_protocol_due = false;
        any_image_due = false;
      }
      if (!opt.quiet && pair_index % 50 == 0) {
        const ssm::ConfusionCounts& c = slots[0].result->sum;
        const ssm::ErrorRates r = ssm::errorRates(c);
        std::fprintf(stderr, "  %s pair %d/%d: %d maps, FN %.2f %% FP %.2f %% (decr %d)\n",
                     ds.name.c_str(), pair_index, pairs_total, slots[0].result->integrated,
                     100 * r.fn, 100 * r.fp, opt.decr[0]);
      }
    }
    for (std::size_t i = 0; i < slots.size(); ++i) {
      DatasetResult& res = *slots[i].result;
      res.bag_seconds = bag_seconds;
      res.wall_seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
      for (LatencyResult& l : res.latency) {
        l.frames_available = static_cast<int>(l.coverage.size());
        l.frames_to_50 = ssm::framesUntilCoverage(l.coverage, 0.5);
        l.frames_to_90 = ssm::framesUntilCoverage(l.coverage, 0.9);
      }
      const std::string csv = "frames/" + ds.name + "_decr" + std::to_string(opt.decr[i]) + ".csv";
      e = writeFrameCsv(opt.out + "/" + csv, res, (*runs)[i].label);
      if (!e.empty()) return e;
    }
    if (!model_written && !ds.latency_only) {
      // One picture of the 3D model: the last map of the first dataset with the first decr.
      const ssm::SafetyMapper& mapper = slots[0].processor->mapper();
      if (mapper.framesIntegrated() > 0) {
        const ssm::SafetyMap& map = mapper.safetyMap();
        const Eigen::Vector3d robot(map.robot_u * map.resolution, map.robot_v * map.resolution,
                                    0.0);
        double yaw = 0.0;
        try {
          const auto t = reader.tf().lookupTransform(opt.fixed_frame, opt.base_frame, ros::Time(0));
          yaw = std::atan2(2.0 * (t.transform.rotation.w * t.transform.rotation.z),
                           1.0 - 2.0 * t.transform.rotation.z * t.transform.rotation.z);
          cv::imwrite(
              opt.out + "/model_3d.png",
              render3dModel(mapper,
                            Eigen::Vector3d(t.transform.translation.x, t.transform.translation.y,
                                            t.transform.translation.z),
                            yaw));
        } catch (const tf2::TransformException&) {
          cv::imwrite(opt.out + "/model_3d.png", render3dModel(mapper, robot, yaw));
        }
        model_written = true;
      }
    }
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// Recorded mode: the SafetyMap messages the nodelets published while the bag was replayed.

ssm::SafetyMap fromMessage(const stereo_safety_map::SafetyMapMsg& msg) {
  ssm::SafetyMap m;
  const double res = msg.info.resolution;
  m.resolution = res;
  m.width = static_cast<int>(msg.info.width);
  m.height = static_cast<int>(msg.info.height);
  if (res > 0.0) {
    m.min_u = static_cast<int>(std::lround(msg.info.origin.position.x / res + 0.5));
    m.min_v = static_cast<int>(std::lround(msg.info.origin.position.y / res + 0.5));
    m.robot_u = static_cast<int>(std::lround(msg.robot_position.x / res));
    m.robot_v = static_cast<int>(std::lround(msg.robot_position.y / res));
  }
  m.robot_segment = msg.robot_segment;
  m.labels.resize(msg.labels.size());
  for (std::size_t k = 0; k < msg.labels.size(); ++k)
    m.labels[k] =
        msg.labels[k] <= 4 ? static_cast<SafetyLabel>(msg.labels[k]) : SafetyLabel::kUnknown;
  m.drop_off = msg.drop_off;
  m.segment = msg.segment;
  m.segments.resize(msg.segments.size());
  for (std::size_t i = 0; i < msg.segments.size(); ++i) {
    const auto& g = msg.segments[i];
    ssm::SegmentInfo& s = m.segments[i];
    s.id = g.id;
    s.label = g.label <= 4 ? static_cast<SafetyLabel>(g.label) : SafetyLabel::kUnknown;
    s.reachable = g.reachable;
    s.indexed_height = g.indexed_height;
    s.plane.valid = g.plane_valid;
    s.plane.a = g.a;
    s.plane.b = g.b;
    s.plane.c = g.c;
    s.plane.normal = Eigen::Vector3d(g.normal.x, g.normal.y, g.normal.z);
    s.plane.slope_deg = g.slope_deg;
  }
  if (m.segment.size() == m.labels.size()) {
    for (std::size_t k = 0; k < m.segment.size(); ++k) {
      const int s = m.segment[k];
      if (s >= 0 && s < static_cast<int>(m.segments.size()))
        m.segments[s].cells.push_back(static_cast<int>(k));
    }
  }
  return m;
}

std::string evaluateRecorded(const Options& opt, const ssm::Dataset& ds, std::vector<Run>* runs) {
  runs->assign(1, Run());
  Run& run = runs->front();
  run.label = "recorded";
  run.decr = -1;
  run.datasets.emplace_back();
  DatasetResult& res = run.datasets.back();
  res.name = ds.name;
  makeDirs(opt.out + "/maps");
  makeDirs(opt.out + "/frames");

  rosbag::Bag bag;
  try {
    bag.open(opt.recorded, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    return "cannot open " + opt.recorded + ": " + e.what();
  }
  // Topics by type, so that any namespace works.
  std::vector<std::string> map_topics, timing_topics;
  {
    rosbag::View all(bag);
    for (const rosbag::ConnectionInfo* c : all.getConnections()) {
      if (c->datatype == "stereo_safety_map/SafetyMap") map_topics.push_back(c->topic);
      if (c->datatype == "stereo_safety_map/StageTimings") timing_topics.push_back(c->topic);
    }
  }
  std::sort(map_topics.begin(), map_topics.end());
  map_topics.erase(std::unique(map_topics.begin(), map_topics.end()), map_topics.end());
  if (map_topics.empty()) return opt.recorded + ": no stereo_safety_map/SafetyMap messages";
  if (map_topics.size() > 1) map_topics.resize(1);

  // Stage timings by stamp.
  std::map<ros::Time, stereo_safety_map::StageTimingsMsg> timings;
  stereo_safety_map::StageTimingsMsg last_timing;
  if (!timing_topics.empty()) {
    rosbag::View tv(bag, rosbag::TopicQuery(timing_topics));
    for (const rosbag::MessageInstance& m : tv) {
      auto t = m.instantiate<stereo_safety_map::StageTimingsMsg>();
      if (!t) continue;
      timings[t->header.stamp] = *t;
      last_timing = *t;
    }
  }
  rosbag::View mv(bag, rosbag::TopicQuery(map_topics));
  const int total = static_cast<int>(mv.size());
  const std::vector<int> protocol = chooseFrames(total, opt.plane_frames, opt.seed);
  std::set<int> protocol_set(protocol.begin(), protocol.end());
  std::set<int> image_set;
  for (int k = 1; k <= opt.images && total > 0; ++k)
    image_set.insert(k * total / (opt.images + 1));
  int index = -1;
  std::vector<ssm::CellOutcome> outcomes;
  for (const rosbag::MessageInstance& m : mv) {
    auto msg = m.instantiate<stereo_safety_map::SafetyMapMsg>();
    if (!msg) continue;
    ++index;
    ++res.pairs;
    const ssm::SafetyMap map = fromMessage(*msg);
    FrameRecord rec;
    rec.index = index;
    rec.stamp = msg->header.stamp.toSec();
    rec.status = "integrated";
    ++res.integrated;
    evaluateFrameMap(ds, map, index, rec.stamp, protocol_set.count(index) > 0, &rec, &res,
                     &outcomes);
    if (protocol_set.count(index)) res.protocol_frames.push_back(index);
    auto t = timings.find(msg->header.stamp);
    if (t != timings.end()) {
      const double values[kStages] = {kNaN,
                                      kNaN,
                                      t->second.integrate_ms,
                                      t->second.height_map_ms,
                                      t->second.segmentation_ms,
                                      t->second.plane_fit_ms,
                                      t->second.labelling_ms,
                                      t->second.total_ms,
                                      kNaN};
      for (int k = 0; k < kStages; ++k) {
        rec.ms[k] = values[k];
        if (std::isfinite(values[k])) res.stage_ms[k].add(values[k]);
      }
    }
    if (image_set.count(index)) {
      const std::string name = ds.name + "_recorded_map" + std::to_string(index) + ".png";
      char title[96];
      std::snprintf(title, sizeof(title), "%s, recorded map %d", ds.name.c_str(), index);
      cv::imwrite(opt.out + "/maps/" + name,
                  mapBesideGroundTruth(map, ds.gt, outcomes,
                                       Eigen::Vector3d(msg->robot_position.x, msg->robot_position.y,
                                                       msg->robot_position.z),
                                       kNaN, title));
      res.images.push_back("maps/" + name);
    }
    res.frames.push_back(rec);
  }
  res.stationary = static_cast<int>(last_timing.frames_skipped_stationary);
  if (last_timing.frames_dropped > 0)
    res.problems["frames dropped by the nodelet (one-slot queue)"] =
        static_cast<int>(last_timing.frames_dropped);
  if (last_timing.frames_rejected > 0)
    res.problems["frames rejected by the nodelet"] = static_cast<int>(last_timing.frames_rejected);
  res.rejected = static_cast<int>(last_timing.frames_dropped + last_timing.frames_rejected);
  const std::string e =
      writeFrameCsv(opt.out + "/frames/" + ds.name + "_recorded.csv", res, "recorded");
  return e;
}

// ---------------------------------------------------------------------------------------------
// Output: JSON and Markdown

using stereo_safety_map::tools::Json;  // tool_support/json.h

void jsonMeanStd(Json& j, const std::string& k, const ssm::MeanStd& m) {
  j.key(k).open('{').kv("mean", m.mean).kv("std", m.stddev).kv("n", m.n).close('}');
}

void jsonCounts(Json& j, const std::string& k, const ssm::ConfusionCounts& c) {
  j.key(k).open('{');
  j.kv("tp", c.tp).kv("fp", c.fp).kv("fn", c.fn).kv("tn", c.tn);
  j.kv("unsafe_cells", c.unsafeCells()).kv("safe_cells", c.safeCells());
  j.kv("unclassified_in_map", c.unclassified_in_map).kv("unclassified_in_gt", c.unclassified_in_gt);
  j.kv("maps", c.maps).close('}');
}

void jsonRates(Json& j, const std::string& k, const ssm::ConfusionCounts& c) {
  const ssm::ErrorRates r = ssm::errorRates(c);
  const ssm::SafeClassScores s = ssm::safeClassScores(c);
  j.key(k).open('{').kv("fn", r.fn).kv("fp", r.fp).kv("tp", r.tp).kv("tn", r.tn);
  j.kv("precision", s.precision).kv("recall", s.recall).kv("f1", s.f1).close('}');
}

struct PlaneSummary {
  ssm::MeanStd angle, distance;
};
PlaneSummary summarize(const std::vector<PlaneSample>& v) {
  std::vector<double> a, d;
  for (const auto& p : v) {
    a.push_back(p.angle_deg);
    d.push_back(p.distance);
  }
  return {ssm::meanStd(a), ssm::meanStd(d)};
}

struct RunSummary {
  ssm::MeanStd fn, fp, tp, tn, precision, recall, f1;
  ssm::MeanStd seeded_fn, seeded_fp;
  ssm::MeanStd local_fn, local_fp;  // over the datasets with a local-horizon GT
  PlaneSummary planes_protocol, planes_all;
  Series stage_ms[kStages];
  int datasets = 0;
  int maps = 0;
  int without_robot_segment = 0;
  double bag_seconds = 0.0, wall_seconds = 0.0;
};

RunSummary summarize(const Run& run) {
  RunSummary s;
  std::vector<double> fn, fp, tp, tn, p, r, f1, sfn, sfp, lfn, lfp;
  std::vector<PlaneSample> pp, pa;
  for (const DatasetResult& d : run.datasets) {
    if (d.latency_only) continue;
    ++s.datasets;
    s.maps += d.integrated;
    s.without_robot_segment += d.without_robot_segment;
    const ssm::ErrorRates e = ssm::errorRates(d.sum);
    const ssm::SafeClassScores c = ssm::safeClassScores(d.sum);
    const ssm::ErrorRates es = ssm::errorRates(d.seeded);
    fn.push_back(e.fn);
    fp.push_back(e.fp);
    tp.push_back(e.tp);
    tn.push_back(e.tn);
    p.push_back(c.precision);
    r.push_back(c.recall);
    f1.push_back(c.f1);
    sfn.push_back(es.fn);
    sfp.push_back(es.fp);
    if (d.local_maps > 0) {
      const ssm::ErrorRates el = ssm::errorRates(d.local);
      lfn.push_back(el.fn);
      lfp.push_back(el.fp);
    }
    pp.insert(pp.end(), d.planes_protocol.begin(), d.planes_protocol.end());
    pa.insert(pa.end(), d.planes_all.begin(), d.planes_all.end());
    for (int k = 0; k < kStages; ++k)
      s.stage_ms[k].v.insert(s.stage_ms[k].v.end(), d.stage_ms[k].v.begin(), d.stage_ms[k].v.end());
    s.bag_seconds += d.bag_seconds;
    s.wall_seconds += d.wall_seconds;
  }
  s.fn = ssm::meanStd(fn);
  s.fp = ssm::meanStd(fp);
  s.tp = ssm::meanStd(tp);
  s.tn = ssm::meanStd(tn);
  s.precision = ssm::meanStd(p);
  s.recall = ssm::meanStd(r);
  s.f1 = ssm::meanStd(f1);
  s.seeded_fn = ssm::meanStd(sfn);
  s.seeded_fp = ssm::meanStd(sfp);
  s.local_fn = ssm::meanStd(lfn);
  s.local_fp = ssm::meanStd(lfp);
  s.planes_protocol = summarize(pp);
  s.planes_all = summarize(pa);
  return s;
}

void jsonTimings(Json& j, const Series* stage_ms) {
  j.key("timings_ms").open('{');
  for (int k = 0; k < kStages; ++k) {
    j.key(kStageNames[k]).open('{');
    j.kv("mean", stage_ms[k].mean()).kv("median", stage_ms[k].quantile(0.5));
    j.kv("p90", stage_ms[k].quantile(0.9)).kv("max", stage_ms[k].max()).close('}');
  }
  j.close('}');
}

struct Target {
  std::string name;
  double measured;
  double limit;
  std::string unit;
  std::string paper;
  bool pass() const { return std::isfinite(measured) && measured <= limit; }
};

// The targets at the default parameters (decr = 1).
std::vector<Target> targets(const std::vector<Run>& runs) {
  std::vector<Target> t;
  const Run* r1 = nullptr;
  for (const Run& r : runs)
    if (r.decr == 1 || (r.decr < 0 && r1 == nullptr)) r1 = &r;
  if (r1 == nullptr) return t;
  const RunSummary s = summarize(*r1);
  if (s.datasets > 0) {
    t.push_back({"FN rate (mean over datasets)", 100 * s.fn.mean, 1.5, "%", "3.0 +- 1.8 %"});
    t.push_back({"FP rate (mean over datasets)", 100 * s.fp.mean, 5.0, "%", "9.3 +- 4.7 %"});
    t.push_back({"plane normal error (paper protocol)", s.planes_protocol.angle.mean, 0.6, "deg",
                 "1.2 +- 0.5 deg"});
    t.push_back({"plane distance (paper protocol)", 100 * s.planes_protocol.distance.mean, 1.0,
                 "cm", "1.9 +- 0.8 cm"});
  }
  // 50 % of the textured board at 5 m.
  double best = kNaN;
  for (const DatasetResult& d : r1->datasets) {
    if (!d.latency_only || d.name.find("untextured") != std::string::npos) continue;
    for (const LatencyResult& l : d.latency) {
      if (std::isfinite(l.start_distance) && std::abs(l.start_distance - 5.0) < 0.3)
        best = l.frames_to_50 > 0 ? l.frames_to_50 : std::numeric_limits<double>::infinity();
    }
  }
  if (!std::isnan(best))
    t.push_back({"frames to 50 % of the textured board at 5 m", best, 5.0, "frames", "8 frames"});
  return t;
}

double share(std::uint64_t part, std::uint64_t whole) {
  return whole == 0 ? kNaN : static_cast<double>(part) / static_cast<double>(whole);
}

std::string fmtPct(double v) {
  if (!std::isfinite(v)) return "n/a";
  char b[32];
  std::snprintf(b, sizeof(b), "%.1f", 100 * v);
  return b;
}
std::string fmtPm(const ssm::MeanStd& m, double scale, int prec = 1) {
  if (!std::isfinite(m.mean)) return "n/a";
  char b[64];
  std::snprintf(b, sizeof(b), "%.*f +- %.*f", prec, scale * m.mean, prec,
                std::isfinite(m.stddev) ? scale * m.stddev : 0.0);
  return b;
}
std::string fmt(double v, int prec = 1) {
  if (!std::isfinite(v)) return "n/a";
  char b[32];
  std::snprintf(b, sizeof(b), "%.*f", prec, v);
  return b;
}

std::string writeOutputs(const Options& opt, const ssm::StereoFrameProcessorConfig& config,
                         const std::vector<Run>& runs, const std::string& command) {
  const std::vector<Target> tg = targets(runs);
  // ---- JSON
  Json j;
  j.open('{');
  j.kv("tool", "evaluate_safety_map").kv("command", command);
  j.kv("mode", opt.recorded.empty() ? "offline" : "recorded");
  j.key("config").open('{');
  const auto& g = config.mapper.grid;
  j.kv("voxel_size", g.voxel_size).kv("incr_high", g.incr_high).kv("incr_low", g.incr_low);
  j.kv("occ_threshold", g.occ_threshold)
      .kv("planning_radius", config.mapper.segmentation.planning_radius);
  j.kv("seed_radius", config.mapper.segmentation.seed_radius);
  j.kv("every", opt.every).kv("disparity_step", config.disparity_step);
  j.kv("matcher",
       config.disparity.matcher == ssm::StereoMatcherType::kBlockMatching ? "BM" : "SGBM");
  j.kv("texture_filter", config.disparity.enable_texture);
  j.kv("plane_frames", opt.plane_frames).kv("seed", static_cast<int>(opt.seed));
  j.key("params_files").open('[');
  for (const std::string& p : opt.params)
    j.val(p);
  j.close(']');
  j.key("set").open('[');
  for (const std::string& a : opt.sets)
    j.val(a);
  j.close(']');
  j.close('}');
  j.key("runs").open('[');
  for (const Run& run : runs) {
    const RunSummary s = summarize(run);
    j.open('{').kv("label", run.label).kv("decr", run.decr);
    j.key("summary").open('{');
    j.kv("datasets", s.datasets)
        .kv("maps", s.maps)
        .kv("maps_without_robot_segment", s.without_robot_segment);
    jsonMeanStd(j, "fn", s.fn);
    jsonMeanStd(j, "fp", s.fp);
    jsonMeanStd(j, "tp", s.tp);
    jsonMeanStd(j, "tn", s.tn);
    jsonMeanStd(j, "precision", s.precision);
    jsonMeanStd(j, "recall", s.recall);
    jsonMeanStd(j, "f1", s.f1);
    jsonMeanStd(j, "fn_with_robot_segment", s.seeded_fn);
    jsonMeanStd(j, "fp_with_robot_segment", s.seeded_fp);
    jsonMeanStd(j, "fn_local_horizon", s.local_fn);
    jsonMeanStd(j, "fp_local_horizon", s.local_fp);
    j.key("planes_protocol").open('{');
    jsonMeanStd(j, "angle_deg", s.planes_protocol.angle);
    jsonMeanStd(j, "distance_m", s.planes_protocol.distance);
    j.close('}');
    j.key("planes_all_frames").open('{');
    jsonMeanStd(j, "angle_deg", s.planes_all.angle);
    jsonMeanStd(j, "distance_m", s.planes_all.distance);
    j.close('}');
    jsonTimings(j, s.stage_ms);
    j.kv("bag_seconds", s.bag_seconds).kv("wall_seconds", s.wall_seconds);
    j.kv("realtime_factor", s.wall_seconds > 0 ? s.bag_seconds / s.wall_seconds : kNaN);
    j.close('}');
    j.key("datasets").open('[');
    for (const DatasetResult& d : run.datasets) {
      j.open('{').kv("name", d.name).kv("latency_only", d.latency_only);
      j.kv("pairs", d.pairs).kv("maps", d.integrated).kv("stationary", d.stationary);
      j.kv("rejected", d.rejected).kv("maps_without_robot_segment", d.without_robot_segment);
      j.key("fp_where").open('{');
      j.kv("ground_segment_labelled_non_ground", d.fp_in_segment);
      j.kv("column_in_no_segment", d.fp_no_segment);
      j.kv("maps_without_robot_segment", d.fp_without_robot_segment).close('}');
      jsonCounts(j, "counts", d.sum);
      jsonRates(j, "rates", d.sum);
      jsonCounts(j, "counts_with_robot_segment", d.seeded);
      jsonRates(j, "rates_with_robot_segment", d.seeded);
      j.kv("local_horizon_maps", d.local_maps);
      jsonCounts(j, "counts_local_horizon", d.local);
      jsonRates(j, "rates_local_horizon", d.local);
      const PlaneSummary pp = summarize(d.planes_protocol), pa = summarize(d.planes_all);
      j.key("planes_protocol").open('{');
      j.key("frames").open('[');
      for (int f : d.protocol_frames)
        j.val(f);
      j.close(']');
      jsonMeanStd(j, "angle_deg", pp.angle);
      jsonMeanStd(j, "distance_m", pp.distance);
      j.key("planes").open('[');
      for (const PlaneSample& p : d.planes_protocol) {
        j.open('{').kv("frame", p.frame).kv("reference", p.reference).kv("angle_deg", p.angle_deg);
        j.kv("distance_m", p.distance)
            .kv("cells", p.cells)
            .kv("label", ssm::toString(p.label))
            .close('}');
      }
      j.close(']').close('}');
      j.key("planes_all_frames").open('{');
      jsonMeanStd(j, "angle_deg", pa.angle);
      jsonMeanStd(j, "distance_m", pa.distance);
      j.close('}');
      j.key("latency").open('[');
      for (const LatencyResult& l : d.latency) {
        j.open('{').kv("board", l.board).kv("start_distance_m", l.start_distance);
        j.kv("textured", d.name.find("untextured") == std::string::npos);
        j.kv("appear_frame", l.appear_frame).kv("frames_available", l.frames_available);
        j.kv("frames_to_50", l.frames_to_50).kv("frames_to_90", l.frames_to_90);
        j.kv("final_coverage", l.coverage.empty() ? kNaN : l.coverage.back()).close('}');
      }
      j.close(']');
      jsonTimings(j, d.stage_ms);
      j.kv("bag_seconds", d.bag_seconds).kv("wall_seconds", d.wall_seconds);
      j.key("images").open('[');
      for (const auto& im : d.images)
        j.val(im);
      j.close(']');
      j.key("problems").open('{');
      for (const auto& p : d.problems)
        j.kv(p.first, p.second);
      j.close('}');
      j.close('}');
    }
    j.close(']').close('}');
  }
  j.close(']');
  j.key("targets").open('[');
  for (const Target& t : tg) {
    j.open('{').kv("name", t.name).kv("measured", t.measured).kv("limit", t.limit);
    j.kv("unit", t.unit).kv("paper", t.paper).kv("pass", t.pass()).close('}');
  }
  j.close(']');
  j.close('}');
  {
    std::ofstream f(opt.out + "/metrics.json");
    if (!f) return "cannot write " + opt.out + "/metrics.json";
    f << j.str() << "\n";
  }

  // ---- Markdown
  std::ostringstream md;
  md << "# Safety map evaluation\n\n"
     << "Made by `" << command << "` ("
     << (opt.recorded.empty() ? "offline: the core pipeline "
                                "on the bags, no roscore"
                              : "recorded: maps published by the nodelets")
     << "). Definitions: docs/evaluation.md. Rates in percent; unsafe (Non-ground) is the "
        "positive class (000 Sec. VII-A); precision / recall / F1 are of the safe class "
        "(001 Sec. 5).\n\n";
  if (!tg.empty()) {
    md << "## Targets\n\n| target | measured | limit | paper | |\n|---|---|---|---|---|\n";
    for (const Target& t : tg)
      md << "| " << t.name << " | " << fmt(t.measured, 2) << " " << t.unit
         << " | <= " << fmt(t.limit, 1) << " " << t.unit << " | " << t.paper << " | "
         << (t.pass() ? "met" : "**missed**") << " |\n";
    md << "\n";
  }
  // Table II.
  bool any_rates = false;
  for (const Run& r : runs)
    any_rates = any_rates || summarize(r).datasets > 0;
  if (any_rates) {
    md << "## Error rates averaged over datasets (000 Table II)\n\n| | ";
    for (const Run& r : runs)
      md << r.label << " | ";
    md << "\n|---|";
    for (std::size_t i = 0; i < runs.size(); ++i)
      md << "---|";
    md << "\n";
    const char* rows[] = {"False negative rate (FN)",
                          "False positive rate (FP)",
                          "True positive rate (TP)",
                          "True negative rate (TN)",
                          "Precision (safe, 001)",
                          "Recall (safe, 001)",
                          "F1 (safe, 001)",
                          "FN, maps with the robot's segment",
                          "FP, maps with the robot's segment",
                          "FN, local-horizon GT",
                          "FP, local-horizon GT"};
    for (int row = 0; row < 11; ++row) {
      md << "| " << rows[row] << " | ";
      for (const Run& r : runs) {
        const RunSummary s = summarize(r);
        const ssm::MeanStd* m[] = {&s.fn,        &s.fp,       &s.tp,      &s.tn,
                                   &s.precision, &s.recall,   &s.f1,      &s.seeded_fn,
                                   &s.seeded_fp, &s.local_fn, &s.local_fp};
        md << (row >= 4 && row <= 6 ? fmtPm(*m[row], 1.0, 3) : fmtPm(*m[row], 100.0)) << " | ";
      }
      md << "\n";
    }
    md << "\nPaper (decr 1 / 3 / 5): FN 3.0 / 8.5 / 11.2, FP 9.3 / 6.2 / 5.2, TP 97.0 / 91.5 / "
          "88.8, "
          "TN 90.7 / 93.8 / 94.8. ROC curve: fig6a_roc.png (scripts/plot_evaluation.py).\n\n"
          "The rates above compare with the dataset's GT map, whose reachability is that of the "
          "whole scene from the robot's start (a lower level reached by a ramp far ahead is "
          "safe). The local-horizon rows compare the same maps with the scene's GT relabelled "
          "at each frame with reachability from the robot's position within R_max, i.e. with "
          "what the robot could know; the difference is the share of errors that only a look "
          "beyond R_max could avoid.\n\n";
    for (const Run& r : runs) {
      md << "### Per dataset, " << r.label << "\n\n"
         << "| dataset | maps | stationary | no robot segment | unsafe cells | safe cells | FN | "
            "FP | "
            "TP | TN | P | R | F1 | FP in Non-ground segments / in no segment / in maps without "
            "robot segment [%] |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
      for (const DatasetResult& d : r.datasets) {
        if (d.latency_only) continue;
        const ssm::ErrorRates e = ssm::errorRates(d.sum);
        const ssm::SafeClassScores c = ssm::safeClassScores(d.sum);
        md << "| " << d.name << " | " << d.integrated << " | " << d.stationary << " | "
           << d.without_robot_segment << " | " << d.sum.unsafeCells() << " | " << d.sum.safeCells()
           << " | " << fmtPct(e.fn) << " | " << fmtPct(e.fp) << " | " << fmtPct(e.tp) << " | "
           << fmtPct(e.tn) << " | " << fmt(c.precision, 3) << " | " << fmt(c.recall, 3) << " | "
           << fmt(c.f1, 3) << " | " << fmtPct(share(d.fp_in_segment, d.sum.fp)) << " / "
           << fmtPct(share(d.fp_no_segment, d.sum.fp)) << " / "
           << fmtPct(share(d.fp_without_robot_segment, d.sum.fp)) << " |\n";
      }
      md << "\n";
    }
    // Planes.
    md << "## Plane accuracy (000 Sec. VII-C)\n\n| run | protocol frames: angle [deg] | distance "
          "[cm] | planes | all frames: angle [deg] | distance [cm] | planes "
          "|\n|---|---|---|---|---|---|---|\n";
    for (const Run& r : runs) {
      const RunSummary s = summarize(r);
      md << "| " << r.label << " | " << fmtPm(s.planes_protocol.angle, 1.0, 2) << " | "
         << fmtPm(s.planes_protocol.distance, 100.0, 2) << " | " << s.planes_protocol.angle.n
         << " | " << fmtPm(s.planes_all.angle, 1.0, 2) << " | "
         << fmtPm(s.planes_all.distance, 100.0, 2) << " | " << s.planes_all.angle.n << " |\n";
    }
    md << "\nProtocol: all safe planes of " << opt.plane_frames
       << " frames per dataset drawn at random (seed " << opt.seed
       << "), averaged over all planes of all datasets (paper: 1.2 +- 0.5 deg, 1.9 +- "
          "0.8 cm).\n\n";
  }
  // Latency.
  bool any_latency = false;
  for (const Run& r : runs)
    for (const DatasetResult& d : r.datasets)
      any_latency = any_latency || !d.latency.empty();
  if (any_latency) {
    md << "## Frame latency (000 Sec. VII-B)\n\nCamera frames from the board's appearance until "
          "50 % / 90 % of its width is occupied in the 3D grid (-1: not reached before the "
          "sequence ends; the robot stops 0.6 m from the board). Plot: fig6b_latency.png.\n\n"
          "| run | dataset | start distance [m] | frames to 50 % | frames to 90 % | frames seen | "
          "final coverage |\n"
          "|---|---|---|---|---|---|---|\n";
    for (const Run& r : runs)
      for (const DatasetResult& d : r.datasets)
        for (const LatencyResult& l : d.latency)
          md << "| " << r.label << " | " << d.name << " | " << fmt(l.start_distance, 2) << " | "
             << l.frames_to_50 << " | " << l.frames_to_90 << " | " << l.frames_available << " | "
             << fmt(l.coverage.empty() ? kNaN : 100 * l.coverage.back(), 0) << " % |\n";
    md << "\n";
  }
  // Timings.
  md << "## Time per stage [ms] (this machine, single thread)\n\n| run | ";
  for (const char* n : kStageNames)
    md << n << " | ";
  md << "real-time factor |\n|---|";
  for (int k = 0; k <= kStages; ++k)
    md << "---|";
  md << "\n";
  for (const Run& r : runs) {
    RunSummary s = summarize(r);
    if (s.datasets == 0) {  // latency-only runs
      for (const DatasetResult& d : r.datasets)
        for (int k = 0; k < kStages; ++k)
          s.stage_ms[k].v.insert(s.stage_ms[k].v.end(), d.stage_ms[k].v.begin(),
                                 d.stage_ms[k].v.end());
    }
    md << "| " << r.label << " (mean / median) | ";
    for (int k = 0; k < kStages; ++k)
      md << fmt(s.stage_ms[k].mean(), 1) << " / " << fmt(s.stage_ms[k].quantile(0.5), 1) << " | ";
    md << (s.wall_seconds > 0 ? fmt(s.bag_seconds / s.wall_seconds, 2) : std::string("n/a"))
       << " |\n";
  }
  md << "\nStages: disparity = matching and post-filters (shared by all decr values: the first "
        "run's time), update = voxel grid (000: 92 ms), segmentation = Alg. 1 (000: 4 ms), "
        "plane_fit (000: 61 ms), labelling = Alg. 2 (000: 71 ms). The real-time factor is bag "
        "duration over wall time for all runs of a dataset together.\n\n";
  // Images.
  md << "## Images\n\n";
  if (fileExists(opt.out + "/model_3d.png")) md << "![3D model](model_3d.png)\n\n";
  for (const Run& r : runs)
    for (const DatasetResult& d : r.datasets)
      for (const std::string& im : d.images)
        md << "![" << d.name << "](" << im << ")\n";
  md << "\n";
  // Problems.
  bool any_problem = false;
  for (const Run& r : runs)
    for (const DatasetResult& d : r.datasets)
      any_problem = any_problem || !d.problems.empty();
  if (any_problem) {
    md << "## Problems\n\n";
    for (const Run& r : runs)
      for (const DatasetResult& d : r.datasets)
        for (const auto& p : d.problems)
          md << "- " << r.label << " " << d.name << ": " << p.second << " x " << p.first << "\n";
  }
  std::ofstream f(opt.out + "/report.md");
  if (!f) return "cannot write " + opt.out + "/report.md";
  f << md.str();
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parseArgs(argc, argv, &opt)) {
    usage();
    return 2;
  }
  ros::Time::init();
  std::string command = "evaluate_safety_map";
  for (int i = 1; i < argc; ++i)
    command += std::string(" ") + argv[i];

  ssm::StereoFrameProcessorConfig config;
  {
    const std::string e = ssm::loadCoreParams(opt.params, opt.sets, &config);
    if (!e.empty()) {
      std::fprintf(stderr, "error: %s\n", e.c_str());
      return 2;
    }
  }
  for (int d : opt.decr) {
    ssm::StereoFrameProcessorConfig c = config;
    c.mapper.grid.decr = d;
    const std::string e = c.validate();
    if (!e.empty()) {
      std::fprintf(stderr, "error: decr %d: %s\n", d, e.c_str());
      return 2;
    }
  }
  if (!makeDirs(opt.out)) {
    std::fprintf(stderr, "error: cannot create %s\n", opt.out.c_str());
    return 1;
  }

  std::vector<ssm::Dataset> datasets;
  for (int pass = 0; pass < 2; ++pass) {
    for (const std::string& b : pass == 0 ? opt.bags : opt.latency_bags) {
      ssm::Dataset d;
      const std::string e = ssm::loadDataset(b, pass == 1, &d);
      if (!e.empty()) {
        std::fprintf(stderr, "error: %s\n", e.c_str());
        return 1;
      }
      datasets.push_back(d);
    }
  }

  std::vector<Run> runs;
  const Clock::time_point t0 = Clock::now();
  const std::string e = opt.recorded.empty() ? evaluateOffline(opt, config, datasets, &runs)
                                             : evaluateRecorded(opt, datasets.front(), &runs);
  if (!e.empty()) {
    std::fprintf(stderr, "error: %s\n", e.c_str());
    return 1;
  }
  const std::string w = writeOutputs(opt, config, runs, command);
  if (!w.empty()) {
    std::fprintf(stderr, "error: %s\n", w.c_str());
    return 1;
  }
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  for (const Run& r : runs) {
    const RunSummary s = summarize(r);
    if (s.datasets == 0) continue;
    std::printf(
        "%s: %d datasets, %d maps: FN %s %%, FP %s %%, TP %s %%, TN %s %%, F1 %s; planes "
        "%s deg, %s cm\n",
        r.label.c_str(), s.datasets, s.maps, fmtPm(s.fn, 100.0).c_str(), fmtPm(s.fp, 100.0).c_str(),
        fmtPm(s.tp, 100.0).c_str(), fmtPm(s.tn, 100.0).c_str(), fmtPm(s.f1, 1.0, 3).c_str(),
        fmtPm(s.planes_protocol.angle, 1.0, 2).c_str(),
        fmtPm(s.planes_protocol.distance, 100.0, 2).c_str());
  }
  for (const Run& r : runs)
    for (const DatasetResult& d : r.datasets)
      for (const LatencyResult& l : d.latency)
        std::printf("%s %s: board at %.2f m: 50 %% after %d frames, 90 %% after %d frames\n",
                    r.label.c_str(), d.name.c_str(), l.start_distance, l.frames_to_50,
                    l.frames_to_90);
  for (const Target& t : targets(runs))
    std::printf("target %s: %.2f %s (limit %.1f): %s\n", t.name.c_str(), t.measured, t.unit.c_str(),
                t.limit, t.pass() ? "met" : "MISSED");
  std::printf("wrote %s/report.md and %s/metrics.json in %.1f s\n", opt.out.c_str(),
              opt.out.c_str(), wall);
  return 0;
}
