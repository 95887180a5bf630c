// evaluate_open_world: the open-world evaluation (docs/evaluation.md, "Open world"). Procedural
// scenes made from seeds (procedural_scene.h), rendered under degradations (degradation.h), mapped
// by the core's one entry point per frame (StereoFrameProcessor, what the safety-map nodelet
// runs) with several mapper variants, and scored against the analytic ground truth
// (open_world_scoring.h). No roscore, no bag: every frame is rendered in memory.
//
//   evaluate_open_world [--split dev|report] [--scenes N] [--first K] [--seeds S1,S2,...]
//                       [--conditions LIST]
//                       [--variants LIST] [--jobs N] [--max-frames N] [--out DIR]
//                       [--params YAML ...] [--set key=value ...] [--images F1,F2,...] [--quiet]
//
// Splits. The seeds of the two splits never overlap:
//   dev     seeds kDevSeedBase + k: for developing and tuning; look at these as much as you like.
//   report  seeds kReportSeedBase + k: the numbers the README reports. NO TUNING EVER LOOKS AT
//           THEM: no parameter, threshold, rule or scene generator change may be chosen by its
//           effect on this split. Run it on the final code, report what it says even when it is
//           worse, and never iterate on it.
// Conditions (degradation presets, degradation.h): perfect (no degradation, perfect pose),
// default (the documented default degradations), strong; or name:spec with a spec that
// parseDegradation() takes, '+' in place of its commas (e.g. "nopitch:default+
// chassis_pitch_offset_deg=0+chassis_jitter_deg=0": the defaults without the chassis tilt), for
// measuring which degradation costs what on the dev split.
// Variants: default (config files), paper (paperFaithful(): every "(ours)" switch off),
// no_margin (drop_off_margin off), sgbm (matcher: sgbm), or name:key=value;key=value (the
// configuration with these parameters: for trying a change on the dev split; detector.<key> sets
// paper 003's detector, config/obstacle_detection.yaml's keys). A variant with obstacle_cue=true
// runs the detector on its disparity each frame and feeds its cue to the next maps (as the two
// nodelets run side by side); --detector scores the detector per frame in every variant
// (precision of its raised points, recall of the obstacles in view: DetectionScore).
//
// Writes DIR/metrics.json, DIR/report.md and DIR/scenes.csv (one line per scene, condition and
// variant). Exits 0 when every scene ran.
#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/dataset/degradation.h"
#include "stereo_safety_map/dataset/open_world.h"
#include "stereo_safety_map/dataset/procedural_scene.h"
#include "stereo_safety_map/ros/obstacle_params.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/tools/args.h"
#include "stereo_safety_map/tools/dataset_reader.h"
#include "stereo_safety_map/tools/json.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace ssm = stereo_safety_map;
namespace ds = stereo_safety_map::dataset;

