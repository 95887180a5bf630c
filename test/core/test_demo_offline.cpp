// The demo script's offline path on a tiny dataset: scripts/demo --offline --small --no-build
// renders a 320x240, 40-frame version of a scene with make_dataset, evaluates it with
// evaluate_safety_map (bag read directly, no roscore) and must leave report.md, metrics.json, the
// per-frame CSV and the PNGs in its output folder and print where they are.
//
// The binaries are those of the workspace this test was built in: catkin puts the tools and the
// gtests side by side (devel/lib/stereo_safety_map/). A standalone build of this file has no
// tools next to it and skips.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace {

#ifndef SSM_SOURCE_DIR
#define SSM_SOURCE_DIR "."
#endif

bool exists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}

std::string selfDir() {
  char buf[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return "";
  buf[n] = '\0';
  const std::string p(buf);
  return p.substr(0, p.find_last_of('/'));
}

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

TEST(DemoOffline, TinyDatasetGivesReportMetricsAndPictures) {
  const std::string bin = selfDir();
  if (!exists(bin + "/evaluate_safety_map") || !exists(bin + "/make_dataset"))
    GTEST_SKIP() << "evaluate_safety_map / make_dataset not built next to this test";
  const std::string root = SSM_SOURCE_DIR;
  ASSERT_TRUE(exists(root + "/scripts/demo"));
  char tmpl[] = "/tmp/ssm_demo_test_XXXXXX";
  ASSERT_NE(mkdtemp(tmpl), nullptr);
  const std::string tmp = tmpl;
  const std::string out = tmp + "/out";

  // The cache is private to the test so that it always renders (and never touches .cache/).
  const std::string cmd = "SSM_BIN_DIR='" + bin + "' SSM_CACHE='" + tmp + "/cache' '" + root +
                          "/scripts/demo' --offline --small --no-build --out '" + out + "' > '" +
                          tmp + "/demo.log' 2>&1";
  const int rc = std::system(cmd.c_str());
  const std::string log = slurp(tmp + "/demo.log");
  ASSERT_EQ(rc, 0) << log;

  EXPECT_TRUE(exists(tmp + "/cache/datasets_small/dataset3_two_ramps.bag")) << log;
  EXPECT_TRUE(exists(tmp + "/cache/datasets_small/dataset3_two_ramps_gt/gt_labels.pgm"));
  EXPECT_TRUE(exists(out + "/report.md")) << log;
  EXPECT_TRUE(exists(out + "/frames/dataset3_two_ramps_decr1.csv"));
  EXPECT_TRUE(exists(out + "/model_3d.png"));
  const std::string metrics = slurp(out + "/metrics.json");
  ASSERT_FALSE(metrics.empty()) << log;
  EXPECT_NE(metrics.find("\"tool\": \"evaluate_safety_map\""), std::string::npos);
  EXPECT_NE(metrics.find("\"name\": \"dataset3_two_ramps\""), std::string::npos);
  EXPECT_NE(metrics.find("\"fn\": {\"mean\": "), std::string::npos);
  // Every pair of the tiny bag was read and most gave a map (the rest are stationary).
  EXPECT_NE(metrics.find("\"pairs\": 40"), std::string::npos) << metrics.substr(0, 2000);
  const std::string report = slurp(out + "/report.md");
  EXPECT_NE(report.find("Error rates averaged over datasets"), std::string::npos);
  EXPECT_NE(report.find("![dataset3_two_ramps](maps/"), std::string::npos);
  // The script says where the results are and gives the headline numbers.
  EXPECT_NE(log.find("Report:   " + out + "/report.md"), std::string::npos) << log;
  EXPECT_NE(log.find("FN "), std::string::npos) << log;
  std::system(("rm -rf '" + tmp + "'").c_str());
}

}  // namespace
