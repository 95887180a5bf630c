#include "bench_support.h"

#include <dlfcn.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <numeric>

namespace bench {

double wallMs() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

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

double medianOf(const Registry& reg, const std::string& id, bool cpu) {
  const Series* s = reg.find(id);
  if (s == nullptr) return std::numeric_limits<double>::quiet_NaN();
  return statsOf(cpu ? s->cpu : s->wall).median;
}

void writeStats(Json& j, const char* key, const Stats& s) {
  if (s.n == 0) {
    j.key(key).null();
    return;
  }
  j.key(key).open('{').kv("n", s.n).kv("min", s.min).kv("median", s.median).kv("max", s.max);
  j.close('}');
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

void progress(const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  std::fprintf(stderr, "[bench_pipeline] ");
  std::vfprintf(stderr, fmt, ap);
  std::fprintf(stderr, "\n");
  va_end(ap);
}

#if SSM_BENCH_HAVE_SIP
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

std::string fmt(double v, int prec) {
  if (!std::isfinite(v)) return "—";
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.*f", prec, v);
  return buf;
}

double fractionOf(const std::vector<double>& flags) {
  if (flags.empty()) return std::numeric_limits<double>::quiet_NaN();
  return std::accumulate(flags.begin(), flags.end(), 0.0) / static_cast<double>(flags.size());
}

}  // namespace bench
