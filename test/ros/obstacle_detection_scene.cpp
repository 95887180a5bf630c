// The obstacle-detection nodelet (paper 003) on a known scene: a level floor with a 0.5 m box
// (x 2.0..2.6, y -0.3..0.3, synthetic_scene.h) seen by a camera pitched down 30 deg. Checks the
// labelled obstacle cloud, the box markers, the label image and the diagnostics from both inputs,
// then bad input and an invalid parameter.
#include "test_util.h"

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <gtest/gtest.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <visualization_msgs/MarkerArray.h>

#include <functional>
#include <limits>
#include <set>

using diagnostic_msgs::DiagnosticStatus;
using test_util::Latest;
using test_util::waitFor;

namespace {

struct CloudSummary {
  std::size_t points = 0, in_box = 0;
  std::set<std::uint32_t> labels;
};

// Raised obstacle points must be on the box: inside it grown by 5 cm, above H_T.
CloudSummary summarise(const sensor_msgs::PointCloud2& c) {
  CloudSummary s;
  sensor_msgs::PointCloud2ConstIterator<float> x(c, "x"), y(c, "y"), z(c, "z");
  sensor_msgs::PointCloud2ConstIterator<std::uint32_t> l(c, "label");
  for (std::size_t i = 0; i < static_cast<std::size_t>(c.width) * c.height;
       ++i, ++x, ++y, ++z, ++l) {
    ++s.points;
    s.labels.insert(*l);
    const double m = 0.05;
    if (*x > synthetic_scene::kBoxMin[0] - m &&
        *x<synthetic_scene::kBoxMax[0] + m&& * y> synthetic_scene::kBoxMin[1] - m &&
        *y<synthetic_scene::kBoxMax[1] + m&& * z> 0.05 - 0.02 &&
        *z < synthetic_scene::kBoxMax[2] + m) {
      ++s.in_box;
    }
  }
  return s;
}

class ObstacleSceneTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    tf_ = new tf2_ros::StaticTransformBroadcaster;
    test_util::publishSceneTf(*tf_);
    diag_ = new test_util::DiagnosticsWatcher(*nh_);
  }
  // Publishes frames until `done` or the timeout.
  static bool publishUntil(const std::function<void()>& publish, const std::function<bool()>& done,
                           double timeout_s) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::WallTime::now() < end && ros::ok()) {
      publish();
      if (waitFor(done, 0.3)) return true;
    }
    return done();
  }
  // The detector's outputs for one namespace, checked against the scene.
  static void checkOutputs(const std::string& ns, const std::function<void()>& publish) {
    SCOPED_TRACE(ns);
    Latest<sensor_msgs::PointCloud2> obstacles(*nh_, ns + "/obstacles");
    Latest<sensor_msgs::Image> labels(*nh_, ns + "/obstacle_labels");
    Latest<visualization_msgs::MarkerArray> markers(*nh_, ns + "/obstacle_markers");
    ASSERT_TRUE(publishUntil(
        publish, [&] { return obstacles.count() > 1 && labels.count() > 1 && markers.count() > 1; },
        30.0))
        << "no output from " << ns;

    // The labelled obstacle cloud: fixed frame, x y z label, one obstacle on the box.
    const auto c = obstacles.get();
    EXPECT_EQ(c->header.frame_id, "odom");
    ASSERT_EQ(c->fields.size(), 4u);
    EXPECT_EQ(c->fields[3].name, "label");
    const CloudSummary s = summarise(*c);
    EXPECT_GT(s.points, 1000u);
    EXPECT_GT(s.in_box, 0.99 * s.points);
    EXPECT_EQ(s.labels.size(), 1u);
    EXPECT_EQ(s.labels.count(0u), 0u);

    // Markers: DELETEALL, then one box (the obstacle's points, foot ring within H_max /
    // tan(theta_T) = 0.3 m included) and its text.
    const auto m = markers.get();
    ASSERT_EQ(m->markers.size(), 3u);
    EXPECT_EQ(m->markers[0].action, visualization_msgs::Marker::DELETEALL);
    const auto& box = m->markers[1];
    EXPECT_EQ(box.type, visualization_msgs::Marker::CUBE);
    EXPECT_EQ(box.header.frame_id, "odom");
    const double x0 = box.pose.position.x - box.scale.x / 2,
                 x1 = box.pose.position.x + box.scale.x / 2;
    const double y0 = box.pose.position.y - box.scale.y / 2,
                 y1 = box.pose.position.y + box.scale.y / 2;
    const double z1 = box.pose.position.z + box.scale.z / 2;
    EXPECT_LT(x0, synthetic_scene::kBoxMin[0] + 0.02);
    EXPECT_GT(x0, synthetic_scene::kBoxMin[0] - 0.35);
    // Only the top's front band is raised: farther than H_max / tan(theta_T) = 0.3 m from the
    // front face no point of the top has a compatible partner (003 Def. 1).
    EXPECT_GT(x1, synthetic_scene::kBoxMin[0] + 0.2);
    EXPECT_LT(x1, synthetic_scene::kBoxMax[0] + 0.35);
    EXPECT_LT(y0, synthetic_scene::kBoxMin[1] + 0.02);
    EXPECT_GT(y0, synthetic_scene::kBoxMin[1] - 0.35);
    EXPECT_GT(y1, synthetic_scene::kBoxMax[1] - 0.02);
    EXPECT_LT(y1, synthetic_scene::kBoxMax[1] + 0.35);
    EXPECT_NEAR(z1, synthetic_scene::kBoxMax[2], 0.03);
    EXPECT_EQ(m->markers[2].type, visualization_msgs::Marker::TEXT_VIEW_FACING);

    // The label image: the camera's size, bgr8, coloured (non-grey) pixels on the box.
    const auto img = labels.get();
    EXPECT_EQ(img->width, static_cast<unsigned>(synthetic_scene::kWidth));
    EXPECT_EQ(img->height, static_cast<unsigned>(synthetic_scene::kHeight));
    EXPECT_EQ(img->encoding, "bgr8");
    std::size_t coloured = 0;
    for (std::size_t i = 0; i + 2 < img->data.size(); i += 3)
      coloured += img->data[i] != img->data[i + 1] || img->data[i + 1] != img->data[i + 2];
    EXPECT_GT(coloured, 1000u);

    const std::string node = ns + "/obstacle_detection";
    EXPECT_TRUE(waitFor(
        [&] { return diag_->lastValue(node, "obstacles accepted, last frame") == "1"; }, 5.0))
        << diag_->lastValue(node, "obstacles accepted, last frame");
  }
  static ros::NodeHandle* nh_;
  static tf2_ros::StaticTransformBroadcaster* tf_;
  static test_util::DiagnosticsWatcher* diag_;
};
ros::NodeHandle* ObstacleSceneTest::nh_ = nullptr;
tf2_ros::StaticTransformBroadcaster* ObstacleSceneTest::tf_ = nullptr;
test_util::DiagnosticsWatcher* ObstacleSceneTest::diag_ = nullptr;

