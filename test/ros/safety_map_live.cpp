// Live changes in the middle of processing. A robot drives over the synthetic scene
// (test_util.h) at 10 Hz while other threads, all at once: change parameters through
// dynamic_reconfigure (stage parameters, which keep the 3D model, and the sensor model, which
// restarts the map), call ~reset, call ~save (two threads on one prefix, one on another), and
// read the saved files back as fast as they can.
//
// What must hold: the nodelet stays up and keeps publishing; no published map is torn (its
// labels and its OccupancyGrid of the same stamp agree cell by cell through the cost table, and
// every array has the grid's size); every save succeeds (or says there is no map yet, right
// after a reset); a reader never sees a half-written file, and no temporary file is left.
#include "disparity_test_util.h"
#include "test_util.h"

#include "stereo_safety_map/SaveMap.h"
#include "stereo_safety_map/core/map_costs.h"
#include "stereo_safety_map/ros/msgs.h"

#include <gtest/gtest.h>

#include <octomap/OcTree.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <opencv2/imgcodecs.hpp>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

using stereo_safety_map::SafetyMapMsg;
using test_util::waitFor;
namespace fs = std::filesystem;

namespace {

constexpr char kNode[] = "/live/safety_map";
constexpr double kSeconds = 12.0;  // of storm

// Checks a labels message and the OccupancyGrid of the same stamp against each other.
class TornMapChecker {
 public:
  explicit TornMapChecker(ros::NodeHandle& nh) {
    labels_sub_ = nh.subscribe<SafetyMapMsg>("/live/safety_map_labels", 100,
                                             [this](const SafetyMapMsg::ConstPtr& m) {
                                               std::lock_guard<std::mutex> lock(mutex_);
                                               ++labels_count_;
                                               checkLabels(*m);
                                               labels_[m->header.stamp] = m;
                                               match(m->header.stamp);
                                             });
    grid_sub_ = nh.subscribe<nav_msgs::OccupancyGrid>(
        "/live/safety_map", 100, [this](const nav_msgs::OccupancyGrid::ConstPtr& g) {
          std::lock_guard<std::mutex> lock(mutex_);
          grids_[g->header.stamp] = g;
          match(g->header.stamp);
        });
  }
  int labelsCount() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return labels_count_;
  }
  int pairsChecked() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return pairs_;
  }
  std::vector<std::string> problems() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return problems_;
  }

 private:
  void fail(const std::string& what) {
    if (problems_.size() < 20) problems_.push_back(what);
  }
  void checkLabels(const SafetyMapMsg& m) {
    const std::size_t n = static_cast<std::size_t>(m.info.width) * m.info.height;
    if (m.labels.size() != n || m.drop_off.size() != n) {
      fail("labels / drop_off arrays do not have width x height entries");
      return;
    }
    for (auto l : m.labels) {
      if (l > SafetyMapMsg::NON_GROUND) {
        fail("a label out of range");
        return;
      }
    }
  }
  // Labels and costs of one stamp: the default cost table (core/map_costs.h), cell by cell, and
  // what costmap_2d's static layer reads (trinary_costmap true, lethal_cost_threshold 100,
  // unknown_cost_value -1): no drop-off edge or Non-ground cell free. (The aging timer can
  // republish one stamp; only whole pairs are compared.)
  void match(const ros::Time& t) {
    const auto l = labels_.find(t);
    const auto g = grids_.find(t);
    if (l == labels_.end() || g == grids_.end()) return;
    const SafetyMapMsg& m = *l->second;
    const nav_msgs::OccupancyGrid& grid = *g->second;
    ++pairs_;
    if (grid.info.width != m.info.width || grid.info.height != m.info.height ||
        grid.info.origin.position.x != m.info.origin.position.x ||
        grid.info.origin.position.y != m.info.origin.position.y ||
        grid.data.size() != m.labels.size()) {
      fail("OccupancyGrid and labels of one stamp have different geometry");
    } else {
      for (std::size_t k = 0; k < m.labels.size(); ++k) {
        const int c = grid.data[k];
        const bool drop = m.drop_off[k] != 0;
        bool ok = false;
        switch (m.labels[k]) {
          case SafetyMapMsg::LEVEL:
            ok = c == (drop ? 100 : 0);
            break;
          case SafetyMapMsg::INCLINED:
            ok = drop ? c == 100 : (c >= 10 && c <= 50);
            break;
          case SafetyMapMsg::NON_GROUND:
            ok = c == 100;
            break;
          default:
            ok = c == -1;
            break;
        }
        const bool hazard =
            m.labels[k] == SafetyMapMsg::NON_GROUND ||
            (drop && (m.labels[k] == SafetyMapMsg::LEVEL || m.labels[k] == SafetyMapMsg::INCLINED));
        if (hazard && stereo_safety_map::staticLayerCost(
                          static_cast<std::int8_t>(c), stereo_safety_map::StaticLayerSettings()) ==
                          stereo_safety_map::kCostmapFreeSpace) {
          ok = false;
        }
        if (!ok) {
          fail("cell " + std::to_string(k) + ": label " + std::to_string(m.labels[k]) +
               " but cost " + std::to_string(c));
          break;
        }
      }
    }
    labels_.erase(l);
    grids_.erase(g);
  }

  ros::Subscriber labels_sub_, grid_sub_;
  mutable std::mutex mutex_;
  std::map<ros::Time, SafetyMapMsg::ConstPtr> labels_;
  std::map<ros::Time, nav_msgs::OccupancyGrid::ConstPtr> grids_;
  int labels_count_ = 0;
  int pairs_ = 0;
  std::vector<std::string> problems_;
};

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream os;
  os << f.rdbuf();
  return os.str();
}

