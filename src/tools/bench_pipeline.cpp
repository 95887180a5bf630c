// One-run benchmark of the whole pipeline against its peers (issue 8): every stage of paper 000
// (disparity + post-filters, reprojection, voxel grid update, height map, segmentation, plane fit,
// labelling, the whole frame) on frames of a benchmark dataset rendered in-process, with the peers
// measured in the same run on identical input:
//   - disparity: OpenCV's StereoBM / StereoSGBM alone, and stereo_image_proc's StereoProcessor::
//     processDisparity() (the call its disparity nodelet makes, from Debian's
//     libstereo-image-proc, loaded with dlopen because the package's CMake does not link it),
//     with our matcher settings, and once more with its own OpenCV post-filters;
//   - reprojection: image_geometry's projectDisparityImageTo3d (stereo_image_proc's point clouds);
//   - voxel grid update: octomap::OcTree::insertPointCloud, with and without discretize, same
//     resolution, same maximum range, the same points in the fixed frame, the same sensor origin;
//   - plane fit: pcl::SACSegmentation (SACMODEL_PLANE, RANSAC, 0.02 m) on the points of the
//     largest segment;
// and scaling sweeps over image size, map size and voxel size. Dataset 1 is poorly textured: BM +
// filters keeps ~6 % of the pixels, too few for the map to grow segments within a benchmark's
// frames, so the map side is measured twice, on the pipeline's points and on dense points (the
// same frames through StereoSGBM without any filter). Prints Markdown tables (stdout),
// progress (stderr), and writes everything to --json. Targets are reported, never asserted: the
// exit code is non-zero only when the pipeline did not work (no points, nothing integrated), so
// that `--quick` is a smoke test for CI.
//
// Fairness on the shared 2-core machine: cv::setNumThreads(1), the measuring thread is pinned to
// one core (after rendering, which uses both), every stage reports thread CPU time next to wall
// time, and the variants of a stage run interleaved frame by frame so that they see the same load.
// Allocations are counted by replacing the global operator new (C++ allocations) and by
// interposing glibc's malloc family (everything, OpenCV's buffers included; not in sanitizer
// builds).
//
//   bench_pipeline [--scene FILE] [--frames N] [--warmup W] [--stride K] [--passes P]
//
// The parts (src/tools/bench/): bench_support.h (allocation counters, clocks, the series
// registry, machine facts, the peers' set-up), bench.h (the run's shared state and one function
// per study), input.cpp, study_map.cpp (1, 1b), study_disparity.cpp (2), study_voxel_grid.cpp
// (3, 4), study_scaling.cpp (5), report.cpp (targets, Markdown, JSON).

#include "bench/bench.h"

#include <sched.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace bench;

namespace {

void usage() {
  std::printf(
      "usage: bench_pipeline [options]\n"
      "  --scene FILE          dataset scene (default scenes/dataset1_rail_dropoff_ramp.yaml)\n"
      "  --frames N            measured frames (default 20)\n"
      "  --warmup W            frames integrated before measuring (default 30)\n"
      "  --stride K            use every K-th moving frame of the trajectory (default 1)\n"
      "  --passes P            passes over the frames for disparity / plane fit (default 2)\n"
      "  --scaling-frames S    frames per point of the image-size sweep (default 6)\n"
      "  --no-scaling          skip the scaling sweeps\n"
      "  --cpu C               pin the measuring thread to core C (default: the current one)\n"
      "  --no-pin              do not pin\n"
      "  --quick               CI smoke: 3 frames, 1 warm-up, 1 pass, 2 scaling frames\n"
      "  --json FILE           write all results as JSON\n");
}

bool parseInt(const char* s, int lo, int hi, int* out) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(s, &end, 10);
  if (errno != 0 || end == s || *end != '\0' || v < lo || v > hi) return false;
  *out = static_cast<int>(v);
  return true;
}

}  // namespace

namespace bench {

bool parseOptions(int argc, char** argv, Options* out, int* exit_code) {
  Options& opt = *out;
  bool frames_set = false, warmup_set = false, passes_set = false, scaling_set = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&](const char* what) -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_pipeline: %s needs a value\n", what);
        std::exit(2);
      }
      return argv[++i];
    };
    auto intArg = [&](const char* what, int lo, int hi, int* out) {
      const char* v = next(what);
      if (!parseInt(v, lo, hi, out)) {
        std::fprintf(stderr, "bench_pipeline: %s must be an integer in [%d, %d], got '%s'\n", what,
                     lo, hi, v);
        std::exit(2);
      }
    };
    if (a == "--scene") {
      opt.scene = next("--scene");
    } else if (a == "--json") {
      opt.json = next("--json");
    } else if (a == "--frames") {
      intArg("--frames", 2, 10000, &opt.frames);
      frames_set = true;
    } else if (a == "--warmup") {
      intArg("--warmup", 0, 10000, &opt.warmup);
      warmup_set = true;
    } else if (a == "--stride") {
      intArg("--stride", 1, 100, &opt.stride);
    } else if (a == "--passes") {
      intArg("--passes", 1, 100, &opt.passes);
      passes_set = true;
    } else if (a == "--scaling-frames") {
      intArg("--scaling-frames", 2, 1000, &opt.scaling_frames);
      scaling_set = true;
    } else if (a == "--no-scaling") {
      opt.scaling = false;
    } else if (a == "--cpu") {
      intArg("--cpu", 0, CPU_SETSIZE - 1, &opt.cpu);
    } else if (a == "--no-pin") {
      opt.pin = false;
    } else if (a == "--quick") {
      opt.quick = true;
    } else if (a == "-h" || a == "--help") {
      usage();
      *exit_code = 0;
      return false;
    } else {
      std::fprintf(stderr, "bench_pipeline: unknown option '%s'\n", a.c_str());
      usage();
      *exit_code = 2;
      return false;
    }
  }
  if (opt.quick) {
    if (!frames_set) opt.frames = 3;
    if (!warmup_set) opt.warmup = 1;
    if (!passes_set) opt.passes = 1;
    if (!scaling_set) opt.scaling_frames = 2;
  }
  return true;
}

}  // namespace bench

// ---------------------------------------------------------------------------------------------

int main(int argc, char** argv) {
  Bench b;
  int exit_code = 0;
  if (!parseOptions(argc, argv, &b.opt, &exit_code)) return exit_code;
  b.t_start = wallMs();
  b.load_start = readFirstLine("/proc/loadavg");
  b.rss_start = rssMb();
  if (!prepareInput(&b)) return 2;
  pinMeasuringThread(&b);

  studyPipeline(&b);
  studyDenseMap(&b);
  studyDisparity(&b);
  studyReprojection(&b);
  studyVoxelGrid(&b);
  studyScaling(&b);

  computeTargets(&b);
  printMarkdown(&b);
  if (!b.opt.json.empty() && !writeJson(&b, argc, argv)) return 1;

  // Smoke checks: the benchmark ran the pipeline for real.
  if (b.extra["voxel_points_median"] <= 0.0)
    b.problems.push_back("no points reached the voxel grid");
  if (b.reg.find("disp.ours_bm") == nullptr || b.reg.find("disp.ours_bm")->wall.empty())
    b.problems.push_back("disparity was not measured");
  for (const std::string& p : b.problems)
    std::fprintf(stderr, "bench_pipeline: PROBLEM: %s\n", p.c_str());
  progress("done in %.1f s", b.run_s);
  return b.problems.empty() ? 0 : 1;
}
