// evaluate_occupancy_2d: the 2D stereo occupancy grid of paper 002 (Murray & Little 1998,
// core/occupancy_grid_2d.h) on the benchmark datasets, measured beside the safety map of paper
// 000 on the same frames and the same disparity images, without a roscore.
//
//   evaluate_occupancy_2d --bag A.bag [--bag ...] [--compare-bag R.bag ...] [--latency-bag L.bag
//   ...]
//                         [--out DIR] [--params config/occupancy_2d.yaml]
//                         [--core-params config/safety_map.yaml] [--set key=value ...]
//                         [--radius R] [--every N] [--max-frames N] [--images N]
//                         [--safety-metrics out/evaluation/metrics.json] [--no-safety-map]
//                         [--scenes scenes] [--quiet]
//
// Per stereo pair of each bag (dataset_reader.h: images, camera model, camera pose and robot from
// the bag's tf) the disparity is computed once with the core's DisparityPipeline (the settings of
// --core-params, as evaluate_safety_map) without spike removal; spike removal (002 Sec. 4.2,
// filterSpikes, the pipeline's last step) is then applied to a copy, so that four grids run side
// by side on identical input: spike removal on / off x accuracy preservation (002 Sec. 4.3) on /
// off. The main variant (both on) is what the nodelet runs behind the disparity nodelet. The
// safety map (StereoFrameProcessor::processDisparity, the nodelet's code path) runs on the
// spike-filtered disparity, i.e. what evaluate_safety_map computes with decr = 1.
//
// Measures (docs/evaluation.md, section "2D occupancy grid"):
//  - obstacle recall and precision against the GT: occupied vs Non-ground, free vs Level /
//    Inclined, cells classified in both (core/occupancy_grid_2d_evaluation.h), within --radius of
//    the robot (default: the safety map's planning radius R_max, so both maps cover the same
//    cells), summed over every frame of a dataset; the safety map's with the same definition;
//  - what the 2D grid cannot see: GT Non-ground cells split by cause (obstacle, too steep, lower
//    ground = drop-off, raised ground = step up), recomputed from the dataset's scene file with
//    the dataset's own ground-truth code, and how many of them each mapper calls free;
//  - frame latency (000 Sec. VII-B) on --latency-bag: camera frames from the board's appearance
//    until 50 % / 90 % of its width is occupied, in the 2D grid and in the safety map's 3D grid;
//  - ghost obstacles on --compare-bag (repeating texture): false positives and precision of the
//    four variants.
// Writes DIR/report.md, DIR/metrics.json, DIR/maps/*.png.
#include "stereo_safety_map/core/disparity_filters.h"
#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/map_image.h"
#include "stereo_safety_map/core/occupancy_grid_2d.h"
#include "stereo_safety_map/core/occupancy_grid_2d_evaluation.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/scene_loader.h"
#include "stereo_safety_map/ros/occupancy_2d_params.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/tools/args.h"
#include "stereo_safety_map/tools/boards.h"
#include "stereo_safety_map/tools/dataset_reader.h"
#include "stereo_safety_map/tools/json.h"

#include <yaml-cpp/yaml.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace ssm = stereo_safety_map;
namespace ds = stereo_safety_map::dataset;
using Clock = std::chrono::steady_clock;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// Options

struct Options {
  std::vector<std::string> bags;          // benchmark datasets
  std::vector<std::string> compare_bags;  // repeating-texture scenes (ghost obstacles)
  std::vector<std::string> latency_bags;
  std::string out = "out/evaluation/occupancy_2d";
  std::string params = "config/occupancy_2d.yaml";
  std::string core_params = "config/safety_map.yaml";
  std::string scenes = "scenes";  // where scene files named relatively in dataset.yaml are
  std::vector<std::string> sets;
  double radius = -1.0;  // < 0: the safety map's planning radius
  int every = 1;
  long max_frames = -1;
  int images = 2;
  std::string safety_metrics;
  bool safety_map = true;
  bool quiet = false;
  std::string command;
};

void usage() {
  std::fprintf(
      stderr,
      "usage: evaluate_occupancy_2d --bag FILE [--bag FILE ...] [--compare-bag FILE ...]\n"
      "         [--latency-bag FILE ...] [--out DIR] [--params YAML] [--core-params YAML]\n"
      "         [--set key=value ...] [--radius R] [--every N] [--max-frames N] [--images N]\n"
      "         [--safety-metrics metrics.json] [--no-safety-map] [--scenes DIR] [--quiet]\n"
      "  --bag            benchmark dataset (make_dataset): recall / precision, causes\n"
      "  --compare-bag    repeating-texture dataset: the four spike-removal / accuracy-\n"
      "                   preservation variants compared (ghost obstacles)\n"
      "  --latency-bag    dataset with a board (000 Sec. VII-B): frame latency\n"
      "  --params         2D grid parameters (config/occupancy_2d.yaml)\n"
      "  --core-params    disparity and safety-map parameters (config/safety_map.yaml)\n"
      "  --set            one 2D grid parameter, e.g. k=10\n"
      "  --radius         evaluate cells within R m of the robot (default: planning_radius)\n"
      "  --safety-metrics evaluate_safety_map's metrics.json: its decr = 1 numbers beside ours\n"
      "  --no-safety-map  do not run the safety map beside the grid\n"
      "  --scenes DIR     scene files named relatively in <bag>_gt/dataset.yaml (default "
      "scenes)\n");
}

