// evaluate_hybrid: the evaluation of paper 001 (Murarka, Modayil & Kuipers 2006, Sec. 5) on the
// package's dataset bags, without a roscore.
//
//   evaluate_hybrid --bag A.bag [--bag B.bag ...] [--overhang-bag T.bag ...]
//                   [--noisy-bag N.bag ...] [--out DIR] [--params config/disparity.yaml
//                   --params config/safety_map.yaml] [--set key=value ...]
//                   [--every N] [--max-frames N] [--ghost-px 2.0] [--quiet]
//
// Every stereo pair goes through the pipeline the nodelets run (StereoFrameProcessor, through the
// shared dataset reader), and every LaserScan up to the pair is ray cast, from its pose in the
// bag's tf, into the LaserGrid that the hybrid nodelet uses. Three maps are
// built on the cells of each integrated frame's stereo safety map (core/hybrid_safety_map.h):
// laser-only, stereo-only and merged (and merged with laser-free unknown cells as safe). Measures:
//  - Table 2 of 001: precision, recall and F1 of the safe class (A = safe in the map and in the
//    ground truth, B = safe in the map only, C = safe in the ground truth only) for the three
//    maps, from cell counts summed over all integrated frames of a dataset; each map counted on
//    its own coverage (001's protocol) and on the cells that all of them classify;
//  - what the laser cannot see (--bag and --overhang-bag): the Non-ground cells under overhangs
//    between the laser plane and the robot's height (table tops, shelves), of obstacles below the
//    plane, and of ground hazards (drop-offs, steep or unreachable ground), and how each map
//    labels them (laserBlindCells());
//  - the landmark filter (001 Sec. 4.2) in front of the voxel grid (--noisy-bag): the same
//    disparity images mapped without and with it; the stereo map's FP / FN rates (000 Sec.
//    VII-A, unsafe positive) and safe-class scores, ghost points (points whose disparity differs
//    from the ground-truth depth's by more than --ghost-px; needs bags rendered with
//    make_dataset --depth) among the points reaching the grid, and the filter's time per frame.
// Writes DIR/report.md, DIR/metrics.json and pictures of the last frame of each --overhang-bag.
#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/hybrid_safety_map.h"
#include "stereo_safety_map/core/laser_grid.h"
#include "stereo_safety_map/core/map_image.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/ros/hybrid_conversions.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/tools/args.h"
#include "stereo_safety_map/tools/dataset_reader.h"
#include "stereo_safety_map/tools/json.h"

#include <cv_bridge/cv_bridge.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Image.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace ssm = stereo_safety_map;
using ssm::ConfusionCounts;
using ssm::HybridLabel;
using ssm::HybridSafetyMap;
using ssm::HybridSource;

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The three maps of 001 Table 2, and the merged map with laser_free_vision_unknown_is_safe
// (laser-free cells that vision has not examined count as Safe), one reading of how 001's merged
// map gained recall over stereo ("because lasers help").
constexpr int kSources = 4;
const HybridSource kSourceOrder[kSources] = {HybridSource::kLaserOnly, HybridSource::kStereoOnly,
                                             HybridSource::kMerged, HybridSource::kMerged};
const char* const kSourceNames[kSources] = {"laser", "stereo", "merged",
                                            "merged_laser_fills_unknown"};

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// ---------------------------------------------------------------------------------------------
// Options

struct Options {
  std::vector<std::string> bags;
  std::vector<std::string> overhang_bags;
  std::vector<std::string> noisy_bags;
  std::string out = "out/evaluation/hybrid";
  std::vector<std::string> params;
  std::vector<std::string> sets;
  int every = 1;
  long max_frames = -1;
  double ghost_px = 2.0;
  bool quiet = false;
};

void usage() {
  std::fprintf(
      stderr,
      "usage: evaluate_hybrid --bag FILE [--bag FILE ...] [--overhang-bag FILE ...]\n"
      "         [--noisy-bag FILE ...] [--out DIR] [--params YAML] [--set key=value ...]\n"
      "         [--every N] [--max-frames N] [--ghost-px PX] [--quiet]\n"
      "  --bag           dataset bag (make_dataset): Table 2 of 001 (laser / stereo / merged)\n"
      "  --overhang-bag  also Table 2, plus pictures of its last frame (a scene with a table)\n"
      "  --noisy-bag     landmark filter on / off (ghost points need make_dataset --depth)\n"
      "  --params        the nodelets' YAML (config/disparity.yaml, config/safety_map.yaml; core\n"
      "                  keys applied, in order; repeatable)\n"
      "  --ghost-px      disparity error [px] beyond which a point is a ghost (default 2)\n");
}

bool parseArgs(int argc, char** argv, Options* o) {
  ssm::tools::Args a(argc, argv);
  while (a.next()) {
    if (a.value("--bag", &o->bags) || a.value("--overhang-bag", &o->overhang_bags) ||
        a.value("--noisy-bag", &o->noisy_bags) || a.value("--out", &o->out) ||
        a.value("--params", &o->params) || a.value("--set", &o->sets) ||
        a.value("--max-frames", &o->max_frames) || a.flag("--quiet", &o->quiet))
      continue;
    if (a.value("--every", &o->every)) {
      o->every = std::max(1, o->every);
    } else if (a.value("--ghost-px", &o->ghost_px)) {
      if (!(o->ghost_px > 0.0)) return false;
    } else if (a.missingValue()) {
      std::fprintf(stderr, "error: %s needs a value\n", a.arg().c_str());
      return false;
    } else {
      std::fprintf(stderr, "error: unknown argument %s\n", a.arg().c_str());
      return false;
    }
  }
  return !o->bags.empty() || !o->overhang_bags.empty() || !o->noisy_bags.empty();
}

