// The disparity nodelet on a stereo pair known by construction (stereo_scene.h): disparities
// against the analytic ones, what each post-filter removes, the organised cloud,
// dynamic_reconfigure, and the safety map built from our disparity and from stereo_image_proc's.
#include "disparity_test_util.h"

#include "stereo_safety_map/ros/msgs.h"

#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <opencv2/core.hpp>

#include <atomic>
#include <thread>

using disparity_test::disparities;
using stereo_safety_map::SafetyMapMsg;
using stereo_safety_map::StageTimingsMsg;
using test_util::Latest;
using test_util::waitFor;
namespace scene = stereo_scene;

namespace {

constexpr int kW = scene::kWidth;
constexpr int kH = scene::kHeight;

/// Disparity quality on the scene.
struct Score {
  int with_truth = 0;        ///< pixels of the valid window that see the floor or the box
  int valid_with_truth = 0;  ///< ... with a valid disparity
  int within_1px = 0;        ///< ... within 1 px of the analytic one
  int background = 0;        ///< untextured background pixels (away from the floor and patch)
  int background_valid = 0;  ///< ... with a valid disparity (all of them wrong)
  int patch_valid = 0;       ///< valid pixels on the floating patch
  double accuracy() const {
    return valid_with_truth > 0 ? within_1px / double(valid_with_truth) : 0;
  }
  double coverage() const { return with_truth > 0 ? valid_with_truth / double(with_truth) : 0; }
};

std::ostream& operator<<(std::ostream& os, const Score& s) {
  return os << "valid " << s.valid_with_truth << " of " << s.with_truth << " (coverage "
            << s.coverage() << "), within 1 px " << s.within_1px << " (" << s.accuracy()
            << "), background valid " << s.background_valid << " of " << s.background
            << ", patch valid " << s.patch_valid;
}

const std::vector<float>& truth() {
  static const std::vector<float> t = scene::analyticDisparity();
  return t;
}

bool isBackground(int u, int v) {
  // No surface within 10 rows below (BM windows near the floor's far edge see the floor) and
  // away from the patch.
  const std::vector<float>& t = truth();
  return std::isnan(t[v * kW + u]) && std::isnan(t[std::min(v + 10, kH - 1) * kW + u]) &&
         !scene::inPatch(u, v, 8);
}

// The region every matcher here can see: right of the widest band without a match (64
// disparities + half of stereo_image_proc's 15 px window), away from the image borders.
bool inRegion(int u, int v) {
  return u >= 72 && u < kW - 8 && v >= 8 && v < kH - 8;
}

Score score(const stereo_msgs::DisparityImage& msg) {
  Score s;
  const std::vector<float> d = disparities(msg);
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      const float di = d[v * kW + u];
      const bool valid = !std::isnan(di);
      if (scene::inPatch(u, v, 0)) {
        s.patch_valid += valid;
        continue;
      }
      const bool in_window = inRegion(u, v);
      const float t = truth()[v * kW + u];
      if (!std::isnan(t)) {
        if (!in_window) continue;
        ++s.with_truth;
        if (valid) {
          ++s.valid_with_truth;
          if (std::abs(di - t) <= 1.0f) ++s.within_1px;
        }
      } else if (in_window && isBackground(u, v)) {
        ++s.background;
        s.background_valid += valid;
      }
    }
  }
  return s;
}

class DisparityScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    tf_ = new tf2_ros::StaticTransformBroadcaster;
    auto ts = scene::sceneTransforms();
    for (auto& t : ts)
      t.header.stamp = ros::Time::now();
    tf_->sendTransform(ts);
    disparity_test::sceneFrame();  // render before the clock starts
    ours_ = new Latest<stereo_msgs::DisparityImage>(*nh_, "/ours/disparity");
    raw_ = new Latest<stereo_msgs::DisparityImage>(*nh_, "/raw/disparity");
    sip_ = new Latest<stereo_msgs::DisparityImage>(*nh_, "/sip/disparity");
    debug_ = new Latest<sensor_msgs::Image>(*nh_, "/ours/disparity_debug");
    cloud_ = new Latest<sensor_msgs::PointCloud2>(*nh_, "/ours/points2");
    pub_ = new disparity_test::StereoPublisher(*nh_, "/stereo");
    // Lazy subscription: every disparity nodelet subscribes once its output is listened to
    // (here by this node and the safety maps). They share the manager's process, which counts as
    // one subscriber; each test waits for the output it checks.
    subscribed_ = pub_->waitForSubscribers(1, 30.0);
    test_util::sleepFor(1.0);
    // A camera at 5 Hz for the whole suite.
    running_ = true;
    thread_ = new std::thread([] {
      while (running_ && ros::ok()) {
        pub_->publishScene(ros::Time::now());
        test_util::sleepFor(0.2);
      }
    });
  }
  static void TearDownTestSuite() {
    running_ = false;
    thread_->join();
  }
  void SetUp() override { ASSERT_TRUE(subscribed_) << "the disparity nodelets did not subscribe"; }

  /// Waits for `n` new messages after now.
  template <typename M>
  static bool waitForNew(Latest<M>& latest, int n, double timeout_s) {
    const int start = latest.count();
    return waitFor([&] { return latest.count() >= start + n; }, timeout_s);
  }

  static ros::NodeHandle* nh_;
  static tf2_ros::StaticTransformBroadcaster* tf_;
  static Latest<stereo_msgs::DisparityImage>*ours_, *raw_, *sip_;
  static Latest<sensor_msgs::Image>* debug_;
  static Latest<sensor_msgs::PointCloud2>* cloud_;
  static disparity_test::StereoPublisher* pub_;
  static bool subscribed_;
  static std::atomic<bool> running_;
  static std::thread* thread_;
};
ros::NodeHandle* DisparityScene::nh_ = nullptr;
tf2_ros::StaticTransformBroadcaster* DisparityScene::tf_ = nullptr;
Latest<stereo_msgs::DisparityImage>* DisparityScene::ours_ = nullptr;
Latest<stereo_msgs::DisparityImage>* DisparityScene::raw_ = nullptr;
Latest<stereo_msgs::DisparityImage>* DisparityScene::sip_ = nullptr;
Latest<sensor_msgs::Image>* DisparityScene::debug_ = nullptr;
Latest<sensor_msgs::PointCloud2>* DisparityScene::cloud_ = nullptr;
disparity_test::StereoPublisher* DisparityScene::pub_ = nullptr;
bool DisparityScene::subscribed_ = false;
std::atomic<bool> DisparityScene::running_{false};
std::thread* DisparityScene::thread_ = nullptr;

TEST_F(DisparityScene, OursMatchesTheAnalyticDisparity) {
  ASSERT_TRUE(waitForNew(*ours_, 2, 30.0)) << "no disparity from our nodelet";
  const auto msg = ours_->get();
  EXPECT_EQ(msg->header.frame_id, scene::kCameraFrame);
  EXPECT_EQ(msg->image.width, static_cast<unsigned>(kW));
  EXPECT_EQ(msg->image.height, static_cast<unsigned>(kH));
  EXPECT_EQ(msg->image.encoding, "32FC1");
  EXPECT_FLOAT_EQ(msg->f, scene::kF);
  EXPECT_FLOAT_EQ(msg->T, scene::kBaseline);
  EXPECT_FLOAT_EQ(msg->min_disparity, 0.0f);
  EXPECT_FLOAT_EQ(msg->max_disparity, 63.0f);
  EXPECT_FLOAT_EQ(msg->delta_d, 1.0f / 16);
  // stereo_image_proc's window: left edge at num_disparities + block_size / 2 - 1.
  EXPECT_EQ(msg->valid_window.x_offset, 64u + 4u - 1u);
  const Score s = score(*msg);
  std::cout << "ours: " << s << std::endl;
  EXPECT_GE(s.accuracy(), 0.97) << s;  // most valid pixels within 1 px of the analytic disparity
  EXPECT_GE(s.coverage(), 0.85) << s;  // and the textured scene is dense
}

TEST_F(DisparityScene, StereoImageProcMatchesTheAnalyticDisparity) {
  // Checks the rendered pair itself with the reference implementation.
  ASSERT_TRUE(waitForNew(*sip_, 2, 30.0)) << "no disparity from stereo_image_proc";
  const auto msg = sip_->get();
  EXPECT_FLOAT_EQ(msg->f, scene::kF);
  EXPECT_FLOAT_EQ(msg->T, scene::kBaseline);
  const Score s = score(*msg);
  std::cout << "stereo_image_proc: " << s << std::endl;
  EXPECT_GE(s.accuracy(), 0.97) << s;
  EXPECT_GE(s.coverage(), 0.8) << s;
}

