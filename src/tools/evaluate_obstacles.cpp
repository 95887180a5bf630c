// evaluate_obstacles: the 3D obstacle detection of paper 003 (and its column-wise baseline)
// against the ground-truth obstacles of the benchmark datasets, and the frame latency of the
// board (000 Sec. VII-B) with and without the single-frame obstacle cue fused into the safety
// map. No roscore: each bag is read directly (dataset_reader.h) and goes through the same core
// code as the nodelets: StereoFrameProcessor (disparity, voxel grid, labelling) and, on its
// disparity, ObstacleDetector and ObstacleCueFusion.
//
// Why one file of ~810 lines (issue 17 asks for a reason above ~800): it is already one function
// per part (parseArgs, scoreFrame, evaluateBag: the frame loop, main: the report); split into
// run / score / report units as the other evaluators are, their result structs (MethodScore,
// Latency, DatasetResult) would move into a header of their own for ten lines over the mark.
//
//   evaluate_obstacles --bag A.bag [--bag B.bag ...] [--latency-bag L.bag ...] [--out DIR]
//                      [--params config/safety_map.yaml] [--obstacle-params
//                      config/obstacle_detection.yaml] [--every N] [--max-frames N]
//                      [--max-range 8] [--min-visible 30] [--min-fraction 0.25]
//                      [--margin 0.1] [--images N] [--quiet]
//
// Definitions (also written into report.md):
//  - Detected obstacle points: the raised points (upper ends of compatible pairs, 003 Def. 1) of
//    the obstacles the Sec. 5 rules accept, within --max-range of the camera (depth). Their feet
//    (lower ends only) are ground and are not counted.
//  - A GT obstacle (an oriented box of <bag>_gt/gt_obstacles.yaml) is in view in a frame when
//    at least --min-visible valid range points lie inside its box, more than H_T above the box's
//    bottom and within --max-range: its visible points. It is detected in that frame when at
//    least --min-fraction of its visible points are detected obstacle points.
//  - Detection time: CPU time of the thread per frame (the machine may be shared).
//  - Recall = detected / in view, over all (frame, GT obstacle) pairs of a dataset. Point recall
//    = detected visible points / visible points.
//  - Precision = detected obstacle points inside some GT box grown by --margin on every side /
//    all detected obstacle points, over all frames. The other points are split by the GT label of
//    their cell: Non-ground (steps, lower sides of drop-offs: unsafe, but not boxes), safe next to
//    a Non-ground cell (the upper edge of a drop-off or step), safe elsewhere (false obstacles),
//    unknown / outside the GT.
//  - Map: 000's FN / FP rates (Sec. VII-A, evaluation_metrics.h) of the safety map without and
//    with the cue of the same frame applied (integrated frames only).
//  - Latency (--latency-bag): camera frames from the board's appearance until 50 % / 90 % of its
//    width is covered, (a) in the voxel grid (000 Sec. VII-B, boardWidthCoverage, as
//    evaluate_safety_map), (b) in the grid or by cells the cue marked, with the cue of the same
//    frame, (c) the same with the cue of the previous frames only (the nodelets run in parallel,
//    so the map of a frame may see the cue one frame late).
#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/obstacle_cue.h"
#include "stereo_safety_map/core/obstacle_detection.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/ros/obstacle_params.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/tools/args.h"
#include "stereo_safety_map/tools/boards.h"
#include "stereo_safety_map/tools/dataset_reader.h"
#include "stereo_safety_map/tools/json.h"
#include "stereo_safety_map/tools/series.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace ssm = stereo_safety_map;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Options {
  std::vector<std::string> bags;
  std::vector<std::string> latency_bags;
  std::string out = "out/evaluation/obstacles";
  std::string params;
  std::string obstacle_params;
  double noise_sigmas = -1.0;  // >= 0: overrides the detector's noise_sigmas (0 = 003's test)
  int decimation = 0;          // > 0: overrides the nodelet's decimation (1 = 003's full image)
  int every = 1;
  long max_frames = -1;
  double max_range = 8.0;
  int min_visible = 30;
  double min_fraction = 0.25;
  double margin = 0.1;
  int images = 2;
  bool quiet = false;
};

void usage() {
  std::fprintf(
      stderr,
      "usage: evaluate_obstacles --bag FILE [--bag FILE ...] [--latency-bag FILE ...]\n"
      "         [--out DIR] [--params YAML] [--obstacle-params YAML] [--noise-sigmas K]\n"
      "         [--decimation N] [--every "
      "N]\n"
      "         [--max-frames N] [--max-range M] [--min-visible N] [--min-fraction F]\n"
      "         [--margin M] [--images N] [--quiet]\n"
      "  --bag              dataset made by make_dataset: recall / precision against\n"
      "                     <bag>_gt/gt_obstacles.yaml, map error rates with / without cue\n"
      "  --latency-bag      board dataset (000 Sec. VII-B): latency with / without cue\n"
      "  --params           safety-map parameters (config/safety_map.yaml; obstacle_cue_*)\n"
      "  --obstacle-params  detector parameters (config/obstacle_detection.yaml)\n"
      "  --noise-sigmas K   override the detector's noise_sigmas (0 = 003's Definition 1)\n"
      "  --decimation N     override the nodelet's decimation (1 = 003's full image)\n"
      "  --max-range M      points farther than M (depth) are ignored [8 m]\n"
      "  --min-visible N    a GT obstacle with fewer visible points is not in view [30]\n"
      "  --min-fraction F   detected when F of its visible points are detected [0.25]\n"
      "  --margin M         GT boxes grown by M for precision [0.1 m]\n"
      "  --images N         overlay PNGs of N frames per dataset [2]\n");
}

