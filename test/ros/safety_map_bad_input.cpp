// Bad input for the safety-map nodelet. After a good map is built, each kind of bad message is
// published; then the test checks that no map was published for it (the map is unchanged),
// that /diagnostics reported it, and that a good frame afterwards still gives the same map.
#include "test_util.h"

#include "stereo_safety_map/ros/msgs.h"

#include <gtest/gtest.h>

#include <limits>

using stereo_safety_map::SafetyMapMsg;
using stereo_safety_map::StageTimingsMsg;
using test_util::Latest;
using test_util::waitFor;

namespace {

constexpr int kWarn = diagnostic_msgs::DiagnosticStatus::WARN;

class BadInputTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    tf_ = new tf2_ros::StaticTransformBroadcaster;
    test_util::publishSceneTf(*tf_);
    disp_ = new test_util::ScenePublisher(*nh_, "/disp");
    cloud_ = new test_util::ScenePublisher(*nh_, "/cloud");
    disp_labels_ = new Latest<SafetyMapMsg>(*nh_, "/disp/safety_map_labels");
    cloud_labels_ = new Latest<SafetyMapMsg>(*nh_, "/cloud/safety_map_labels");
    disp_timings_ = new Latest<StageTimingsMsg>(*nh_, "/disp/stage_timings");
    cloud_timings_ = new Latest<StageTimingsMsg>(*nh_, "/cloud/stage_timings");
    diagnostics_ = new test_util::DiagnosticsWatcher(*nh_);
    ASSERT_TRUE(disp_->waitForSubscribers(20.0));
    ASSERT_TRUE(cloud_->waitForCloudSubscriber(20.0));
    test_util::sleepFor(0.5);
    // A good map from both inputs.
    for (int i = 0; i < 16; ++i) {
      disp_->publishDisparity(ros::Time::now());
      cloud_->publishCloud(ros::Time::now());
      test_util::sleepFor(0.3);  // slower than the cloud nodelet's max_rate: nothing dropped
    }
    ASSERT_TRUE(waitFor(
        [] { return disp_timings_->get() && disp_timings_->get()->frames_processed >= 14; }, 20));
    ASSERT_TRUE(waitFor(
        [] { return cloud_timings_->get() && cloud_timings_->get()->frames_processed >= 14; }, 20));
    test_util::sleepFor(0.5);
    good_disp_ = disp_labels_->get();
    good_cloud_ = cloud_labels_->get();
    ASSERT_TRUE(good_disp_);
    ASSERT_TRUE(good_cloud_);
  }

  // Labels of cells known by construction: floor Level, box Non-ground.
  static void expectGoodLabels(const SafetyMapMsg& m) {
    const int floor = test_util::cellAt(m.info, 1.3, 0.0);
    const int box = test_util::cellAt(m.info, 2.3, 0.0);
    ASSERT_GE(floor, 0);
    ASSERT_GE(box, 0);
    EXPECT_EQ(m.labels[floor], SafetyMapMsg::LEVEL);
    EXPECT_EQ(m.labels[box], SafetyMapMsg::NON_GROUND);
  }

  // Publishes `bad` (a few times), then checks: no new map, the diagnostic, and that a good
  // frame still gives a map with the same labels.
  // Waits until the nodelet has worked off the frames already sent (no new map for 1 s), so that
  // maps published later come from later messages only.
  static void waitIdle(Latest<SafetyMapMsg>& labels) {
    int count = -1;
    for (int i = 0; i < 20 && labels.count() != count; ++i) {
      count = labels.count();
      test_util::sleepFor(1.0);
    }
  }

  static void checkBad(bool cloud, const std::function<void()>& bad, const std::string& diag_text,
                       int repeat = 3) {
    Latest<SafetyMapMsg>& labels = cloud ? *cloud_labels_ : *disp_labels_;
    waitIdle(labels);
    const std::string name = cloud ? "/cloud/safety_map" : "/disp/safety_map";
    const int before = labels.count();
    const auto last = labels.get();
    diagnostics_->clear();
    for (int i = 0; i < repeat; ++i) {
      bad();
      test_util::sleepFor(0.3);
    }
    EXPECT_TRUE(waitFor([&] { return diagnostics_->seen(name, kWarn, diag_text); }, 5.0))
        << "no WARN diagnostic containing '" << diag_text << "' from " << name;
    test_util::sleepFor(0.3);
    EXPECT_EQ(labels.count(), before)
        << "a map was published for bad input, stamp " << labels.get()->header.stamp;
    EXPECT_EQ(labels.get(), last);
    // Still serving: a good frame gives a new map with the same labels as before.
    if (cloud) {
      cloud_->publishCloud(ros::Time::now());
    } else {
      disp_->publishDisparity(ros::Time::now());
    }
    ASSERT_TRUE(waitFor([&] { return labels.count() > before; }, 10.0))
        << "nodelet stopped serving";
    expectGoodLabels(*labels.get());
    // The good frame only adds evidence: the labels stay (nearly) those of the first good map.
    const auto& now = labels.get()->labels;
    const auto& first = (cloud ? good_cloud_ : good_disp_)->labels;
    ASSERT_EQ(now.size(), first.size());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < now.size(); ++i)
      differ += now[i] != first[i];
    EXPECT_LT(differ, now.size() / 50) << differ << " cells changed";
  }

  static std_msgs::Header header() {
    std_msgs::Header h;
    h.stamp = ros::Time::now();
    h.frame_id = synthetic_scene::kCameraFrame;
    return h;
  }

  static ros::NodeHandle* nh_;
  static tf2_ros::StaticTransformBroadcaster* tf_;
  static test_util::ScenePublisher* disp_;
  static test_util::ScenePublisher* cloud_;
  static Latest<SafetyMapMsg>* disp_labels_;
  static Latest<SafetyMapMsg>* cloud_labels_;
  static Latest<StageTimingsMsg>* disp_timings_;
  static Latest<StageTimingsMsg>* cloud_timings_;
  static test_util::DiagnosticsWatcher* diagnostics_;
  static SafetyMapMsg::ConstPtr good_disp_;
  static SafetyMapMsg::ConstPtr good_cloud_;
};
ros::NodeHandle* BadInputTest::nh_ = nullptr;
tf2_ros::StaticTransformBroadcaster* BadInputTest::tf_ = nullptr;
test_util::ScenePublisher* BadInputTest::disp_ = nullptr;
test_util::ScenePublisher* BadInputTest::cloud_ = nullptr;
Latest<SafetyMapMsg>* BadInputTest::disp_labels_ = nullptr;
Latest<SafetyMapMsg>* BadInputTest::cloud_labels_ = nullptr;
Latest<StageTimingsMsg>* BadInputTest::disp_timings_ = nullptr;
Latest<StageTimingsMsg>* BadInputTest::cloud_timings_ = nullptr;
test_util::DiagnosticsWatcher* BadInputTest::diagnostics_ = nullptr;
SafetyMapMsg::ConstPtr BadInputTest::good_disp_;
SafetyMapMsg::ConstPtr BadInputTest::good_cloud_;