// ---------------------------------------------------------------------------------------------
// Ground truth and maps

// 000's ground-truth labels as hybrid classes: only safe / unsafe / unclassified matters for the
// scores (Non-ground counts as unsafe whatever its kind).
HybridSafetyMap hybridTruth(const ssm::LabelGrid& gt) {
  HybridSafetyMap h;
  h.min_u = gt.min_u;
  h.min_v = gt.min_v;
  h.width = gt.width;
  h.height = gt.height;
  h.resolution = gt.resolution;
  h.labels.resize(gt.labels.size());
  for (std::size_t i = 0; i < gt.labels.size(); ++i) {
    switch (gt.labels[i]) {
      case ssm::SafetyLabel::kLevel:
        h.labels[i] = HybridLabel::kSafe;
        break;
      case ssm::SafetyLabel::kInclined:
        h.labels[i] = HybridLabel::kCaution;
        break;
      case ssm::SafetyLabel::kNonGround:
        h.labels[i] = HybridLabel::kObstacle;
        break;
      default:
        h.labels[i] = HybridLabel::kUnknown;
        break;
    }
  }
  return h;
}

// Copies of the three maps (same cells) in which a cell keeps its class only when all three
// classify it (not Unknown).
void commonCells(const HybridSafetyMap (&in)[kSources], HybridSafetyMap (*out)[kSources]) {
  for (int s = 0; s < kSources; ++s)
    (*out)[s] = in[s];
  for (std::size_t i = 0; i < in[0].labels.size(); ++i) {
    bool all = true;
    for (int s = 0; s < kSources; ++s)
      all = all && in[s].labels[i] != HybridLabel::kUnknown;
    if (!all) {
      for (int s = 0; s < kSources; ++s)
        (*out)[s].labels[i] = HybridLabel::kUnknown;
    }
  }
}

// Axis-aligned xy bounds of an oriented box.
void xyBounds(const ssm::BoardBox& b, double* x0, double* y0, double* x1, double* y1) {
  *x0 = *y0 = std::numeric_limits<double>::infinity();
  *x1 = *y1 = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c((k & 1 ? 1 : -1) * b.half_size.x(), (k & 2 ? 1 : -1) * b.half_size.y(),
                            (k & 4 ? 1 : -1) * b.half_size.z());
    const Eigen::Vector3d p = b.center + b.rotation * c;
    *x0 = std::min(*x0, p.x());
    *y0 = std::min(*y0, p.y());
    *x1 = std::max(*x1, p.x());
    *y1 = std::max(*y1, p.y());
  }
}

double zMin(const ssm::BoardBox& b) {
  double z = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c((k & 1 ? 1 : -1) * b.half_size.x(), (k & 2 ? 1 : -1) * b.half_size.y(),
                            (k & 4 ? 1 : -1) * b.half_size.z());
    z = std::min(z, (b.center + b.rotation * c).z());
  }
  return z;
}
double zMax(const ssm::BoardBox& b) {
  double z = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c((k & 1 ? 1 : -1) * b.half_size.x(), (k & 2 ? 1 : -1) * b.half_size.y(),
                            (k & 4 ? 1 : -1) * b.half_size.z());
    z = std::max(z, (b.center + b.rotation * c).z());
  }
  return z;
}

// Ground-truth Non-ground cells the laser cannot see by construction, in GT cell indices (u, v),
// three kinds: under obstacles whose bottom lies between the laser plane and the robot's height
// (overhangs: table tops, shelves), in obstacles whose top lies below the laser plane (low
// obstacles), and Non-ground cells with no obstacle within `margin` (ground hazards: below a
// drop-off, too steep, unreachable). Cells within `margin` of an obstacle that reaches into the
// laser plane are left out (the laser sees those).
constexpr int kBlindKinds = 3;
const char* const kBlindNames[kBlindKinds] = {"overhangs above the laser plane",
                                              "obstacles below the laser plane",
                                              "ground hazards (drop-offs, steep or unreachable)"};
const char* const kBlindKeys[kBlindKinds] = {"overhang", "low", "ground"};

struct LaserBlindCells {
  std::vector<std::pair<int, int>> cells[kBlindKinds];
  std::vector<std::string> names[kBlindKinds];  ///< obstacles that gave cells
};

LaserBlindCells laserBlindCells(const ssm::Dataset& d, double laser_z, double robot_height,
                                double margin = 0.1) {
  LaserBlindCells out;
  const double res = d.gt.resolution;
  struct Xy {
    double x0, y0, x1, y1;
    int kind;  // 0 above, 1 below, 2 through the laser plane, 3 above the robot
    std::string name;
    bool used;
  };
  std::vector<Xy> boxes;
  for (const ssm::DatasetObstacle& o : d.obstacles) {
    Xy b;
    xyBounds(o.box, &b.x0, &b.y0, &b.x1, &b.y1);
    const double z0 = zMin(o.box), z1 = zMax(o.box);
    b.kind = z0 > laser_z + 0.02 ? (z0 < robot_height ? 0 : 3) : (z1 < laser_z - 0.02 ? 1 : 2);
    b.name = o.name;
    b.used = false;
    boxes.push_back(b);
  }
  for (int v = d.gt.min_v; v < d.gt.min_v + d.gt.height; ++v) {
    for (int u = d.gt.min_u; u < d.gt.min_u + d.gt.width; ++u) {
      if (d.gt.at(u, v) != ssm::SafetyLabel::kNonGround) continue;
      const double x = u * res, y = v * res;
      const auto inside = [x, y](const Xy& b, double m) {
        return x >= b.x0 - m && x <= b.x1 + m && y >= b.y0 - m && y <= b.y1 + m;
      };
      bool near_through = false, near_any = false;
      Xy* low = nullptr;
      Xy* above = nullptr;
      for (Xy& b : boxes) {
        if (b.kind == 3) continue;  // above the robot: not why the cell is Non-ground
        near_any = near_any || inside(b, margin);
        if (b.kind == 2) near_through = near_through || inside(b, margin);
        if (b.kind == 1 && inside(b, 0.0)) low = &b;
        if (b.kind == 0 && inside(b, 0.0)) above = &b;
      }
      if (near_through) continue;
      if (low) {
        out.cells[1].emplace_back(u, v);
        low->used = true;
      } else if (above) {
        out.cells[0].emplace_back(u, v);
        above->used = true;
      } else if (!near_any) {
        out.cells[2].emplace_back(u, v);
      }
    }
  }
  for (const Xy& b : boxes) {
    if (b.used) out.names[b.kind].push_back(b.name);
  }
  return out;
}

