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
//
// Units: main.cpp (this: options, main), run.cpp, score.cpp, report.cpp, model_3d.cpp; what they
// share is in evaluate_safety_map.h.
#include "evaluate_safety_map.h"

#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/tools/args.h"

#include <ros/time.h>

#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace evaluate_safety_map {

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
  ssm::tools::Args a(argc, argv);
  while (a.next()) {
    if (a.value("--bag", &o->bags) || a.value("--latency-bag", &o->latency_bags) ||
        a.value("--out", &o->out) || a.value("--max-frames", &o->max_frames) ||
        a.value("--seed", &o->seed) || a.value("--params", &o->params) ||
        a.value("--set", &o->sets) || a.value("--recorded", &o->recorded) ||
        a.value("--fixed-frame", &o->fixed_frame) || a.value("--base-frame", &o->base_frame) ||
        a.value("--camera", &o->camera) || a.flag("--no-model", &o->model, false) ||
        a.flag("--quiet", &o->quiet) || a.value("--scenes", &o->scenes) ||
        a.value("--dump-frame", &o->dump_frame))
      continue;
    std::string decr;
    if (a.value("--decr", &decr)) {
      if (!parseIntList(decr, &o->decr)) return false;
    } else if (a.value("--every", &o->every)) {
      if (o->every < 1) return false;
    } else if (a.value("--images", &o->images)) {
      o->images = std::max(0, o->images);
    } else if (a.value("--plane-frames", &o->plane_frames)) {
      o->plane_frames = std::max(0, o->plane_frames);
    } else {
      std::fprintf(stderr, "bad or incomplete argument: %s\n", a.arg().c_str());
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

}  // namespace evaluate_safety_map

using namespace evaluate_safety_map;  // NOLINT(build/namespaces)

int main(int argc, char** argv) {
  Options opt;
  if (!parseArgs(argc, argv, &opt)) return ssm::tools::usageError(usage);
  ros::Time::init();
  const std::string command = ssm::tools::commandLine("evaluate_safety_map", argc, argv);

  ssm::StereoFrameProcessorConfig config;
  if (ssm::tools::printError(ssm::loadCoreParams(opt.params, opt.sets, &config))) return 2;
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
      if (ssm::tools::printError(ssm::loadDataset(b, pass == 1, &d))) return 1;
      datasets.push_back(d);
    }
  }

  std::vector<Run> runs;
  const Clock::time_point t0 = Clock::now();
  if (ssm::tools::printError(opt.recorded.empty()
                                 ? evaluateOffline(opt, config, datasets, &runs)
                                 : evaluateRecorded(opt, datasets.front(), &runs)) ||
      ssm::tools::printError(writeOutputs(opt, config, runs, command)))
    return 1;
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