namespace {

// The two splits' seeds (see the header comment: the report split is never tuned on).
constexpr std::uint64_t kDevSeedBase = 1;
constexpr std::uint64_t kReportSeedBase = 1000001;

struct Options {
  std::string split = "dev";
  int scenes = 10;
  int first = 0;
  std::vector<std::string> conditions = {"default"};
  std::vector<std::string> variants = {"default"};
  int jobs = 2;
  int max_frames = -1;
  std::string out = "out/open_world";
  std::vector<std::string> params;
  std::vector<std::string> sets;
  bool quiet = false;
  bool detector = false;          // score paper 003's detector per frame in every variant
  std::vector<int> image_frames;  // pictures of these frames of every scene (DIR/images/)
  std::vector<Eigen::Vector2d> trace_cells;  // --trace: cells traced frame by frame
  std::vector<std::uint64_t>
      seeds;  // --seeds: these seeds of the split instead of --first/--scenes
};

std::vector<std::string> splitList(const std::string& s, char sep = ',') {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

void usage() {
  std::fprintf(
      stderr,
      "usage: evaluate_open_world [--split dev|report] [--scenes N] [--first K] [--seeds S,...]\n"
      "         [--conditions perfect,default,strong] [--variants default,paper,"
      "no_margin,sgbm]\n"
      "         [--jobs N] [--max-frames N] [--out DIR] [--params YAML ...] [--set "
      "key=value ...] [--detector] [--quiet]\n"
      "         [--images F1,F2,...]   pictures of these frames of every scene (DIR/images/),\n"
      "                                beside each its segments (_segments.txt) and cells "
      "(_cells.csv)\n"
      "         [--trace X:Y;X:Y...]   these cells (world x:y [m]) frame by frame, every "
      "variant\n"
      "                                (DIR/images/seed<S>_trace.txt)\n"
      "  --variants: comma-separated; name:key=value;key=value adds a variant of its own\n"
      "  --conditions: perfect, default, strong or name:spec (degradation.h)\n"
      "  --split report: NEVER tune on it (see the comment at the top of this file)\n");
}

bool parse(int argc, char** argv, Options* o) {
  ssm::tools::Args a(argc, argv);
  while (a.next()) {
    std::string v;
    if (a.value("--split", &o->split) || a.value("--scenes", &o->scenes) ||
        a.value("--first", &o->first) || a.value("--max-frames", &o->max_frames) ||
        a.value("--out", &o->out) || a.value("--params", &o->params) ||
        a.value("--set", &o->sets) || a.flag("--quiet", &o->quiet) ||
        a.flag("--detector", &o->detector))
      continue;
    if (a.value("--conditions", &v)) {
      o->conditions = splitList(v);
    } else if (a.value("--variants", &v)) {
      o->variants = splitList(v);
    } else if (a.value("--jobs", &o->jobs)) {
      o->jobs = std::max(1, o->jobs);
    } else if (a.value("--seeds", &v)) {
      for (const std::string& f : splitList(v))
        o->seeds.push_back(std::strtoull(f.c_str(), nullptr, 10));
    } else if (a.value("--trace", &v)) {
      const std::vector<std::string> f = splitList(v, ';');
      for (const std::string& xy : f) {
        double x = 0.0, y = 0.0;
        if (std::sscanf(xy.c_str(), "%lf:%lf", &x, &y) != 2) return false;
        o->trace_cells.emplace_back(x, y);
      }
    } else if (a.value("--images", &v)) {
      for (const std::string& f : splitList(v))
        o->image_frames.push_back(std::atoi(f.c_str()));
    } else {
      return false;
    }
  }
  return (o->split == "dev" || o->split == "report") && o->scenes > 0 && o->first >= 0 &&
         !o->conditions.empty() && !o->variants.empty();
}

std::string makeVariant(const std::string& name, const ssm::StereoFrameProcessorConfig& base,
                        ds::OpenWorldVariant* v) {
  v->name = name;
  v->config = base;
  v->own_disparity = false;
  if (name == "default") return "";
  if (name == "paper") {
    v->config.mapper = ssm::paperFaithful(base.mapper);
    v->config.row_gap_fill.enabled = false;  // the processor's "(ours)" switches
    v->config.obstacle_cue = false;          // 000 alone: no cue from 003's detector
    return "";
  }
  if (name == "no_margin") {
    v->config.mapper.labelling.drop_off_margin = false;
    return "";
  }
  if (name == "sgbm") {
    v->config.disparity.matcher = ssm::StereoMatcherType::kSemiGlobal;
    v->own_disparity = true;
    return v->config.validate();
  }
  // name:key=value;key=value...: the default configuration with these parameters (the keys of
  // the config files, setCoreParam), for trying a change on the dev split.
  const std::size_t colon = name.find(':');
  if (colon != std::string::npos) {
    v->name = name.substr(0, colon);
    std::stringstream ss(name.substr(colon + 1));
    std::string kv;
    while (std::getline(ss, kv, ';')) {
      if (kv.empty()) continue;
      // detector.<key>=value: paper 003's detector (config/obstacle_detection.yaml's keys).
      if (kv.rfind("detector.", 0) == 0) {
        YAML::Node root;
        std::string e = ssm::parseAssignment(kv.substr(9), &root);
        std::vector<std::string> unknown;
        if (e.empty()) {
          e = ssm::applyYamlFields(root, ssm::obstacleDetectionFields(), &v->detector, "variant",
                                   &unknown);
        }
        if (e.empty() && !unknown.empty()) {
          // The nodelet's own keys (min_depth, max_depth, decimation).
          ssm::ObstacleDetectionRosConfig ros;
          ros.min_depth = v->detector_min_depth;
          ros.max_depth = v->detector_max_depth;
          ros.decimation = v->detector_decimation;
          std::vector<std::string> still_unknown;
          e = ssm::applyYamlFields(root, ssm::obstacleDetectionRosFields(), &ros, "variant",
                                   &still_unknown);
          if (e.empty()) e = ros.validate();
          if (e.empty() && !still_unknown.empty()) {
            e = "unknown detector parameter " + still_unknown.front();
          }
          v->detector_min_depth = ros.min_depth;
          v->detector_max_depth = ros.max_depth;
          v->detector_decimation = ros.decimation;
        }
        if (e.empty()) e = v->detector.validate();
        if (!e.empty()) return "variant " + v->name + ": " + e;
        continue;
      }
      // obstacle_cue*: the safety-map nodelet's cue settings (the processor's obstacle_cue, cue).
      if (kv.rfind("obstacle_cue", 0) == 0) {
        ssm::ObstacleCueRosConfig cue;
        cue.enabled = v->config.obstacle_cue;
        cue.cue = v->config.cue;
        YAML::Node root;
        std::string e = ssm::parseAssignment(kv, &root);
        std::vector<std::string> unknown;
        if (e.empty()) {
          e = ssm::applyYamlFields(root, ssm::obstacleCueFields(), &cue, "variant", &unknown);
        }
        if (e.empty() && !unknown.empty()) e = "unknown cue parameter " + unknown.front();
        if (e.empty()) e = ssm::obstacleCueFields().validate(cue);
        if (!e.empty()) return "variant " + v->name + ": " + e;
        v->config.obstacle_cue = cue.enabled;
        v->config.cue = cue.cue;
        continue;
      }
      const std::string e = ssm::setCoreParam(kv, &v->config);
      if (!e.empty()) return "variant " + v->name + ": " + e;
    }
    // Its own disparity unless the disparity settings are the first variant's (checked by the
    // caller, which knows the first variant).
    v->own_disparity = true;
    return v->config.validate();
  }
  return "unknown variant '" + name +
         "' (default, paper, no_margin, sgbm, or name:key=value;key=value)";
}

// Per condition and variant: the scenes' scores.
struct Cell {
  std::string condition, variant;
  std::vector<ds::SceneScore> scenes;
  std::vector<std::uint64_t> seeds;
};

double rate(std::uint64_t num, std::uint64_t den) {
  return den > 0 ? static_cast<double>(num) / den : std::numeric_limits<double>::quiet_NaN();
}
double fnRate(const ssm::ConfusionCounts& c) {
  return rate(c.fn, c.tp + c.fn);
}
double fpRate(const ssm::ConfusionCounts& c) {
  return rate(c.fp, c.fp + c.tn);
}
double coverage(const ds::SceneScore& s) {
  return rate(s.coverage_classified, s.coverage_cells);
}
double noSegment(const ds::SceneScore& s) {
  return rate(s.maps_without_robot_segment, s.maps_after_grace);
}
double stuck(const ds::SceneScore& s) {
  return rate(s.maps_stuck, s.maps_after_grace);
}
double stuckTruth(const ds::SceneScore& s) {
  return rate(s.maps_stuck_truth, s.maps_after_grace);
}
// Tilt error of the camera pose the map used (or of the reported one): the bias (mean) and the
// RMS of its pitch and roll components [deg] (SceneScore::TiltError).
struct TiltSummary {
  double pitch_bias, roll_bias, pitch_rms, roll_rms;
};
TiltSummary tiltSummary(const ds::SceneScore::TiltError& e, int n) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (n <= 0) return {nan, nan, nan, nan};
  return {e.pitch / n, e.roll / n, std::sqrt(e.pitch2 / n), std::sqrt(e.roll2 / n)};
}

struct Stat {
  ssm::MeanStd ms;
  double worst = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t worst_seed = 0;
};

// Mean +- sd over scenes and the worst scene (highest value; lowest with `low_is_bad`).
template <typename F>
Stat stat(const Cell& c, F f, bool low_is_bad = false) {
  std::vector<double> v;
  Stat s;
  for (std::size_t k = 0; k < c.scenes.size(); ++k) {
    const double x = f(c.scenes[k]);
    v.push_back(x);
    if (!std::isfinite(x)) continue;
    if (!std::isfinite(s.worst) || (low_is_bad ? x < s.worst : x > s.worst)) {
      s.worst = x;
      s.worst_seed = c.seeds[k];
    }
  }
  s.ms = ssm::meanStd(v);
  return s;
}

// The ground truth's stuck share: mean and worst scene only.
std::string truthPct(const Stat& s) {
  char buf[64];
  if (s.ms.n == 0) return "n/a";
  std::snprintf(buf, sizeof(buf), "%.2f, worst %.1f", 100.0 * s.ms.mean, 100.0 * s.worst);
  return buf;
}

std::string pct(const Stat& s) {
  char buf[96];
  if (s.ms.n == 0) return "n/a";
  std::snprintf(buf, sizeof(buf), "%.2f +- %.2f (worst %.1f, seed %llu)", 100.0 * s.ms.mean,
                100.0 * s.ms.stddev, 100.0 * s.worst,
                static_cast<unsigned long long>(s.worst_seed));
  return buf;
}

void jsonStat(ssm::tools::Json& j, const std::string& k, const Stat& s) {
  j.key(k).open('{');
  j.kv("mean", s.ms.mean).kv("sd", s.ms.stddev).kv("n", s.ms.n).kv("worst", s.worst);
  j.kv("worst_seed", static_cast<std::uint64_t>(s.worst_seed));
  j.close('}');
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) return ssm::tools::usageError(usage);
  ssm::StereoFrameProcessorConfig base;
  for (const std::string& p : opt.params) {
    const std::string e = ssm::loadCoreParams(p, &base);
    if (!e.empty()) {
      std::fprintf(stderr, "%s: %s\n", p.c_str(), e.c_str());
      return 2;
    }
  }
  for (const std::string& s : opt.sets) {
    const std::string e = ssm::setCoreParam(s, &base);
    if (!e.empty()) {
      std::fprintf(stderr, "--set %s: %s\n", s.c_str(), e.c_str());
      return 2;
    }
  }
  std::vector<ds::OpenWorldVariant> variants;
  for (const std::string& name : opt.variants) {
    ds::OpenWorldVariant v;
    const std::string e = makeVariant(name, base, &v);
    if (!e.empty()) {
      std::fprintf(stderr, "%s\n", e.c_str());
      return 2;
    }
    v.score_detector = opt.detector;
    variants.push_back(v);
  }
  // A variant that maps the first one's disparity must not change the disparity settings.
  std::vector<ds::DegradationConfig> conditions;
  for (std::string& c : opt.conditions) {
    ds::DegradationConfig d;
    std::string spec = c == "perfect" ? "none" : c;
    const std::size_t colon = c.find(':');
    if (colon != std::string::npos) {
      spec = c.substr(colon + 1);
      std::replace(spec.begin(), spec.end(), '+', ',');
      c = c.substr(0, colon);
    }
    const std::string e = ds::parseDegradation(spec, &d);
    if (!e.empty()) {
      std::fprintf(stderr, "condition %s: %s\n", c.c_str(), e.c_str());
      return 2;
    }
    conditions.push_back(d);
  }
  ds::OpenWorldRunOptions run;
  run.max_frames = opt.max_frames;
  if (!opt.image_frames.empty() || !opt.trace_cells.empty()) {
    run.image_dir = opt.out + "/images";
    run.image_frames = opt.image_frames;
    run.trace_cells = opt.trace_cells;
    if (!ssm::makeDirs(run.image_dir)) {
      std::fprintf(stderr, "cannot create %s\n", run.image_dir.c_str());
      return 2;
    }
  }
  run.scoring.planning_radius = base.mapper.segmentation.planning_radius;
  run.scoring.min_range = base.mapper.grid.min_range;
  run.scoring.max_range = base.mapper.grid.max_range;
  run.scoring.robot_height = base.mapper.height_map.robot_height;
  run.ground_truth.theta_max_deg = base.mapper.labelling.max_slope_deg;
  run.ground_truth.theta_t_deg = base.mapper.labelling.level_slope_deg;
  run.ground_truth.h_t = base.mapper.labelling.max_step_height;
  run.ground_truth.robot_height = base.mapper.height_map.robot_height;
  run.ground_truth.resolution = base.mapper.grid.voxel_size;