// How each map labels a set of cells, summed over frames: counts[source][label].
struct CellClassCounts {
  std::uint64_t counts[kSources][5] = {};
  void add(const HybridSafetyMap (&maps)[kSources], const std::vector<std::pair<int, int>>& cells) {
    for (int s = 0; s < kSources; ++s) {
      for (const auto& c : cells) {
        if (!maps[s].inside(c.first, c.second)) continue;
        ++counts[s][static_cast<int>(maps[s].labelAt(c.first, c.second))];
      }
    }
  }
  std::uint64_t classified(int s) const {
    return counts[s][1] + counts[s][2] + counts[s][3] + counts[s][4];
  }
  double fraction(int s, std::initializer_list<HybridLabel> labels) const {
    const std::uint64_t n = classified(s);
    if (n == 0) return kNaN;
    std::uint64_t k = 0;
    for (HybridLabel l : labels)
      k += counts[s][static_cast<int>(l)];
    return static_cast<double>(k) / n;
  }
};

// 001 Fig. 5 colours (BGR): obstacles black, hazards dark grey, unknown light grey, safe white;
// caution (not in 001's figure) yellow.
cv::Vec3b hybridColour(HybridLabel l) {
  switch (l) {
    case HybridLabel::kObstacle:
      return {0, 0, 0};
    case HybridLabel::kHazard:
      return {90, 90, 90};
    case HybridLabel::kCaution:
      return {80, 210, 235};
    case HybridLabel::kSafe:
      return {255, 255, 255};
    default:
      return {200, 200, 200};
  }
}

ssm::SafetyMap geometryOf(const HybridSafetyMap& h) {
  ssm::SafetyMap g;
  g.min_u = h.min_u;
  g.min_v = h.min_v;
  g.width = h.width;
  g.height = h.height;
  g.resolution = h.resolution;
  return g;
}

cv::Mat hybridPanel(const HybridSafetyMap& h, const Eigen::Vector3d& robot, double yaw,
                    const std::string& title) {
  const ssm::SafetyMap g = geometryOf(h);
  cv::Mat img = ssm::mapPanel(g, [&h](int, int, int k) { return hybridColour(h.labels[k]); });
  ssm::drawRobot(&img, g, robot, yaw);
  return ssm::titled(img, title);
}

// ---------------------------------------------------------------------------------------------
// Every LaserScan of a bag in stamp order with its pose from the bag's tf, as the hybrid nodelet
// receives them (the dataset reader keeps only the newest scan per stereo pair, and in the
// package's bags half of the scans are replaced before the next pair is complete).

class ScanReader {
 public:
  bool open(const std::string& bag, const std::string& topic) {
    try {
      bag_.open(bag, rosbag::bagmode::Read);
      view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery(topic));
    } catch (const std::exception&) {
      return false;
    }
    it_ = view_->begin();
    return view_->size() > 0;
  }
  // The next scan stamped at or before `stamp`; false when there is none (yet).
  bool next(const ros::Time& stamp, sensor_msgs::LaserScanConstPtr* scan) {
    while (view_ && it_ != view_->end()) {
      if (it_->getTime() > stamp) return false;
      *scan = it_->instantiate<sensor_msgs::LaserScan>();
      ++it_;
      if (*scan) return true;
    }
    return false;
  }

 private:
  rosbag::Bag bag_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
};

// ---------------------------------------------------------------------------------------------
// Ground-truth depth of a bag rendered with --depth, read alongside the stereo pairs.

class DepthReader {
 public:
  bool open(const std::string& bag) {
    try {
      bag_.open(bag, rosbag::bagmode::Read);
      view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery("/ground_truth/depth"));
    } catch (const std::exception&) {
      return false;
    }
    if (view_->size() == 0) return false;
    it_ = view_->begin();
    return true;
  }
  // The depth image stamped `stamp` (CV_32FC1), empty when there is none.
  cv::Mat at(const ros::Time& stamp) {
    if (!view_) return {};
    while (it_ != view_->end()) {
      sensor_msgs::ImageConstPtr m = it_->instantiate<sensor_msgs::Image>();
      if (!m || m->header.stamp < stamp) {
        ++it_;
        continue;
      }
      if (m->header.stamp > stamp) return {};
      try {
        return cv_bridge::toCvShare(m, "32FC1")->image.clone();
      } catch (const std::exception&) {
        return {};
      }
    }
    return {};
  }

 private:
  rosbag::Bag bag_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
};