TEST_F(BadInputTest, GoodMapToStartWith) {
  expectGoodLabels(*good_disp_);
  expectGoodLabels(*good_cloud_);
}

TEST_F(BadInputTest, DisparitySizeDiffersFromCameraInfo) {
  checkBad(
      false,
      [] {
        const auto h = header();
        auto l = synthetic_scene::cameraInfo(false, h), r = synthetic_scene::cameraInfo(true, h);
        l.width = r.width = 640;
        l.height = r.height = 480;
        disp_->publishDisparity(disp_->goodDisparity(), l, r, h.stamp);
      },
      "does not match the left CameraInfo");
}

TEST_F(BadInputTest, DisparityDataShorterThanItsSize) {
  checkBad(
      false,
      [] {
        const auto h = header();
        auto d = disp_->goodDisparity();
        d.image.data.resize(d.image.data.size() / 2);
        disp_->publishDisparity(d, synthetic_scene::cameraInfo(false, h),
                                synthetic_scene::cameraInfo(true, h), h.stamp);
      },
      "bytes");
}

TEST_F(BadInputTest, UnsupportedDisparityEncoding) {
  checkBad(
      false,
      [] {
        const auto h = header();
        auto d = disp_->goodDisparity();
        d.image.encoding = "16UC1";
        disp_->publishDisparity(d, synthetic_scene::cameraInfo(false, h),
                                synthetic_scene::cameraInfo(true, h), h.stamp);
      },
      "unsupported encoding '16UC1'");
}

TEST_F(BadInputTest, CameraInfoWithZeroFocalLength) {
  checkBad(
      false,
      [] {
        const auto h = header();
        auto l = synthetic_scene::cameraInfo(false, h);
        l.K.fill(0.0);
        l.P.fill(0.0);
        disp_->publishDisparity(disp_->goodDisparity(), l, synthetic_scene::cameraInfo(true, h),
                                h.stamp);
      },
      "zero focal length");
}

TEST_F(BadInputTest, CameraInfoWithZeroBaseline) {
  checkBad(
      false,
      [] {
        const auto h = header();
        auto r = synthetic_scene::cameraInfo(true, h);
        r.P[3] = 0.0;
        disp_->publishDisparity(disp_->goodDisparity(), synthetic_scene::cameraInfo(false, h), r,
                                h.stamp);
      },
      "zero baseline");
}

TEST_F(BadInputTest, DisparityImageWithZeroBaseline) {
  checkBad(
      false,
      [] {
        const auto h = header();
        auto d = disp_->goodDisparity();
        d.T = 0.0f;
        disp_->publishDisparity(d, synthetic_scene::cameraInfo(false, h),
                                synthetic_scene::cameraInfo(true, h), h.stamp);
      },
      "baseline T");
}