  const std::uint64_t seed_base = opt.split == "report" ? kReportSeedBase : kDevSeedBase;
  // --seeds: chosen seeds of the split (for looking at a few scenes again); they must belong to
  // it, so that the dev and report splits stay apart.
  std::vector<std::uint64_t> seeds;
  if (opt.seeds.empty()) {
    for (int k = 0; k < opt.scenes; ++k)
      seeds.push_back(seed_base + static_cast<std::uint64_t>(opt.first + k));
  } else {
    const std::uint64_t end = opt.split == "report" ? ~0ull : kReportSeedBase;
    for (const std::uint64_t sd : opt.seeds) {
      if (sd < seed_base || sd >= end) {
        std::fprintf(stderr, "seed %llu is not in the %s split\n",
                     static_cast<unsigned long long>(sd), opt.split.c_str());
        return 2;
      }
      seeds.push_back(sd);
    }
    opt.scenes = static_cast<int>(seeds.size());
  }
  std::vector<Cell> cells;
  for (const std::string& c : opt.conditions)
    for (const ds::OpenWorldVariant& v : variants)
      cells.push_back(Cell{c, v.name, {}, {}});
  std::vector<std::string> scene_lines;
  int failures = 0;

  // Work items: (condition, scene); each runs every variant on the same frames.
  struct Item {
    std::size_t condition;
    int scene;
  };
  std::vector<Item> items;
  for (std::size_t c = 0; c < conditions.size(); ++c)
    for (int k = 0; k < opt.scenes; ++k)
      items.push_back(Item{c, k});
  std::vector<ds::OpenWorldSceneResult> results(items.size());
  std::atomic<std::size_t> next{0};
  std::mutex print_mutex;
  auto worker = [&]() {
    for (;;) {
      const std::size_t i = next++;
      if (i >= items.size()) return;
      const std::uint64_t seed = seeds[static_cast<std::size_t>(items[i].scene)];
      ds::ProceduralScene scene;
      const std::string e = ds::generateProceduralScene(seed, ds::ProceduralConfig(), &scene);
      if (!e.empty()) {
        results[i].seed = seed;
        results[i].error = "generator: " + e;
      } else {
        results[i] = ds::runOpenWorldScene(scene, conditions[items[i].condition], variants, run);
      }
      if (!opt.quiet) {
        std::lock_guard<std::mutex> lock(print_mutex);
        const ds::OpenWorldSceneResult& r = results[i];
        std::fprintf(stderr, "[%zu/%zu] %s seed %llu (%s): %d frames, %.0f s%s%s\n", i + 1,
                     items.size(), opt.conditions[items[i].condition].c_str(),
                     static_cast<unsigned long long>(seed), r.description.c_str(), r.frames,
                     r.seconds, r.error.empty() ? "" : ", ERROR: ", r.error.c_str());
        if (r.error.empty()) {
          for (std::size_t v = 0; v < variants.size(); ++v) {
            const ds::SceneScore& s = r.scores[v];
            std::fprintf(stderr,
                         "    %-10s FN %5.2f %% FP %5.2f %% (tol 1; local %5.2f / %5.2f) coverage "
                         "%5.1f %% no seg "
                         "%4.1f %% stuck %4.1f %% forgotten %d obstacles missed %d/%d\n",
                         variants[v].name.c_str(), 100 * fnRate(s.tol1), 100 * fpRate(s.tol1),
                         100 * fnRate(s.local_tol1), 100 * fpRate(s.local_tol1), 100 * coverage(s),
                         100 * noSegment(s), 100 * stuck(s), s.forgotten_cells,
                         s.obstacles_missed_lenient, s.obstacles_in_view);
            for (const std::string& m : s.misses)
              std::fprintf(stderr, "        missed %s\n", m.c_str());
            for (const std::string& m : s.forgotten)
              std::fprintf(stderr, "        forgotten %s\n", m.c_str());
          }
        }
      }
    }
  };
  std::vector<std::thread> threads;
  for (int j = 0; j < opt.jobs; ++j)
    threads.emplace_back(worker);
  for (std::thread& t : threads)
    t.join();