bool parse(int argc, char** argv, Options* o) {
  o->command = ssm::tools::commandLine(argv[0], argc, argv);
  ssm::tools::Args a(argc, argv);
  while (a.next()) {
    if (a.value("--bag", &o->bags) || a.value("--compare-bag", &o->compare_bags) ||
        a.value("--latency-bag", &o->latency_bags) || a.value("--out", &o->out) ||
        a.value("--params", &o->params) || a.value("--core-params", &o->core_params) ||
        a.value("--scenes", &o->scenes) || a.value("--set", &o->sets) ||
        a.value("--radius", &o->radius) || a.value("--max-frames", &o->max_frames) ||
        a.value("--safety-metrics", &o->safety_metrics) ||
        a.flag("--no-safety-map", &o->safety_map, false) || a.flag("--quiet", &o->quiet))
      continue;
    if (a.value("--every", &o->every)) {
      o->every = std::max(1, o->every);
    } else if (a.value("--images", &o->images)) {
      o->images = std::max(0, o->images);
    } else {
      std::fprintf(stderr, "unknown or incomplete argument: %s\n", a.arg().c_str());
      return false;
    }
  }
  return !(o->bags.empty() && o->compare_bags.empty() && o->latency_bags.empty());
}

// ---------------------------------------------------------------------------------------------
// Results

// The four grids run side by side (002 Sec. 4.2 spike removal x Sec. 4.3 accuracy preservation).
struct Variant {
  const char* name;
  bool spikes;
  bool preservation;
};
constexpr Variant kVariants[] = {
    {"spike removal + accuracy preservation", true, true},
    {"spike removal only", true, false},
    {"accuracy preservation only", false, true},
    {"neither", false, false},
};
constexpr int kNumVariants = 4;

struct Latency {
  std::string board;
  double start_distance = kNaN;
  int appear_frame = -1;
  std::vector<double> coverage;
  int frames_to_50 = -1;
  int frames_to_90 = -1;
};

// One mapper's results on one dataset.
struct MapperResult {
  ssm::ConfusionCounts counts;
  ssm::UnsafeCauseCounts causes;
  ssm::DropOffEdgeCounts edges;
  std::vector<Latency> latency;
  int maps = 0;  // maps evaluated (the safety map skips stationary frames)
};

enum class Kind { kBenchmark, kCompare, kLatency };
const char* kindName(Kind k) {
  return k == Kind::kBenchmark ? "benchmark" : k == Kind::kCompare ? "compare" : "latency";
}

struct DatasetResult {
  std::string name;
  Kind kind = Kind::kBenchmark;
  bool causes_ok = false;
  std::array<int, ssm::kNumUnsafeCauses> gt_cause_cells{};
  int gt_edge_cells = 0;
  std::string note;
  int pairs = 0;
  int rejected = 0;
  std::map<std::string, int> problems;
  std::array<MapperResult, kNumVariants> grid;
  MapperResult safety;
  bool safety_ran = false;
  std::vector<double> disparity_ms, grid_ms, safety_ms;
  std::vector<std::string> images;
};

double ratio(std::uint64_t a, std::uint64_t b) {
  return b > 0 ? static_cast<double>(a) / static_cast<double>(b) : kNaN;
}
double recallOf(const ssm::ConfusionCounts& c) {
  return ratio(c.tp, c.tp + c.fn);
}
double precisionOf(const ssm::ConfusionCounts& c) {
  return ratio(c.tp, c.tp + c.fp);
}
double fpRateOf(const ssm::ConfusionCounts& c) {
  return ratio(c.fp, c.fp + c.tn);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5));
  return v[k];
}
double mean(const std::vector<double>& v) {
  if (v.empty()) return kNaN;
  double s = 0.0;
  for (double x : v)
    s += x;
  return s / v.size();
}

// ---------------------------------------------------------------------------------------------
// Ground truth causes: the dataset's own GT code run again from its scene file, for the per-cell
// information the label file does not keep (obstacle, slope, reachability).

// Per GT cell: why it is Non-ground, and whether it is a drop-off edge (a safe cell with an
// 8-neighbour whose ground is lower by at least h_T, 000 Sec. VI; cells next to the end of the
// ground, e.g. at a wall's foot, are not counted as drop-off edges here).
struct GtExtras {
  std::vector<ssm::UnsafeCause> causes;
  std::vector<std::uint8_t> edge;
  std::array<int, ssm::kNumUnsafeCauses> cause_cells{};  // in the whole GT map
  int edge_cells = 0;
};