// Ghost points (001 Sec. 4: "false positives, e.g., points in free space") among camera-frame
// points: the point's disparity differs from the ground-truth depth's at its pixel by more than
// `ghost_px`. Points on pixels without ground truth are not counted.
void countGhosts(const std::vector<Eigen::Vector3f>& points, const cv::Mat& depth,
                 const ssm::StereoCameraModel& cam, double ghost_px, std::uint64_t* checked,
                 std::uint64_t* ghosts) {
  if (depth.empty()) return;
  for (const Eigen::Vector3f& p : points) {
    if (!(p.z() > 0.0f)) continue;
    const int col = static_cast<int>(std::lround(cam.fx * p.x() / p.z() + cam.cx));
    const int row = static_cast<int>(std::lround(cam.fy * p.y() / p.z() + cam.cy));
    if (col < 0 || row < 0 || col >= depth.cols || row >= depth.rows) continue;
    const float z_gt = depth.at<float>(row, col);
    if (!std::isfinite(z_gt) || z_gt <= 0.0f) continue;
    ++*checked;
    const double d = cam.disparityFromDepth(p.z());
    const double d_gt = cam.disparityFromDepth(z_gt);
    if (std::abs(d - d_gt) > ghost_px) ++*ghosts;
  }
}

struct Stats {
  double mean = kNaN, median = kNaN, max = kNaN;
};
Stats statsOf(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  double sum = 0.0;
  for (double x : v)
    sum += x;
  s.mean = sum / v.size();
  s.median = v[v.size() / 2];
  s.max = v.back();
  return s;
}

// ---------------------------------------------------------------------------------------------
// Table 2 run: laser-only, stereo-only and merged maps of every integrated frame.

struct FusionResult {
  std::string name;
  std::string scene;
  int pairs = 0;
  int integrated = 0;
  int scans = 0;
  double laser_z = kNaN;
  ConfusionCounts own[kSources], common[kSources];
  LaserBlindCells blind;
  CellClassCounts blind_counts[kBlindKinds];
  std::vector<double> laser_ms, build_ms, frame_ms;
  std::vector<std::string> images;
};