bool parseArgs(int argc, char** argv, Options* o) {
  ssm::tools::Args a(argc, argv);
  while (a.next()) {
    if (a.value("--bag", &o->bags) || a.value("--latency-bag", &o->latency_bags) ||
        a.value("--out", &o->out) || a.value("--params", &o->params) ||
        a.value("--obstacle-params", &o->obstacle_params) ||
        a.value("--noise-sigmas", &o->noise_sigmas) || a.value("--decimation", &o->decimation) ||
        a.value("--max-frames", &o->max_frames) || a.flag("--quiet", &o->quiet))
      continue;
    if (a.value("--every", &o->every)) {
      if (o->every < 1) return false;
    } else if (a.value("--max-range", &o->max_range)) {
      if (!(o->max_range > 0.0)) return false;
    } else if (a.value("--min-visible", &o->min_visible)) {
      o->min_visible = std::max(1, o->min_visible);
    } else if (a.value("--min-fraction", &o->min_fraction)) {
      if (!(o->min_fraction > 0.0 && o->min_fraction <= 1.0)) return false;
    } else if (a.value("--margin", &o->margin)) {
      if (!(o->margin >= 0.0)) return false;
    } else if (a.value("--images", &o->images)) {
      o->images = std::max(0, o->images);
    } else {
      std::fprintf(stderr, "bad or incomplete argument: %s\n", a.arg().c_str());
      return false;
    }
  }
  return !o->bags.empty() || !o->latency_bags.empty();
}

using ssm::tools::Series;  // tools/series.h

// CPU time of this thread [ms]: the cost of a detection on one core, whatever else the machine
// runs (wall time on a shared machine measures the neighbours too).
double threadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double ratio(double a, double b) {
  return b > 0.0 ? a / b : kNaN;
}

// Scores of one method (3D or column-wise) over a dataset.
struct MethodScore {
  std::uint64_t instances = 0;         // (frame, GT obstacle) pairs in view
  std::uint64_t detected = 0;          // of which detected
  std::uint64_t visible_points = 0;    // their visible points
  std::uint64_t visible_detected = 0;  // of which detected obstacle points
  std::uint64_t points = 0;            // detected obstacle points
  std::uint64_t in_box = 0;            // inside a GT box (+ margin)
  std::uint64_t gt_nonground = 0;      // else in a GT Non-ground cell
  std::uint64_t gt_edge = 0;           // else safe next to a Non-ground cell
  std::uint64_t gt_safe = 0;           // else safe
  std::uint64_t gt_unknown = 0;        // else unknown / outside the GT
  std::map<std::string, std::pair<std::uint64_t, std::uint64_t>> by_type;  // in view, detected
  Series ms;  // detection time, CPU of one thread [ms]
  void add(const MethodScore& o) {
    instances += o.instances;
    detected += o.detected;
    visible_points += o.visible_points;
    visible_detected += o.visible_detected;
    points += o.points;
    in_box += o.in_box;
    gt_nonground += o.gt_nonground;
    gt_edge += o.gt_edge;
    gt_safe += o.gt_safe;
    gt_unknown += o.gt_unknown;
    for (const auto& kv : o.by_type) {
      by_type[kv.first].first += kv.second.first;
      by_type[kv.first].second += kv.second.second;
    }
    ms.v.insert(ms.v.end(), o.ms.v.begin(), o.ms.v.end());
  }
  double recall() const { return ratio(detected, instances); }
  double pointRecall() const { return ratio(visible_detected, visible_points); }
  double precision() const { return ratio(in_box, points); }
};

struct Latency {
  std::string board;
  int appear = -1;  // index of the first frame the board is in view
  std::vector<double> grid, cue, lagged;
  int frames(const std::vector<double>& c, double f) const {
    return ssm::framesUntilCoverage(c, f);
  }
};

struct DatasetResult {
  std::string name;
  bool latency_only = false;
  int pairs = 0, used = 0, integrated = 0, rejected = 0;
  int seeded = 0;  // maps in which 000's labelling found the robot's segment
  MethodScore m3d, col;
  ssm::ConfusionCounts map_plain, map_cue;
  std::uint64_t cue_cells_changed = 0, cue_safe_cells_changed = 0;
  std::vector<Latency> latency;
  std::vector<std::string> images;
  std::map<std::string, int> problems;
};

// An oriented GT box with its axes, for inside tests.
struct GtBox {
  std::string name, type;
  Eigen::Vector3d center;
  Eigen::Matrix3d rt;  // world -> box axes
  Eigen::Vector3d half;
  double bottom = 0.0;  // lowest corner z
};