std::string computeCauses(const ssm::Dataset& d, const std::string& scenes_dir, GtExtras* x) {
  std::vector<ssm::UnsafeCause>* causes = &x->causes;
  ds::GroundTruthConfig gtc;  // make_dataset's
  ds::GroundTruthMap gt;
  std::string e = ds::recomputeDatasetGroundTruth(d.gt_dir, scenes_dir, gtc, &gt);
  if (!e.empty()) return "ground truth: " + e;
  const ssm::LabelGrid& lg = d.gt;
  if (gt.min_u != lg.min_u || gt.min_v != lg.min_v || gt.width != lg.width ||
      gt.height != lg.height) {
    return "recomputed ground truth differs in size from the dataset's (scene file changed?)";
  }
  std::size_t differ = 0;
  for (std::size_t k = 0; k < gt.labels.size(); ++k)
    differ += gt.labels[k] != lg.labels[k];
  if (differ > 0) {
    return "recomputed ground truth differs from the dataset's in " + std::to_string(differ) +
           " cells (scene file changed?)";
  }
  const int start = gt.index(gt.start_u, gt.start_v);
  const double start_z = gt.ground_height[start];
  causes->assign(gt.labels.size(), ssm::UnsafeCause::kNotUnsafe);
  for (std::size_t k = 0; k < gt.labels.size(); ++k) {
    if (gt.labels[k] != ssm::SafetyLabel::kNonGround) continue;
    ssm::UnsafeCause c;
    if (gt.obstacle[k]) {
      c = ssm::UnsafeCause::kObstacle;
    } else if (gt.slope_deg[k] > gtc.theta_max_deg) {
      c = ssm::UnsafeCause::kTooSteep;
    } else if (gt.ground_height[k] <= start_z - gtc.h_t) {
      c = ssm::UnsafeCause::kLowerGround;
    } else if (gt.ground_height[k] >= start_z + gtc.h_t) {
      c = ssm::UnsafeCause::kRaisedGround;
    } else {
      c = ssm::UnsafeCause::kUnreachable;
    }
    (*causes)[k] = c;
    ++x->cause_cells[static_cast<int>(c)];
  }
  x->edge.assign(gt.labels.size(), 0);
  for (int v = gt.min_v; v < gt.min_v + gt.height; ++v) {
    for (int u = gt.min_u; u < gt.min_u + gt.width; ++u) {
      const int k = gt.index(u, v);
      if (!ssm::isSafe(gt.labels[k])) continue;
      bool edge = false;
      for (int dv = -1; dv <= 1 && !edge; ++dv) {
        for (int du = -1; du <= 1 && !edge; ++du) {
          if ((du || dv) && gt.inside(u + du, v + dv)) {
            const int n = gt.index(u + du, v + dv);
            edge = gt.ground[n] >= 0 && gt.ground_height[n] <= gt.ground_height[k] - gtc.h_t;
          }
        }
      }
      x->edge[k] = edge ? 1 : 0;
      x->edge_cells += edge ? 1 : 0;
    }
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// Latency helpers (000 Sec. VII-B, as evaluate_safety_map counts them).

void finishLatency(std::vector<Latency>* v) {
  for (Latency& l : *v) {
    l.frames_to_50 = ssm::framesUntilCoverage(l.coverage, 0.5);
    l.frames_to_90 = ssm::framesUntilCoverage(l.coverage, 0.9);
  }
}

// ---------------------------------------------------------------------------------------------
// One dataset

struct Setup {
  ssm::OccupancyGrid2DConfig grid;
  ssm::StereoFrameProcessorConfig core;  // disparity (with spike removal) and safety map
  double radius = 4.0;
};

std::string evaluateDataset(const Options& opt, const Setup& setup, const std::string& bag,
                            Kind kind, DatasetResult* res) {
  ssm::Dataset d;
  std::string e = ssm::loadDataset(bag, kind == Kind::kLatency, &d);
  if (!e.empty()) return e;
  res->name = d.name;
  res->kind = kind;
  GtExtras gx;
  const std::vector<ssm::UnsafeCause>& causes = gx.causes;
  if (kind != Kind::kLatency) {
    e = computeCauses(d, opt.scenes, &gx);
    res->causes_ok = e.empty();
    res->gt_cause_cells = gx.cause_cells;
    res->gt_edge_cells = gx.edge_cells;
    if (!e.empty()) {
      res->note = "no causes: " + e;
      std::fprintf(stderr, "warning: %s: %s\n", d.name.c_str(), res->note.c_str());
    }
  }

  // Disparity without spike removal; the filter runs on a copy (it is the pipeline's last step).
  ssm::DisparityPipelineConfig dcfg = setup.core.disparity;
  const ssm::SpikeRemovalConfig spike_cfg = dcfg.spike_removal;
  dcfg.enable_spike_removal = false;
  ssm::DisparityPipeline pipeline(dcfg);
  ssm::DisparityFilterWorkspace spike_ws;

  std::vector<std::unique_ptr<ssm::OccupancyGrid2D>> grids;
  for (const Variant& v : kVariants) {
    ssm::OccupancyGrid2DConfig c = setup.grid;
    c.accuracy_preservation = v.preservation;
    grids.push_back(std::make_unique<ssm::OccupancyGrid2D>(c));
  }
  std::unique_ptr<ssm::StereoFrameProcessor> safety;
  if (opt.safety_map) {
    safety = std::make_unique<ssm::StereoFrameProcessor>(setup.core);
    res->safety_ran = true;
  }
  Latency fresh;
  for (const auto& b : d.boards) {
    fresh.board = b.name;
    for (auto& g : res->grid)
      g.latency.push_back(fresh);
    res->safety.latency.push_back(fresh);
  }

  ssm::StereoBagReaderOptions ro;
  ro.scan_topic.clear();
  ro.max_frames = opt.max_frames;
  ssm::StereoBagReader reader;
  e = reader.open(d.bag, ro);
  if (!e.empty()) return e;
  const int pairs_total = reader.pairCount();
  std::set<int> image_frames;
  for (int k = 1; k <= opt.images && kind != Kind::kLatency; ++k)
    image_frames.insert(k * pairs_total / (opt.images + 1));

  cv::Mat raw, spiked;
  ssm::SafetyMap as_map;
  std::vector<ssm::CellOutcome> outcomes;
  ssm::StereoBagFrame frame;
  int camera_frames = 0;  // frames going by since the first, for the latency
  while (reader.next(&frame)) {
    if (frame.index % opt.every != 0) continue;
    ++res->pairs;
    if (!frame.error.empty()) {
      ++res->rejected;
      ++res->problems[frame.error];
      continue;
    }
    const Eigen::Isometry3f T = frame.T_fixed_sensor.cast<float>();
    const Eigen::Vector3f robot = frame.robot.cast<float>();
    const Eigen::Vector2f robot_xy = robot.head<2>();

    const auto t0 = Clock::now();
    std::string err;
    if (!pipeline.compute(frame.left, frame.right, &raw, nullptr, &err)) {
      ++res->rejected;
      ++res->problems["disparity: " + err];
      continue;
    }
    raw.copyTo(spiked);
    if (setup.core.disparity.enable_spike_removal) {
      ssm::filterSpikes(spike_cfg, &spiked, &spike_ws);  // 002 Sec. 4.2
    }
    const auto t1 = Clock::now();
    res->disparity_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());

    for (int i = 0; i < kNumVariants; ++i) {
      ssm::OccupancyGrid2D& g = *grids[i];
      const auto g0 = Clock::now();
      g.recenter(robot_xy);
      const ssm::Grid2DUpdateStats s =
          g.update(kVariants[i].spikes ? spiked : raw, frame.camera, T, robot.z());
      if (i == 0) {
        res->grid_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - g0).count());
      }
      if (!s.ok()) {
        if (i == 0) ++res->problems[std::string("grid: ") + ssm::toString(s.status)];
        continue;
      }
      MapperResult& m = res->grid[i];
      if (kind != Kind::kLatency) {
        ssm::occupancyGridAsSafetyMap(g, robot_xy, setup.radius, &as_map);
        e = ssm::countConfusion(as_map, d.gt, &m.counts, i == 0 ? &outcomes : nullptr);
        if (!e.empty()) return "confusion: " + e;
        if (res->causes_ok) {
          ssm::countUnsafeCauses(as_map, d.gt, causes, &m.causes);
          ssm::countDropOffEdges(as_map, d.gt, gx.edge, &m.edges);
        }
        ++m.maps;
        if (i == 0 && image_frames.count(frame.index)) {
          const std::string name = d.name + "_frame" + std::to_string(frame.index) + ".png";
          char title[128];
          std::snprintf(title, sizeof(title), "%s frame %d, 2D grid (002)", d.name.c_str(),
                        frame.index);
          cv::imwrite(
              opt.out + "/maps/" + name,
              ssm::mapBesideGroundTruth(as_map, d.gt, outcomes, frame.robot,
                                        ssm::yawOfOpticalAxis(frame.T_fixed_sensor), title));
          res->images.push_back("maps/" + name);
        }
      }
    }

    bool safety_integrated = false;
    if (safety) {
      const auto s0 = Clock::now();
      ssm::StereoFrameResult fr;
      safety_integrated =
          safety->processDisparity(spiked, frame.camera, T, robot, frame.stamp.toSec(), &fr, &err);
      res->safety_ms.push_back(
          std::chrono::duration<double, std::milli>(Clock::now() - s0).count());
      if (safety_integrated && kind != Kind::kLatency) {
        const ssm::SafetyMap& map = safety->mapper().safetyMap();
        e = ssm::countConfusion(map, d.gt, &res->safety.counts);
        if (!e.empty()) return "confusion: " + e;
        if (res->causes_ok) {
          ssm::countUnsafeCauses(map, d.gt, causes, &res->safety.causes);
          ssm::countDropOffEdges(map, d.gt, gx.edge, &res->safety.edges);
        }
        ++res->safety.maps;
      }
    }

    // Latency: camera frames from the board's appearance (first frame with its centre in the
    // left image); a frame the safety map skipped keeps its previous grid.
    for (std::size_t b = 0; b < d.boards.size(); ++b) {
      const ssm::BoardBox& box = d.boards[b].box;
      for (int i = 0; i < kNumVariants; ++i) {
        Latency& l = res->grid[i].latency[b];
        if (l.appear_frame < 0) {
          if (!ssm::boardInView(box, frame.T_fixed_sensor, frame.camera)) continue;
          l.appear_frame = camera_frames;
          l.start_distance = ssm::distanceToBoardFace(box, frame.T_fixed_sensor.translation());
        }
        l.coverage.push_back(ssm::boardWidthCoverage2D(*grids[i], box).fraction());
      }
      if (safety) {
        Latency& l = res->safety.latency[b];
        if (l.appear_frame < 0) {
          if (!ssm::boardInView(box, frame.T_fixed_sensor, frame.camera)) continue;
          l.appear_frame = camera_frames;
          l.start_distance = ssm::distanceToBoardFace(box, frame.T_fixed_sensor.translation());
        }
        l.coverage.push_back(ssm::boardWidthCoverage(safety->mapper().grid(), box).fraction());
      }
    }
    ++camera_frames;
    if (!opt.quiet && frame.index % 100 == 0) {
      const ssm::ConfusionCounts& c = res->grid[0].counts;
      std::fprintf(stderr, "  %s pair %d/%d: 2D grid recall %.3f precision %.3f\n", d.name.c_str(),
                   frame.index, pairs_total, recallOf(c), precisionOf(c));
    }
  }
  for (auto& g : res->grid)
    finishLatency(&g.latency);
  finishLatency(&res->safety.latency);
  return "";
}