// "" when `bytes` is a whole binary PGM (header, then exactly width x height pixels).
std::string checkPgm(const std::string& bytes, int* width = nullptr, int* height = nullptr) {
  std::istringstream is(bytes);
  std::string magic, comment;
  is >> magic;
  if (magic != "P5") return "not a P5 PGM";
  is >> std::ws;
  while (is.peek() == '#')
    std::getline(is, comment);
  int w = 0, h = 0, maxval = 0;
  is >> w >> h >> maxval;
  if (!is || w <= 0 || h <= 0 || maxval != 255) return "bad PGM header";
  is.get();  // the single whitespace before the pixels
  const std::size_t header = static_cast<std::size_t>(is.tellg());
  if (bytes.size() != header + static_cast<std::size_t>(w) * h) {
    return "PGM has " + std::to_string(bytes.size() - header) + " pixel bytes, " +
           std::to_string(w * h) + " expected";
  }
  if (width) *width = w;
  if (height) *height = h;
  return "";
}

class LiveTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // Under the nodelet's save_directory (safety_map_live.test).
    dir_ = fs::path("/tmp/ssm_live_test") / std::to_string(::getpid());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static fs::path dir_;
};
fs::path LiveTest::dir_;

TEST_F(LiveTest, ReconfigureResetAndSaveDuringProcessing) {
  ros::NodeHandle nh;
  tf2_ros::StaticTransformBroadcaster static_tf;
  tf2_ros::TransformBroadcaster tf;
  test_util::ScenePublisher scene(nh, "/live");
  TornMapChecker torn(nh);
  test_util::DiagnosticsWatcher diagnostics(nh);
  auto t = synthetic_scene::toMsg(synthetic_scene::baseToCamera(), "base_link",
                                  synthetic_scene::kCameraFrame);
  t.header.stamp = ros::Time::now();
  static_tf.sendTransform(t);
  ASSERT_TRUE(scene.waitForSubscribers(20.0));
  ASSERT_TRUE(ros::service::waitForService(std::string(kNode) + "/save", 20000));
  ASSERT_TRUE(ros::service::waitForService(std::string(kNode) + "/reset", 20000));
  ASSERT_TRUE(ros::service::waitForService(std::string(kNode) + "/set_parameters", 20000));
  test_util::sleepFor(0.5);

  std::atomic<bool> stop{false};
  // The robot drives back and forth over 2 m at 10 Hz.
  std::thread driver([&] {
    int k = 0;
    while (!stop) {
      const int phase = k % 80;
      const double x = -1.0 + 0.05 * (phase < 40 ? phase : 80 - phase);
      const ros::Time stamp = ros::Time::now();
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation().x() = x;
      auto m = synthetic_scene::toMsg(T, "odom", "base_link");
      m.header.stamp = stamp;
      tf.sendTransform(m);
      test_util::sleepFor(0.01);
      std_msgs::Header h;
      h.stamp = stamp;
      h.frame_id = synthetic_scene::kCameraFrame;
      scene.publishDisparity(
          synthetic_scene::disparityImage(T * synthetic_scene::baseToCamera(), h),
          synthetic_scene::cameraInfo(false, h), synthetic_scene::cameraInfo(true, h), stamp);
      ++k;
      test_util::sleepFor(0.09);
    }
  });
  ASSERT_TRUE(waitFor([&] { return torn.labelsCount() > 5; }, 20.0));

  std::atomic<int> reconfigures{0}, resets{0}, saves{0}, save_failures{0}, reads{0};
  std::mutex problems_mutex;
  std::vector<std::string> problems;
  auto problem = [&](const std::string& p) {
    std::lock_guard<std::mutex> lock(problems_mutex);
    if (problems.size() < 20) problems.push_back(p);
  };

  std::thread reconfigurer([&] {
    int k = 0;
    while (!stop) {
      dynamic_reconfigure::Config c;
      dynamic_reconfigure::DoubleParameter d;
      dynamic_reconfigure::IntParameter i;
      switch (k % 4) {
        case 0:  // labelling: keeps the 3D model
          d.name = "max_slope_deg";
          d.value = (k / 4) % 2 ? 12.0 : 10.0;
          c.doubles.push_back(d);
          break;
        case 1:
          d.name = "planning_radius";
          d.value = (k / 4) % 2 ? 3.5 : 4.0;
          c.doubles.push_back(d);
          d.name = "max_cell_age";
          d.value = (k / 4) % 2 ? 20.0 : 30.0;
          c.doubles.push_back(d);
          break;
        case 2:  // the sensor model: a new grid, the map starts again
          i.name = "decr";
          i.value = (k / 4) % 2 ? 2 : 1;
          c.ints.push_back(i);
          break;
        default:  // refused (level_slope_deg > max_slope_deg): nothing changes
          d.name = "level_slope_deg";
          d.value = 45.0;
          c.doubles.push_back(d);
          break;
      }
      if (disparity_test::reconfigure(kNode, c)) {
        ++reconfigures;
      } else {
        problem("set_parameters call failed");
      }
      ++k;
      test_util::sleepFor(0.15);
    }
  });
  std::thread resetter([&] {
    while (!stop) {
      test_util::sleepFor(0.7);
      std_srvs::Empty srv;
      if (ros::service::call(std::string(kNode) + "/reset", srv)) {
        ++resets;
      } else {
        problem("reset call failed");
      }
    }
  });
  auto saver = [&](const std::string& prefix) {
    while (!stop) {
      stereo_safety_map::SaveMap srv;
      srv.request.path_prefix = (dir_ / prefix).string();
      if (!ros::service::call(std::string(kNode) + "/save", srv)) {
        problem("save call failed");
      } else if (srv.response.success) {
        ++saves;
        if (srv.response.files.size() != 4) problem("a save wrote fewer than 4 files");
      } else if (srv.response.message.find("no map yet") == std::string::npos) {
        problem("save failed: " + srv.response.message);
      } else {
        ++save_failures;  // right after a reset: nothing to save
      }
      test_util::sleepFor(0.1);
    }
  };
  std::thread saver1(saver, "a/map"), saver2(saver, "a/map"), saver3(saver, "b/map");
  // A reader that never must see a half-written file.
  std::thread reader([&] {
    while (!stop) {
      for (const char* prefix : {"a/map", "b/map"}) {
        const fs::path pgm = dir_ / (std::string(prefix) + ".pgm");
        const fs::path png = dir_ / (std::string(prefix) + "_labels.png");
        if (!fs::exists(pgm)) continue;
        const std::string err = checkPgm(slurp(pgm));
        if (!err.empty()) problem(pgm.string() + ": " + err);
        const std::string bytes = slurp(png);
        const std::vector<unsigned char> buf(bytes.begin(), bytes.end());
        if (!bytes.empty() && cv::imdecode(buf, cv::IMREAD_UNCHANGED).empty()) {
          problem(png.string() + " does not decode");
        }
        ++reads;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });

  test_util::sleepFor(kSeconds);
  stop = true;
  for (std::thread* th : {&reconfigurer, &resetter, &saver1, &saver2, &saver3, &reader})
    th->join();
  driver.join();

  for (const std::string& p : problems)
    ADD_FAILURE() << p;
  for (const std::string& p : torn.problems())
    ADD_FAILURE() << "torn map: " << p;
  std::printf(
      "[live] %d reconfigurations, %d resets, %d saves (+%d with no map yet), %d reads, "
      "%d label / cost pairs checked\n",
      reconfigures.load(), resets.load(), saves.load(), save_failures.load(), reads.load(),
      torn.pairsChecked());
  EXPECT_GT(reconfigures.load(), 20);
  EXPECT_GT(resets.load(), 5);
  EXPECT_GT(saves.load(), 20);
  EXPECT_GT(reads.load(), 100);
  EXPECT_GT(torn.pairsChecked(), 20);

  // Still up and serving: a few more frames give maps.
  const int before = torn.labelsCount();
  for (int k = 0; k < 12; ++k) {
    const ros::Time stamp = ros::Time::now();
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = 0.05 * k;
    auto m = synthetic_scene::toMsg(T, "odom", "base_link");
    m.header.stamp = stamp;
    tf.sendTransform(m);
    test_util::sleepFor(0.01);
    std_msgs::Header h;
    h.stamp = stamp;
    h.frame_id = synthetic_scene::kCameraFrame;
    scene.publishDisparity(synthetic_scene::disparityImage(T * synthetic_scene::baseToCamera(), h),
                           synthetic_scene::cameraInfo(false, h),
                           synthetic_scene::cameraInfo(true, h), stamp);
    test_util::sleepFor(0.15);
  }
  EXPECT_TRUE(waitFor([&] { return torn.labelsCount() > before + 5; }, 10.0));

  // The last files of each prefix: whole, of one map, readable by their readers, and no
  // temporary file left behind.
  for (const char* prefix : {"a/map", "b/map"}) {
    const fs::path base = dir_ / prefix;
    int w = 0, h = 0;
    EXPECT_EQ(checkPgm(slurp(base.string() + ".pgm"), &w, &h), "") << prefix;
    const cv::Mat png = cv::imread(base.string() + "_labels.png", cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(png.empty()) << prefix;
    EXPECT_EQ(png.cols, w);
    EXPECT_EQ(png.rows, h);
    const std::string yaml = slurp(base.string() + ".yaml");
    EXPECT_NE(yaml.find("image: map.pgm"), std::string::npos) << yaml;
    EXPECT_NE(yaml.find("resolution: 0.1"), std::string::npos) << yaml;
    octomap::OcTree tree(0.1);
    EXPECT_TRUE(tree.readBinary(base.string() + ".bt")) << prefix;
    EXPECT_GT(tree.size(), 0u);
  }
  for (const auto& e : fs::recursive_directory_iterator(dir_)) {
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos)
        << "temporary file left: " << e.path();
  }
  EXPECT_TRUE(waitFor(
      [&] { return std::stol("0" + diagnostics.lastValue(kNode, "map resets")) > resets; }, 5.0))
      << "map resets " << diagnostics.lastValue(kNode, "map resets");
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_map_live_test");
  ros::AsyncSpinner spinner(4);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