std::vector<GtBox> gtBoxes(const ssm::Dataset& ds) {
  std::vector<GtBox> out;
  for (const ssm::DatasetObstacle& o : ds.obstacles) {
    GtBox b;
    b.name = o.name;
    b.type = o.type;
    b.center = o.box.center;
    b.rt = o.box.rotation.transpose();
    b.half = o.box.half_size;
    b.bottom = std::numeric_limits<double>::infinity();
    for (int c = 0; c < 8; ++c) {
      Eigen::Vector3d s;
      for (int k = 0; k < 3; ++k)
        s[k] = (c >> k) & 1 ? 1.0 : -1.0;
      b.bottom = std::min(b.bottom, (o.box.center + o.box.rotation * s.cwiseProduct(b.half)).z());
    }
    out.push_back(b);
  }
  return out;
}

bool inside(const GtBox& b, const Eigen::Vector3d& p, double margin) {
  const Eigen::Vector3d t = b.rt * (p - b.center);
  return std::abs(t.x()) <= b.half.x() + margin && std::abs(t.y()) <= b.half.y() + margin &&
         std::abs(t.z()) <= b.half.z() + margin;
}

// Scores one detection result of one frame against the GT boxes and labels.
void scoreFrame(const ssm::Dataset& ds, const std::vector<GtBox>& boxes, const cv::Mat& xyz,
                const Eigen::Isometry3d& T, const ssm::ObstacleDetectionResult& res,
                const Options& opt, double ht, MethodScore* s) {
  const int n_boxes = static_cast<int>(boxes.size());
  std::vector<std::uint64_t> visible(n_boxes, 0), hit(n_boxes, 0);
  const ssm::LabelGrid& gt = ds.gt;
  auto unsafeAt = [&gt](int u, int v) {
    return gt.inside(u, v) && gt.at(u, v) == ssm::SafetyLabel::kNonGround;
  };
  for (int r = 0; r < xyz.rows; ++r) {
    const cv::Vec3f* row = xyz.ptr<cv::Vec3f>(r);
    const std::uint8_t* m = res.mask.ptr<std::uint8_t>(r);
    for (int c = 0; c < xyz.cols; ++c) {
      const float z = row[c][2];
      if (!(z > 0.0f) || z > opt.max_range) continue;
      const Eigen::Vector3d p = T * Eigen::Vector3d(row[c][0], row[c][1], z);
      const bool detected = m[c] == ssm::ObstacleDetectionResult::kRaised;
      for (int k = 0; k < n_boxes; ++k) {
        if (p.z() > boxes[k].bottom + ht && inside(boxes[k], p, 0.0)) {
          ++visible[k];
          if (detected) ++hit[k];
          break;
        }
      }
      if (!detected) continue;
      ++s->points;
      bool in_box = false;
      for (int k = 0; k < n_boxes && !in_box; ++k)
        in_box = inside(boxes[k], p, opt.margin);
      if (in_box) {
        ++s->in_box;
        continue;
      }
      const double l = gt.resolution;
      const int u = static_cast<int>(std::floor(p.x() / l + 0.5)),
                v = static_cast<int>(std::floor(p.y() / l + 0.5));
      if (!gt.inside(u, v) || !ssm::isSafe(gt.at(u, v))) {
        if (unsafeAt(u, v)) {
          ++s->gt_nonground;
        } else {
          ++s->gt_unknown;
        }
        continue;
      }
      bool edge = false;
      for (int dv = -1; dv <= 1 && !edge; ++dv)
        for (int du = -1; du <= 1 && !edge; ++du)
          edge = unsafeAt(u + du, v + dv);
      if (edge) {
        ++s->gt_edge;
      } else {
        ++s->gt_safe;
      }
    }
  }
  for (int k = 0; k < n_boxes; ++k) {
    if (visible[k] < static_cast<std::uint64_t>(opt.min_visible)) continue;
    ++s->instances;
    s->visible_points += visible[k];
    s->visible_detected += hit[k];
    const bool det = static_cast<double>(hit[k]) >= opt.min_fraction * visible[k];
    s->detected += det;
    auto& t = s->by_type[boxes[k].type];
    ++t.first;
    t.second += det;
  }
}

// The raised points of the accepted obstacles, in the fixed frame: the obstacle cue, exactly as
// ObstacleDetectionNodelet publishes it.
void cuePoints(const cv::Mat& xyz, const ssm::ObstacleDetectionResult& res,
               const Eigen::Isometry3f& T, std::vector<Eigen::Vector3f>* out) {
  out->clear();
  for (int r = 0; r < xyz.rows; ++r) {
    const cv::Vec3f* row = xyz.ptr<cv::Vec3f>(r);
    const std::uint8_t* m = res.mask.ptr<std::uint8_t>(r);
    for (int c = 0; c < xyz.cols; ++c) {
      if (m[c] == ssm::ObstacleDetectionResult::kRaised)
        out->push_back(T * Eigen::Vector3f(row[c][0], row[c][1], row[c][2]));
    }
  }
}