TEST_F(ObstacleSceneTest, DisparityInputFindsTheBox) {
  test_util::ScenePublisher pub(*nh_, "/disp");
  checkOutputs("/disp", [&] { pub.publishDisparity(ros::Time::now()); });
}

TEST_F(ObstacleSceneTest, OrganisedCloudInputFindsTheBox) {
  test_util::ScenePublisher pub(*nh_, "/cloud");
  checkOutputs("/cloud", [&] { pub.publishCloud(ros::Time::now()); });
  const std::string f =
      diag_->lastValue("/cloud/obstacle_detection", "focal length, last frame [px]");
  ASSERT_FALSE(f.empty());
  EXPECT_NEAR(std::stod(f), synthetic_scene::kF, 1.0);  // fitted from the cloud
}

TEST_F(ObstacleSceneTest, BadInputIsReportedAndSkipped) {
  test_util::ScenePublisher cloud_pub(*nh_, "/cloud");
  test_util::ScenePublisher disp_pub(*nh_, "/disp");
  Latest<sensor_msgs::PointCloud2> cloud_out(*nh_, "/cloud/obstacles");
  Latest<sensor_msgs::PointCloud2> disp_out(*nh_, "/disp/obstacles");
  // Both run (and are subscribed) before the bad input.
  ASSERT_TRUE(publishUntil([&] { cloud_pub.publishCloud(ros::Time::now()); },
                           [&] { return cloud_out.count() > 0; }, 20.0));
  ASSERT_TRUE(publishUntil([&] { disp_pub.publishDisparity(ros::Time::now()); },
                           [&] { return disp_out.count() > 0; }, 20.0));
  const std::string cloud_node = "/cloud/obstacle_detection",
                    disp_node = "/disp/obstacle_detection";
  auto reported = [&](const std::string& node, const std::string& text) {
    return waitFor([&] { return diag_->seen(node, DiagnosticStatus::WARN, text); }, 10.0);
  };

  // Unorganised cloud.
  sensor_msgs::PointCloud2 flat = cloud_pub.goodCloud();
  flat.width = flat.width * flat.height;
  flat.height = 1;
  flat.row_step = flat.width * flat.point_step;
  diag_->clear();
  cloud_pub.publishCloud(flat, ros::Time::now());
  EXPECT_TRUE(reported(cloud_node, "not organised"));

  // Only NaN.
  sensor_msgs::PointCloud2 nan = cloud_pub.goodCloud();
  sensor_msgs::PointCloud2Iterator<float> it(nan, "x");
  for (; it != it.end(); ++it)
    it[0] = it[1] = it[2] = std::numeric_limits<float>::quiet_NaN();
  diag_->clear();
  cloud_pub.publishCloud(nan, ros::Time::now());
  EXPECT_TRUE(reported(cloud_node, "focal length"));  // nothing to fit f from: skipped

  // No tf for the data's frame.
  sensor_msgs::PointCloud2 lost = cloud_pub.goodCloud();
  lost.header.frame_id = "nowhere";
  diag_->clear();
  for (int k = 0; k < 8; ++k) {  // more than the tf filter's queue: the oldest are dropped
    cloud_pub.publishCloud(lost, ros::Time::now());
    test_util::sleepFor(0.1);
  }
  EXPECT_TRUE(waitFor([&] { return diag_->seen(cloud_node, DiagnosticStatus::WARN, "tf"); }, 15.0));

  // A CameraInfo of another size than the disparity image.
  std_msgs::Header h;
  h.frame_id = synthetic_scene::kCameraFrame;
  sensor_msgs::CameraInfo left = synthetic_scene::cameraInfo(false, h);
  left.width = 640;
  diag_->clear();
  disp_pub.publishDisparity(disp_pub.goodDisparity(), left, synthetic_scene::cameraInfo(true, h),
                            ros::Time::now());
  EXPECT_TRUE(reported(disp_node, "does not match"));

  // Both still serve good frames.
  cloud_out.reset();
  disp_out.reset();
  EXPECT_TRUE(publishUntil([&] { cloud_pub.publishCloud(ros::Time::now()); },
                           [&] { return cloud_out.count() > 0; }, 20.0));
  EXPECT_TRUE(publishUntil([&] { disp_pub.publishDisparity(ros::Time::now()); },
                           [&] { return disp_out.count() > 0; }, 20.0));
  EXPECT_GT(summarise(*cloud_out.get()).points, 1000u);
}

TEST_F(ObstacleSceneTest, InvalidParameterIsAnError) {
  EXPECT_TRUE(waitFor(
      [&] {
        return diag_->seen("/bad/obstacle_detection", DiagnosticStatus::ERROR,
                           "slope_threshold_deg");
      },
      15.0));
  EXPECT_TRUE(waitFor(
      [&] {
        return diag_->seen("/bad_type/obstacle_detection", DiagnosticStatus::ERROR,
                           "max_candidates_per_pixel: must be an integer");
      },
      15.0));
  // It advertises nothing.
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  for (const auto& t : topics)
    EXPECT_NE(t.name, "/bad/obstacles");
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "obstacle_detection_scene_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
