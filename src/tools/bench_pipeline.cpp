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
//                  [--scaling-frames S] [--cpu C | --no-pin] [--quick] [--json FILE]
#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/ground_segmentation.h"
#include "stereo_safety_map/core/height_map.h"
#include "stereo_safety_map/core/plane_fit.h"
#include "stereo_safety_map/core/safety_labelling.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/core/voxel_grid.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene_loader.h"
#include "stereo_safety_map/dataset/trajectory.h"
#include "stereo_safety_map/ros/conversions.h"

#include <image_geometry/stereo_camera_model.h>
#include <octomap/OcTree.h>
#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>
#include <sensor_msgs/CameraInfo.h>
#include <stereo_msgs/DisparityImage.h>
#if __has_include(<stereo_image_proc/processor.h>)
#include <stereo_image_proc/processor.h>
#define SSM_BENCH_HAVE_SIP 1
#else
#define SSM_BENCH_HAVE_SIP 0
#endif

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <deque>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <new>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <dlfcn.h>
#include <malloc.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/utsname.h>
#include <unistd.h>

// ---------------------------------------------------------------------------------------------
// Allocation counters. Constant-initialised, so they are valid before any static constructor.
namespace alloc_count {
std::atomic<std::uint64_t> news{0};       // global operator new calls (C++ allocations)
std::atomic<std::uint64_t> new_bytes{0};  // bytes asked of operator new
std::atomic<std::uint64_t> mallocs{0};    // malloc-family calls (everything, C and C++)
}  // namespace alloc_count

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define SSM_BENCH_SANITIZED 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define SSM_BENCH_SANITIZED 1
#endif

// Interposing malloc: glibc documents replacing its malloc family in the executable; these
// forward to glibc's own allocator (__libc_*), so blocks from any of them may be freed by any.
// Sanitizers intercept malloc themselves, so their builds count operator new only.
#if defined(__GLIBC__) && !defined(SSM_BENCH_SANITIZED)
#define SSM_BENCH_COUNT_MALLOC 1
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
void __libc_free(void* p);

void* malloc(std::size_t size) noexcept {
  alloc_count::mallocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) noexcept {
  alloc_count::mallocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) noexcept {
  alloc_count::mallocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, size);
}
void free(void* p) noexcept {
  __libc_free(p);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) noexcept {
  alloc_count::mallocs.fetch_add(1, std::memory_order_relaxed);
  if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  alloc_count::mallocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_memalign(alignment, size);
}
void* memalign(std::size_t alignment, std::size_t size) noexcept {
  alloc_count::mallocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_memalign(alignment, size);
}
}  // extern "C"
#else
#define SSM_BENCH_COUNT_MALLOC 0
#endif