TEST_F(DisparityScene, FiltersRemoveWhatThePapersSay) {
  ASSERT_TRUE(waitForNew(*ours_, 2, 30.0));
  ASSERT_TRUE(waitForNew(*raw_, 2, 30.0));
  ASSERT_TRUE(waitForNew(*debug_, 2, 30.0));
  const Score ours = score(*ours_->get());
  const Score raw = score(*raw_->get());
  std::cout << "ours: " << ours << "\nraw:  " << raw << std::endl;

  // Untextured background: the bare matcher returns noise there; texture and uniqueness
  // validation (002 Sec. 2.2) remove it.
  ASSERT_GT(ours.background, 2000);
  EXPECT_GT(raw.background_valid, ours.background / 4) << raw;
  EXPECT_LE(ours.background_valid, ours.background / 100) << ours;
  // The floating patch is a real match but a small surface without support: spike removal
  // (002 Sec. 4.2) removes it.
  EXPECT_GE(raw.patch_valid, scene::kPatchSize * scene::kPatchSize / 2) << raw;
  EXPECT_EQ(ours.patch_valid, 0) << ours;
  // The filters cost little density on the textured scene and only remove wrong values.
  EXPECT_GE(ours.accuracy(), raw.accuracy()) << ours << "\n" << raw;
  EXPECT_GE(ours.valid_with_truth, raw.valid_with_truth * 0.9) << ours << "\n" << raw;

  // The debug image: each removed pixel in its filter's colour (disparity_pipeline.h).
  const auto img = debug_->get();
  ASSERT_EQ(img->encoding, "bgr8");
  ASSERT_EQ(img->width, static_cast<unsigned>(kW));
  auto colour = [&img](int u, int v) {
    const std::uint8_t* p = &img->data[v * img->step + u * 3];
    return cv::Vec3b(p[0], p[1], p[2]);
  };
  int spike = 0, left_right = 0, texture_or_uniqueness = 0, background = 0;
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      const cv::Vec3b c = colour(u, v);
      if (scene::inPatch(u, v, 0) && c == cv::Vec3b(255, 0, 255)) ++spike;
      if (c == cv::Vec3b(0, 0, 255)) ++left_right;
      if (inRegion(u, v) && isBackground(u, v)) {
        ++background;
        if (c == cv::Vec3b(255, 0, 0) || c == cv::Vec3b(0, 200, 0)) ++texture_or_uniqueness;
      }
    }
  }
  EXPECT_GE(spike, scene::kPatchSize * scene::kPatchSize / 2) << "patch not magenta (spike)";
  EXPECT_GT(left_right, 0) << "nothing red (left-right check) at the box's occlusion edges";
  EXPECT_GE(texture_or_uniqueness, background * 9 / 10)
      << "background not blue (texture) or green (uniqueness)";
}

TEST_F(DisparityScene, DynamicReconfigureSwitchesAFilter) {
  ASSERT_TRUE(disparity_test::reconfigure(
      "/ours/disparity", disparity_test::boolConfig("enable_spike_removal", false)));
  ASSERT_TRUE(waitForNew(*ours_, 3, 30.0));
  EXPECT_GE(score(*ours_->get()).patch_valid, scene::kPatchSize * scene::kPatchSize / 2)
      << "spike removal off: the patch stays";
  ASSERT_TRUE(disparity_test::reconfigure(
      "/ours/disparity", disparity_test::boolConfig("enable_spike_removal", true)));
  ASSERT_TRUE(waitForNew(*ours_, 3, 30.0));
  EXPECT_EQ(score(*ours_->get()).patch_valid, 0) << "spike removal on again";

  // The other matcher, live.
  ASSERT_TRUE(
      disparity_test::reconfigure("/ours/disparity", disparity_test::strConfig("matcher", "sgbm")));
  ASSERT_TRUE(waitForNew(*ours_, 3, 60.0));
  const Score sgbm = score(*ours_->get());
  std::cout << "ours with sgbm: " << sgbm << std::endl;
  EXPECT_GE(sgbm.accuracy(), 0.97) << sgbm;
  EXPECT_GE(sgbm.coverage(), 0.85) << sgbm;
  ASSERT_TRUE(
      disparity_test::reconfigure("/ours/disparity", disparity_test::strConfig("matcher", "bm")));
  ASSERT_TRUE(waitForNew(*ours_, 2, 30.0));
}

