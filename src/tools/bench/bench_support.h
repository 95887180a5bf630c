// bench_pipeline's support (src/tools/bench/): the allocation counters (alloc_count.cpp), clocks
// and the measuring of one call, the registry of timed series, machine facts, the peers' set-up
// that several studies share (OpenCV's matcher alone, stereo_image_proc's processDisparity), and
// small output helpers. The JSON writer is the tools' one (stereo_safety_map/tools/json.h).
// Only bench_pipeline is built from these files (CMakeLists.txt).
#pragma once

#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/tools/json.h"

#include <image_geometry/stereo_camera_model.h>
#include <stereo_msgs/DisparityImage.h>
#if __has_include(<stereo_image_proc/processor.h>)
#include <stereo_image_proc/processor.h>
#define SSM_BENCH_HAVE_SIP 1
#else
#define SSM_BENCH_HAVE_SIP 0
#endif

#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <atomic>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <string>
#include <vector>

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define SSM_BENCH_SANITIZED 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define SSM_BENCH_SANITIZED 1
#endif

// Interposing malloc: glibc only, and not under sanitizers (they intercept malloc themselves), so
// their builds count operator new only (alloc_count.cpp).
#if defined(__GLIBC__) && !defined(SSM_BENCH_SANITIZED)
#define SSM_BENCH_COUNT_MALLOC 1
#else
#define SSM_BENCH_COUNT_MALLOC 0
#endif

// Allocation counters (alloc_count.cpp). Constant-initialised, so they are valid before any
// static constructor.
namespace alloc_count {
extern std::atomic<std::uint64_t> news;       // global operator new calls (C++ allocations)
extern std::atomic<std::uint64_t> new_bytes;  // bytes asked of operator new
extern std::atomic<std::uint64_t> mallocs;    // malloc-family calls (everything, C and C++)
}  // namespace alloc_count

namespace bench {

namespace ssm = stereo_safety_map;
using stereo_safety_map::tools::Json;

// ---------------------------------------------------------------------------------------------
// Clocks, samples, series.

double wallMs();
// CPU time of the calling thread: not inflated when other processes take the core.
double threadCpuMs();

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

Stats statsOf(std::vector<double> v);

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

/// Median wall (or thread CPU) time of the series `id` [ms]; NaN when there is none.
double medianOf(const Registry& reg, const std::string& id, bool cpu);

/// `key`: {n, min, median, max}, or null when there is no sample.
void writeStats(Json& j, const char* key, const Stats& s);

// ---------------------------------------------------------------------------------------------
// Machine facts and progress.

std::string readFirstLine(const char* path);
std::string cpuModel();
double rssMb();
double peakRssMb();
std::string isoTime();
/// A line on stderr, prefixed with [bench_pipeline].
void progress(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

// ---------------------------------------------------------------------------------------------
// Peers and measures shared by the studies.

#if SSM_BENCH_HAVE_SIP
// Peer: stereo_image_proc's StereoProcessor::processDisparity (what its disparity nodelet calls
// per frame after cv_bridge's zero-copy view of the mono8 images). The package's CMake does not
// link libstereo_image_proc, so the function is looked up in Debian's shared library at run time;
// a non-virtual const member function is called with `this` as its first argument (Itanium C++
// ABI), which is what the function pointer below does.
using SipProcessDisparity = void (*)(const stereo_image_proc::StereoProcessor*, const cv::Mat&,
                                     const cv::Mat&, const image_geometry::StereoCameraModel&,
                                     stereo_msgs::DisparityImage&);
SipProcessDisparity loadSip(std::string* why);
// Same matcher settings as DisparityPipeline::createMatcher for `c`.
void configureSip(stereo_image_proc::StereoProcessor* p, const ssm::DisparityPipelineConfig& c,
                  bool own_filters);
#endif

double validFraction(const cv::Mat& disparity_float);

// Points whose distance to the camera is within [min_range, max_range]: what VoxelGrid uses, so
// that OctoMap gets exactly the points our grid integrates.
void rangeFilter(const std::vector<Eigen::Vector3f>& in, double min_range, double max_range,
                 std::vector<Eigen::Vector3f>* out);

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

// ---------------------------------------------------------------------------------------------
// Output helpers.

/// `v` with `prec` decimals, an em dash when not finite.
std::string fmt(double v, int prec = 2);
/// Mean of 0 / 1 flags; NaN when empty.
double fractionOf(const std::vector<double>& flags);

}  // namespace bench
