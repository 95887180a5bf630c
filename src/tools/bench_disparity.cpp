// Benchmark of the disparity stage (disparity_pipeline.h) on one core: 640x480, 64 disparities,
// a synthetic indoor scene (random-texture floor, back wall, three boxes) rendered into the right
// view by forward warping with a z-buffer. Prints min / median / max ms per step over the
// repetitions, for block matching with every filter, SGBM with every filter, and the OpenCV
// matchers alone. Target: block matching + filters <= 33 ms median (30 Hz).
//
// Standalone build (one line):
//   g++ -std=c++17 -O2 -Iinclude -I/usr/include/eigen3 -I/usr/include/opencv4
//     src/core/disparity_filters.cpp src/core/disparity_pipeline.cpp src/tools/bench_disparity.cpp
//     -lopencv_core -lopencv_imgproc -lopencv_calib3d -o /tmp/bench_disparity
//   /tmp/bench_disparity [repetitions]
#include "stereo_safety_map/core/disparity_pipeline.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <time.h>

using stereo_safety_map::DisparityPipeline;
using stereo_safety_map::DisparityPipelineConfig;
using stereo_safety_map::DisparityStats;
using stereo_safety_map::DisparityStep;
using stereo_safety_map::kNumDisparitySteps;

namespace {

constexpr int kRows = 480;
constexpr int kCols = 640;

struct Scene {
  cv::Mat left, right, truth;
};

// Camera 0.8 m above a floor, looking horizontally, f B = 60 px m (f = 500 px, B = 0.12 m):
// floor rows below the horizon (row 240) have d = 0.15 (y - 240), up to 36 px; a wall at 6 m
// (d = 10) above; boxes at 1.5 m (d = 40), 2.5 m (d = 24) and 4 m (d = 15) standing on the floor.
Scene makeScene() {
  Scene s;
  cv::RNG rng(12345);
  s.left.create(kRows, kCols, CV_8UC1);
  rng.fill(s.left, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(s.left, s.left, cv::Size(), 1.0);

  s.truth.create(kRows, kCols, CV_32FC1);
  for (int y = 0; y < kRows; ++y) {
    const float floor_d = 0.15f * static_cast<float>(y - 240);
    s.truth.row(y).setTo(std::max(10.0f, std::round(floor_d)));
  }
  struct Box {
    float d;
    int x0, x1;
  };
  const Box boxes[] = {{15.0f, 420, 520}, {24.0f, 120, 260}, {40.0f, 300, 420}};
  for (const Box& b : boxes) {
    const int bottom = static_cast<int>(240 + b.d / 0.15f);         // where it stands on the floor
    const int top = bottom - static_cast<int>(b.d * 0.5f / 0.12f);  // 0.5 m tall
    for (int y = std::max(0, top); y < std::min(kRows, bottom); ++y) {
      for (int x = b.x0; x < b.x1; ++x)
        s.truth.at<float>(y, x) = b.d;
    }
  }

  // Forward warp: left pixel x lands on right pixel x - d; the nearest surface wins; holes
  // (seen only by the right camera) get fresh texture.
  s.right.create(kRows, kCols, CV_8UC1);
  rng.fill(s.right, cv::RNG::UNIFORM, 0, 256);
  cv::Mat zbuffer(kRows, kCols, CV_32FC1, cv::Scalar(-1.0f));
  for (int y = 0; y < kRows; ++y) {
    for (int x = 0; x < kCols; ++x) {
      const float d = s.truth.at<float>(y, x);
      const int xr = x - static_cast<int>(d);
      if (xr < 0 || d <= zbuffer.at<float>(y, xr)) continue;
      zbuffer.at<float>(y, xr) = d;
      s.right.at<uchar>(y, xr) = s.left.at<uchar>(y, x);
    }
  }
  return s;
}

// CPU time of this thread [ms]: unlike wall time, not inflated when other processes share the
// cores (this machine's two cores are shared), so it is the fairer "one core" figure.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

struct Series {
  std::vector<double> values;
  void add(double v) { values.push_back(v); }
  void print(const char* name) {
    if (values.empty()) return;
    std::sort(values.begin(), values.end());
    const std::size_t n = values.size();
    const double median = n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
    std::printf("  %-26s min %7.2f  median %7.2f  max %7.2f ms\n", name, values.front(), median,
                values.back());
  }
};

void benchPipeline(const char* title, const DisparityPipelineConfig& config, const Scene& scene,
                   int repetitions) {
  DisparityPipeline pipeline(config);
  cv::Mat disparity;
  DisparityStats stats;
  std::string error;
  for (int i = 0; i < 3; ++i) {  // warm-up: matcher and buffer allocation
    if (!pipeline.compute(scene.left, scene.right, &disparity, &stats, &error)) {
      std::printf("%s: %s\n", title, error.c_str());
      std::exit(1);
    }
  }
  std::vector<Series> steps(kNumDisparitySteps);
  Series total, cpu;
  for (int i = 0; i < repetitions; ++i) {
    const double cpu0 = threadCpuMs();
    pipeline.compute(scene.left, scene.right, &disparity, &stats, &error);
    cpu.add(threadCpuMs() - cpu0);
    for (int s = 0; s < kNumDisparitySteps; ++s) {
      if (stats.steps[s].ran) steps[s].add(stats.steps[s].ms);
    }
    total.add(stats.total_ms);
  }
  int wrong = 0;
  for (int y = 0; y < kRows; ++y) {
    for (int x = 0; x < kCols; ++x) {
      const float d = disparity.at<float>(y, x);
      wrong += d > 0.0f && std::fabs(d - scene.truth.at<float>(y, x)) > 1.0f;
    }
  }
  std::printf("%s (%d repetitions): %d valid (%.1f %%), %d of them > 1 px from the truth\n", title,
              repetitions, stats.valid, 100.0 * stats.valid / stats.pixels, wrong);
  for (int s = 0; s < kNumDisparitySteps; ++s) {
    steps[s].print(stereo_safety_map::disparityStepName(static_cast<DisparityStep>(s)));
  }
  total.print("TOTAL (wall)");
  cpu.print("TOTAL (thread CPU)");
}

}  // namespace

int main(int argc, char** argv) {
  const int repetitions = argc > 1 ? std::max(1, std::atoi(argv[1])) : 50;
  cv::setNumThreads(1);
  const Scene scene = makeScene();
  std::printf("640x480, 64 disparities, block size 9, cv::setNumThreads(1)\n\n");

  DisparityPipelineConfig bm;  // defaults: block matching, every filter on
  benchPipeline("Block matching + all filters", bm, scene, repetitions);

  DisparityPipelineConfig coarse = bm;  // the multi-scale fill (off by default)
  coarse.coarse_fill_levels = 1;
  benchPipeline("\nBlock matching + all filters + coarse_fill_levels 1", coarse, scene,
                repetitions);

  DisparityPipelineConfig sgbm = bm;
  sgbm.matcher = stereo_safety_map::StereoMatcherType::kSemiGlobal;
  sgbm.block_size = 5;
  benchPipeline("\nSGBM (block 5) + all filters", sgbm, scene, std::max(1, repetitions / 3));

  DisparityPipelineConfig bare = bm;
  bare.enable_texture = bare.enable_left_right = bare.enable_neighbour_consistency =
      bare.enable_spike_removal = false;
  benchPipeline("\nBlock matching alone (pipeline, float output)", bare, scene, repetitions);

  // The OpenCV matcher call alone, fixed-point output, same settings as the pipeline's.
  cv::Ptr<cv::StereoBM> raw = cv::StereoBM::create(64, 9);
  raw->setPreFilterCap(31);
  raw->setTextureThreshold(0);
  raw->setUniquenessRatio(15);
  raw->setSpeckleWindowSize(0);
  raw->setDisp12MaxDiff(-1);
  cv::Mat out;
  Series raw_ms, raw_cpu;
  for (int i = 0; i < 3 + repetitions; ++i) {
    const auto t = std::chrono::steady_clock::now();
    const double cpu0 = threadCpuMs();
    raw->compute(scene.left, scene.right, out);
    if (i >= 3) {
      raw_cpu.add(threadCpuMs() - cpu0);
      raw_ms.add(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count());
    }
  }
  std::printf("\ncv::StereoBM::compute alone (%d repetitions):\n", repetitions);
  raw_ms.print("StereoBM (wall)");
  raw_cpu.print("StereoBM (thread CPU)");
  return 0;
}