// Left image with the detected obstacle points: 3D (left half) and column-wise (right half).
cv::Mat overlay(const cv::Mat& left, const ssm::ObstacleDetectionResult& a,
                const ssm::ObstacleDetectionResult& b, const std::string& title) {
  cv::Mat grey;
  if (left.channels() == 1) {
    cv::cvtColor(left, grey, cv::COLOR_GRAY2BGR);
  } else {
    grey = left.clone();
  }
  cv::Mat out(grey.rows, grey.cols * 2, CV_8UC3);
  for (int k = 0; k < 2; ++k) {
    const ssm::ObstacleDetectionResult& r = k == 0 ? a : b;
    cv::Mat half = out(cv::Rect(k * grey.cols, 0, grey.cols, grey.rows));
    grey.copyTo(half);
    // A decimated detection (the nodelet's ~decimation): pixel (x, y) is its (x / n, y / n).
    const int n = std::max(1, (grey.cols + r.mask.cols - 1) / std::max(1, r.mask.cols));
    for (int y = 0; y < grey.rows && y / n < r.mask.rows; ++y) {
      const std::uint8_t* m = r.mask.ptr<std::uint8_t>(y / n);
      const std::int32_t* l = r.labels.ptr<std::int32_t>(y / n);
      cv::Vec3b* o = half.ptr<cv::Vec3b>(y);
      for (int x = 0; x < grey.cols && x / n < r.mask.cols; ++x) {
        const int xd = x / n;
        const bool rejected = l[xd] > 0 && r.obstacles[l[xd] - 1].rejected;
        if (m[xd] == ssm::ObstacleDetectionResult::kRaised) {
          o[x] = cv::Vec3b(o[x][0] / 3, 200, o[x][2] / 3 + 40);  // accepted: green
        } else if (rejected) {
          o[x] = cv::Vec3b(o[x][0] / 3, o[x][1] / 3, 220);  // rejected by Sec. 5: red
        }
      }
    }
    cv::putText(half, k == 0 ? "3D (003 OD/OS Alg. 2)" : "column-wise baseline", cv::Point(8, 20),
                cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(255, 255, 255), 2);
  }
  cv::putText(out, title, cv::Point(8, grey.rows - 10), cv::FONT_HERSHEY_SIMPLEX, 0.5,
              cv::Scalar(255, 255, 255), 1);
  return out;
}