  for (std::size_t i = 0; i < items.size(); ++i) {
    const ds::OpenWorldSceneResult& r = results[i];
    if (!r.error.empty()) {
      ++failures;
      std::fprintf(stderr, "seed %llu: %s\n", static_cast<unsigned long long>(r.seed),
                   r.error.c_str());
      continue;
    }
    for (std::size_t v = 0; v < variants.size(); ++v) {
      Cell& cell = cells[items[i].condition * variants.size() + v];
      cell.scenes.push_back(r.scores[v]);
      cell.seeds.push_back(r.seed);
      const ds::SceneScore& s = r.scores[v];
      const TiltSummary tu = tiltSummary(s.tilt_used, s.tilt_frames);
      const TiltSummary tr = tiltSummary(s.tilt_reported, s.tilt_frames);
      char line[512];
      std::snprintf(line, sizeof(line),
                    "%s,%s,%llu,\"%s\",%d,%.5f,%.5f,%.5f,%.5f,%.5f,%.5f,%.5f,%.5f,%d,%d,%d,%d,"
                    "%d,%.5f,%.5f,%d,%.4f,%.4f,%.4f,%.4f,%.5f,%.5f",
                    cell.condition.c_str(), cell.variant.c_str(),
                    static_cast<unsigned long long>(r.seed), r.description.c_str(), s.maps,
                    fnRate(s.tol0), fpRate(s.tol0), fnRate(s.tol1), fpRate(s.tol1),
                    fnRate(s.local_tol1), fpRate(s.local_tol1), coverage(s), noSegment(s),
                    s.forgotten_cells, s.obstacles_in_view, s.obstacles_missed_strict,
                    s.obstacles_missed_lenient, s.detection.frames, s.detection.precision(),
                    s.detection.recall(), s.detection.accepted_false, tu.pitch_bias, tu.pitch_rms,
                    tr.pitch_bias, tr.pitch_rms, stuck(s), stuckTruth(s));
      scene_lines.push_back(line);
    }
  }

