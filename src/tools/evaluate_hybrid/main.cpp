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
//
// Units: main.cpp (this: options, main), run.cpp, score.cpp, report.cpp; what they share is in
// evaluate_hybrid.h.
#include "evaluate_hybrid.h"

#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/tools/args.h"

#include <ros/time.h>

#include <algorithm>
#include <cstdio>

namespace evaluate_hybrid {

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

}  // namespace evaluate_hybrid

using namespace evaluate_hybrid;  // NOLINT(build/namespaces)

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
  writeOutputs(opt, command, wall_s, fusion, landmarks);
  return 0;
}