std::string evaluateBag(const std::string& bag, bool latency_only, const Options& opt,
                        const ssm::StereoFrameProcessorConfig& pcfg,
                        const ssm::ObstacleDetectionConfig& ocfg,
                        const ssm::ObstacleDetectionRosConfig& orcfg,
                        const ssm::ObstacleCueConfig& ccfg, DatasetResult* res) {
  ssm::Dataset ds;
  std::string e = ssm::loadDataset(bag, latency_only, &ds);
  if (!e.empty()) return e;
  res->name = ds.name;
  res->latency_only = latency_only;
  const std::vector<GtBox> boxes = gtBoxes(ds);
  for (const ssm::DatasetBoard& b : ds.boards)
    res->latency.push_back(Latency{b.name, -1, {}, {}, {}});

  ssm::StereoBagReaderOptions ro;
  ro.scan_topic.clear();
  ro.max_frames = opt.max_frames;
  ssm::StereoBagReader reader;
  e = reader.open(bag, ro);
  if (!e.empty()) return e;
  std::set<int> image_frames;
  for (int k = 1; k <= opt.images && !latency_only; ++k)
    image_frames.insert(k * reader.pairCount() / (opt.images + 1));

  ssm::StereoFrameProcessor processor(pcfg);
  ssm::ObstacleDetector detector(ocfg);
  ssm::ObstacleCueFusion cue(ccfg), lagged(ccfg);
  ssm::ObstacleDetectionResult r3, rc;
  cv::Mat xyz_full, xyz;  // the range image, and what the detector gets (~decimation)
  std::vector<Eigen::Vector3f> pts;
  std::vector<std::uint8_t> marked, marked_lag, bins;
  const double ht = ocfg.height_threshold;
  const float robot_height = static_cast<float>(pcfg.mapper.height_map.robot_height);
  const bool columnwise_only = orcfg.method == "columnwise";
  ssm::StereoBagFrame frame;
  int index_in_bag = 0;
  while (reader.next(&frame)) {
    ++res->pairs;
    if (frame.index % opt.every != 0) continue;
    if (!frame.error.empty()) {
      ++res->rejected;
      ++res->problems[frame.error];
      continue;
    }
    ++res->used;
    const Eigen::Isometry3f T = frame.T_fixed_sensor.cast<float>();
    ssm::StereoFrameResult fr;
    std::string err;
    const bool integrated =
        processor.processImages(frame.left, frame.right, frame.camera, T, frame.robot.cast<float>(),
                                frame.stamp.toSec(), &fr, &err);
    const cv::Mat& disp = processor.disparity();
    if (disp.empty()) {
      ++res->rejected;
      ++res->problems[err];
      continue;
    }
    // The range image as the nodelet builds it: [min_depth, max_depth].
    ssm::reprojectDisparityOrganized(disp, frame.camera, orcfg.max_depth, &xyz_full);
    ssm::limitRangeImageDepth(orcfg.min_depth, orcfg.max_depth, &xyz_full);
    // ~decimation as the nodelet applies it: every n-th pixel, f / n, the full image's margin.
    const int n = orcfg.decimation;
    const double f = std::max(frame.camera.fx, frame.camera.fy) / n;
    const double baseline = frame.camera.baseline * n;
    double t0 = threadCpuMs();
    ssm::decimateRangeImage(xyz_full, n, &xyz);
    const bool ok3 = detector.detect(xyz, f, T, &r3, baseline);
    const double ms3 = threadCpuMs() - t0;
    t0 = threadCpuMs();
    const bool okc = detector.detectColumnwise(xyz, f, T, &rc, baseline);
    const double msc = threadCpuMs() - t0;
    if (!ok3 || !okc) {
      ++res->problems["detector: " + (ok3 ? rc.error : r3.error)];
      continue;
    }
    res->m3d.ms.add(ms3);
    res->col.ms.add(msc);
    if (!latency_only) {
      scoreFrame(ds, boxes, xyz, frame.T_fixed_sensor, r3, opt, ht, &res->m3d);
      scoreFrame(ds, boxes, xyz, frame.T_fixed_sensor, rc, opt, ht, &res->col);
      if (image_frames.count(frame.index)) {
        const std::string name = ds.name + "_frame" + std::to_string(frame.index) + ".png";
        cv::imwrite(opt.out + "/images/" + name,
                    overlay(frame.left, r3, rc, ds.name + " frame " + std::to_string(frame.index)));
        res->images.push_back("images/" + name);
      }
    }

    // The cue of this frame (the configured method's obstacles), as the nodelet publishes it.
    cuePoints(xyz, columnwise_only ? rc : r3, T, &pts);
    const double stamp = frame.stamp.toSec();
    const float max_z = static_cast<float>(frame.robot.z()) + robot_height;
    cue.addCue(stamp, pts);
    if (integrated) {
      ++res->integrated;
      const ssm::SafetyMap& plain = processor.mapper().safetyMap();
      if (plain.robot_segment >= 0) ++res->seeded;
      ssm::SafetyMap fused = plain;
      const ssm::ObstacleCueStats cs = cue.apply(stamp, max_z, &fused, &marked);
      ssm::SafetyMap fused_lag = plain;
      lagged.apply(stamp, max_z, &fused_lag, &marked_lag);  // previous frames' cues only
      res->cue_cells_changed += cs.cells_changed;
      res->cue_safe_cells_changed += cs.safe_cells_changed;
      if (!latency_only) {
        std::string ce = ssm::countConfusion(plain, ds.gt, &res->map_plain);
        if (ce.empty()) ce = ssm::countConfusion(fused, ds.gt, &res->map_cue);
        if (!ce.empty()) ++res->problems["confusion: " + ce];
      }
    }
    lagged.addCue(stamp, pts);

    // Frame latency (000 Sec. VII-B), counted in camera frames from the board's appearance; a
    // frame the mapper skipped keeps the previous grid and map.
    const ssm::SafetyMap& map = processor.mapper().safetyMap();
    for (std::size_t b = 0; b < ds.boards.size(); ++b) {
      Latency& l = res->latency[b];
      if (l.appear < 0) {
        if (!ssm::boardInView(ds.boards[b].box, frame.T_fixed_sensor, frame.camera)) continue;
        l.appear = index_in_bag;
      }
      const ssm::BoardBox& box = ds.boards[b].box;
      const ssm::BoardCoverage g = ssm::boardWidthCoverage(processor.mapper().grid(), box, &bins);
      l.grid.push_back(g.fraction());
      std::vector<std::uint8_t> both = bins;
      const ssm::BoardCoverage c1 = ssm::boardWidthCoverageOfCells(map, marked, box, &both);
      l.cue.push_back(c1.bins > 0
                          ? static_cast<double>(std::count(both.begin(), both.end(), 1)) / c1.bins
                          : g.fraction());
      both = bins;
      const ssm::BoardCoverage c2 = ssm::boardWidthCoverageOfCells(map, marked_lag, box, &both);
      l.lagged.push_back(
          c2.bins > 0 ? static_cast<double>(std::count(both.begin(), both.end(), 1)) / c2.bins
                      : g.fraction());
    }
    ++index_in_bag;
    if (!opt.quiet && frame.index % 50 == 0) {
      std::fprintf(stderr,
                   "  %s pair %d/%d: 3D recall %.2f precision %.2f, column-wise %.2f / %.2f\n",
                   ds.name.c_str(), frame.index, reader.pairCount(), res->m3d.recall(),
                   res->m3d.precision(), res->col.recall(), res->col.precision());
    }
  }
  return "";
}

