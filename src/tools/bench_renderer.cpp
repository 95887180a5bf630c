// Benchmark of the dataset stereo renderer: renders frames of a scene's trajectory and prints
// min / median / max wall-clock and process CPU time per stereo pair.
//
//   bench_renderer SCENE.yaml [frames=30] [threads=1] [small=0]
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene_loader.h"
#include "stereo_safety_map/dataset/trajectory.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

namespace ds = stereo_safety_map::dataset;

namespace {

double cpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

void print(const char* what, std::vector<double> v) {
  std::sort(v.begin(), v.end());
  std::printf("%s: min %.1f  median %.1f  max %.1f ms\n", what, v.front(), v[v.size() / 2],
              v.back());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_renderer SCENE.yaml [frames=30] [threads=1] [small=0]\n");
    return 2;
  }
  const int frames = argc > 2 ? std::atoi(argv[2]) : 30;
  const int threads = argc > 3 ? std::atoi(argv[3]) : 1;
  const bool small = argc > 4 && std::atoi(argv[4]) != 0;
  ds::SceneFile sf;
  const std::string e = ds::loadSceneFromFile(argv[1], "", &sf);
  if (!e.empty()) {
    std::fprintf(stderr, "%s\n", e.c_str());
    return 1;
  }
  ds::StereoHeadConfig head = small ? sf.camera.scaledTo(320, 240) : sf.camera;
  head.threads = std::max(1, threads);
  ds::StereoRenderer r(sf.scene, head, sf.seed);
  const auto poses = ds::sampleTrajectory(sf.trajectory);
  const auto idx = ds::subsampleFrames(poses.size(), static_cast<std::size_t>(std::max(1, frames)));
  cv::Mat left, right;
  std::vector<double> wall, cpu;
  for (std::size_t i : idx) {
    const auto& p = poses[i];
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpuSeconds();
    r.render(ds::basePose(p.x, p.y, sf.trajectory.base_z, p.yaw) * head.baseToLeftOptical(), i,
             &left, &right);
    cpu.push_back(1e3 * (cpuSeconds() - c0));
    wall.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::printf("%s: %dx%d, %zu primitives, %zu frames, %d thread(s)\n", sf.scene.name.c_str(),
              head.width, head.height, sf.scene.primitives.size(), idx.size(), head.threads);
  print("stereo pair wall", wall);
  print("stereo pair CPU ", cpu);
  return 0;
}