TEST_F(BadInputTest, DisparityAllNaNAndInf) {
  checkBad(
      false,
      [] {
        const auto h = header();
        auto d = disp_->goodDisparity();
        float* px = reinterpret_cast<float*>(d.image.data.data());
        for (std::size_t i = 0; i < d.image.width * d.image.height; ++i) {
          px[i] = (i % 2) ? std::numeric_limits<float>::quiet_NaN()
                          : std::numeric_limits<float>::infinity();
        }
        disp_->publishDisparity(d, synthetic_scene::cameraInfo(false, h),
                                synthetic_scene::cameraInfo(true, h), h.stamp);
      },
      "NaN / inf");
}

TEST_F(BadInputTest, CloudAllNaNAndInf) {
  checkBad(
      true,
      [] {
        auto c = cloud_->goodCloud();
        float* p = reinterpret_cast<float*>(c.data.data());
        for (std::size_t i = 0; i < c.data.size() / sizeof(float); ++i) {
          p[i] = (i % 3) ? std::numeric_limits<float>::quiet_NaN()
                         : -std::numeric_limits<float>::infinity();
        }
        cloud_->publishCloud(c, ros::Time::now());
      },
      "NaN / inf");
}

TEST_F(BadInputTest, CloudWithoutZField) {
  checkBad(
      true,
      [] {
        auto c = cloud_->goodCloud();
        c.fields[2].name = "intensity";
        cloud_->publishCloud(c, ros::Time::now());
      },
      "no field 'z'");
}

TEST_F(BadInputTest, CloudWithDoubleFields) {
  checkBad(
      true,
      [] {
        auto c = cloud_->goodCloud();
        for (auto& f : c.fields)
          f.datatype = sensor_msgs::PointField::FLOAT64;
        cloud_->publishCloud(c, ros::Time::now());
      },
      "not a single FLOAT32");
}

TEST_F(BadInputTest, CloudDataShorterThanItsSize) {
  checkBad(
      true,
      [] {
        auto c = cloud_->goodCloud();
        c.data.resize(c.data.size() - 100);
        cloud_->publishCloud(c, ros::Time::now());
      },
      "bytes");
}

TEST_F(BadInputTest, MissingTf) {
  // A frame nobody publishes a transform for waits in the tf filter until newer frames push it
  // out of its queue (queue_size = 5).
  checkBad(
      true,
      [] {
        auto c = cloud_->goodCloud();
        c.header.frame_id = "no_such_frame";
        cloud_->publishCloud(c, ros::Time::now());
      },
      "no tf", 8);
}

TEST_F(BadInputTest, DisparityWithoutACameraInfoOfItsStampIsNamed) {
  // A driver that stamps the right CameraInfo 10 ms after the disparity: with exact matching
  // (approximate_sync false) no frame completes. Once queue_size = 5 newer disparities wait, the
  // oldest is dropped with a message that says what is missing.
  checkBad(
      false,
      [] {
        std_msgs::Header h = header();
        auto d = disp_->goodDisparity();
        d.header.stamp = d.image.header.stamp = h.stamp;
        const auto left = synthetic_scene::cameraInfo(false, h);
        h.stamp += ros::Duration(0.01);
        disp_->publishDisparityParts(d, left, synthetic_scene::cameraInfo(true, h));
      },
      "CameraInfo published with the disparity's stamp", 8);
}

TEST_F(BadInputTest, FrameOlderThanTheLastIsDropped) {
  waitIdle(*disp_labels_);
  const ros::Time last = disp_labels_->get()->header.stamp;
  checkBad(
      false,
      [last] {
        disp_->publishDisparity(last - ros::Duration(1.0));  // less than time_jump_reset = 5 s
      },
      "out of order");
}

TEST_F(BadInputTest, FramesFasterThanProcessingAreDroppedAndCounted) {
  const auto before = cloud_timings_->get();
  ASSERT_TRUE(before);
  for (int i = 0; i < 20; ++i) {
    cloud_->publishCloud(ros::Time::now());
    test_util::sleepFor(0.02);  // 50 Hz against max_rate 4 Hz
  }
  test_util::sleepFor(1.0);
  cloud_->publishCloud(ros::Time::now());  // one more, so that a map with the counters goes out
  ASSERT_TRUE(waitFor(
      [&] { return cloud_timings_->get()->frames_dropped > before->frames_dropped; }, 10.0));
  EXPECT_GE(cloud_timings_->get()->frames_dropped, before->frames_dropped + 5);
  EXPECT_TRUE(waitFor(
      [] {
        return diagnostics_->lastValue("/cloud/safety_map",
                                       "frames dropped (processing slower than input)") != "0";
      },
      5.0));
  expectGoodLabels(*cloud_labels_->get());
}

// A message from the distant past while the clock runs on (a stale or replayed message, not a
// restart): dropped, the map kept and not reset, however old it is. A restart - the clock going
// back with the stamps, as when a bag is played again - resets the map: safety_map_degraded.test.
TEST_F(BadInputTest, StaleFrameDoesNotResetTheMap) {
  checkBad(
      false,
      [] {
        disp_->publishDisparity(ros::Time::now() - ros::Duration(60.0));  // > time_jump_reset
      },
      "the clock did not go back with it");
  EXPECT_EQ(diagnostics_->lastValue("/disp/safety_map", "map resets"), "0");
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_map_bad_input_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
