// evaluate_occupancy_2d: the 2D stereo occupancy grid of paper 002 (Murray & Little 1998,
// core/occupancy_grid_2d.h) on the benchmark datasets, measured beside the safety map of paper
// 000 on the same frames and the same disparity images, without a roscore.
//
//   evaluate_occupancy_2d --bag A.bag [--bag ...] [--compare-bag R.bag ...] [--latency-bag L.bag
//   ...]
//                         [--out DIR] [--params config/occupancy_grid_2d.yaml]
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
//
// Units: main.cpp (this: options, main), run.cpp, score.cpp, report.cpp; what they share is in
// evaluate_occupancy_2d.h.
#include "evaluate_occupancy_2d.h"

#include "stereo_safety_map/ros/occupancy_grid_2d_params.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/tools/args.h"

#include <algorithm>
#include <cstdio>

namespace evaluate_occupancy_2d {

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
      "  --params         2D grid parameters (config/occupancy_grid_2d.yaml)\n"
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

}  // namespace evaluate_occupancy_2d

using namespace evaluate_occupancy_2d;  // NOLINT(build/namespaces)

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) return ssm::tools::usageError(usage);
  Setup setup;
  std::string e = ssm::loadOccupancyGrid2DParamsFile(opt.params, &setup.grid);
  for (const std::string& a : opt.sets)
    if (e.empty()) e = ssm::setOccupancyGrid2DParam(a, &setup.grid);
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