  if (!ssm::makeDirs(opt.out)) {
    std::fprintf(stderr, "cannot create %s\n", opt.out.c_str());
    return 2;
  }
  {
    std::ofstream csv(opt.out + "/scenes.csv");
    csv << "condition,variant,seed,scene,maps,fn_tol0,fp_tol0,fn_tol1,fp_tol1,fn_local_tol1,"
           "fp_local_tol1,coverage,"
           "no_robot_segment,forgotten_cells,obstacles_in_view,obstacles_missed_strict,"
           "obstacles_missed_lenient,detector_frames,detector_precision,detector_recall,"
           "detector_false_obstacles,pitch_error_bias_deg,pitch_error_rms_deg,"
           "reported_pitch_error_bias_deg,reported_pitch_error_rms_deg,stuck,stuck_truth\n";
    for (const std::string& l : scene_lines)
      csv << l << "\n";
  }

  static const char* kClassNames[ds::kHazardClassCount] = {
      "none", "drop_off", "step_up", "steep_ramp", "gentle_ramp", "obstacle", "overhang"};
  ssm::tools::Json j;
  j.open('{');
  j.kv("split", opt.split).kv("first_seed", seeds.front());
  j.kv("scenes", opt.scenes);
  j.key("cells").open('[');
  std::ostringstream md;
  md << "# Open-world evaluation, " << opt.split << " split\n\n"
     << "Seeds " << seeds.front() << " .. " << seeds.back() << " (" << opt.scenes
     << " scenes per condition"
     << (opt.split == "report" ? "; the report split: no tuning ever looks at it" : "")
     << "). Rates in %: mean +- sd over scenes (each scene's rate from sums over its maps), "
        "worst scene. tol 1 = one cell of tolerance at label boundaries.\n\n";
  md << "| condition | variant | scenes | FN tol 0 | FN tol 1 | FP tol 0 | FP tol 1 | coverage | "
        "FN local tol 1 | FP local tol 1 | maps without robot segment | maps stuck (reachable safe "
        "ground < "
     << run.scoring.stuck_area
     << " m^2; in brackets the ground truth's, a check: 0) | forgotten obstacle cells | "
        "obstacles missed (strict / after "
     << run.scoring.obstacle_lenient_frames
     << " frames) / in view |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  std::ostringstream detector_md;
  detector_md << "\n## Paper 003's detector, per frame\n\nRaised points of accepted obstacles "
                 "(the obstacle cue) on an obstacle or within one cell of unsafe ground truth "
                 "(precision), qualifying obstacles in view within R_max with a raised point on "
                 "them (recall, per frame), accepted obstacles with less than half of their raised "
                 "points true (false obstacles per frame).\n\n| condition | variant | frames | "
                 "precision | recall | obstacles per frame | false obstacles per frame |\n"
                 "|---|---|---|---|---|---|---|\n";
  bool any_detector = false;
  std::ostringstream classes_md;
  classes_md << "\n## Per hazard class (tol 1)\n\n| condition | variant | class | FN | FP "
                "|\n|---|---|---|---|---|\n";
  std::ostringstream tilt_md;
  tilt_md << "\n## Camera tilt (integrated frames, pooled over the scenes)\n\nThe rotation "
             "from the pose the map used (the reported pose, re-levelled when `relevel` is on) to "
             "the true camera pose, about the heading's lateral axis (pitch) and forward axis "
             "(roll): bias (mean) and RMS [deg]; `reported`: the odometry's pose alone.\n\n"
             "| condition | variant | frames | pitch bias | pitch RMS | roll bias | roll RMS | "
             "reported: pitch bias | pitch RMS | roll bias | roll RMS |\n"
             "|---|---|---|---|---|---|---|---|---|---|---|\n";
  std::ostringstream sources_md;
  sources_md << "\n## Where the false positives come from (tol 1, pooled over the scenes)\n\n"
                "Share of the FP cell-maps by the map cell's segment (not safe: unreached or too "
                "steep, 000 Alg. 2; safe but the cell overridden: drop-off margin, obstacle memory "
                "or cue; no segment: a non-traversable column, memory or cue) and by distance from "
                "the robot.\n\n| condition | variant | FP cell-maps | unsafe segment | safe "
                "segment | no segment | < 1.5 m | 1.5-2.5 m | 2.5-3.5 m | >= 3.5 m |\n"
                "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Cell& c : cells) {
    const Stat fn0 = stat(c, [](const ds::SceneScore& s) { return fnRate(s.tol0); });
    const Stat fn1 = stat(c, [](const ds::SceneScore& s) { return fnRate(s.tol1); });
    const Stat fp0 = stat(c, [](const ds::SceneScore& s) { return fpRate(s.tol0); });
    const Stat fp1 = stat(c, [](const ds::SceneScore& s) { return fpRate(s.tol1); });
    const Stat lfn = stat(c, [](const ds::SceneScore& s) { return fnRate(s.local_tol1); });
    const Stat lfp = stat(c, [](const ds::SceneScore& s) { return fpRate(s.local_tol1); });
    const Stat cov = stat(c, coverage, true);
    const Stat seg = stat(c, noSegment);
    const Stat stk = stat(c, stuck);
    const Stat stk_truth = stat(c, stuckTruth);
    ds::SceneScore total;
    for (const ds::SceneScore& s : c.scenes)
      total += s;
    {
      constexpr int kBins = ds::SceneScore::kFpRangeBins;
      std::uint64_t all = 0, by_source[ds::SceneScore::kFpSourceCount] = {}, by_range[kBins] = {};
      for (int src = 0; src < ds::SceneScore::kFpSourceCount; ++src) {
        for (int b = 0; b < kBins; ++b) {
          const std::uint64_t n = total.fp_sources[src * kBins + b];
          all += n;
          by_source[src] += n;
          by_range[b] += n;
        }
      }
      auto share = [all](std::uint64_t n) {
        char b[16];
        std::snprintf(b, sizeof(b), "%.1f %%", all > 0 ? 100.0 * n / all : 0.0);
        return std::string(b);
      };
      sources_md << "| " << c.condition << " | " << c.variant << " | " << all;
      for (const std::uint64_t n : by_source)
        sources_md << " | " << share(n);
      for (const std::uint64_t n : by_range)
        sources_md << " | " << share(n);
      sources_md << " |\n";
    }
    {
      const TiltSummary u = tiltSummary(total.tilt_used, total.tilt_frames);
      const TiltSummary t = tiltSummary(total.tilt_reported, total.tilt_frames);
      char row[320];
      std::snprintf(row, sizeof(row),
                    "| %s | %s | %d | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f |\n",
                    c.condition.c_str(), c.variant.c_str(), total.tilt_frames, u.pitch_bias,
                    u.pitch_rms, u.roll_bias, u.roll_rms, t.pitch_bias, t.pitch_rms, t.roll_bias,
                    t.roll_rms);
      tilt_md << row;
    }
    if (total.detection.frames > 0) {
      any_detector = true;
      const ds::DetectionScore& d = total.detection;
      char row[256];
      std::snprintf(row, sizeof(row), "| %s | %s | %d | %.1f %% | %.1f %% | %.2f | %.2f |\n",
                    c.condition.c_str(), c.variant.c_str(), d.frames, 100.0 * d.precision(),
                    100.0 * d.recall(), static_cast<double>(d.accepted) / d.frames,
                    static_cast<double>(d.accepted_false) / d.frames);
      detector_md << row;
    }
    md << "| " << c.condition << " | " << c.variant << " | " << c.scenes.size() << " | " << pct(fn0)
       << " | " << pct(fn1) << " | " << pct(fp0) << " | " << pct(fp1) << " | " << pct(cov) << " | "
       << pct(lfn) << " | " << pct(lfp) << " | " << pct(seg) << " | " << pct(stk) << " ("
       << truthPct(stk_truth) << ") | " << total.forgotten_cells << " | "
       << total.obstacles_missed_strict << " / " << total.obstacles_missed_lenient << " / "
       << total.obstacles_in_view << " |\n";
    j.open('{');
    j.kv("condition", c.condition)
        .kv("variant", c.variant)
        .kv("scenes", static_cast<int>(c.scenes.size()));
    jsonStat(j, "fn_tol0", fn0);
    jsonStat(j, "fn_tol1", fn1);
    jsonStat(j, "fp_tol0", fp0);
    jsonStat(j, "fp_tol1", fp1);
    jsonStat(j, "fn_local_tol1", lfn);
    jsonStat(j, "fp_local_tol1", lfp);
    jsonStat(j, "coverage", cov);
    jsonStat(j, "maps_without_robot_segment", seg);
    jsonStat(j, "maps_stuck", stk);
    jsonStat(j, "maps_stuck_truth", stk_truth);
    j.kv("forgotten_cells", total.forgotten_cells).kv("forgotten_events", total.forgotten_events);
    j.kv("obstacles", total.obstacles).kv("obstacles_in_view", total.obstacles_in_view);
    j.kv("obstacles_missed_strict", total.obstacles_missed_strict);
    j.kv("obstacles_missed_lenient", total.obstacles_missed_lenient);
    j.kv("obstacle_maps_strict", total.obstacle_maps_strict);
    j.kv("obstacle_maps_missed_strict", total.obstacle_maps_missed_strict);
    j.kv("obstacle_maps_lenient", total.obstacle_maps_lenient);
    j.kv("obstacle_maps_missed_lenient", total.obstacle_maps_missed_lenient);
    j.kv("obstacle_safe_cells", total.obstacle_safe_cells);
    {
      const TiltSummary u = tiltSummary(total.tilt_used, total.tilt_frames);
      const TiltSummary t = tiltSummary(total.tilt_reported, total.tilt_frames);
      j.kv("pitch_error_bias_deg", u.pitch_bias).kv("pitch_error_rms_deg", u.pitch_rms);
      j.kv("roll_error_bias_deg", u.roll_bias).kv("roll_error_rms_deg", u.roll_rms);
      j.kv("reported_pitch_error_bias_deg", t.pitch_bias);
      j.kv("reported_pitch_error_rms_deg", t.pitch_rms);
      j.kv("reported_roll_error_bias_deg", t.roll_bias);
      j.kv("reported_roll_error_rms_deg", t.roll_rms);
    }
    if (total.detection.frames > 0) {
      const ds::DetectionScore& d = total.detection;
      j.key("detector").open('{');
      j.kv("frames", d.frames).kv("precision", d.precision()).kv("recall", d.recall());
      j.kv("raised_points", static_cast<std::uint64_t>(d.raised_points));
      j.kv("accepted", d.accepted).kv("accepted_false", d.accepted_false);
      j.kv("checks", d.checks).kv("checks_detected", d.checks_detected);
      j.close('}');
    }
    j.key("classes").open('{');
    for (int k = 1; k < ds::kHazardClassCount; ++k) {
      const Stat cfn = stat(c, [k](const ds::SceneScore& s) { return fnRate(s.by_class[k]); });
      const Stat cfp = stat(c, [k](const ds::SceneScore& s) { return fpRate(s.by_class[k]); });
      j.key(kClassNames[k]).open('{');
      jsonStat(j, "fn", cfn);
      jsonStat(j, "fp", cfp);
      j.close('}');
      classes_md << "| " << c.condition << " | " << c.variant << " | " << kClassNames[k] << " | "
                 << pct(cfn) << " | " << pct(cfp) << " |\n";
    }
    j.close('}');
    j.key("misses").open('[');
    for (const std::string& m : total.misses)
      j.val(m);
    j.close(']');
    j.close('}');
  }
  j.close(']');
  j.kv("failures", failures);
  j.close('}');
  std::ofstream(opt.out + "/metrics.json") << j.str() << "\n";
  const std::string detector_text = any_detector ? detector_md.str() : std::string();
  std::ofstream(opt.out + "/report.md")
      << md.str() << detector_text << classes_md.str() << sources_md.str() << tilt_md.str();
  std::printf("%s", md.str().c_str());
  std::printf("%s", detector_text.c_str());
  std::printf("%s", classes_md.str().c_str());
  std::printf("%s", sources_md.str().c_str());
  std::printf("%s", tilt_md.str().c_str());
  if (failures > 0) std::fprintf(stderr, "%d scene runs failed\n", failures);
  return failures > 0 ? 1 : 0;
}