namespace {
void* countedNew(std::size_t size) {
  alloc_count::news.fetch_add(1, std::memory_order_relaxed);
  alloc_count::new_bytes.fetch_add(size, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* countedAlignedNew(std::size_t size, std::align_val_t al) {
  alloc_count::news.fetch_add(1, std::memory_order_relaxed);
  alloc_count::new_bytes.fetch_add(size, std::memory_order_relaxed);
  const std::size_t a = std::max(static_cast<std::size_t>(al), sizeof(void*));
  void* p = nullptr;
  if (posix_memalign(&p, a, size == 0 ? a : size) != 0) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t size) {
  return countedNew(size);
}
void* operator new[](std::size_t size) {
  return countedNew(size);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return countedNew(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return countedNew(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t size, std::align_val_t al) {
  return countedAlignedNew(size, al);
}
void* operator new[](std::size_t size, std::align_val_t al) {
  return countedAlignedNew(size, al);
}
void* operator new(std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  try {
    return countedAlignedNew(size, al);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  try {
    return countedAlignedNew(size, al);
  } catch (...) {
    return nullptr;
  }
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  std::free(p);
}

namespace {

namespace ssm = stereo_safety_map;
namespace ds = stereo_safety_map::dataset;

// ---------------------------------------------------------------------------------------------
// Clocks, samples, series.

double wallMs() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// CPU time of the calling thread: not inflated when other processes take the core.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

struct Sample {
  double wall = 0.0, cpu = 0.0;
  double news = 0.0, mallocs = 0.0;
};

class Meter {
 public:
  void start() {
    n0_ = alloc_count::news.load(std::memory_order_relaxed);
    m0_ = alloc_count::mallocs.load(std::memory_order_relaxed);
    c0_ = threadCpuMs();
    w0_ = wallMs();
  }
  Sample stop() const {
    Sample s;
    s.wall = wallMs() - w0_;
    s.cpu = threadCpuMs() - c0_;
    s.news = static_cast<double>(alloc_count::news.load(std::memory_order_relaxed) - n0_);
    s.mallocs = static_cast<double>(alloc_count::mallocs.load(std::memory_order_relaxed) - m0_);
    return s;
  }

 private:
  double w0_ = 0.0, c0_ = 0.0;
  std::uint64_t n0_ = 0, m0_ = 0;
};

template <typename F>
Sample measure(F&& f) {
  Meter m;
  m.start();
  f();
  return m.stop();
}

struct Stats {
  int n = 0;
  double min = std::numeric_limits<double>::quiet_NaN();
  double median = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
};

Stats statsOf(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  s.n = static_cast<int>(n);
  s.min = v.front();
  s.max = v.back();
  s.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  return s;
}

// One timed quantity: wall and CPU [ms] and allocations per call. Stage times taken from the
// core's own StageTimings have wall time only.
struct Series {
  std::string id, group, label, impl, note;
  std::vector<double> wall, cpu, news, mallocs;
  void add(const Sample& s) {
    wall.push_back(s.wall);
    cpu.push_back(s.cpu);
    news.push_back(s.news);
    mallocs.push_back(s.mallocs);
  }
  void addWall(double w) { wall.push_back(w); }
};

class Registry {
 public:
  Series& get(const std::string& id, const std::string& group, const std::string& label,
              const std::string& impl, const std::string& note = "") {
    auto it = index_.find(id);
    if (it != index_.end()) return series_[it->second];
    index_[id] = series_.size();
    Series s;
    s.id = id;
    s.group = group;
    s.label = label;
    s.impl = impl;
    s.note = note;
    series_.push_back(s);
    return series_.back();
  }
  const Series* find(const std::string& id) const {
    auto it = index_.find(id);
    return it == index_.end() ? nullptr : &series_[it->second];
  }
  const std::deque<Series>& all() const { return series_; }

 private:
  std::deque<Series> series_;  // deque: references stay valid while series are added
  std::map<std::string, std::size_t> index_;
};

// ---------------------------------------------------------------------------------------------
// Minimal JSON writer (objects, arrays, numbers, strings; NaN/inf as null).

class Json {
 public:
  Json& beginObject(const char* key = nullptr) { return open(key, '{'); }
  Json& endObject() { return close('}'); }
  Json& beginArray(const char* key = nullptr) { return open(key, '['); }
  Json& endArray() { return close(']'); }
  Json& num(const char* key, double v) {
    prefix(key);
    if (std::isfinite(v)) {
      char buf[40];
      std::snprintf(buf, sizeof(buf), "%.6g", v);
      os_ << buf;
    } else {
      os_ << "null";
    }
    return *this;
  }
  Json& num(double v) { return num(nullptr, v); }
  Json& integer(const char* key, long long v) {
    prefix(key);
    os_ << v;
    return *this;
  }
  Json& boolean(const char* key, bool v) {
    prefix(key);
    os_ << (v ? "true" : "false");
    return *this;
  }
  Json& str(const char* key, const std::string& v) {
    prefix(key);
    quote(v);
    return *this;
  }
  Json& str(const std::string& v) { return str(nullptr, v); }
  Json& null(const char* key) {
    prefix(key);
    os_ << "null";
    return *this;
  }
  std::string text() const { return os_.str() + "\n"; }

 private:
  Json& open(const char* key, char c) {
    prefix(key);
    os_ << c;
    first_.push_back(true);
    return *this;
  }
  Json& close(char c) {
    first_.pop_back();
    os_ << '\n' << std::string(2 * first_.size(), ' ') << c;
    return *this;
  }
  void prefix(const char* key) {
    if (!first_.empty()) {
      if (!first_.back()) os_ << ',';
      first_.back() = false;
      os_ << '\n' << std::string(2 * first_.size(), ' ');
    }
    if (key != nullptr) {
      quote(key);
      os_ << ": ";
    }
  }
  void quote(const std::string& s) {
    os_ << '"';
    for (char ch : s) {
      switch (ch) {
        case '"':
          os_ << "\\\"";
          break;
        case '\\':
          os_ << "\\\\";
          break;
        case '\n':
          os_ << "\\n";
          break;
        case '\t':
          os_ << "\\t";
          break;
        default:
          if (static_cast<unsigned char>(ch) < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof(buf), "\\u%04x", ch);
            os_ << buf;
          } else {
            os_ << ch;
          }
      }
    }
    os_ << '"';
  }
  std::ostringstream os_;
  std::vector<bool> first_;
};

void writeStats(Json& j, const char* key, const Stats& s) {
  if (s.n == 0) {
    j.null(key);
    return;
  }
  j.beginObject(key).integer("n", s.n).num("min", s.min).num("median", s.median).num("max", s.max);
  j.endObject();
}

// ---------------------------------------------------------------------------------------------
// Options and machine state.

struct Options {
  std::string scene = "scenes/dataset1_rail_dropoff_ramp.yaml";
  std::string json;
  int frames = 20;  // measured frames
  int warmup = 30;  // frames integrated first so that the map has grown (2 s at 15 Hz)
  int stride = 1;   // take every stride-th moving frame of the trajectory
  int passes = 2;   // passes over the measured frames for the stateless stages
  int scaling_frames = 6;
  int cpu = -1;  // -1 = the core the program starts on
  bool pin = true;
  bool quick = false;
  bool scaling = true;
};

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

std::string readFirstLine(const char* path) {
  std::ifstream f(path);
  std::string line;
  std::getline(f, line);
  return line;
}

std::string cpuModel() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  }
  return "unknown";
}

double rssMb() {
  std::ifstream f("/proc/self/statm");
  long pages_total = 0, pages_rss = 0;
  f >> pages_total >> pages_rss;
  return static_cast<double>(pages_rss) * static_cast<double>(sysconf(_SC_PAGESIZE)) / 1048576.0;
}

double peakRssMb() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_maxrss) / 1024.0;
}

std::string isoTime() {
  const std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%S%z", std::localtime(&t));
  return buf;
}

void progress(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
void progress(const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  std::fprintf(stderr, "[bench_pipeline] ");
  std::vfprintf(stderr, fmt, ap);
  std::fprintf(stderr, "\n");
  va_end(ap);
}

// ---------------------------------------------------------------------------------------------
// Input: frames of the dataset rendered in-process.

struct Frame {
  std::size_t index = 0;  // frame number in the trajectory
  cv::Mat left, right;
  Eigen::Isometry3f T_fixed_left = Eigen::Isometry3f::Identity();
  Eigen::Vector3f base = Eigen::Vector3f::Zero();
  double stamp = 0.0;  // [s], the trajectory's time
};

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

// ---------------------------------------------------------------------------------------------
// Peer: stereo_image_proc's StereoProcessor::processDisparity (what its disparity nodelet calls
// per frame after cv_bridge's zero-copy view of the mono8 images). The package's CMake does not
// link libstereo_image_proc, so the function is looked up in Debian's shared library at run time;
// a non-virtual const member function is called with `this` as its first argument (Itanium C++
// ABI), which is what the function pointer below does.

#if SSM_BENCH_HAVE_SIP
using SipProcessDisparity = void (*)(const stereo_image_proc::StereoProcessor*, const cv::Mat&,
                                     const cv::Mat&, const image_geometry::StereoCameraModel&,
                                     stereo_msgs::DisparityImage&);

SipProcessDisparity loadSip(std::string* why) {
  void* lib = dlopen("libstereo_image_proc.so.0d", RTLD_NOW | RTLD_LOCAL);
  if (lib == nullptr) lib = dlopen("libstereo_image_proc.so", RTLD_NOW | RTLD_LOCAL);
  if (lib == nullptr) {
    *why = std::string("cannot load libstereo_image_proc: ") + dlerror();
    return nullptr;
  }
  void* sym = dlsym(lib,
                    "_ZNK17stereo_image_proc15StereoProcessor16processDisparityERKN2cv3MatES4_"
                    "RKN14image_geometry17StereoCameraModelERN11stereo_msgs15DisparityImage_"
                    "ISaIvEEE");
  if (sym == nullptr) {
    *why = "StereoProcessor::processDisparity not found in libstereo_image_proc";
    return nullptr;
  }
  SipProcessDisparity fn = nullptr;
  static_assert(sizeof(fn) == sizeof(sym), "function and object pointers differ in size");
  std::memcpy(&fn, &sym, sizeof(fn));
  return fn;
}

// Same matcher settings as DisparityPipeline::createMatcher for `c`.
void configureSip(stereo_image_proc::StereoProcessor* p, const ssm::DisparityPipelineConfig& c,
                  bool own_filters) {
  p->setStereoType(c.matcher == ssm::StereoMatcherType::kSemiGlobal
                       ? stereo_image_proc::StereoProcessor::SGBM
                       : stereo_image_proc::StereoProcessor::BM);
  p->setMinDisparity(c.min_disparity);
  p->setDisparityRange(c.num_disparities);
  p->setCorrelationWindowSize(c.block_size);
  p->setPreFilterCap(c.pre_filter_cap);
  p->setUniquenessRatio(
      static_cast<float>(c.enable_uniqueness ? c.uniqueness.uniqueness_ratio : 0));
  // Its Disparity.cfg defaults: texture_threshold 10, speckle_size 100, speckle_range 4.
  p->setTextureThreshold(own_filters ? 10 : c.bm_texture_threshold);
  p->setSpeckleSize(own_filters ? 100 : c.speckle_window_size);
  p->setSpeckleRange(own_filters ? 4 : c.speckle_range);
  const int b2 = c.block_size * c.block_size;
  p->setP1(c.sgbm_p1 > 0 ? c.sgbm_p1 : 8 * b2);
  p->setP2(c.sgbm_p2 > 0 ? c.sgbm_p2 : 32 * b2);
  p->setDisp12MaxDiff(-1);
  p->setSgbmMode(c.sgbm_three_way ? cv::StereoSGBM::MODE_SGBM_3WAY : cv::StereoSGBM::MODE_SGBM);
}
#endif

// OpenCV matcher alone with the settings DisparityPipeline gives it (fixed-point output).
cv::Ptr<cv::StereoMatcher> rawMatcher(const ssm::DisparityPipelineConfig& c) {
  const int uniq = c.enable_uniqueness ? c.uniqueness.uniqueness_ratio : 0;
  if (c.matcher == ssm::StereoMatcherType::kSemiGlobal) {
    const int b2 = c.block_size * c.block_size;
    return cv::StereoSGBM::create(
        c.min_disparity, c.num_disparities, c.block_size, c.sgbm_p1 > 0 ? c.sgbm_p1 : 8 * b2,
        c.sgbm_p2 > 0 ? c.sgbm_p2 : 32 * b2, -1, c.pre_filter_cap, uniq, c.speckle_window_size,
        c.speckle_range,
        c.sgbm_three_way ? cv::StereoSGBM::MODE_SGBM_3WAY : cv::StereoSGBM::MODE_SGBM);
  }
  cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(c.num_disparities, c.block_size);
  bm->setMinDisparity(c.min_disparity);
  bm->setPreFilterType(cv::StereoBM::PREFILTER_XSOBEL);
  bm->setPreFilterCap(c.pre_filter_cap);
  bm->setTextureThreshold(c.bm_texture_threshold);
  bm->setUniquenessRatio(uniq);
  bm->setSpeckleWindowSize(c.speckle_window_size);
  bm->setSpeckleRange(c.speckle_range);
  bm->setDisp12MaxDiff(-1);
  return bm;
}

double validFraction(const cv::Mat& disparity_float) {
  if (disparity_float.empty()) return 0.0;
  int valid = 0;
  for (int y = 0; y < disparity_float.rows; ++y) {
    const float* row = disparity_float.ptr<float>(y);
    for (int x = 0; x < disparity_float.cols; ++x)
      valid += row[x] > 0.0f && std::isfinite(row[x]);
  }
  return static_cast<double>(valid) / static_cast<double>(disparity_float.total());
}

// Points whose distance to the camera is within [min_range, max_range]: what VoxelGrid uses, so
// that OctoMap gets exactly the points our grid integrates.
void rangeFilter(const std::vector<Eigen::Vector3f>& in, double min_range, double max_range,
                 std::vector<Eigen::Vector3f>* out) {
  out->clear();
  const float lo2 = static_cast<float>(min_range * min_range);
  const float hi2 = static_cast<float>(max_range * max_range);
  for (const Eigen::Vector3f& p : in) {
    const float r2 = p.squaredNorm();
    if (p.allFinite() && r2 >= lo2 && r2 <= hi2) out->push_back(p);
  }
}

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = std::min(1.0, std::abs(a.normalized().dot(b.normalized())));
  return std::acos(c) * 180.0 / M_PI;
}

// ---------------------------------------------------------------------------------------------
// Output helpers.

std::string fmt(double v, int prec = 2) {
  if (!std::isfinite(v)) return "—";
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.*f", prec, v);
  return buf;
}

struct Comparison {
  std::string ours, peer, what;
};

struct Target {
  Target(std::string n, std::string u) : name(std::move(n)), unit(std::move(u)) {}
  std::string name, unit;
  double wall = std::numeric_limits<double>::quiet_NaN();
  double cpu = std::numeric_limits<double>::quiet_NaN();
  double limit = 0.0;
  int limit_digits = 0;  // decimals of the limit as printed
  bool at_most = true;   // value <= limit (else >= limit)
  std::string note;
  bool metBy(double v) const { return std::isfinite(v) && (at_most ? v <= limit : v >= limit); }
};

struct ScalingPoint {
  std::string sweep;  // "image_size", "map_size", "voxel_size"
  double x = 0.0;
  std::string label;
  std::map<std::string, double> wall_median;  // stage -> median wall [ms]
  double cpu_total_median = std::numeric_limits<double>::quiet_NaN();
  double points_median = std::numeric_limits<double>::quiet_NaN();
  double mallocs_median = std::numeric_limits<double>::quiet_NaN();
  int frames = 0;
  std::string error;
};

// What the map stages worked on, and how our plane fit compares with PCL's on it. The stage
// objects are our own instances with the mapper's configuration, kept across frames so that
// their buffers are reused as in SafetyMapper.
struct MapStudy {
  MapStudy(std::string s, std::string w) : suffix(std::move(s)), what(std::move(w)) {}
  std::string suffix;  // "" for the pipeline's map, "_dense" for the dense one
  std::string what;
  std::vector<double> fit_angle, fit_points, inlier_fraction, segments, columns, seed;
  std::unique_ptr<ssm::HeightMap> height_map;
  std::unique_ptr<ssm::GroundSegmentation> segmentation;
  std::unique_ptr<ssm::PlaneFitter> fitter;
  std::unique_ptr<ssm::SafetyLabelling> labelling;
  ssm::GroundSegments segs;
  std::vector<ssm::GroundPlane> planes;
  ssm::SafetyMap map;
};

double fractionOf(const std::vector<double>& flags) {
  if (flags.empty()) return std::numeric_limits<double>::quiet_NaN();
  return std::accumulate(flags.begin(), flags.end(), 0.0) / static_cast<double>(flags.size());
}

// On `mapper`'s current grid: the map stages of SafetyMapper::computeSafetyMap() called one by
// one, with thread CPU time and allocations per stage; the state of the map; then the largest
// segment's plane by our least squares (000 Sec. V-B) and by pcl::SACSegmentation (plane,
// RANSAC, 0.02 m) on the very same points.
void studyMap(const ssm::SafetyMapper& mapper, const Eigen::Vector3f& base, int reps, Registry& reg,
              MapStudy* st) {
  const ssm::SafetyMapperConfig& mc = mapper.config();
  if (!st->height_map) {
    st->height_map = std::make_unique<ssm::HeightMap>(mc.height_map);
    st->segmentation = std::make_unique<ssm::GroundSegmentation>(mc.segmentation);
    st->fitter = std::make_unique<ssm::PlaneFitter>(mc.plane_fit);
    st->labelling = std::make_unique<ssm::SafetyLabelling>(mc.labelling);
  }
  const ssm::VoxelGrid& grid = mapper.grid();
  const double l = grid.config().voxel_size;
  const std::string group = "map stages called directly (" + st->what + ")";
  const std::string id = "map" + st->suffix + ".";
  const Sample hm = measure([&] { st->height_map->build(grid, base.z()); });
  const Sample sg = measure(
      [&] { st->segmentation->segment(*st->height_map, grid.indexOf(base), l, &st->segs); });
  const Sample pf = measure([&] { st->fitter->fitAll(grid, st->segs, &st->planes); });
  const Sample lb =
      measure([&] { st->labelling->label(*st->height_map, st->segs, st->planes, l, &st->map); });
  Sample sum;
  for (const Sample* x : {&sg, &pf, &lb}) {
    sum.wall += x->wall;
    sum.cpu += x->cpu;
    sum.news += x->news;
    sum.mallocs += x->mallocs;
  }
  reg.get(id + "height_map", group, "HeightMap::build", "ours").add(hm);
  reg.get(id + "segmentation", group, "GroundSegmentation::segment (Alg. 1)", "ours").add(sg);
  reg.get(id + "plane_fit", group, "PlaneFitter::fitAll (every segment)", "ours").add(pf);
  reg.get(id + "labelling", group, "SafetyLabelling::label (Alg. 2)", "ours").add(lb);
  reg.get(id + "seg_fit_label", group, "segmentation + plane fit + labelling", "ours").add(sum);
  const ssm::GroundSegments& segs = st->segs;
  st->segments.push_back(segs.numSegments());
  int with_height = 0;
  for (std::int32_t w : st->height_map->data())
    with_height += w != ssm::HeightMap::kNoHeight;
  st->columns.push_back(with_height);
  st->seed.push_back(segs.seed_cell >= 0 ? 1.0 : 0.0);

  int best = -1;
  for (int i = 0; i < segs.numSegments(); ++i) {
    if (best < 0 || segs.segmentSize(i) > segs.segmentSize(best)) best = i;
  }
  if (best < 0) return;
  std::vector<Eigen::Vector3d> points;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  const int w = segs.segment_height[best];
  for (const int* c = segs.cellsBegin(best); c != segs.cellsEnd(best); ++c) {
    for (const ssm::VoxelPoint& p :
         grid.points(ssm::VoxelIndex{segs.cellU(*c), segs.cellV(*c), w})) {
      points.push_back(p.position.cast<double>());
      cloud->push_back(pcl::PointXYZ(p.position.x(), p.position.y(), p.position.z()));
    }
  }
  if (points.size() < 3) return;
  const ssm::PlaneFitConfig& cfg = mc.plane_fit;
  const ssm::PlaneFitter& fitter = *st->fitter;
  pcl::SACSegmentation<pcl::PointXYZ> sac;
  sac.setOptimizeCoefficients(true);
  sac.setModelType(pcl::SACMODEL_PLANE);
  sac.setMethodType(pcl::SAC_RANSAC);
  sac.setDistanceThreshold(0.02);
  sac.setInputCloud(cloud);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coeffs;
  const std::string fgroup = "plane fit, largest segment (" + st->what + ")";
  Series& a = reg.get("planefit" + st->suffix + ".ours_segment", fgroup,
                      "PlaneFitter::fitSegment (gathers the voxel point lists)", "ours");
  Series& b = reg.get("planefit" + st->suffix + ".ours_points", fgroup,
                      "fitPlane() on the gathered points (least squares, 000 V-B)", "ours");
  Series& c = reg.get("planefit" + st->suffix + ".pcl_sac", fgroup,
                      "pcl::SACSegmentation plane, RANSAC, 0.02 m, same points", "peer");
  ssm::GroundPlane ours, ours_pts;
  for (int rep = 0; rep < reps; ++rep) {
    a.add(measure([&] { ours = fitter.fitSegment(grid, segs, best); }));
    b.add(measure([&] { ours_pts = ssm::fitPlane(points, cfg); }));
    c.add(measure([&] { sac.segment(inliers, coeffs); }));
  }
  st->fit_points.push_back(static_cast<double>(points.size()));
  if (coeffs.values.size() == 4 && ours.valid) {
    const Eigen::Vector3d n(coeffs.values[0], coeffs.values[1], coeffs.values[2]);
    st->fit_angle.push_back(angleDeg(n, ours.normal));
    st->inlier_fraction.push_back(static_cast<double>(inliers.indices.size()) /
                                  static_cast<double>(points.size()));
  }
}

// Stage list of StageTimings / StereoFrameTimings, in pipeline order.
const char* const kStageKeys[] = {"disparity",  "reproject",     "integrate",
                                  "height_map", "segmentation",  "plane_fit",
                                  "labelling",  "seg_fit_label", "total"};

}  // namespace

// ---------------------------------------------------------------------------------------------

int main(int argc, char** argv) {
  Options opt;
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
      return 0;
    } else {
      std::fprintf(stderr, "bench_pipeline: unknown option '%s'\n", a.c_str());
      usage();
      return 2;
    }
  }
  if (opt.quick) {
    if (!frames_set) opt.frames = 3;
    if (!warmup_set) opt.warmup = 1;
    if (!passes_set) opt.passes = 1;
    if (!scaling_set) opt.scaling_frames = 2;
  }
  const double t_start = wallMs();
  const std::string load_start = readFirstLine("/proc/loadavg");
  const double rss_start = rssMb();
  std::vector<std::string> problems;  // functional failures: non-zero exit
  std::vector<std::string> pending;   // measurements not made in this run

  // ---- input: the benchmark dataset, rendered in-process ---------------------------------------
  ds::SceneFile sf;
  {
    const std::string err = ds::loadSceneFromFile(opt.scene, "", &sf);
    if (!err.empty()) {
      std::fprintf(stderr, "bench_pipeline: cannot load scene %s: %s\n", opt.scene.c_str(),
                   err.c_str());
      return 2;
    }
  }
  const std::vector<ds::RobotPose> poses = ds::sampleTrajectory(sf.trajectory);
  const int total_frames = opt.warmup + opt.frames;
  const std::vector<std::size_t> chosen = pickFrames(poses, total_frames, opt.stride);
  if (static_cast<int>(chosen.size()) < total_frames) {
    std::fprintf(stderr, "bench_pipeline: the trajectory has only %zu moving frames\n",
                 chosen.size());
    return 2;
  }
  ds::StereoHeadConfig head = sf.camera.scaledTo(640, 480);
  head.threads = 2;  // rendering is not measured; the core is pinned only afterwards
  const double t_render0 = wallMs();
  ds::StereoRenderer renderer(sf.scene, head, sf.seed);
  const std::vector<Frame> frames = renderFrames(renderer, sf, poses, chosen);
  const std::vector<Frame> measured(frames.begin() + opt.warmup, frames.end());
  // Image-size sweep: the first measured poses at three resolutions (640x480 reuses `frames`).
  struct SizedFrames {
    int width, height;
    ds::StereoHeadConfig head;
    std::vector<Frame> frames;
  };
  std::vector<SizedFrames> sized;
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
  const double render_s = (wallMs() - t_render0) / 1e3;
  progress("rendered %zu frames of %s at 640x480 (+ sweep frames) in %.1f s", frames.size(),
           sf.scene.name.c_str(), render_s);

  // ---- fairness: one thread, one core --------------------------------------------------------
  cv::setNumThreads(1);
  cpu_set_t start_mask;  // every core the program may use, for the two-thread disparity variant
  CPU_ZERO(&start_mask);
  sched_getaffinity(0, sizeof(start_mask), &start_mask);
  int pinned_cpu = -1;
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

  const ssm::StereoCameraModel cam = ds::stereoCameraModel(head);
  Registry reg;
  std::vector<Comparison> comparisons;
  std::map<std::string, double> extra;  // scalar facts for the JSON / tables

  // ---- 1. the whole pipeline per frame (StereoFrameProcessor: BM + filters, default mapper) ---
  ssm::StereoFrameProcessorConfig pcfg;  // package defaults
  std::vector<std::vector<Eigen::Vector3f>> points_of(frames.size());
  std::vector<cv::Mat> disparity_of(measured.size());
  int not_integrated = 0;
  MapStudy pipeline_map("", "the pipeline's map");
  MapStudy dense_map("_dense", "dense map, SGBM points");
  {
    progress("whole pipeline: %d warm-up + %d measured frames", opt.warmup, opt.frames);
    ssm::StereoFrameProcessor proc(pcfg);
    Series& s_total = reg.get("pipeline.frame", "whole pipeline per frame",
                              "whole frame: stereo pair -> safety map (BM + filters)", "ours");
    const char* stage_labels[] = {"disparity + filters (BM)",
                                  "reprojection",
                                  "voxel grid update (recenter + integrate)",
                                  "height map",
                                  "segmentation (Alg. 1)",
                                  "plane fit (all segments)",
                                  "labelling (Alg. 2)",
                                  "segmentation + plane fit + labelling",
                                  "total (StereoFrameTimings)"};
    for (int k = 0; k < 9; ++k) {
      reg.get(std::string("pipeline.") + kStageKeys[k], "whole pipeline per frame", stage_labels[k],
              "ours", "wall time from the core's StereoFrameTimings");
    }
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const Frame& f = frames[k];
      ssm::StereoFrameResult res;
      std::string err;
      bool ok = false;
      const Sample s = measure([&] {
        ok = proc.processImages(f.left, f.right, cam, f.T_fixed_left, f.base, f.stamp, &res, &err);
      });
      points_of[k] = proc.points();
      if (!ok) {
        ++not_integrated;
        progress("frame %zu not integrated: %s", f.index, err.c_str());
        continue;
      }
      if (static_cast<int>(k) < opt.warmup) continue;
      const std::size_t m = k - static_cast<std::size_t>(opt.warmup);
      disparity_of[m] = proc.disparity().clone();
      s_total.add(s);
      const ssm::StereoFrameTimings& t = res.timings;
      const ssm::StageTimings& st = t.mapper;
      const double values[9] = {
          t.disparity_ms,     t.reproject_ms,
          st.integrate_ms,    st.height_map_ms,
          st.segmentation_ms, st.plane_fit_ms,
          st.labelling_ms,    st.segmentation_ms + st.plane_fit_ms + st.labelling_ms,
          t.total_ms};
      for (int i = 0; i < 9; ++i)
        reg.get(std::string("pipeline.") + kStageKeys[i], "", "", "").addWall(values[i]);
      extra["points_sum"] += static_cast<double>(res.points);
      extra["points_frames"] += 1.0;
      studyMap(proc.mapper(), f.base, 3 * opt.passes, reg, &pipeline_map);
    }
  }
  if (extra["points_frames"] > 0.0) {
    extra["points_per_frame_mean"] = extra["points_sum"] / extra["points_frames"];
  } else {
    problems.push_back("no measured frame was integrated by the pipeline");
  }

  // ---- 1b. a dense map: the same frames through OpenCV SGBM without any filter --------------
  // On this poorly textured dataset BM + filters keeps ~5 % of the pixels, too few for the map
  // to grow ground segments within a benchmark's frames, so the map stages would be timed on a
  // nearly empty map. The dense points (~70 % of the pixels) fill it: an upper bound for the
  // segmentation, plane fit and labelling, and for the voxel update (section 4).
  std::vector<std::vector<Eigen::Vector3f>> dense_points_of(frames.size());
  {
    progress("dense map (SGBM points): %zu frames", frames.size());
    ssm::DisparityPipelineConfig dense_cfg = pcfg.disparity;
    dense_cfg.matcher = ssm::StereoMatcherType::kSemiGlobal;
    dense_cfg.enable_uniqueness = false;
    const cv::Ptr<cv::StereoMatcher> matcher = rawMatcher(dense_cfg);
    cv::Mat raw16, disparity;
    for (std::size_t k = 0; k < frames.size(); ++k) {
      matcher->compute(frames[k].left, frames[k].right, raw16);
      raw16.convertTo(disparity, CV_32F, 1.0 / cv::StereoMatcher::DISP_SCALE);
      ssm::reprojectDisparity(disparity, cam, pcfg.mapper.grid.min_range,
                              pcfg.mapper.grid.max_range, 1, &dense_points_of[k]);
    }
    // --quick has too few frames for any voxel to reach occ_t = 100 (ten hits, 000 Sec. IV):
    // there the dense map uses the package's single-frame configuration (occ_t = incr_H) so that
    // the segment and plane-fit code still runs.
    const ssm::SafetyMapperConfig mcfg =
        opt.quick ? ssm::singleFrameMapperConfig(pcfg.mapper, 2.0) : pcfg.mapper;
    ssm::SafetyMapper mapper(mcfg);
    const std::string group = "mapper on the dense map (SGBM points, no filter)";
    const char* labels[] = {"voxel grid update (recenter + integrate)",
                            "height map",
                            "segmentation (Alg. 1)",
                            "plane fit (all segments)",
                            "labelling (Alg. 2)",
                            "segmentation + plane fit + labelling",
                            "integrateFrame total"};
    const char* keys[] = {"integrate", "height_map",    "segmentation", "plane_fit",
                          "labelling", "seg_fit_label", "total"};
    Series& s_frame = reg.get("mapper_dense.frame", group,
                              "SafetyMapper::integrateFrame (thread CPU, allocations)", "ours");
    for (int i = 0; i < 7; ++i) {
      reg.get(std::string("mapper_dense.") + keys[i], group, labels[i], "ours",
              "wall time from the core's StageTimings");
    }
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const Frame& f = frames[k];
      ssm::FrameResult r;
      bool ok = false;
      const Sample s = measure(
          [&] { ok = mapper.integrateFrame(dense_points_of[k], f.T_fixed_left, f.base, &r); });
      if (static_cast<int>(k) < opt.warmup || !ok) continue;
      s_frame.add(s);
      const ssm::StageTimings& t = r.timings;
      const double values[7] = {
          t.integrate_ms, t.height_map_ms, t.segmentation_ms,
          t.plane_fit_ms, t.labelling_ms,  t.segmentation_ms + t.plane_fit_ms + t.labelling_ms,
          t.total_ms};
      for (int i = 0; i < 7; ++i)
        reg.get(std::string("mapper_dense.") + keys[i], "", "", "").addWall(values[i]);
      studyMap(mapper, f.base, 3 * opt.passes, reg, &dense_map);
    }
    extra["dense_quick_single_frame_config"] = opt.quick ? 1.0 : 0.0;
  }
  for (MapStudy* st : {&pipeline_map, &dense_map}) {
    comparisons.push_back({"planefit" + st->suffix + ".ours_segment",
                           "planefit" + st->suffix + ".pcl_sac",
                           "plane fit of the largest segment (" + st->what + ")"});
    comparisons.push_back({"planefit" + st->suffix + ".ours_points",
                           "planefit" + st->suffix + ".pcl_sac",
                           "same, points already gathered (" + st->what + ")"});
  }

  // ---- 2. disparity: ours vs OpenCV alone vs stereo_image_proc ----------------------------------
  std::map<std::string, std::vector<double>> density;
  std::vector<std::pair<std::string, Sample>> disparity_allocs;
  {
    progress("disparity: %zu frames x %d passes", measured.size(), opt.passes);
    ssm::DisparityPipelineConfig bm_cfg = pcfg.disparity;  // package defaults: BM + all filters
    ssm::DisparityPipelineConfig bare_cfg = bm_cfg;
    bare_cfg.enable_texture = bare_cfg.enable_left_right = false;
    bare_cfg.enable_neighbour_consistency = bare_cfg.enable_spike_removal = false;
    ssm::DisparityPipelineConfig sgbm_cfg = bm_cfg;  // `matcher: sgbm`, every other default kept
    sgbm_cfg.matcher = ssm::StereoMatcherType::kSemiGlobal;

    struct Variant {
      std::string id, label, impl;
      std::function<void(const Frame&, cv::Mat*)> run;  // output: float disparity for density
    };
    std::vector<Variant> variants;
    auto ours = [&](const ssm::DisparityPipelineConfig& c) {
      auto p = std::make_shared<ssm::DisparityPipeline>(c);
      auto stats = std::make_shared<ssm::DisparityStats>();
      auto buf = std::make_shared<cv::Mat>();
      return std::function<void(const Frame&, cv::Mat*)>(
          [p, stats, buf](const Frame& f, cv::Mat* out) {
            std::string e;
            if (!p->compute(f.left, f.right, out != nullptr ? out : buf.get(), stats.get(), &e))
              throw std::runtime_error("DisparityPipeline: " + e);
          });
    };
    auto raw = [&](const ssm::DisparityPipelineConfig& c) {
      auto m = rawMatcher(c);
      auto buf = std::make_shared<cv::Mat>();
      return std::function<void(const Frame&, cv::Mat*)>([m, buf](const Frame& f, cv::Mat* out) {
        m->compute(f.left, f.right, *buf);
        if (out != nullptr) buf->convertTo(*out, CV_32F, 1.0 / cv::StereoMatcher::DISP_SCALE);
      });
    };
    // Pipeline objects kept outside the lambdas so that per-step stats can be read.
    ssm::DisparityPipeline ours_bm(bm_cfg);
    ssm::DisparityStats ours_bm_stats;
    cv::Mat ours_bm_out;
    variants.push_back({"disp.ours_bm", "ours: DisparityPipeline BM + all filters", "ours",
                        [&](const Frame& f, cv::Mat* out) {
                          std::string e;
                          if (!ours_bm.compute(f.left, f.right, out != nullptr ? out : &ours_bm_out,
                                               &ours_bm_stats, &e))
                            throw std::runtime_error("DisparityPipeline: " + e);
                        }});
    // The same with the right-to-left matcher on the pipeline's helper thread. The helper is
    // created at the first call and inherits this thread's core mask, so that call runs with
    // every core allowed: the measuring thread stays on its core, the helper may use another.
    // Thread CPU counts the measuring thread only: the wall time is the figure to read.
    ssm::DisparityPipelineConfig par_cfg = bm_cfg;
    par_cfg.parallel_left_right = true;
    ssm::DisparityPipeline ours_par(par_cfg);
    {
      cpu_set_t pinned_mask;
      CPU_ZERO(&pinned_mask);
      sched_getaffinity(0, sizeof(pinned_mask), &pinned_mask);
      sched_setaffinity(0, sizeof(start_mask), &start_mask);
      cv::Mat d;
      std::string e;
      ours_par.compute(measured.front().left, measured.front().right, &d, nullptr, &e);
      sched_setaffinity(0, sizeof(pinned_mask), &pinned_mask);
    }
    cv::Mat ours_par_out;
    variants.push_back({"disp.ours_bm_parallel",
                        "ours: BM + all filters, right-to-left matcher on a second thread "
                        "(parallel_left_right; CPU: measuring thread only)",
                        "ours", [&](const Frame& f, cv::Mat* out) {
                          std::string e;
                          if (!ours_par.compute(f.left, f.right,
                                                out != nullptr ? out : &ours_par_out, nullptr, &e))
                            throw std::runtime_error("DisparityPipeline: " + e);
                        }});
    variants.push_back({"disp.ours_bm_nofilters",
                        "ours: DisparityPipeline BM, filters off (matcher + float conversion)",
                        "ours", ours(bare_cfg)});
    variants.push_back(
        {"disp.opencv_bm", "OpenCV StereoBM::compute alone (same settings)", "peer", raw(bm_cfg)});
#if SSM_BENCH_HAVE_SIP
    std::string sip_why;
    const SipProcessDisparity sip_fn = loadSip(&sip_why);
    auto sip = [&](const ssm::DisparityPipelineConfig& c, bool own_filters) {
      auto p = std::make_shared<stereo_image_proc::StereoProcessor>();
      configureSip(p.get(), c, own_filters);
      auto model = std::make_shared<image_geometry::StereoCameraModel>();
      model->fromCameraInfo(ssm::toCameraInfo(ds::stereoCameraModel(head), false),
                            ssm::toCameraInfo(ds::stereoCameraModel(head), true));
      auto msg = std::make_shared<stereo_msgs::DisparityImage>();
      return std::function<void(const Frame&, cv::Mat*)>(
          [p, model, msg, sip_fn](const Frame& f, cv::Mat* out) {
            sip_fn(p.get(), f.left, f.right, *model, *msg);
            if (out != nullptr) {
              const sensor_msgs::Image& im = msg->image;
              cv::Mat(static_cast<int>(im.height), static_cast<int>(im.width), CV_32FC1,
                      const_cast<std::uint8_t*>(im.data.data()), im.step)
                  .copyTo(*out);
            }
          });
    };
    if (sip_fn != nullptr) {
      variants.push_back({"disp.sip_bm",
                          "stereo_image_proc StereoProcessor::processDisparity, BM, same settings",
                          "peer", sip(bm_cfg, false)});
      variants.push_back({"disp.sip_bm_own_filters",
                          "stereo_image_proc BM + its own filters (texture 10, speckle 100/4)",
                          "peer", sip(bm_cfg, true)});
    } else {
      pending.push_back("stereo_image_proc disparity peer: " + sip_why);
    }
#else
    const bool sip_fn = false;
    pending.push_back(
        "stereo_image_proc disparity peer: stereo_image_proc/processor.h not installed "
        "(Debian libstereo-image-proc-dev)");
#endif
    variants.push_back(
        {"disp.ours_sgbm", "ours: DisparityPipeline SGBM + all filters", "ours", ours(sgbm_cfg)});
    variants.push_back({"disp.opencv_sgbm", "OpenCV StereoSGBM::compute alone (same settings)",
                        "peer", raw(sgbm_cfg)});
#if SSM_BENCH_HAVE_SIP
    if (sip_fn != nullptr) {
      variants.push_back({"disp.sip_sgbm",
                          "stereo_image_proc processDisparity, SGBM, same settings", "peer",
                          sip(sgbm_cfg, false)});
    }
#endif
    for (const Variant& v : variants)
      reg.get(v.id, "disparity 640x480, 64 disparities, block 9", v.label, v.impl);
    cv::Mat out;
    for (const Variant& v : variants)
      v.run(measured.front(), &out);  // warm-up: matchers and buffers
    for (int pass = 0; pass < opt.passes; ++pass) {
      for (const Frame& f : measured) {
        for (const Variant& v : variants) {
          Series& s = reg.get(v.id, "", "", "");
          s.add(measure([&] { v.run(f, nullptr); }));
          if (v.id == "disp.ours_bm") {
            for (int st = 0; st < ssm::kNumDisparitySteps; ++st) {
              const ssm::DisparityStepStats& ss = ours_bm_stats.steps[st];
              if (!ss.ran) continue;
              const char* name = ssm::disparityStepName(static_cast<ssm::DisparityStep>(st));
              reg.get(std::string("disp.ours_bm.step.") + name, "disparity steps (ours, BM)",
                      std::string("step: ") + name, "ours", "wall time from DisparityStats")
                  .addWall(ss.ms);
            }
          }
        }
      }
    }
    for (const Variant& v : variants) {  // output density, outside the timing
      v.run(measured.front(), &out);
      density[v.id].push_back(validFraction(out));
    }
    // Where DisparityPipeline's per-frame allocations come from: the bare matcher, then each
    // post-filter alone on top of it (third call on the same frame, after two warm-ups).
    {
      auto allocsWith = [&](const std::function<void(ssm::DisparityPipelineConfig*)>& enable) {
        ssm::DisparityPipelineConfig c = bare_cfg;
        enable(&c);
        ssm::DisparityPipeline p(c);
        cv::Mat d;
        std::string e;
        p.compute(measured.front().left, measured.front().right, &d, nullptr, &e);
        p.compute(measured.front().left, measured.front().right, &d, nullptr, &e);
        return measure(
            [&] { p.compute(measured.front().left, measured.front().right, &d, nullptr, &e); });
      };
      const std::pair<const char*, std::function<void(ssm::DisparityPipelineConfig*)>> steps[] = {
          {"matcher only", [](ssm::DisparityPipelineConfig*) {}},
          {"+ texture", [](ssm::DisparityPipelineConfig* c) { c->enable_texture = true; }},
          {"+ left-right (2nd matcher)",
           [](ssm::DisparityPipelineConfig* c) { c->enable_left_right = true; }},
          {"+ neighbour consistency",
           [](ssm::DisparityPipelineConfig* c) { c->enable_neighbour_consistency = true; }},
          {"+ spike removal",
           [](ssm::DisparityPipelineConfig* c) { c->enable_spike_removal = true; }},
      };
      for (const auto& st : steps) {
        const Sample a = allocsWith(st.second);
        disparity_allocs.push_back({st.first, a});
      }
    }
    comparisons.push_back({"disp.ours_bm", "disp.opencv_bm", "disparity BM + filters"});
    comparisons.push_back({"disp.ours_bm_nofilters", "disp.opencv_bm", "disparity BM, no filters"});
    comparisons.push_back({"disp.ours_sgbm", "disp.opencv_sgbm", "disparity SGBM + filters"});
    if (sip_fn) {
      comparisons.push_back({"disp.ours_bm", "disp.sip_bm", "disparity BM + filters"});
      comparisons.push_back({"disp.ours_bm", "disp.sip_bm_own_filters", "disparity BM + filters"});
      comparisons.push_back({"disp.ours_bm_nofilters", "disp.sip_bm", "disparity BM, no filters"});
      comparisons.push_back({"disp.ours_sgbm", "disp.sip_sgbm", "disparity SGBM + filters"});
    }
  }
  pending.push_back(
      "stereo_image_proc through ROS (its disparity nodelet with message transport and "
      "cv_bridge), the ROS replay at 30 Hz (latency, drops) and the nodelet manager's memory: "
      "scripts/bench --ros");

  // ---- 3. reprojection: ours vs image_geometry (stereo_image_proc's point clouds) --------------
  {
    progress("reprojection");
    image_geometry::StereoCameraModel model;
    model.fromCameraInfo(ssm::toCameraInfo(ds::stereoCameraModel(head), false),
                         ssm::toCameraInfo(ds::stereoCameraModel(head), true));
    std::vector<Eigen::Vector3f> pts;
    cv::Mat xyz;
    Series& a = reg.get("reproject.ours", "reprojection 640x480",
                        "reprojectDisparity -> point list in [0.2, 8] m", "ours");
    Series& b = reg.get("reproject.image_geometry", "reprojection 640x480",
                        "image_geometry projectDisparityImageTo3d (organised)", "peer");
    for (const cv::Mat& d : disparity_of) {  // warm-up
      if (d.empty()) continue;
      ssm::reprojectDisparity(d, cam, pcfg.mapper.grid.min_range, pcfg.mapper.grid.max_range, 1,
                              &pts);
      model.projectDisparityImageTo3d(d, xyz, true);
      break;
    }
    for (int pass = 0; pass < opt.passes; ++pass) {
      for (const cv::Mat& d : disparity_of) {
        if (d.empty()) continue;
        a.add(measure([&] {
          ssm::reprojectDisparity(d, cam, pcfg.mapper.grid.min_range, pcfg.mapper.grid.max_range, 1,
                                  &pts);
        }));
        b.add(measure([&] { model.projectDisparityImageTo3d(d, xyz, true); }));
      }
    }
    comparisons.push_back({"reproject.ours", "reproject.image_geometry", "reprojection"});
  }

  // ---- 4. voxel grid update: ours vs OctoMap (same points, same origin, same range) ------------
  // Two inputs: the points the pipeline integrates (BM + filters: sparse on this poorly
  // textured dataset), and a dense frame (OpenCV SGBM without any filter, reprojected the same
  // way) as the upper bound of what one 640x480 stereo frame can hand the grid.
  {
    const ssm::VoxelGridConfig gcfg = pcfg.mapper.grid;
    {
      const std::uint64_t nb0 = alloc_count::new_bytes.load();
      ssm::VoxelGrid probe(gcfg);
      extra["voxel_grid_bytes"] = static_cast<double>(alloc_count::new_bytes.load() - nb0);
    }
    const std::size_t first = opt.warmup > 0 ? static_cast<std::size_t>(opt.warmup - 1) : 0;
    auto compare =
        [&](const std::string& prefix, const std::string& group, std::size_t count,
            const std::function<void(std::size_t, std::vector<Eigen::Vector3f>*)>& points_sensor) {
          ssm::VoxelGrid grid(gcfg);
          octomap::OcTree tree_plain(gcfg.voxel_size), tree_disc(gcfg.voxel_size);
          Series& s_ours = reg.get(prefix + ".ours", group,
                                   "VoxelGrid::integrate (l_v 0.1 m, max range 8 m)", "ours");
          Series& s_rec = reg.get(prefix + ".ours_recenter", group,
                                  "VoxelGrid::recenter (scrolling the window)", "ours");
          Series& s_oct =
              reg.get(prefix + ".octomap", group,
                      "octomap OcTree::insertPointCloud (0.1 m, max range 8 m)", "peer");
          Series& s_octd = reg.get(prefix + ".octomap_discretize", group,
                                   "octomap insertPointCloud, discretize = true", "peer");
          std::vector<Eigen::Vector3f> raw_pts, pts;
          octomap::Pointcloud cloud;
          std::vector<double> n_points, n_rays;
          const std::size_t last = std::min(frames.size(), first + count);
          for (std::size_t k = first; k < last; ++k) {
            const Frame& f = frames[k];
            points_sensor(k, &raw_pts);
            rangeFilter(raw_pts, gcfg.min_range, gcfg.max_range, &pts);
            cloud.clear();
            cloud.reserve(pts.size());
            for (const Eigen::Vector3f& p : pts) {
              const Eigen::Vector3f q = f.T_fixed_left * p;
              cloud.push_back(q.x(), q.y(), q.z());
            }
            const Eigen::Vector3f o = f.T_fixed_left.translation();
            const octomap::point3d origin(o.x(), o.y(), o.z());
            ssm::IntegrationStats st;
            const Sample r = measure([&] { grid.recenter(f.base); });
            const Sample a = measure([&] { st = grid.integrate(pts, f.T_fixed_left); });
            const Sample b =
                measure([&] { tree_plain.insertPointCloud(cloud, origin, gcfg.max_range); });
            const Sample c = measure(
                [&] { tree_disc.insertPointCloud(cloud, origin, gcfg.max_range, false, true); });
            if (k == first && opt.warmup > 0) continue;  // the first frame is the warm-up
            s_rec.add(r);
            s_ours.add(a);
            s_oct.add(b);
            s_octd.add(c);
            n_points.push_back(static_cast<double>(pts.size()));
            n_rays.push_back(static_cast<double>(st.points_used));
          }
          extra[prefix + "_points_median"] = statsOf(n_points).median;
          extra[prefix + "_rays_median"] = statsOf(n_rays).median;
          extra[prefix + "_octomap_bytes"] = static_cast<double>(tree_plain.memoryUsage());
          extra[prefix + "_octomap_discretize_bytes"] =
              static_cast<double>(tree_disc.memoryUsage());
          extra[prefix + "_octomap_nodes"] = static_cast<double>(tree_plain.size());
          comparisons.push_back({prefix + ".ours", prefix + ".octomap", group});
          comparisons.push_back({prefix + ".ours", prefix + ".octomap_discretize", group});
        };
    progress("voxel grid vs OctoMap, pipeline points: %d frames", opt.frames);
    compare("voxel", "voxel grid update, 640x480, pipeline points (BM + filters)", frames.size(),
            [&](std::size_t k, std::vector<Eigen::Vector3f>* out) { *out = points_of[k]; });
    const std::size_t dense_frames = opt.quick ? 2 : frames.size();
    progress("voxel grid vs OctoMap, dense SGBM points: %zu frames",
             std::min(dense_frames, frames.size() - first) - (opt.warmup > 0 ? 1 : 0));
    compare("voxel_dense", "voxel grid update, 640x480, dense points (SGBM, no filter)",
            dense_frames,
            [&](std::size_t k, std::vector<Eigen::Vector3f>* out) { *out = dense_points_of[k]; });
  }

  // ---- 5. scaling sweeps ----------------------------------------------------------------------
  std::vector<ScalingPoint> scaling;
  if (opt.scaling) {
    progress("scaling: image size");
    for (const SizedFrames& sz : sized) {
      ScalingPoint sp;
      sp.sweep = "image_size";
      sp.x = sz.width;
      sp.label = std::to_string(sz.width) + "x" + std::to_string(sz.height);
      ssm::StereoFrameProcessorConfig c = pcfg;
      // Same depth range at every size: the disparity search grows with the image width.
      c.disparity.num_disparities = std::max(16, 64 * sz.width / 640 / 16 * 16);
      sp.label += ", " + std::to_string(c.disparity.num_disparities) + " disp.";
      try {
        ssm::StereoFrameProcessor proc(c);
        const ssm::StereoCameraModel m = ds::stereoCameraModel(sz.head);
        std::map<std::string, std::vector<double>> w;
        std::vector<double> cpu, pts, mallocs;
        for (std::size_t k = 0; k < sz.frames.size(); ++k) {
          const Frame& f = sz.frames[k];
          ssm::StereoFrameResult res;
          std::string err;
          bool ok = false;
          const Sample s = measure([&] {
            ok =
                proc.processImages(f.left, f.right, m, f.T_fixed_left, f.base, f.stamp, &res, &err);
          });
          if (k == 0 || !ok) continue;  // first frame: warm-up
          const ssm::StageTimings& st = res.timings.mapper;
          w["disparity"].push_back(res.timings.disparity_ms);
          w["reproject"].push_back(res.timings.reproject_ms);
          w["integrate"].push_back(st.integrate_ms);
          w["seg_fit_label"].push_back(st.segmentation_ms + st.plane_fit_ms + st.labelling_ms);
          w["total"].push_back(res.timings.total_ms);
          cpu.push_back(s.cpu);
          pts.push_back(static_cast<double>(res.points));
          mallocs.push_back(s.mallocs);
        }
        for (auto& kv : w)
          sp.wall_median[kv.first] = statsOf(kv.second).median;
        sp.cpu_total_median = statsOf(cpu).median;
        sp.points_median = statsOf(pts).median;
        sp.mallocs_median = statsOf(mallocs).median;
        sp.frames = static_cast<int>(cpu.size());
      } catch (const std::exception& e) {
        sp.error = e.what();
        problems.push_back("image-size sweep " + sp.label + ": " + e.what());
      }
      scaling.push_back(sp);
    }

    // Map and voxel size: the mapper alone on the dense points of every rendered 640x480 frame
    // (the pipeline's sparse points leave the map without segments, see section 1b).
    auto mapperSweep = [&](const std::string& sweep, double x, const std::string& label,
                           const ssm::SafetyMapperConfig& c) {
      ScalingPoint sp;
      sp.sweep = sweep;
      sp.x = x;
      sp.label = label;
      try {
        ssm::SafetyMapper mapper(c);
        std::map<std::string, std::vector<double>> w;
        std::vector<double> cpu, mallocs;
        for (std::size_t k = 0; k < frames.size(); ++k) {
          ssm::FrameResult r;
          bool ok = false;
          const Sample s = measure([&] {
            ok = mapper.integrateFrame(dense_points_of[k], frames[k].T_fixed_left, frames[k].base,
                                       &r);
          });
          if (static_cast<int>(k) < opt.warmup || !ok) continue;
          w["integrate"].push_back(r.timings.integrate_ms);
          w["height_map"].push_back(r.timings.height_map_ms);
          w["segmentation"].push_back(r.timings.segmentation_ms);
          w["plane_fit"].push_back(r.timings.plane_fit_ms);
          w["labelling"].push_back(r.timings.labelling_ms);
          w["seg_fit_label"].push_back(r.timings.segmentation_ms + r.timings.plane_fit_ms +
                                       r.timings.labelling_ms);
          w["total"].push_back(r.timings.total_ms);
          cpu.push_back(s.cpu);
          mallocs.push_back(s.mallocs);
        }
        for (auto& kv : w)
          sp.wall_median[kv.first] = statsOf(kv.second).median;
        sp.cpu_total_median = statsOf(cpu).median;
        sp.mallocs_median = statsOf(mallocs).median;
        sp.frames = static_cast<int>(cpu.size());
      } catch (const std::exception& e) {
        sp.error = e.what();
        problems.push_back(sweep + " " + label + ": " + e.what());
      }
      scaling.push_back(sp);
    };
    progress("scaling: map size");
    for (double L : {5.0, 10.0, 20.0}) {
      ssm::SafetyMapperConfig c = pcfg.mapper;
      c.grid.size_x = c.grid.size_y = L;
      // The look-ahead must leave R_max behind the robot inside the window (safety_mapper.h).
      c.grid_look_ahead =
          std::min(c.grid_look_ahead, std::max(0.0, 0.5 * L - c.segmentation.planning_radius));
      mapperSweep("map_size", L, fmt(L, 0) + " x " + fmt(L, 0) + " x 3 m", c);
    }
    progress("scaling: voxel size");
    for (double lv : {0.05, 0.1, 0.2}) {
      ssm::SafetyMapperConfig c = pcfg.mapper;
      c.grid.voxel_size = lv;
      mapperSweep("voxel_size", lv, "l_v = " + fmt(lv, 2) + " m", c);
    }
  }

  // ---- targets ------------------------------------------------------------------------------
  auto med = [&](const std::string& id, bool cpu) {
    const Series* s = reg.find(id);
    if (s == nullptr) return std::numeric_limits<double>::quiet_NaN();
    return statsOf(cpu ? s->cpu : s->wall).median;
  };
  std::vector<Target> targets;
  {
    for (const char* prefix : {"voxel", "voxel_dense"}) {
      const std::string p = prefix;
      const std::string what =
          p == "voxel"
              ? "pipeline points, " + fmt(extra["voxel_points_median"], 0) + " points"
              : "dense SGBM points, " + fmt(extra["voxel_dense_points_median"], 0) + " points";
      Target t("voxel update, 640x480 frame (" + what + ")", "ms");
      t.wall = med(p + ".ours", false);
      t.cpu = med(p + ".ours", true);
      t.limit = 5.0;
      targets.push_back(t);
      for (const char* peer : {".octomap", ".octomap_discretize"}) {
        Target r(std::string("voxel update speed-up over ") +
                     (std::string(peer) == ".octomap" ? "insertPointCloud"
                                                      : "insertPointCloud(discretize)") +
                     " (" + (p == "voxel" ? "pipeline" : "dense") + " points)",
                 "x");
        r.wall = med(p + peer, false) / t.wall;
        r.cpu = med(p + peer, true) / t.cpu;
        r.limit = 10.0;
        r.at_most = false;
        targets.push_back(r);
      }
    }
    for (const MapStudy* st : {&pipeline_map, &dense_map}) {
      Target t("segmentation + plane fit + labelling, R_max = 4 m (" + st->what + ", " +
                   fmt(statsOf(st->segments).median, 0) + " segments)",
               "ms");
      t.wall = med("map" + st->suffix + ".seg_fit_label", false);
      t.cpu = med("map" + st->suffix + ".seg_fit_label", true);
      t.limit = 5.0;
      targets.push_back(t);
    }
    Target d("disparity + filters, BM, 640x480, 64 disparities", "ms");
    d.wall = med("disp.ours_bm", false);
    d.cpu = med("disp.ours_bm", true);
    d.limit = 33.0;
    targets.push_back(d);
    // Issue 18: the stage with every post-filter against the bare OpenCV matcher, same frames,
    // same run (interleaved frame by frame).
    for (const auto& m : {std::make_pair("BM", "bm"), std::make_pair("SGBM", "sgbm")}) {
      const std::string ours = std::string("disp.ours_") + m.second;
      const std::string peer = std::string("disp.opencv_") + m.second;
      Target r(std::string("disparity ") + m.first + " + all filters / OpenCV Stereo" + m.first +
                   " alone (same frames, same run)",
               "x");
      r.wall = med(ours, false) / med(peer, false);
      r.cpu = med(ours, true) / med(peer, true);
      r.limit = 1.3;
      r.limit_digits = 1;
      targets.push_back(r);
    }
  }

  // ---- output: Markdown ---------------------------------------------------------------------
  const std::string load_end = readFirstLine("/proc/loadavg");
  const double run_s = (wallMs() - t_start) / 1e3;
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  const double proc_cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                            1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);

  std::printf("# bench_pipeline%s\n\n",
              opt.quick ? " (--quick smoke: too few frames to quote)" : "");
  std::printf(
      "Input: %s, %zu measured + %d warm-up frames at 640x480 (moving frames %zu..%zu of %zu, "
      "stride %d), %.0f points/frame after reprojection (dense SGBM input: %.0f points, %.0f rays "
      "cast after one-point-per-voxel). Machine: %s, %ld cores, load average "
      "%s at start, %s at end; measuring thread %s; cv::setNumThreads(1). Run %.0f s.\n\n",
      sf.scene.name.c_str(), measured.size(), opt.warmup, chosen.front(), chosen.back(),
      poses.size(), opt.stride, extra["points_per_frame_mean"], extra["voxel_dense_points_median"],
      extra["voxel_dense_rays_median"], cpuModel().c_str(), sysconf(_SC_NPROCESSORS_ONLN),
      load_start.c_str(), load_end.c_str(),
      pinned_cpu >= 0 ? ("pinned to core " + std::to_string(pinned_cpu)).c_str() : "not pinned",
      run_s);

  std::printf("## Stages\n\n");
  std::printf(
      "| stage | impl | n | wall min | wall median | wall max | CPU median | allocs/call (median) "
      "|\n|---|---|---|---|---|---|---|---|\n");
  std::string last_group;
  for (const Series& s : reg.all()) {
    if (s.group != last_group) {
      std::printf("| **%s** | | | | | | | |\n", s.group.c_str());
      last_group = s.group;
    }
    const Stats w = statsOf(s.wall), c = statsOf(s.cpu), a = statsOf(s.mallocs),
                n = statsOf(s.news);
    std::string allocs = "—";
    if (a.n > 0) {
      allocs = SSM_BENCH_COUNT_MALLOC ? fmt(a.median, 0) + " (new " + fmt(n.median, 0) + ")"
                                      : "new " + fmt(n.median, 0);
    }
    std::printf("| %s | %s | %d | %s | %s | %s | %s | %s |\n", s.label.c_str(), s.impl.c_str(), w.n,
                fmt(w.min).c_str(), fmt(w.median).c_str(), fmt(w.max).c_str(),
                fmt(c.median).c_str(), allocs.c_str());
  }
  std::printf(
      "\nTimes in ms. allocs = malloc-family calls (OpenCV buffers included), new = C++ "
      "operator new calls.\n\n");

  std::printf("## Ours vs peers (same run, identical input)\n\n");
  std::printf(
      "| comparison | ours | peer | ours median | peer median | peer / ours (wall) | peer / ours "
      "(CPU) |\n|---|---|---|---|---|---|---|\n");
  for (const Comparison& c : comparisons) {
    const Series* a = reg.find(c.ours);
    const Series* b = reg.find(c.peer);
    if (a == nullptr || b == nullptr) continue;
    std::printf("| %s | %s | %s | %s | %s | %s | %s |\n", c.what.c_str(), a->label.c_str(),
                b->label.c_str(), fmt(med(c.ours, false)).c_str(), fmt(med(c.peer, false)).c_str(),
                fmt(med(c.peer, false) / med(c.ours, false)).c_str(),
                fmt(med(c.peer, true) / med(c.ours, true)).c_str());
  }
  std::printf("\npeer / ours > 1: ours is faster by that factor.\n\n");

  std::printf("## Targets (medians, one core; reported, not asserted)\n\n");
  std::printf(
      "| target | wall | CPU | limit | met (wall) | met (CPU) |\n|---|---|---|---|---|---|\n");
  for (const Target& t : targets) {
    const char* op = t.at_most ? "<=" : ">=";
    std::printf("| %s | %s %s | %s %s | %s %s %s | %s | %s |\n", t.name.c_str(),
                fmt(t.wall).c_str(), t.unit.c_str(), fmt(t.cpu).c_str(), t.unit.c_str(), op,
                fmt(t.limit, t.limit_digits).c_str(), t.unit.c_str(),
                t.metBy(t.wall) ? "yes" : "NO",
                std::isfinite(t.cpu) ? (t.metBy(t.cpu) ? "yes" : "NO") : "—");
  }
  std::printf(
      "\nSGBM (package defaults, block 9, MODE_SGBM) + all filters, 640x480: median %s ms "
      "wall, %s ms CPU.\n",
      fmt(med("disp.ours_sgbm", false)).c_str(), fmt(med("disp.ours_sgbm", true)).c_str());
  std::printf("Disparity density (valid pixels, frame 1):");
  for (const auto& kv : density)
    std::printf(" %s %.1f %%;", kv.first.c_str(), 100.0 * kv.second.front());
  std::printf("\n");
  for (const MapStudy* st : {&pipeline_map, &dense_map}) {
    std::printf(
        "Map state (%s) over the measured frames: %s columns with a height (median), %s "
        "segments (median, max %s), robot's seed found in %s %% of the frames. Largest "
        "segment: %s points (median); our plane normal and PCL's differ by %s deg "
        "(median, max %s); PCL inliers %s %% (median).\n",
        st->what.c_str(), fmt(statsOf(st->columns).median, 0).c_str(),
        fmt(statsOf(st->segments).median, 0).c_str(), fmt(statsOf(st->segments).max, 0).c_str(),
        fmt(100.0 * fractionOf(st->seed), 0).c_str(),
        fmt(statsOf(st->fit_points).median, 0).c_str(), fmt(statsOf(st->fit_angle).median).c_str(),
        fmt(statsOf(st->fit_angle).max).c_str(),
        fmt(100.0 * statsOf(st->inlier_fraction).median, 1).c_str());
  }
  if (opt.quick) {
    std::printf("(--quick: the dense map uses singleFrameMapperConfig, occ_t = incr_H.)\n");
  }
  std::printf("PCL SACSegmentation: default max iterations (50), optimise coefficients on.\n\n");

  if (!scaling.empty()) {
    std::printf("## Scaling (median wall ms per frame; CPU = thread CPU of the whole call)\n\n");
    for (const char* sweep : {"image_size", "map_size", "voxel_size"}) {
      const bool img = std::string(sweep) == "image_size";
      std::printf(
          "%s\n\n",
          img ? "Image size (whole pipeline, BM + filters):"
              : (std::string(sweep) == "map_size"
                     ? "Map size (mapper only, dense 640x480 SGBM points, l_v 0.1 m):"
                     : "Voxel size (mapper only, dense 640x480 SGBM points, 10 x 10 x 3 m):"));
      if (img) {
        std::printf(
            "| size | frames | points | disparity | reproject | integrate | seg+fit+label "
            "| total | CPU total | allocs |\n|---|---|---|---|---|---|---|---|---|---|\n");
      } else {
        std::printf(
            "| config | frames | integrate | height map | segmentation | plane fit | "
            "labelling | total | CPU total | allocs |\n"
            "|---|---|---|---|---|---|---|---|---|---|\n");
      }
      for (const ScalingPoint& sp : scaling) {
        if (sp.sweep != sweep) continue;
        auto g = [&](const char* k) {
          auto it = sp.wall_median.find(k);
          return fmt(it == sp.wall_median.end() ? std::numeric_limits<double>::quiet_NaN()
                                                : it->second);
        };
        if (!sp.error.empty()) {
          std::printf("| %s | error: %s |\n", sp.label.c_str(), sp.error.c_str());
        } else if (img) {
          std::printf("| %s | %d | %s | %s | %s | %s | %s | %s | %s | %s |\n", sp.label.c_str(),
                      sp.frames, fmt(sp.points_median, 0).c_str(), g("disparity").c_str(),
                      g("reproject").c_str(), g("integrate").c_str(), g("seg_fit_label").c_str(),
                      g("total").c_str(), fmt(sp.cpu_total_median).c_str(),
                      fmt(sp.mallocs_median, 0).c_str());
        } else {
          std::printf("| %s | %d | %s | %s | %s | %s | %s | %s | %s | %s |\n", sp.label.c_str(),
                      sp.frames, g("integrate").c_str(), g("height_map").c_str(),
                      g("segmentation").c_str(), g("plane_fit").c_str(), g("labelling").c_str(),
                      g("total").c_str(), fmt(sp.cpu_total_median).c_str(),
                      fmt(sp.mallocs_median, 0).c_str());
        }
      }
      std::printf("\n");
    }
  }

  const double rss_end = rssMb(), rss_peak = peakRssMb();
  std::printf("## Memory\n\n");
  std::printf("| quantity | value |\n|---|---|\n");
  auto allocLine = [&](const char* what, const char* id) {
    const Series* s = reg.find(id);
    if (s == nullptr || s->news.empty()) return;
    const Stats a = statsOf(s->mallocs), n = statsOf(s->news);
    if (SSM_BENCH_COUNT_MALLOC) {
      std::printf(
          "| allocations per call, %s | median %s, max %s (operator new: median %s, max "
          "%s) |\n",
          what, fmt(a.median, 0).c_str(), fmt(a.max, 0).c_str(), fmt(n.median, 0).c_str(),
          fmt(n.max, 0).c_str());
    } else {
      std::printf("| operator new calls per call, %s | median %s, max %s |\n", what,
                  fmt(n.median, 0).c_str(), fmt(n.max, 0).c_str());
    }
  };
  allocLine("VoxelGrid::integrate (pipeline points)", "voxel.ours");
  allocLine("VoxelGrid::integrate (dense points)", "voxel_dense.ours");
  allocLine("VoxelGrid::recenter", "voxel.ours_recenter");
  allocLine("DisparityPipeline::compute (BM + filters)", "disp.ours_bm");
  if (!disparity_allocs.empty()) {
    std::printf("| DisparityPipeline allocations per call by configuration (malloc / new) |");
    for (const auto& da : disparity_allocs)
      std::printf(" %s: %s / %s;", da.first.c_str(), fmt(da.second.mallocs, 0).c_str(),
                  fmt(da.second.news, 0).c_str());
    std::printf(" |\n");
  }
  allocLine("segmentation + plane fit + labelling (pipeline map)", "map.seg_fit_label");
  allocLine("segmentation + plane fit + labelling (dense map)", "map_dense.seg_fit_label");
  allocLine("SafetyMapper::integrateFrame (dense map)", "mapper_dense.frame");
  allocLine("whole frame (processImages)", "pipeline.frame");
  allocLine("OcTree::insertPointCloud", "voxel.octomap");
  std::printf("| VoxelGrid storage (10 x 10 x 3 m, 0.1 m, 8 points/voxel), allocated | %s MB |\n",
              fmt(extra["voxel_grid_bytes"] / 1048576.0, 1).c_str());
  for (const char* prefix : {"voxel", "voxel_dense"}) {
    const std::string p = prefix;
    std::printf(
        "| OcTree memoryUsage() after the %s run (plain / discretize) | %s / %s MB, %.0f "
        "nodes |\n",
        p == "voxel" ? "pipeline-points" : "dense-points",
        fmt(extra[p + "_octomap_bytes"] / 1048576.0, 1).c_str(),
        fmt(extra[p + "_octomap_discretize_bytes"] / 1048576.0, 1).c_str(),
        extra[p + "_octomap_nodes"]);
  }
  std::printf("| process RSS at start / end / peak | %s / %s / %s MB |\n",
              fmt(rss_start, 0).c_str(), fmt(rss_end, 0).c_str(), fmt(rss_peak, 0).c_str());
  std::printf("\n");

  pending.push_back(
      "30-minute memory run (RSS over time): scripts/soak (long looped replays through "
      "bag_replay.launch, the manager's memory sampled)");
  std::printf("## Not measured in this run\n\n");
  for (const std::string& p : pending)
    std::printf("- %s\n", p.c_str());
  if (not_integrated > 0)
    std::printf("- %d frame(s) were not integrated (see stderr)\n", not_integrated);
  std::printf("\n");

  // ---- output: JSON -------------------------------------------------------------------------
  if (!opt.json.empty()) {
    Json j;
    j.beginObject();
    std::string cmdline;
    for (int i = 0; i < argc; ++i)
      cmdline += (i ? " " : "") + std::string(argv[i]);
    j.str("tool", "bench_pipeline").integer("schema", 1).boolean("quick", opt.quick);
    j.str("command", cmdline);
    j.beginObject("machine")
        .str("cpu_model", cpuModel())
        .integer("cores_online", sysconf(_SC_NPROCESSORS_ONLN))
        .str("loadavg_start", load_start)
        .str("loadavg_end", load_end)
        .integer("pinned_cpu", pinned_cpu)
        .integer("cv_threads", cv::getNumThreads())
        .str("opencv", CV_VERSION)
        .str("compiler", __VERSION__)
#ifdef NDEBUG
        .boolean("ndebug", true)
#else
        .boolean("ndebug", false)
#endif
        .boolean("malloc_counted", SSM_BENCH_COUNT_MALLOC != 0)
        .str("time", isoTime());
    {
      utsname u{};
      if (uname(&u) == 0) j.str("kernel", std::string(u.sysname) + " " + u.release);
    }
    j.num("run_s", run_s).num("render_s", render_s).num("process_cpu_s", proc_cpu_s);
    j.endObject();
    j.beginObject("input")
        .str("scene", sf.scene.name)
        .str("scene_file", opt.scene)
        .integer("width", head.width)
        .integer("height", head.height)
        .integer("measured_frames", static_cast<long long>(measured.size()))
        .integer("warmup_frames", opt.warmup)
        .integer("stride", opt.stride)
        .integer("passes", opt.passes)
        .num("points_per_frame_mean", extra["points_per_frame_mean"])
        .num("voxel_points_median", extra["voxel_points_median"])
        .num("voxel_rays_median", extra["voxel_rays_median"])
        .num("voxel_dense_points_median", extra["voxel_dense_points_median"])
        .num("voxel_dense_rays_median", extra["voxel_dense_rays_median"])
        .integer("frames_not_integrated", not_integrated);
    j.beginArray("frame_indices");
    for (const Frame& f : frames)
      j.num(static_cast<double>(f.index));
    j.endArray().endObject();
    j.beginArray("stages");
    for (const Series& s : reg.all()) {
      j.beginObject()
          .str("id", s.id)
          .str("group", s.group)
          .str("label", s.label)
          .str("impl", s.impl);
      if (!s.note.empty()) j.str("note", s.note);
      writeStats(j, "wall_ms", statsOf(s.wall));
      writeStats(j, "cpu_ms", statsOf(s.cpu));
      writeStats(j, "new_per_call", statsOf(s.news));
      if (SSM_BENCH_COUNT_MALLOC) {
        writeStats(j, "allocs_per_call", statsOf(s.mallocs));
      } else {
        j.null("allocs_per_call");
      }
      j.endObject();
    }
    j.endArray();
    j.beginArray("comparisons");
    for (const Comparison& c : comparisons) {
      if (reg.find(c.ours) == nullptr || reg.find(c.peer) == nullptr) continue;
      j.beginObject()
          .str("what", c.what)
          .str("ours", c.ours)
          .str("peer", c.peer)
          .num("ours_median_ms", med(c.ours, false))
          .num("peer_median_ms", med(c.peer, false))
          .num("peer_over_ours_wall", med(c.peer, false) / med(c.ours, false))
          .num("peer_over_ours_cpu", med(c.peer, true) / med(c.ours, true))
          .endObject();
    }
    j.endArray();
    j.beginArray("targets");
    for (const Target& t : targets) {
      j.beginObject()
          .str("name", t.name)
          .str("unit", t.unit)
          .num("wall", t.wall)
          .num("cpu", t.cpu)
          .str("op", t.at_most ? "<=" : ">=")
          .num("limit", t.limit)
          .boolean("met_wall", t.metBy(t.wall));
      if (std::isfinite(t.cpu)) {
        j.boolean("met_cpu", t.metBy(t.cpu));
      } else {
        j.null("met_cpu");
      }
      if (!t.note.empty()) j.str("note", t.note);
      j.endObject();
    }
    j.endArray();
    j.beginObject("sgbm").num("wall_median_ms", med("disp.ours_sgbm", false));
    j.num("cpu_median_ms", med("disp.ours_sgbm", true)).endObject();
    j.beginObject("disparity_density");
    for (const auto& kv : density)
      j.num(kv.first.c_str(), kv.second.front());
    j.endObject();
    j.beginArray("maps");
    for (const MapStudy* st : {&pipeline_map, &dense_map}) {
      j.beginObject()
          .str("map", st->what)
          .str("suffix", st->suffix)
          .num("columns_with_height_median", statsOf(st->columns).median)
          .num("segments_median", statsOf(st->segments).median)
          .num("segments_max", statsOf(st->segments).max)
          .num("robot_seed_found_fraction", fractionOf(st->seed))
          .num("largest_segment_points_median", statsOf(st->fit_points).median)
          .num("normal_angle_vs_pcl_deg_median", statsOf(st->fit_angle).median)
          .num("normal_angle_vs_pcl_deg_max", statsOf(st->fit_angle).max)
          .num("pcl_inlier_fraction_median", statsOf(st->inlier_fraction).median)
          .endObject();
    }
    j.endArray();
    j.boolean("dense_map_single_frame_config", opt.quick);
    j.beginArray("scaling");
    for (const ScalingPoint& sp : scaling) {
      j.beginObject()
          .str("sweep", sp.sweep)
          .num("x", sp.x)
          .str("label", sp.label)
          .integer("frames", sp.frames);
      if (!sp.error.empty()) j.str("error", sp.error);
      j.beginObject("wall_median_ms");
      for (const auto& kv : sp.wall_median)
        j.num(kv.first.c_str(), kv.second);
      j.endObject();
      j.num("cpu_total_median_ms", sp.cpu_total_median)
          .num("points_median", sp.points_median)
          .num("allocs_median", sp.mallocs_median)
          .endObject();
    }
    j.endArray();
    j.beginObject("memory")
        .num("rss_start_mb", rss_start)
        .num("rss_end_mb", rss_end)
        .num("rss_peak_mb", rss_peak)
        .num("voxel_grid_bytes", extra["voxel_grid_bytes"])
        .num("octomap_bytes", extra["voxel_octomap_bytes"])
        .num("octomap_discretize_bytes", extra["voxel_octomap_discretize_bytes"])
        .num("octomap_nodes", extra["voxel_octomap_nodes"])
        .num("dense_octomap_bytes", extra["voxel_dense_octomap_bytes"])
        .num("dense_octomap_discretize_bytes", extra["voxel_dense_octomap_discretize_bytes"])
        .num("dense_octomap_nodes", extra["voxel_dense_octomap_nodes"])
        .endObject();
    j.beginArray("disparity_allocs_by_config");
    for (const auto& da : disparity_allocs) {
      j.beginObject()
          .str("config", da.first)
          .num("allocs", SSM_BENCH_COUNT_MALLOC ? da.second.mallocs
                                                : std::numeric_limits<double>::quiet_NaN())
          .num("new", da.second.news)
          .endObject();
    }
    j.endArray();
    j.beginArray("pending");
    for (const std::string& p : pending)
      j.str(p);
    j.endArray();
    j.beginArray("problems");
    for (const std::string& p : problems)
      j.str(p);
    j.endArray();
    j.endObject();
    std::ofstream out(opt.json);
    out << j.text();
    if (!out) {
      std::fprintf(stderr, "bench_pipeline: cannot write %s\n", opt.json.c_str());
      return 1;
    }
    progress("wrote %s", opt.json.c_str());
  }

  // Smoke checks: the benchmark ran the pipeline for real.
  if (extra["voxel_points_median"] <= 0.0) problems.push_back("no points reached the voxel grid");
  if (reg.find("disp.ours_bm") == nullptr || reg.find("disp.ours_bm")->wall.empty())
    problems.push_back("disparity was not measured");
  for (const std::string& p : problems)
    std::fprintf(stderr, "bench_pipeline: PROBLEM: %s\n", p.c_str());
  progress("done in %.1f s", run_s);
  return problems.empty() ? 0 : 1;
}