std::string runFusion(const std::string& bag, const ssm::StereoFrameProcessorConfig& config,
                      const Options& opt, bool pictures, FusionResult* r) {
  ssm::Dataset d;
  std::string e = ssm::loadDataset(bag, false, &d);
  if (!e.empty()) return e;
  r->name = d.name;
  r->scene = d.scene;
  const HybridSafetyMap truth = hybridTruth(d.gt);

  ssm::StereoBagReader reader;
  ssm::StereoBagReaderOptions ro;
  ro.max_frames = opt.max_frames;
  e = reader.open(bag, ro);
  if (!e.empty()) return e;
  ScanReader scans;
  if (!scans.open(bag, ro.scan_topic)) return d.name + ": no " + ro.scan_topic + " in " + bag;

  ssm::StereoFrameProcessor proc(config);
  // The laser grid of the hybrid nodelet: its defaults (config/hybrid_safety_map.yaml), cells of
  // the voxel grid's size, a window 2 m larger than the stereo map.
  ssm::LaserGridConfig lc;
  lc.resolution = config.mapper.grid.voxel_size;
  lc.width = static_cast<int>(std::lround((config.mapper.grid.size_x + 2.0) / lc.resolution));
  lc.height = static_cast<int>(std::lround((config.mapper.grid.size_y + 2.0) / lc.resolution));
  ssm::LaserGrid laser(lc);
  ssm::HybridSafetyMapBuilder builder;
  ssm::HybridSafetyMapConfig fill_config;
  fill_config.laser_free_vision_unknown_is_safe = true;
  ssm::HybridSafetyMapBuilder fill_builder(fill_config);
  HybridSafetyMap maps[kSources], common[kSources];
  sensor_msgs::LaserScanConstPtr scan;
  ssm::StereoBagFrame f;
  Eigen::Vector3d last_robot = Eigen::Vector3d::Zero();
  double last_yaw = kNaN;
  bool blind_ready = false;

  while (reader.next(&f)) {
    ++r->pairs;
    const Clock::time_point t0 = Clock::now();
    // Every scan up to this pair, as the nodelet integrates them.
    while (scans.next(f.stamp, &scan)) {
      ssm::LaserScanInfo info;
      if (!ssm::laserScanInfoFromMsg(*scan, &info).empty()) continue;
      Eigen::Isometry3f T;
      try {
        T = tf2::transformToEigen(reader.tf().lookupTransform(ro.fixed_frame, scan->header.frame_id,
                                                              scan->header.stamp))
                .cast<float>();
      } catch (const tf2::TransformException&) {
        continue;
      }
      const Clock::time_point tl = Clock::now();
      laser.recenter(T.translation().x(), T.translation().y());
      laser.integrate(info, scan->ranges, T);
      r->laser_ms.push_back(msSince(tl));
      ++r->scans;
      if (!blind_ready) {
        r->laser_z = T.translation().z();
        r->blind = laserBlindCells(d, r->laser_z, config.mapper.height_map.robot_height);
        blind_ready = true;
      }
    }
    if (!f.error.empty() || f.index % opt.every != 0) continue;
    ssm::StereoFrameResult res;
    std::string err;
    if (!proc.processImages(f.left, f.right, f.camera, f.T_fixed_sensor.cast<float>(),
                            f.robot.cast<float>(), f.stamp.toSec(), &res, &err)) {
      continue;
    }
    ++r->integrated;
    const Clock::time_point tb = Clock::now();
    for (int s = 0; s < kSources; ++s) {
      (s == 3 ? fill_builder : builder)
          .build(kSourceOrder[s], proc.mapper().safetyMap(), laser, &maps[s]);
    }
    r->build_ms.push_back(msSince(tb) / kSources);
    commonCells(maps, &common);
    for (int s = 0; s < kSources; ++s) {
      e = ssm::countHybridConfusion(maps[s], truth, &r->own[s]);
      if (e.empty()) e = ssm::countHybridConfusion(common[s], truth, &r->common[s]);
      if (!e.empty()) return d.name + ": " + e;
    }
    if (blind_ready) {
      for (int k = 0; k < kBlindKinds; ++k)
        r->blind_counts[k].add(maps, r->blind.cells[k]);
    }
    last_robot = f.robot;
    last_yaw = ssm::yawOfOpticalAxis(f.T_fixed_sensor);
    r->frame_ms.push_back(msSince(t0));
    if (!opt.quiet && r->integrated % 50 == 0) {
      std::fprintf(stderr, "  %s: %d pairs, %d integrated\n", d.name.c_str(), r->pairs,
                   r->integrated);
    }
  }
  if (r->integrated == 0) return d.name + ": no frame was integrated";

  if (pictures) {
    // Last frame: laser-only | stereo-only | merged | ground truth, 001 Fig. 5 colours.
    HybridSafetyMap gt_window = maps[0];
    for (int row = 0; row < gt_window.height; ++row) {
      for (int col = 0; col < gt_window.width; ++col) {
        gt_window.labels[static_cast<std::size_t>(row) * gt_window.width + col] =
            truth.labelAt(gt_window.min_u + col, gt_window.min_v + row);
      }
    }
    // In the truth panel, the laser-blind cells as hazards (what 001's annotator would mark).
    for (int k = 0; k < kBlindKinds; ++k) {
      for (const auto& c : r->blind.cells[k]) {
        if (gt_window.inside(c.first, c.second)) {
          gt_window.labels[gt_window.index(c.first, c.second)] = HybridLabel::kHazard;
        }
      }
    }
    std::vector<cv::Mat> panels;
    panels.push_back(hybridPanel(maps[0], last_robot, last_yaw, "laser only"));
    panels.push_back(hybridPanel(maps[1], last_robot, last_yaw, "stereo only"));
    panels.push_back(hybridPanel(maps[2], last_robot, last_yaw, "merged (001)"));
    panels.push_back(hybridPanel(gt_window, last_robot, last_yaw, "ground truth"));
    cv::Mat row;
    cv::hconcat(panels, row);
    const std::string file = d.name + "_last_frame.png";
    if (cv::imwrite(opt.out + "/" + file, row)) r->images.push_back(file);
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// Landmark filter off / on on the same disparity images.

struct LandmarkRun {
  int integrated = 0;
  ConfusionCounts map;
  std::uint64_t points_reprojected = 0, points_to_grid = 0;
  std::uint64_t checked_to_grid = 0, ghosts_to_grid = 0;
  std::vector<double> landmark_ms, landmark_cpu_ms, frame_ms;
  std::size_t permanent = 0;
};

struct LandmarkResult {
  std::string name;
  std::string disparity;  ///< which disparity post-filters ran
  bool has_depth = false;
  int pairs = 0;
  LandmarkRun off, on;
};

std::string runLandmarks(const std::string& bag, const ssm::StereoFrameProcessorConfig& config,
                         const Options& opt, LandmarkResult* r) {
  ssm::Dataset d;
  std::string e = ssm::loadDataset(bag, false, &d);
  if (!e.empty()) return e;
  r->name = d.name;
  ssm::StereoBagReader reader;
  ssm::StereoBagReaderOptions ro;
  ro.max_frames = opt.max_frames;
  ro.scan_topic = "";
  e = reader.open(bag, ro);
  if (!e.empty()) return e;
  DepthReader depth;
  r->has_depth = depth.open(bag);

  ssm::StereoFrameProcessorConfig c_off = config, c_on = config;
  c_off.landmark_filter.enabled = false;
  c_on.landmark_filter.enabled = true;
  ssm::StereoFrameProcessor off(c_off), on(c_on);
  ssm::StereoBagFrame f;
  std::vector<ssm::CellOutcome> outcomes;
  while (reader.next(&f)) {
    ++r->pairs;
    if (!f.error.empty() || f.index % opt.every != 0) continue;
    const Eigen::Isometry3f T = f.T_fixed_sensor.cast<float>();
    const Eigen::Vector3f robot = f.robot.cast<float>();
    const double stamp = f.stamp.toSec();
    ssm::StereoFrameResult res;
    std::string err;
    const Clock::time_point t0 = Clock::now();
    const bool ok_off = off.processImages(f.left, f.right, f.camera, T, robot, stamp, &res, &err);
    if (off.disparity().empty()) continue;  // bad pair: neither run sees it
    const double disparity_ms = res.timings.disparity_ms;
    const cv::Mat dmap = depth.at(f.stamp);
    if (ok_off) {
      LandmarkRun& run = r->off;
      ++run.integrated;
      run.frame_ms.push_back(msSince(t0));
      run.points_reprojected += res.points_reprojected;
      run.points_to_grid += res.points;
      countGhosts(off.points(), dmap, f.camera, opt.ghost_px, &run.checked_to_grid,
                  &run.ghosts_to_grid);
      e = ssm::countConfusion(off.mapper().safetyMap(), d.gt, &run.map);
      if (!e.empty()) return d.name + ": " + e;
    }
    const Clock::time_point t1 = Clock::now();
    ssm::StereoFrameResult res_on;
    const bool ok_on =
        on.processDisparity(off.disparity(), off.disparityCamera(), T, robot, stamp, &res_on, &err);
    LandmarkRun& run = r->on;
    if (res_on.landmark_filter_ran) {
      run.landmark_ms.push_back(res_on.timings.landmark_ms);
      run.landmark_cpu_ms.push_back(res_on.timings.landmark_cpu_ms);
      run.points_reprojected += res_on.points_reprojected;
      run.points_to_grid += res_on.points;
      countGhosts(on.points(), dmap, f.camera, opt.ghost_px, &run.checked_to_grid,
                  &run.ghosts_to_grid);
      run.permanent = res_on.landmarks.permanent;
    }
    if (ok_on) {
      ++run.integrated;
      run.frame_ms.push_back(msSince(t1) + disparity_ms);
      e = ssm::countConfusion(on.mapper().safetyMap(), d.gt, &run.map);
      if (!e.empty()) return d.name + ": " + e;
    }
    if (!opt.quiet && r->pairs % 100 == 0) {
      std::fprintf(stderr, "  %s (landmarks): %d pairs\n", d.name.c_str(), r->pairs);
    }
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// Output

std::string fmt(double v, int digits = 2) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << v;
  return os.str();
}
std::string pct(double v, int digits = 1) {
  return std::isfinite(v) ? fmt(100.0 * v, digits) + " %" : "n/a";
}
double ratio(std::uint64_t a, std::uint64_t b) {
  return b > 0 ? static_cast<double>(a) / b : kNaN;
}

using stereo_safety_map::tools::Json;  // tools/json.h

// 001's A, B, C: safe in both, safe in the map only, safe in the ground truth only.
void jsonCounts(Json& j, const std::string& k, const ConfusionCounts& c) {
  const ssm::SafeClassScores s = ssm::safeClassScores(c);
  j.key(k).open('{').kv("A", c.tn).kv("B", c.fn).kv("C", c.fp).kv("unsafe_both", c.tp);
  j.kv("precision", s.precision).kv("recall", s.recall).kv("f1", s.f1).close('}');
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parseArgs(argc, argv, &opt)) return ssm::tools::usageError(usage);
  ros::Time::init();
  const std::string command = ssm::tools::commandLine("evaluate_hybrid", argc, argv);

  ssm::StereoFrameProcessorConfig config;
  if (ssm::tools::printError(ssm::loadCoreParams(opt.params, opt.sets, &config))) return 2;
  if (!ssm::makeDirs(opt.out)) {
    std::fprintf(stderr, "error: cannot create %s\n", opt.out.c_str());
    return 1;
  }
  const Clock::time_point start = Clock::now();

  std::vector<FusionResult> fusion;
  for (int pass = 0; pass < 2; ++pass) {
    for (const std::string& b : pass == 0 ? opt.bags : opt.overhang_bags) {
      if (!opt.quiet) std::fprintf(stderr, "fusion: %s\n", b.c_str());
      FusionResult r;
      if (ssm::tools::printError(runFusion(b, config, opt, pass == 1, &r))) return 1;
      fusion.push_back(r);
    }
  }
  std::vector<LandmarkResult> landmarks;
  // Twice per bag: the disparity post-filters as configured (000 Sec. III, 002 Sec. 2.2, 4.2),
  // and the matcher alone (its uniqueness test only), closer to the raw dense stereo of 001.
  ssm::StereoFrameProcessorConfig raw = config;
  raw.disparity.enable_texture = false;
  raw.disparity.enable_left_right = false;
  raw.disparity.enable_neighbour_consistency = false;
  raw.disparity.enable_spike_removal = false;
  for (const std::string& b : opt.noisy_bags) {
    for (int pass = 0; pass < 2; ++pass) {
      if (!opt.quiet) std::fprintf(stderr, "landmark filter: %s\n", b.c_str());
      LandmarkResult r;
      r.disparity = pass == 0 ? "post-filters as configured" : "matcher only";
      if (ssm::tools::printError(runLandmarks(b, pass == 0 ? config : raw, opt, &r))) return 1;
      landmarks.push_back(r);
    }
  }
  const double wall_s = msSince(start) / 1000.0;

  // Table 2 over the --bag datasets (the overhang scenes are reported on their own).
  ConfusionCounts total_own[kSources], total_common[kSources];
  for (std::size_t k = 0; k < opt.bags.size(); ++k) {
    for (int s = 0; s < kSources; ++s) {
      total_own[s] += fusion[k].own[s];
      total_common[s] += fusion[k].common[s];
    }
  }

  // ---- JSON (its layout: one line per top-level member and per dataset)
  Json j;
  j.open('{').wrap(2).kv("command", command).wrap(2).kv("wall_s", wall_s);
  // 001 Table 2's precision / recall / F1, as the paper prints them.
  const char* const paper_table2[3][3] = {
      {"0.78", "0.99", "0.87"}, {"0.94", "0.86", "0.90"}, {"0.94", "0.89", "0.92"}};
  j.wrap(2).key("paper_table2").open('{');
  for (int s = 0; s < 3; ++s) {
    j.key(kSourceNames[s]).open('[');
    for (const char* v : paper_table2[s])
      j.raw(v);
    j.close(']');
  }
  j.close('}');
  j.wrap(2).key("table2").open('{');
  for (int s = 0; s < kSources; ++s) {
    j.key(kSourceNames[s]).open('{');
    jsonCounts(j, "own", total_own[s]);
    jsonCounts(j, "common", total_common[s]);
    j.close('}');
  }
  j.close('}');
  j.wrap(2).key("datasets").open('[');
  for (std::size_t k = 0; k < fusion.size(); ++k) {
    const FusionResult& r = fusion[k];
    j.wrap(4).open('{').kv("name", r.name).kv("in_table2", k < opt.bags.size());
    j.kv("pairs", r.pairs).kv("integrated", r.integrated).kv("scans", r.scans);
    j.kv("laser_z", r.laser_z);
    for (int s = 0; s < kSources; ++s) {
      j.key(kSourceNames[s]).open('{');
      jsonCounts(j, "own", r.own[s]);
      jsonCounts(j, "common", r.common[s]);
      for (int k = 0; k < kBlindKinds; ++k) {
        const CellClassCounts& c = r.blind_counts[k];
        const std::string key = kBlindKeys[k];
        j.kv(key + "_traversable", c.fraction(s, {HybridLabel::kSafe, HybridLabel::kCaution}));
        j.kv(key + "_hazard", c.fraction(s, {HybridLabel::kHazard}));
        j.kv(key + "_classified", c.classified(s));
      }
      j.close('}');
    }
    j.kv("laser_ms_median", statsOf(r.laser_ms).median);
    j.kv("build_ms_median", statsOf(r.build_ms).median).close('}');
  }
  j.wrap(2).close(']');
  j.wrap(2).key("landmark_filter").open('[');
  for (const LandmarkResult& r : landmarks) {
    j.wrap(4).open('{').kv("name", r.name).kv("disparity", r.disparity);
    j.kv("has_depth", r.has_depth).kv("ghost_px", opt.ghost_px);
    for (int on = 0; on < 2; ++on) {
      const LandmarkRun& run = on ? r.on : r.off;
      const ssm::ErrorRates er = ssm::errorRates(run.map);
      const ssm::SafeClassScores sc = ssm::safeClassScores(run.map);
      j.key(on ? "on" : "off").open('{').kv("integrated", run.integrated);
      j.kv("fp_rate", er.fp).kv("fn_rate", er.fn);
      j.kv("precision", sc.precision).kv("recall", sc.recall).kv("f1", sc.f1);
      j.kv("points_reprojected", run.points_reprojected).kv("points_to_grid", run.points_to_grid);
      j.kv("ghost_fraction_to_grid", ratio(run.ghosts_to_grid, run.checked_to_grid));
      j.kv("ghosts_to_grid", run.ghosts_to_grid);
      j.kv("landmark_ms_median", statsOf(run.landmark_ms).median);
      j.kv("landmark_ms_mean", statsOf(run.landmark_ms).mean);
      j.kv("landmark_ms_max", statsOf(run.landmark_ms).max);
      j.kv("landmark_cpu_ms_median", statsOf(run.landmark_cpu_ms).median);
      j.kv("landmark_cpu_ms_max", statsOf(run.landmark_cpu_ms).max);
      j.kv("frame_ms_median", statsOf(run.frame_ms).median).close('}');
    }
    j.close('}');
  }
  j.wrap(2).close(']').wrap(0).close('}');
  {
    std::ofstream out(opt.out + "/metrics.json");
    out << j.str() << "\n";
  }

  // ---- Markdown
  std::ostringstream md;
  md << "# Laser + stereo hybrid safety map (paper 001)\n\n"
     << "Command: `" << command << "` (" << fmt(wall_s, 0) << " s).\n\n";
  if (!opt.bags.empty()) {
    md << "## Table 2 of 001: safe-class precision / recall / F1\n\n"
       << "Cells of every integrated frame's map against the ground truth, summed over the "
       << opt.bags.size()
       << " datasets (A = safe in map and ground truth, B = safe in the map only, C = safe in the "
          "ground truth only; Unknown cells do not count). *Own*: each map on the cells it "
          "classifies (001's protocol); *common*: the cells all of them classify. "
          "merged_laser_fills_unknown: the merged map with laser_free_vision_unknown_is_safe "
          "(laser-free cells vision has not examined are Safe).\n\n"
       << "| map | precision | recall | F1 | precision (common) | recall (common) | F1 (common) "
          "| 001 Table 2 (P / R / F1) |\n|---|---|---|---|---|---|---|---|\n";
    const char* paper[kSources] = {"0.78 / 0.99 / 0.87", "0.94 / 0.86 / 0.90", "0.94 / 0.89 / 0.92",
                                   "-"};
    for (int s = 0; s < kSources; ++s) {
      const ssm::SafeClassScores a = ssm::safeClassScores(total_own[s]);
      const ssm::SafeClassScores b = ssm::safeClassScores(total_common[s]);
      md << "| " << kSourceNames[s] << " | " << fmt(a.precision) << " | " << fmt(a.recall) << " | "
         << fmt(a.f1) << " | " << fmt(b.precision) << " | " << fmt(b.recall) << " | " << fmt(b.f1)
         << " | " << paper[s] << " |\n";
    }
    md << "\nPer dataset (own coverage, P / R / F1):\n\n| dataset | frames | laser | stereo | "
          "merged | merged, laser fills unknown |\n|---|---|---|---|---|---|\n";
    for (std::size_t k = 0; k < fusion.size(); ++k) {
      const FusionResult& r = fusion[k];
      md << "| " << r.name << (k < opt.bags.size() ? "" : " (not in the total)") << " | "
         << r.integrated;
      for (int s = 0; s < kSources; ++s) {
        const ssm::SafeClassScores a = ssm::safeClassScores(r.own[s]);
        md << " | " << fmt(a.precision) << " / " << fmt(a.recall) << " / " << fmt(a.f1);
      }
      md << " |\n";
    }
  }
  if (!fusion.empty()) {
    md << "\n## What the laser cannot see\n\n"
       << "Ground-truth Non-ground cells the laser cannot see: under obstacles whose bottom "
          "lies between the laser plane and the robot's height (overhangs: table tops, shelves), "
          "in obstacles entirely below the plane, and Non-ground ground with no obstacle within "
          "0.1 m (below drop-offs, too steep, unreachable); cells within 0.1 m of an obstacle "
          "that reaches into the plane are left out. Over all integrated frames: the share of "
          "the cell observations each map classifies (not Unknown) that it calls traversable "
          "(Safe / Caution) or Hazard, and how many it classifies.\n\n"
       << "| dataset | kind (obstacles) | GT cells | laser: traversable | stereo: traversable | "
          "merged: traversable | merged: hazard | observations classified (laser / stereo / "
          "merged) |\n|---|---|---|---|---|---|---|---|\n";
    for (const FusionResult& r : fusion) {
      for (int kind = 0; kind < kBlindKinds; ++kind) {
        const CellClassCounts& c = r.blind_counts[kind];
        if (r.blind.cells[kind].empty()) continue;
        std::string list;
        for (const std::string& n : r.blind.names[kind])
          list += (list.empty() ? "" : ", ") + n;
        md << "| " << r.name << " | " << kBlindNames[kind]
           << (list.empty() ? "" : " (" + list + ")") << " | " << r.blind.cells[kind].size()
           << " | " << pct(c.fraction(0, {HybridLabel::kSafe, HybridLabel::kCaution})) << " | "
           << pct(c.fraction(1, {HybridLabel::kSafe, HybridLabel::kCaution})) << " | "
           << pct(c.fraction(2, {HybridLabel::kSafe, HybridLabel::kCaution})) << " | "
           << pct(c.fraction(2, {HybridLabel::kHazard})) << " | " << c.classified(0) << " / "
           << c.classified(1) << " / " << c.classified(2) << " |\n";
      }
    }
    for (const FusionResult& r : fusion) {
      for (const std::string& img : r.images) {
        md << "\n![" << r.name << "](" << img << ")\n\n"
           << "Last frame of " << r.name
           << ": laser only, stereo only, merged, ground truth (obstacles black, hazards dark "
              "grey, caution yellow, unknown light grey, safe white; in the ground truth the "
              "cells the laser cannot see are drawn as hazards).\n";
      }
    }
    md << "\nTime per frame (median): laser scan ray casting " <<
        [&] {
          std::vector<double> all;
          for (const FusionResult& r : fusion)
            all.insert(all.end(), r.laser_ms.begin(), r.laser_ms.end());
          return fmt(statsOf(all).median, 3);
        }()
       << " ms, building one hybrid map " <<
        [&] {
          std::vector<double> all;
          for (const FusionResult& r : fusion)
            all.insert(all.end(), r.build_ms.begin(), r.build_ms.end());
          return fmt(statsOf(all).median, 3);
        }()
       << " ms.\n";
  }
  if (!landmarks.empty()) {
    md << "\n## Landmark filter (001 Sec. 4.2) in front of the voxel grid\n\n"
       << "The same disparity images mapped without and with the filter. Map rates as 000 Sec. "
          "VII-A (unsafe positive: FP = unsafe in the map, safe in the ground truth), summed over "
          "the integrated frames; ghost points: points reaching the voxel grid whose disparity is "
          "more than "
       << fmt(opt.ghost_px, 1)
       << " px from the ground-truth depth's; time: the filter's update per frame, wall and "
          "thread CPU (the machine may be shared; bench_landmark_filter measures the filter "
          "alone). Disparity: the post-filters as configured, or the matcher alone (its "
          "uniqueness test only), closer to the raw dense stereo of 001.\n\n"
       << "| dataset | disparity | filter | frames | FP rate | FN rate | safe P / R / F1 | points "
          "to the grid per frame | ghost points to the grid | of which ghosts | filter wall "
          "median / max [ms] | filter CPU median / max [ms] |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const LandmarkResult& r : landmarks) {
      for (int on = 0; on < 2; ++on) {
        const LandmarkRun& run = on ? r.on : r.off;
        const ssm::ErrorRates er = ssm::errorRates(run.map);
        const ssm::SafeClassScores sc = ssm::safeClassScores(run.map);
        const std::size_t frames = on ? run.landmark_ms.size() : run.frame_ms.size();
        md << "| " << r.name << " | " << r.disparity << " | " << (on ? "on" : "off") << " | "
           << run.integrated << " | " << pct(er.fp, 2) << " | " << pct(er.fn, 2) << " | "
           << fmt(sc.precision) << " / " << fmt(sc.recall) << " / " << fmt(sc.f1) << " | "
           << fmt(frames ? static_cast<double>(run.points_to_grid) / frames : kNaN, 0) << " | "
           << (r.has_depth ? std::to_string(run.ghosts_to_grid) : "n/a (no depth)") << " | "
           << (r.has_depth ? pct(ratio(run.ghosts_to_grid, run.checked_to_grid), 2) : "n/a")
           << " | "
           << (on ? fmt(statsOf(run.landmark_ms).median, 1) + " / " +
                        fmt(statsOf(run.landmark_ms).max, 1)
                  : "-")
           << " | "
           << (on ? fmt(statsOf(run.landmark_cpu_ms).median, 1) + " / " +
                        fmt(statsOf(run.landmark_cpu_ms).max, 1)
                  : "-")
           << " |\n";
      }
    }
    md << "\nPermanent landmarks at the end: ";
    for (std::size_t k = 0; k < landmarks.size(); ++k)
      md << (k ? ", " : "") << landmarks[k].name << " (" << landmarks[k].disparity << ") "
         << landmarks[k].on.permanent;
    md << ".\n";
  }
  {
    std::ofstream out(opt.out + "/report.md");
    out << md.str();
  }
  std::printf("%s", md.str().c_str());
  std::printf("wrote %s/report.md and %s/metrics.json in %.0f s\n", opt.out.c_str(),
              opt.out.c_str(), wall_s);
  return 0;
}
