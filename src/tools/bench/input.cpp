// bench_pipeline's input: frames of the benchmark dataset rendered in-process, and the measuring
// thread pinned to one core.
#include "bench.h"

#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

namespace bench {

namespace {

std::vector<std::size_t> pickFrames(const std::vector<ds::RobotPose>& poses, int count,
                                    int stride) {
  std::vector<std::size_t> moving;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!poses[i].stationary) moving.push_back(i);
  }
  std::vector<std::size_t> out;
  const std::size_t want = static_cast<std::size_t>(count);
  if (moving.size() >= want * static_cast<std::size_t>(stride)) {
    for (std::size_t k = 0; k < want; ++k)
      out.push_back(moving[k * static_cast<std::size_t>(stride)]);
  } else {
    for (std::size_t k : ds::subsampleFrames(moving.size(), want))
      out.push_back(moving[k]);
  }
  return out;
}

std::vector<Frame> renderFrames(ds::StereoRenderer& renderer, const ds::SceneFile& sf,
                                const std::vector<ds::RobotPose>& poses,
                                const std::vector<std::size_t>& which) {
  const Eigen::Isometry3d T_base_left = renderer.config().baseToLeftOptical();
  std::vector<Frame> frames;
  for (std::size_t i : which) {
    const ds::RobotPose& p = poses[i];
    Frame f;
    f.index = i;
    const Eigen::Isometry3d T = ds::basePose(p.x, p.y, sf.trajectory.base_z, p.yaw) * T_base_left;
    renderer.render(T, i, &f.left, &f.right);
    f.T_fixed_left = T.cast<float>();
    f.stamp = p.t;
    f.base = Eigen::Vector3f(static_cast<float>(p.x), static_cast<float>(p.y),
                             static_cast<float>(sf.trajectory.base_z));
    frames.push_back(f);
  }
  return frames;
}

}  // namespace

bool prepareInput(Bench* b) {
  const Options& opt = b->opt;
  auto& sf = b->sf;
  auto& poses = b->poses;
  auto& chosen = b->chosen;
  auto& head = b->head;
  auto& frames = b->frames;
  auto& measured = b->measured;
  auto& sized = b->sized;
  auto& render_s = b->render_s;
  auto& cam = b->cam;

  // ---- input: the benchmark dataset, rendered in-process ---------------------------------------
  {
    const std::string err = ds::loadSceneFromFile(opt.scene, "", &sf);
    if (!err.empty()) {
      std::fprintf(stderr, "bench_pipeline: cannot load scene %s: %s\n", opt.scene.c_str(),
                   err.c_str());
      return false;
    }
  }
  poses = ds::sampleTrajectory(sf.trajectory);
  const int total_frames = opt.warmup + opt.frames;
  chosen = pickFrames(poses, total_frames, opt.stride);
  if (static_cast<int>(chosen.size()) < total_frames) {
    std::fprintf(stderr, "bench_pipeline: the trajectory has only %zu moving frames\n",
                 chosen.size());
    return false;
  }
  head = sf.camera.scaledTo(640, 480);
  head.threads = 2;  // rendering is not measured; the core is pinned only afterwards
  const double t_render0 = wallMs();
  ds::StereoRenderer renderer(sf.scene, head, sf.seed);
  frames = renderFrames(renderer, sf, poses, chosen);
  measured.assign(frames.begin() + opt.warmup, frames.end());
  // Image-size sweep: the first measured poses at three resolutions (640x480 reuses `frames`).
  if (opt.scaling) {
    const int s = std::min(opt.scaling_frames, opt.frames);
    const std::vector<std::size_t> which(chosen.begin() + opt.warmup,
                                         chosen.begin() + opt.warmup + s);
    for (const auto& wh :
         {std::make_pair(320, 240), std::make_pair(640, 480), std::make_pair(1280, 960)}) {
      SizedFrames sz{wh.first, wh.second, sf.camera.scaledTo(wh.first, wh.second), {}};
      sz.head.threads = 2;
      if (wh.first == 640) {
        sz.frames.assign(measured.begin(), measured.begin() + s);
      } else {
        ds::StereoRenderer r(sf.scene, sz.head, sf.seed);
        sz.frames = renderFrames(r, sf, poses, which);
      }
      sized.push_back(std::move(sz));
    }
  }
  render_s = (wallMs() - t_render0) / 1e3;
  progress("rendered %zu frames of %s at 640x480 (+ sweep frames) in %.1f s", frames.size(),
           sf.scene.name.c_str(), render_s);
  cam = ds::stereoCameraModel(head);
  return true;
}

void pinMeasuringThread(Bench* b) {
  const Options& opt = b->opt;
  auto& start_mask = b->start_mask;
  auto& pinned_cpu = b->pinned_cpu;
  cv::setNumThreads(1);
  CPU_ZERO(&start_mask);
  sched_getaffinity(0, sizeof(start_mask), &start_mask);
  if (opt.pin) {
    const int cpu = opt.cpu >= 0 ? opt.cpu : sched_getcpu();
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    if (sched_setaffinity(0, sizeof(set), &set) == 0) {
      pinned_cpu = cpu;
    } else {
      progress("could not pin to core %d: %s (continuing unpinned)", cpu, std::strerror(errno));
    }
  }
}

}  // namespace bench