std::string pct(double v, int digits = 1) {
  if (!std::isfinite(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f %%", digits, 100.0 * v);
  return buf;
}

std::string num(double v, int digits = 1) {
  if (!std::isfinite(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
  return buf;
}

std::string frames(int n) {
  return n < 0 ? std::string("never") : std::to_string(n);
}

using stereo_safety_map::tools::Json;  // stereo_safety_map/tools/json.h

void methodJson(Json& j, const std::string& name, const MethodScore& m) {
  j.key(name).open('{');
  j.num("in_view", m.instances).num("detected", m.detected).num("recall", m.recall());
  j.num("point_recall", m.pointRecall()).num("points", m.points).num("points_in_box", m.in_box);
  j.num("precision", m.precision()).num("points_gt_nonground", m.gt_nonground);
  j.num("points_gt_edge", m.gt_edge).num("points_gt_safe", m.gt_safe);
  j.num("points_gt_unknown", m.gt_unknown);
  j.num("ms_mean", m.ms.mean()).num("ms_p95", m.ms.quantile(0.95));
  j.key("by_type").open('{');
  for (const auto& kv : m.by_type) {
    j.key(kv.first).open('{');
    j.num("in_view", kv.second.first).num("detected", kv.second.second).close('}');
  }
  j.close('}').close('}');
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parseArgs(argc, argv, &opt)) return ssm::tools::usageError(usage);
  ssm::StereoFrameProcessorConfig pcfg;
  ssm::ObstacleDetectionConfig ocfg;
  ssm::ObstacleDetectionRosConfig orcfg;
  ssm::ObstacleCueRosConfig ccfg;
  std::string e;
  if (!opt.params.empty()) {
    e = ssm::loadCoreParams(opt.params, &pcfg);
    if (e.empty()) e = ssm::loadObstacleCueParams(opt.params, &ccfg);
  }
  if (e.empty() && !opt.obstacle_params.empty())
    e = ssm::loadObstacleDetectionParams(opt.obstacle_params, &ocfg, &orcfg);
  if (e.empty() && opt.noise_sigmas >= 0.0) {
    ocfg.noise_sigmas = opt.noise_sigmas;
    e = ocfg.validate();
  }
  if (e.empty() && opt.decimation > 0) {
    orcfg.decimation = opt.decimation;
    e = orcfg.validate();
  }
  if (!e.empty()) {
    std::fprintf(stderr, "evaluate_obstacles: %s\n", e.c_str());
    return 2;
  }
  if (!ssm::makeDirs(opt.out + "/images")) {
    std::fprintf(stderr, "evaluate_obstacles: cannot create %s\n", opt.out.c_str());
    return 1;
  }

  std::vector<DatasetResult> results;
  for (int pass = 0; pass < 2; ++pass) {
    for (const std::string& bag : pass == 0 ? opt.bags : opt.latency_bags) {
      if (!opt.quiet) std::fprintf(stderr, "evaluate_obstacles: %s\n", bag.c_str());
      DatasetResult r;
      e = evaluateBag(bag, pass == 1, opt, pcfg, ocfg, orcfg, ccfg.cue, &r);
      if (!e.empty()) {
        std::fprintf(stderr, "evaluate_obstacles: %s: %s\n", bag.c_str(), e.c_str());
        return 1;
      }
      results.push_back(r);
    }
  }

  // ------------------------------------------------------------------------------------------
  // report.md
  std::ostringstream md;
  md << "# Obstacle detection (paper 003) and the obstacle cue\n\n"
     << "Tool: `evaluate_obstacles` (src/tools/evaluate_obstacles.cpp). Detector: H_T "
     << ocfg.height_threshold << " m, H_max " << ocfg.max_height << " m, theta_T "
     << ocfg.slope_threshold_deg << " deg, decimation " << orcfg.decimation
     << " (every n-th pixel; 1 = 003's full image), stereo noise margin " << ocfg.noise_sigmas
     << " sigma (sigma_d " << ocfg.disparity_sigma << " px; 0 = 003's Definition 1), "
     << (ocfg.exhaustive_search ? "exhaustive" : "early-exit") << " search, min_volume "
     << ocfg.min_volume << " m^3; range image " << orcfg.min_depth << ".." << orcfg.max_depth
     << " m. Cue: lifetime " << ccfg.cue.lifetime << " s, " << ccfg.cue.min_points_per_cell
     << " points per cell.\n\n"
     << "Definitions. *Detected obstacle points*: raised points (upper ends of compatible pairs, "
        "003 Def. 1) of the obstacles the Sec. 5 rules accept, within "
     << opt.max_range
     << " m (depth). A GT obstacle (oriented box of gt_obstacles.yaml) is *in view* in a frame "
        "when at least "
     << opt.min_visible
     << " valid range points lie in its box, more than H_T above its bottom "
        "(its visible points); it is *detected* when at least "
     << pct(opt.min_fraction, 0)
     << " of them are detected obstacle points. Recall = detected / in view over all (frame, "
        "obstacle) pairs; point recall = detected visible points / visible points. Precision = "
        "detected obstacle points inside a GT box grown by "
     << opt.margin
     << " m / all detected obstacle points. Detection time: CPU time of one thread per frame. "
        "Points outside every box are split by the GT label "
        "of their cell: Non-ground (steps, lower sides of drop-offs), safe next to a Non-ground "
        "cell (upper edges of drop-offs and steps), safe elsewhere, unknown.\n\n";

  MethodScore all3, allc;
  ssm::ConfusionCounts all_plain, all_cue;
  bool any_datasets = false;
  for (const DatasetResult& r : results) {
    if (r.latency_only) continue;
    any_datasets = true;
    all3.add(r.m3d);
    allc.add(r.col);
    all_plain += r.map_plain;
    all_cue += r.map_cue;
  }
  if (any_datasets) {
    md << "## Recall and precision per dataset\n\n"
       << "| dataset | frames | method | in view | recall | point recall | precision | not in a "
          "box: GT Non-ground / edge / safe / unknown | ms mean (p95) |\n"
       << "|---|---|---|---|---|---|---|---|---|\n";
    auto row = [&md](const std::string& name, const std::string& frames_s, const char* method,
                     const MethodScore& m) {
      const double out = static_cast<double>(m.points - m.in_box);
      md << "| " << name << " | " << frames_s << " | " << method << " | " << m.instances << " | "
         << pct(m.recall()) << " | " << pct(m.pointRecall()) << " | " << pct(m.precision()) << " | "
         << pct(ratio(m.gt_nonground, m.points)) << " / " << pct(ratio(m.gt_edge, m.points))
         << " / " << pct(ratio(m.gt_safe, m.points)) << " / " << pct(ratio(m.gt_unknown, m.points))
         << " (" << static_cast<long long>(out) << " points) | " << num(m.ms.mean()) << " ("
         << num(m.ms.quantile(0.95)) << ") |\n";
    };
    for (const DatasetResult& r : results) {
      if (r.latency_only) continue;
      row(r.name, std::to_string(r.used), "3D", r.m3d);
      row(r.name, std::to_string(r.used), "column-wise", r.col);
    }
    row("**all**", "", "3D", all3);
    row("**all**", "", "column-wise", allc);

    md << "\n## Recall per obstacle type (all datasets)\n\n| type | in view | 3D recall | "
          "column-wise recall |\n|---|---|---|---|\n";
    for (const auto& kv : all3.by_type) {
      const auto& c = allc.by_type[kv.first];
      md << "| " << kv.first << " | " << kv.second.first << " | "
         << pct(ratio(kv.second.second, kv.second.first)) << " | " << pct(ratio(c.second, c.first))
         << " |\n";
    }

    md << "\n## Safety map with and without the cue (000 Sec. VII-A, integrated frames)\n\n"
       << "The cue of the same frame applied to each map. FN rate = unsafe cells labelled safe, "
          "FP rate = safe cells labelled unsafe (evaluation_metrics.h). *seeded*: maps in which "
          "000's labelling found the robot's ground segment (without it no cell is safe and the "
          "rates say little about the cue).\n\n"
       << "| dataset | maps (seeded) | FN rate without | FN rate with cue | FP rate without | FP "
          "rate "
          "with cue | cells made Non-ground per map (safe before) "
          "|\n|---|---|---|---|---|---|---|\n";
    for (const DatasetResult& r : results) {
      if (r.latency_only) continue;
      const ssm::ErrorRates a = ssm::errorRates(r.map_plain), b = ssm::errorRates(r.map_cue);
      md << "| " << r.name << " | " << r.integrated << " (" << r.seeded << ") | " << pct(a.fn, 2)
         << " | " << pct(b.fn, 2) << " | " << pct(a.fp, 2) << " | " << pct(b.fp, 2) << " | "
         << num(ratio(r.cue_cells_changed, r.integrated)) << " ("
         << num(ratio(r.cue_safe_cells_changed, r.integrated)) << ") |\n";
    }
    const ssm::ErrorRates a = ssm::errorRates(all_plain), b = ssm::errorRates(all_cue);
    md << "| **all** | | " << pct(a.fn, 2) << " | " << pct(b.fn, 2) << " | " << pct(a.fp, 2)
       << " | " << pct(b.fp, 2) << " | |\n";
  }

  bool any_latency = false;
  for (const DatasetResult& r : results)
    any_latency = any_latency || !r.latency.empty();
  if (any_latency) {
    md << "\n## Frame latency of the board with and without the cue (000 Sec. VII-B)\n\n"
       << "Camera frames from the board's appearance until 50 % / 90 % of its width is covered: "
          "in the voxel grid (000), in the grid or by cells the cue of the same frame marked, and "
          "with the cue one frame late. `never`: not reached before the sequence ends.\n\n"
       << "| dataset | frames | grid 50 % | grid 90 % | + cue 50 % | + cue 90 % | + cue one frame "
          "late 50 % | 90 % |\n|---|---|---|---|---|---|---|---|\n";
    for (const DatasetResult& r : results) {
      for (const Latency& l : r.latency) {
        md << "| " << r.name << " | " << l.grid.size() << " | " << frames(l.frames(l.grid, 0.5))
           << " | " << frames(l.frames(l.grid, 0.9)) << " | " << frames(l.frames(l.cue, 0.5))
           << " | " << frames(l.frames(l.cue, 0.9)) << " | " << frames(l.frames(l.lagged, 0.5))
           << " | " << frames(l.frames(l.lagged, 0.9)) << " |\n";
      }
    }
  }
  bool any_images = false;
  for (const DatasetResult& r : results)
    any_images = any_images || !r.images.empty();
  if (any_images) {
    md << "\n## Pictures\n\nDetected obstacle points green (3D left, column-wise right), obstacles "
          "rejected by the Sec. 5 rules red.\n\n";
    for (const DatasetResult& r : results)
      for (const std::string& im : r.images)
        md << "![" << im << "](" << im << ")\n";
  }
  for (const DatasetResult& r : results) {
    for (const auto& p : r.problems)
      md << "\nProblem in " << r.name << ": " << p.first << " (" << p.second << " frames)\n";
  }
  {
    std::ofstream f(opt.out + "/report.md");
    f << md.str();
  }

  // ------------------------------------------------------------------------------------------
  // metrics.json
  {
    std::ofstream f(opt.out + "/metrics.json");
    Json j;
    j.open('{');
    j.key("settings").open('{');
    j.num("max_range", opt.max_range).num("min_visible", opt.min_visible);
    j.num("min_fraction", opt.min_fraction).num("margin", opt.margin);
    j.num("height_threshold", ocfg.height_threshold).num("max_height", ocfg.max_height);
    j.num("slope_threshold_deg", ocfg.slope_threshold_deg);
    j.num("cue_lifetime", ccfg.cue.lifetime).num("cue_min_points", ccfg.cue.min_points_per_cell);
    j.close('}');
    j.key("datasets").open('[');
    for (const DatasetResult& r : results) {
      j.open('{').kv("name", r.name).num("latency_only", r.latency_only ? 1.0 : 0.0);
      j.num("pairs", r.pairs)
          .num("frames", r.used)
          .num("maps", r.integrated)
          .num("seeded", r.seeded);
      if (!r.latency_only) {
        methodJson(j, "3d", r.m3d);
        methodJson(j, "columnwise", r.col);
        const ssm::ErrorRates a = ssm::errorRates(r.map_plain), b = ssm::errorRates(r.map_cue);
        j.key("map").open('{').num("fn_rate", a.fn).num("fp_rate", a.fp);
        j.num("fn_rate_cue", b.fn).num("fp_rate_cue", b.fp);
        j.num("cue_cells_changed", r.cue_cells_changed);
        j.num("cue_safe_cells_changed", r.cue_safe_cells_changed).close('}');
      }
      j.key("latency").open('[');
      for (const Latency& l : r.latency) {
        j.open('{').kv("board", l.board).num("frames", l.grid.size());
        j.num("grid_50", l.frames(l.grid, 0.5)).num("grid_90", l.frames(l.grid, 0.9));
        j.num("cue_50", l.frames(l.cue, 0.5)).num("cue_90", l.frames(l.cue, 0.9));
        j.num("cue_lagged_50", l.frames(l.lagged, 0.5))
            .num("cue_lagged_90", l.frames(l.lagged, 0.9));
        j.close('}');
      }
      j.close(']').close('}');
    }
    j.close(']');
    if (any_datasets) {
      j.key("all").open('{');
      methodJson(j, "3d", all3);
      methodJson(j, "columnwise", allc);
      j.close('}');
    }
    j.close('}');
    f << j.str() << "\n";
  }

  // Summary on stdout.
  std::printf("obstacle detection (003): recall / precision against GT obstacles\n");
  for (const DatasetResult& r : results) {
    if (r.latency_only) continue;
    std::printf("  %-28s 3D %s / %s, column-wise %s / %s (%d frames)\n", r.name.c_str(),
                pct(r.m3d.recall()).c_str(), pct(r.m3d.precision()).c_str(),
                pct(r.col.recall()).c_str(), pct(r.col.precision()).c_str(), r.used);
  }
  if (any_datasets) {
    std::printf("  %-28s 3D %s / %s, column-wise %s / %s\n", "all", pct(all3.recall()).c_str(),
                pct(all3.precision()).c_str(), pct(allc.recall()).c_str(),
                pct(allc.precision()).c_str());
  }
  for (const DatasetResult& r : results) {
    for (const Latency& l : r.latency) {
      std::printf(
          "  latency %-26s 50 %%: grid %s, + cue %s (late %s); 90 %%: grid %s, + cue %s "
          "(late %s) frames\n",
          r.name.c_str(), frames(l.frames(l.grid, 0.5)).c_str(),
          frames(l.frames(l.cue, 0.5)).c_str(), frames(l.frames(l.lagged, 0.5)).c_str(),
          frames(l.frames(l.grid, 0.9)).c_str(), frames(l.frames(l.cue, 0.9)).c_str(),
          frames(l.frames(l.lagged, 0.9)).c_str());
    }
  }
  std::printf("report: %s/report.md\n", opt.out.c_str());
  return 0;
}