TEST_F(DisparityScene, PointCloudIsOrganisedInTheCameraFrame) {
  ASSERT_TRUE(waitForNew(*cloud_, 2, 30.0)) << "no points2";
  const auto cloud = cloud_->get();
  EXPECT_EQ(cloud->header.frame_id, scene::kCameraFrame);
  ASSERT_EQ(cloud->width, static_cast<unsigned>(kW));
  ASSERT_EQ(cloud->height, static_cast<unsigned>(kH));
  EXPECT_FALSE(cloud->is_dense);
  sensor_msgs::PointCloud2ConstIterator<float> it(*cloud, "x");
  int finite = 0, close = 0, background_points = 0;
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u, ++it) {
      if (!std::isfinite(it[2])) continue;
      const float t = truth()[v * kW + u];
      if (std::isnan(t)) {
        background_points += isBackground(u, v);
        continue;
      }
      ++finite;
      const double depth = scene::kF * scene::kBaseline / t;
      if (std::abs(it[2] - depth) <= 0.05 * depth &&
          std::abs(it[0] - (u - scene::kCx) / scene::kF * it[2]) < 1e-3 &&
          std::abs(it[1] - (v - scene::kCy) / scene::kF * it[2]) < 1e-3) {
        ++close;
      }
    }
  }
  EXPECT_GT(finite, kW * kH / 2);
  EXPECT_GE(close, finite * 0.97) << close << " of " << finite << " within 5% of the true depth";
  EXPECT_LE(background_points, 50);
}

void expectFloorAndBox(const std::string& ns) {
  SCOPED_TRACE(ns);
  ros::NodeHandle nh;
  Latest<SafetyMapMsg> labels(nh, ns + "/safety_map_labels");
  Latest<nav_msgs::OccupancyGrid> grid(nh, ns + "/safety_map");
  Latest<StageTimingsMsg> timings(nh, ns + "/stage_timings");
  // occ_t / incr_H = 10 frames make a voxel occupied.
  ASSERT_TRUE(waitFor(
      [&] {
        auto t = timings.get();
        return t && t->frames_processed >= 14u;
      },
      60.0))
      << ns << ": the safety map processed "
      << (timings.get() ? timings.get()->frames_processed : 0) << " frames";
  labels.reset();
  grid.reset();
  ASSERT_TRUE(waitFor([&] { return labels.count() > 0 && grid.count() > 0; }, 10.0));
  const auto m = labels.get();
  auto label = [&m](double x, double y) {
    const int k = test_util::cellAt(m->info, x, y);
    return k < 0 ? -1 : static_cast<int>(m->labels[k]);
  };
  for (double x : {1.1, 1.4, 1.7}) {
    for (double y : {-0.3, 0.0, 0.3}) {
      EXPECT_EQ(label(x, y), SafetyMapMsg::LEVEL) << "floor at " << x << ", " << y;
      EXPECT_EQ(test_util::costAt(*grid.get(), x, y), 0) << "floor at " << x << ", " << y;
    }
  }
  // The box's top is a strip about ten rows high in the image: near its far edge (x = 2.45)
  // stereo_image_proc's 15x15 windows reach the floor behind it, and a cell there may hold too
  // few points to be judged. It must never read safe; the rest of the box must be Non-ground.
  for (double x : {2.15, 2.3, 2.45}) {
    for (double y : {-0.15, 0.0, 0.15}) {
      const int l = label(x, y);
      const int cost = test_util::costAt(*grid.get(), x, y);
      if (x < 2.4) {
        EXPECT_EQ(l, SafetyMapMsg::NON_GROUND) << "box at " << x << ", " << y;
        EXPECT_EQ(cost, 100) << "box at " << x << ", " << y;
      } else {
        EXPECT_TRUE(l == SafetyMapMsg::NON_GROUND || l == SafetyMapMsg::UNKNOWN)
            << "box at " << x << ", " << y << ": label " << l;
        EXPECT_TRUE(cost == 100 || cost == -1) << "box at " << x << ", " << y << ": cost " << cost;
      }
    }
  }
  int box_non_ground = 0;
  for (double x : {2.15, 2.3, 2.45})
    for (double y : {-0.15, 0.0, 0.15})
      box_non_ground += label(x, y) == SafetyMapMsg::NON_GROUND;
  EXPECT_GE(box_non_ground, 8) << "of the box's 9 checked cells";
  ASSERT_GE(m->robot_segment, 0);
  ASSERT_LT(m->robot_segment, static_cast<int>(m->segments.size()));
  const auto& floor = m->segments[m->robot_segment];
  EXPECT_EQ(floor.label, SafetyMapMsg::LEVEL);
  EXPECT_LT(floor.slope_deg, 1.0);
  EXPECT_NEAR(floor.c, 0.0, 0.05);  // the floor z = 0
}

TEST_F(DisparityScene, SafetyMapFromOurDisparityLabelsFloorAndBox) {
  expectFloorAndBox("/ours");
}

TEST_F(DisparityScene, SafetyMapFromStereoImageProcLabelsFloorAndBox) {
  expectFloorAndBox("/sip");
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "disparity_scene_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