// ---------------------------------------------------------------------------------------------
// evaluate_safety_map's metrics.json (optional): its decr = 1 counts and latency per dataset.

struct SafetyReference {
  bool loaded = false;
  std::map<std::string, ssm::ConfusionCounts> counts;
  std::map<std::string, std::pair<int, int>> latency;  // dataset -> frames to 50 / 90 (board 0)
};

SafetyReference loadSafetyReference(const std::string& path) {
  SafetyReference r;
  if (path.empty() || !ssm::fileExists(path)) return r;
  try {
    const YAML::Node root = YAML::LoadFile(path);
    for (const auto& run : root["runs"]) {
      if (run["decr"].as<int>() != 1) continue;
      for (const auto& d : run["datasets"]) {
        const std::string name = d["name"].as<std::string>();
        ssm::ConfusionCounts c;
        c.tp = d["counts"]["tp"].as<std::uint64_t>();
        c.fp = d["counts"]["fp"].as<std::uint64_t>();
        c.fn = d["counts"]["fn"].as<std::uint64_t>();
        c.tn = d["counts"]["tn"].as<std::uint64_t>();
        c.maps = d["counts"]["maps"].as<std::uint64_t>();
        r.counts[name] = c;
        if (d["latency"] && d["latency"].size() > 0) {
          r.latency[name] = {d["latency"][0]["frames_to_50"].as<int>(),
                             d["latency"][0]["frames_to_90"].as<int>()};
        }
      }
      r.loaded = true;
      break;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "warning: cannot read %s: %s\n", path.c_str(), e.what());
    r.loaded = false;
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Output

std::string num(double v, int prec = 3) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}
std::string pct(double v) {
  return std::isfinite(v) ? num(100.0 * v, 1) + " %" : "n/a";
}
std::string frames(int f) {
  return f < 0 ? "never" : std::to_string(f);
}
using stereo_safety_map::tools::Json;  // tools/json.h

void jsonCounts(Json& j, const std::string& k, const ssm::ConfusionCounts& c) {
  j.key(k).open('{').kv("tp", c.tp).kv("fp", c.fp).kv("fn", c.fn).kv("tn", c.tn);
  j.kv("recall", recallOf(c)).kv("precision", precisionOf(c)).kv("fp_rate", fpRateOf(c));
  j.close('}');
}

void jsonCauses(Json& j, const std::string& k, const ssm::UnsafeCauseCounts& c) {
  j.key(k).open('{');
  for (int i = 1; i < ssm::kNumUnsafeCauses; ++i) {
    j.key(ssm::toString(static_cast<ssm::UnsafeCause>(i))).open('{');
    j.kv("occupied", c.occupied[i]).kv("free", c.free[i]);
    j.kv("unclassified", c.unclassified[i]).close('}');
  }
  j.close('}');
}

void jsonEdges(Json& j, const std::string& k, const ssm::DropOffEdgeCounts& c) {
  j.key(k).open('{').kv("marked", c.marked).kv("safe_unmarked", c.safe_unmarked);
  j.kv("unsafe", c.unsafe).kv("unclassified", c.unclassified).close('}');
}

void jsonLatency(Json& j, const std::string& k, const std::vector<Latency>& v) {
  j.key(k).open('[');
  for (const Latency& l : v) {
    j.open('{').kv("board", l.board).kv("start_distance_m", l.start_distance);
    j.kv("appear_frame", l.appear_frame).kv("frames_to_50", l.frames_to_50);
    j.kv("frames_to_90", l.frames_to_90);
    j.kv("final_coverage", l.coverage.empty() ? kNaN : l.coverage.back()).close('}');
  }
  j.close(']');
}

void jsonMapper(Json& j, const MapperResult& m) {
  j.kv("maps", m.maps);
  jsonCounts(j, "counts", m.counts);
  jsonCauses(j, "causes", m.causes);
  jsonEdges(j, "drop_off_edges", m.edges);
  jsonLatency(j, "latency", m.latency);
}

// Its layout: one line per top-level member, per dataset's part and per grid variant.
std::string writeJson(const Options& opt, const Setup& s, const std::vector<DatasetResult>& all) {
  Json j;
  j.open('{').wrap(2).kv("tool", "evaluate_occupancy_2d").wrap(2).kv("command", opt.command);
  j.wrap(2).key("grid").open('{').kv("resolution", s.grid.resolution).kv("k", s.grid.k);
  j.kv("free_threshold", s.grid.free_threshold);
  j.kv("occupied_threshold", s.grid.occupied_threshold);
  j.kv("floor_clearance", s.grid.floor_clearance);
  j.kv("robot_height", s.grid.robot_height).close('}');
  j.wrap(2).kv("radius_m", s.radius);
  j.wrap(2).key("datasets").open('[');
  for (const DatasetResult& d : all) {
    j.wrap(4).open('{').kv("name", d.name).kv("kind", kindName(d.kind));
    j.kv("pairs", d.pairs).kv("rejected", d.rejected).kv("causes", d.causes_ok);
    j.kv("note", d.note).kv("gt_drop_off_edge_cells", d.gt_edge_cells);
    j.key("gt_non_ground_cells").open('{');
    for (int k = 1; k < ssm::kNumUnsafeCauses; ++k)
      j.kv(ssm::toString(static_cast<ssm::UnsafeCause>(k)), d.gt_cause_cells[k]);
    j.close('}');
    j.wrap(5).key("grid").open('[');
    for (int v = 0; v < kNumVariants; ++v) {
      if (v > 0) j.wrap(8);
      j.open('{').kv("variant", kVariants[v].name).kv("spike_removal", kVariants[v].spikes);
      j.kv("accuracy_preservation", kVariants[v].preservation);
      jsonMapper(j, d.grid[v]);
      j.close('}');
    }
    j.close(']');
    j.wrap(5).key("safety_map");
    if (d.safety_ran) {
      j.open('{');
      jsonMapper(j, d.safety);
      j.close('}');
    } else {
      j.null();
    }
    j.wrap(5).key("timings_ms").open('{').kv("disparity_mean", mean(d.disparity_ms));
    j.kv("grid_update_mean", mean(d.grid_ms));
    j.kv("grid_update_p90", percentile(d.grid_ms, 0.9));
    j.kv("safety_map_mean", mean(d.safety_ms)).close('}').close('}');
  }
  j.wrap(2).close(']').wrap(0).close('}');
  std::ofstream f(opt.out + "/metrics.json");
  if (!f) return "cannot write " + opt.out + "/metrics.json";
  f << j.str() << "\n";
  return "";
}

ssm::UnsafeCauseCounts sumCauses(const std::vector<DatasetResult>& all, int variant, bool safety) {
  ssm::UnsafeCauseCounts s;
  for (const DatasetResult& d : all) {
    if (d.kind != Kind::kBenchmark || !d.causes_ok) continue;
    s += safety ? d.safety.causes : d.grid[variant].causes;
  }
  return s;
}

std::string writeReport(const Options& opt, const Setup& s, const std::vector<DatasetResult>& all,
                        const SafetyReference& ref, double wall_s) {
  std::ostringstream md;
  md << "# 2D stereo occupancy grid (paper 002) beside the safety map\n\n"
     << "Made by `" << opt.command << "` in " << num(wall_s, 0) << " s.\n\n"
     << "The grid of Murray & Little 1998 (`core/occupancy_grid_2d.h`): per image column the "
        "largest disparity whose point lies "
     << num(s.grid.floor_clearance, 2) << " .. " << num(s.grid.robot_height, 2)
     << " m above the floor (002 Sec. 3.3), trapezoid sensor model and clear triangle (Sec. "
        "3.2), +/-K = "
     << s.grid.k << " on 0..255, free < " << s.grid.free_threshold << ", occupied > "
     << s.grid.occupied_threshold
     << " (Sec. 3.4). Occupied counts as Non-ground (the positive class), free as Level; cells "
        "within "
     << num(s.radius, 1)
     << " m of the robot (the safety map's R_max) classified in the map and the GT, summed over "
        "all frames of a dataset (the 2D grid integrates every frame; the safety map skips "
        "stationary ones). Both mappers get the same disparity images (DisparityPipeline with the "
        "settings of `"
     << opt.core_params
     << "`, spike removal on); the safety map is run here by the nodelet's code path "
        "(StereoFrameProcessor::processDisparity), i.e. evaluate_safety_map's decr = 1.\n\n";

  // --- recall / precision ---
  md << "## Obstacle recall and precision\n\n"
     << "Recall = TP / (TP + FN) over all GT Non-ground cells; precision = TP / (TP + FP); "
        "obstacle recall counts only the GT cells where an object stands (the cells this mapper "
        "is built for).\n\n"
     << "| dataset | 2D grid recall | 2D grid obstacle recall | 2D grid precision | 2D grid FP "
        "rate | safety map recall | safety map precision | safety map FP rate | 2D maps | "
        "safety maps |\n|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<double> gr, gor, gp, sr, sp;
  const int obstacle = static_cast<int>(ssm::UnsafeCause::kObstacle);
  for (const DatasetResult& d : all) {
    if (d.kind != Kind::kBenchmark) continue;
    const MapperResult& g = d.grid[0];
    const double obstacle_recall =
        d.causes_ok ? ratio(g.causes.occupied[obstacle],
                            g.causes.occupied[obstacle] + g.causes.free[obstacle])
                    : kNaN;
    gr.push_back(recallOf(g.counts));
    gor.push_back(obstacle_recall);
    gp.push_back(precisionOf(g.counts));
    sr.push_back(recallOf(d.safety.counts));
    sp.push_back(precisionOf(d.safety.counts));
    md << "| " << d.name << " | " << num(recallOf(g.counts)) << " | " << num(obstacle_recall)
       << " | " << num(precisionOf(g.counts)) << " | " << num(fpRateOf(g.counts)) << " | "
       << (d.safety_ran ? num(recallOf(d.safety.counts)) : "-") << " | "
       << (d.safety_ran ? num(precisionOf(d.safety.counts)) : "-") << " | "
       << (d.safety_ran ? num(fpRateOf(d.safety.counts)) : "-") << " | " << g.maps << " | "
       << (d.safety_ran ? std::to_string(d.safety.maps) : "-") << " |\n";
  }
  if (!gr.empty()) {
    auto ms = [](const std::vector<double>& v) {
      const ssm::MeanStd m = ssm::meanStd(v);
      return num(m.mean) + " +/- " + num(m.stddev);
    };
    md << "| **mean +/- std** | " << ms(gr) << " | " << ms(gor) << " | " << ms(gp) << " | | "
       << ms(sr) << " | " << ms(sp) << " | | | |\n";
  }
  if (ref.loaded) {
    md << "\nevaluate_safety_map's own decr = 1 run (`--safety-metrics " << opt.safety_metrics
       << "`), same definitions: ";
    bool first = true;
    for (const DatasetResult& d : all) {
      if (d.kind != Kind::kBenchmark) continue;
      const auto it = ref.counts.find(d.name);
      if (it == ref.counts.end()) continue;
      md << (first ? "" : "; ") << d.name << " recall " << num(recallOf(it->second))
         << ", precision " << num(precisionOf(it->second));
      first = false;
    }
    md << ".\n";
  }

  // --- causes ---
  md << "\n## What the 2D grid cannot see\n\n"
     << "GT Non-ground cell-frames of the benchmark datasets by cause (recomputed from each "
        "dataset's scene file with the dataset's ground-truth code): *occupied* / *unsafe* = "
        "seen, *free* / *safe* = the map invites the robot in, *unclassified* = unknown to the "
        "map. Lower ground is the low side of a drop-off or curb: below the 2D grid's height band, "
        "so it gives no reading and is cleared by the readings of whatever stands beyond it. A "
        "ramp too steep is seen only where it rises into the band (above floor_clearance), a "
        "steep ramp down never; raised ground only when its step exceeds floor_clearance.\n\n"
     << "| cause | GT cell-frames | 2D grid occupied | 2D grid free | 2D grid unclassified | "
        "safety map unsafe | safety map safe | safety map unclassified |\n"
     << "|---|---|---|---|---|---|---|---|\n";
  const ssm::UnsafeCauseCounts gc = sumCauses(all, 0, false);
  const ssm::UnsafeCauseCounts sc = sumCauses(all, 0, true);
  bool any_safety = false;
  for (const DatasetResult& d : all)
    any_safety = any_safety || (d.kind == Kind::kBenchmark && d.safety_ran);
  for (int k = 1; k < ssm::kNumUnsafeCauses; ++k) {
    const std::uint64_t n = gc.occupied[k] + gc.free[k] + gc.unclassified[k];
    if (n == 0) continue;
    const std::uint64_t ns = sc.occupied[k] + sc.free[k] + sc.unclassified[k];
    md << "| " << ssm::toString(static_cast<ssm::UnsafeCause>(k)) << " | " << n << " | "
       << gc.occupied[k] << " (" << pct(ratio(gc.occupied[k], n)) << ") | " << gc.free[k] << " ("
       << pct(ratio(gc.free[k], n)) << ") | " << gc.unclassified[k] << " | ";
    if (any_safety) {
      md << sc.occupied[k] << " (" << pct(ratio(sc.occupied[k], ns)) << ") | " << sc.free[k] << " ("
         << pct(ratio(sc.free[k], ns)) << ") | " << sc.unclassified[k] << " |\n";
    } else {
      md << "- | - | - |\n";
    }
  }
  // Drop-off edges.
  ssm::DropOffEdgeCounts ge, se;
  for (const DatasetResult& d : all) {
    if (d.kind != Kind::kBenchmark || !d.causes_ok) continue;
    ge += d.grid[0].edges;
    if (d.safety_ran) se += d.safety.edges;
  }
  md << "\nGT drop-off edges (safe cells next to ground lower by >= h_T, 000 Sec. VI), "
        "cell-frames: "
        "the 2D grid cannot mark them, it can only call them free, occupied or unknown.\n\n"
     << "| mapper | edge cell-frames | marked as potential drop-off edge | safe / free, not "
        "marked | Non-ground / occupied | unclassified |\n|---|---|---|---|---|---|\n"
     << "| 2D grid | " << ge.total() << " | - | " << ge.safe_unmarked << " ("
     << pct(ratio(ge.safe_unmarked, ge.total())) << ") | " << ge.unsafe << " ("
     << pct(ratio(ge.unsafe, ge.total())) << ") | " << ge.unclassified << " |\n";
  if (any_safety) {
    md << "| safety map | " << se.total() << " | " << se.marked << " ("
       << pct(ratio(se.marked, se.total())) << ") | " << se.safe_unmarked << " ("
       << pct(ratio(se.safe_unmarked, se.total())) << ") | " << se.unsafe << " ("
       << pct(ratio(se.unsafe, se.total())) << ") | " << se.unclassified << " |\n";
  }
  md << "\nGround truth of each dataset (cells of the whole GT map) and the 2D grid's misses "
        "(free / (occupied + free) cell-frames) per cause:\n\n"
     << "| dataset | obstacle | too steep | lower ground | raised ground | unreachable | "
        "drop-off edges | 2D grid free / seen, by cause |\n|---|---|---|---|---|---|---|---|\n";
  for (const DatasetResult& d : all) {
    if (d.kind == Kind::kLatency) continue;
    if (!d.causes_ok) {
      md << "| " << d.name << " | n/a | n/a | n/a | n/a | n/a | n/a | " << d.note << " |\n";
      continue;
    }
    md << "| " << d.name;
    for (int k = 1; k < ssm::kNumUnsafeCauses; ++k)
      md << " | " << d.gt_cause_cells[k];
    md << " | " << d.gt_edge_cells << " |";
    const auto& c = d.grid[0].causes;
    for (int k = 1; k < ssm::kNumUnsafeCauses; ++k) {
      if (c.occupied[k] + c.free[k] == 0) continue;
      md << " " << ssm::toString(static_cast<ssm::UnsafeCause>(k)) << " " << c.free[k] << " / "
         << (c.occupied[k] + c.free[k]) << ";";
    }
    md << " |\n";
  }

  // --- latency ---
  bool any_latency = false;
  for (const DatasetResult& d : all)
    any_latency = any_latency || (d.kind == Kind::kLatency && !d.grid[0].latency.empty());
  if (any_latency) {
    md << "\n## Frame latency (000 Sec. VII-B)\n\n"
       << "Camera frames from the board's appearance until 50 % / 90 % of its width is occupied: "
          "in the 2D grid (an occupied cell under the width sample, one cell of slack across the "
          "board) and in the safety map's 3D grid (core boardWidthCoverage, as "
          "evaluate_safety_map). 'never' = not reached before the sequence ends.\n\n"
       << "| dataset | start distance [m] | 2D grid 50 % | 2D grid 90 % | safety map 50 % | "
          "safety map 90 % |"
       << (ref.loaded ? " evaluate_safety_map 50 % / 90 % |" : "") << "\n|---|---|---|---|---|---|"
       << (ref.loaded ? "---|" : "") << "\n";
    for (const DatasetResult& d : all) {
      if (d.kind != Kind::kLatency) continue;
      for (std::size_t b = 0; b < d.grid[0].latency.size(); ++b) {
        const Latency& g = d.grid[0].latency[b];
        md << "| " << d.name << " | " << num(g.start_distance, 2) << " | " << frames(g.frames_to_50)
           << " | " << frames(g.frames_to_90) << " | ";
        if (d.safety_ran && b < d.safety.latency.size()) {
          md << frames(d.safety.latency[b].frames_to_50) << " | "
             << frames(d.safety.latency[b].frames_to_90) << " |";
        } else {
          md << "- | - |";
        }
        if (ref.loaded) {
          const auto it = ref.latency.find(d.name);
          md << " "
             << (it == ref.latency.end()
                     ? std::string("-")
                     : frames(it->second.first) + " / " + frames(it->second.second))
             << " |";
        }
        md << "\n";
      }
    }
  }

  // --- ghost obstacles ---
  bool any_compare = false;
  for (const DatasetResult& d : all)
    any_compare = any_compare || d.kind == Kind::kCompare;
  if (any_compare) {
    md << "\n## Ghost obstacles on repeating texture: spike removal and accuracy preservation\n\n"
       << "Stereo mismatches on repeating patterns (002 Sec. 4.1, the picket-fence problem) give "
          "coherent patches of wrong disparity; in the grid they become obstacles where the GT "
          "is free (FP). Spike removal (002 Sec. 4.2) and accuracy preservation (Sec. 4.3) on and "
          "off, on identical disparity images.\n\n"
       << "| dataset | variant | FP cell-frames | FP rate | precision | recall | obstacle recall "
          "|\n|---|---|---|---|---|---|---|\n";
    for (const DatasetResult& d : all) {
      if (d.kind != Kind::kCompare) continue;
      for (int v = 0; v < kNumVariants; ++v) {
        const MapperResult& m = d.grid[v];
        const double orc = d.causes_ok
                               ? ratio(m.causes.occupied[obstacle],
                                       m.causes.occupied[obstacle] + m.causes.free[obstacle])
                               : kNaN;
        md << "| " << d.name << " | " << kVariants[v].name << " | " << m.counts.fp << " | "
           << num(fpRateOf(m.counts), 4) << " | " << num(precisionOf(m.counts)) << " | "
           << num(recallOf(m.counts)) << " | " << num(orc) << " |\n";
      }
      if (d.safety_ran) {
        md << "| " << d.name << " | safety map (spike removal on) | " << d.safety.counts.fp << " | "
           << num(fpRateOf(d.safety.counts), 4) << " | " << num(precisionOf(d.safety.counts))
           << " | " << num(recallOf(d.safety.counts)) << " | |\n";
      }
    }
  }

  // --- timings ---
  std::vector<double> dm, gm, sm;
  for (const DatasetResult& d : all) {
    dm.insert(dm.end(), d.disparity_ms.begin(), d.disparity_ms.end());
    gm.insert(gm.end(), d.grid_ms.begin(), d.grid_ms.end());
    sm.insert(sm.end(), d.safety_ms.begin(), d.safety_ms.end());
  }
  md << "\n## Time per frame (this machine, shared cores)\n\n"
     << "| stage | mean [ms] | p90 [ms] |\n|---|---|---|\n"
     << "| disparity (matching + filters) | " << num(mean(dm), 1) << " | "
     << num(percentile(dm, 0.9), 1) << " |\n"
     << "| 2D grid update (reduction + update, 002) | " << num(mean(gm), 2) << " | "
     << num(percentile(gm, 0.9), 2) << " |\n";
  if (!sm.empty()) {
    md << "| safety map (reprojection + mapper, 000) | " << num(mean(sm), 1) << " | "
       << num(percentile(sm, 0.9), 1) << " |\n";
  }

  // --- notes and images ---
  bool notes = false;
  for (const DatasetResult& d : all) {
    if (d.note.empty() && d.problems.empty()) continue;
    if (!notes) md << "\n## Notes\n\n";
    notes = true;
    md << "- " << d.name << ": " << d.note;
    for (const auto& p : d.problems)
      md << " " << p.first << " (" << p.second << " frames);";
    md << "\n";
  }
  bool any_image = false;
  for (const DatasetResult& d : all)
    any_image = any_image || !d.images.empty();
  if (any_image) {
    md << "\n## Maps\n\n2D grid as labels (occupied black, free white, unknown grey) | GT | "
          "outcomes (TP dark, FP orange, FN red, TN pale).\n\n";
    for (const DatasetResult& d : all)
      for (const std::string& im : d.images)
        md << "![" << im << "](" << im << ")\n";
  }
  std::ofstream f(opt.out + "/report.md");
  if (!f) return "cannot write " + opt.out + "/report.md";
  f << md.str();
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) return ssm::tools::usageError(usage);
  Setup setup;
  std::string e = ssm::loadOccupancy2DParamsFile(opt.params, &setup.grid);
  for (const std::string& a : opt.sets)
    if (e.empty()) e = ssm::setOccupancy2DParam(a, &setup.grid);
  if (e.empty()) e = ssm::loadCoreParams(opt.core_params, &setup.core);
  if (!e.empty()) {
    std::fprintf(stderr, "error: %s\n", e.c_str());
    return 2;
  }
  setup.radius = opt.radius >= 0.0 ? opt.radius : setup.core.mapper.segmentation.planning_radius;
  if (!ssm::makeDirs(opt.out + "/maps")) {
    std::fprintf(stderr, "error: cannot create %s/maps\n", opt.out.c_str());
    return 1;
  }
  const auto t0 = Clock::now();
  std::vector<DatasetResult> all;
  const std::pair<const std::vector<std::string>*, Kind> groups[] = {
      {&opt.bags, Kind::kBenchmark},
      {&opt.compare_bags, Kind::kCompare},
      {&opt.latency_bags, Kind::kLatency}};
  for (const auto& g : groups) {
    for (const std::string& bag : *g.first) {
      if (!opt.quiet) std::fprintf(stderr, "%s (%s)\n", bag.c_str(), kindName(g.second));
      DatasetResult r;
      e = evaluateDataset(opt, setup, bag, g.second, &r);
      if (!e.empty()) {
        std::fprintf(stderr, "error: %s: %s\n", bag.c_str(), e.c_str());
        return 1;
      }
      all.push_back(std::move(r));
    }
  }
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  const SafetyReference ref = loadSafetyReference(opt.safety_metrics);
  e = writeJson(opt, setup, all);
  if (e.empty()) e = writeReport(opt, setup, all, ref, wall);
  if (!e.empty()) {
    std::fprintf(stderr, "error: %s\n", e.c_str());
    return 1;
  }
  // Summary on stdout.
  for (const DatasetResult& d : all) {
    const MapperResult& g = d.grid[0];
    if (d.kind == Kind::kLatency) {
      for (std::size_t b = 0; b < g.latency.size(); ++b) {
        std::printf("%s: 2D grid frames to 50/90 %% %d/%d, safety map %d/%d\n", d.name.c_str(),
                    g.latency[b].frames_to_50, g.latency[b].frames_to_90,
                    d.safety_ran ? d.safety.latency[b].frames_to_50 : -1,
                    d.safety_ran ? d.safety.latency[b].frames_to_90 : -1);
      }
    } else {
      std::printf(
          "%s: 2D grid recall %.3f precision %.3f FP %llu; safety map recall %.3f "
          "precision %.3f\n",
          d.name.c_str(), recallOf(g.counts), precisionOf(g.counts),
          static_cast<unsigned long long>(g.counts.fp), recallOf(d.safety.counts),
          precisionOf(d.safety.counts));
    }
  }
  std::printf("wrote %s/report.md and %s/metrics.json in %.1f s\n", opt.out.c_str(),
              opt.out.c_str(), wall);
  return 0;
}
