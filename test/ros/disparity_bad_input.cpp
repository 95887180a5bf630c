// Bad input for the disparity nodelet: each case is refused with a diagnostic naming it,
// produces no disparity, and the nodelet keeps serving the good frames that follow.
#include "disparity_test_util.h"

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <gtest/gtest.h>

#include <limits>
#include <string>

using disparity_test::StereoFrame;
using test_util::Latest;
using test_util::waitFor;

namespace {

constexpr int kWarn = diagnostic_msgs::DiagnosticStatus::WARN;
constexpr char kNode[] = "/stereo/disparity";

std::uint64_t valueOf(const test_util::DiagnosticsWatcher& d, const std::string& key) {
  const std::string v = d.lastValue(kNode, key);
  return v.empty() ? 0 : std::stoull(v);
}

sensor_msgs::Image resized(const sensor_msgs::Image& in, unsigned width, unsigned height) {
  sensor_msgs::Image out = in;
  out.width = width;
  out.height = height;
  out.step = width;
  out.data.assign(static_cast<std::size_t>(width) * height, 128);
  for (unsigned v = 0; v < height; ++v) {
    for (unsigned u = 0; u < width; ++u)
      out.data[v * width + u] = in.data[v * 2 * in.step + u * 2];
  }
  return out;
}

sensor_msgs::CameraInfo resized(sensor_msgs::CameraInfo info, unsigned width, unsigned height) {
  const double s = static_cast<double>(width) / info.width;
  info.width = width;
  info.height = height;
  for (int i : {0, 2, 4, 5})
    info.K[i] *= s;
  for (int i : {0, 2, 3, 5, 6})
    info.P[i] *= s;
  return info;
}

class BadInput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    pub_ = new disparity_test::StereoPublisher(*nh_, "/stereo");
    disparity_ = new Latest<stereo_msgs::DisparityImage>(*nh_, "/stereo/disparity");
    diagnostics_ = new test_util::DiagnosticsWatcher(*nh_);
    disparity_test::sceneFrame();
    subscribed_ = pub_->waitForSubscribers(1, 30.0);
    test_util::sleepFor(0.5);
  }
  void SetUp() override { ASSERT_TRUE(subscribed_) << "the disparity nodelet did not subscribe"; }

  /// A good frame produces a disparity: the nodelet is up and serving.
  static void expectServing() {
    const int before = disparity_->count();
    pub_->publishScene(ros::Time::now());
    EXPECT_TRUE(waitFor([&] { return disparity_->count() > before; }, 15.0))
        << "no disparity for a good frame";
  }

  /// `frame` is refused: a WARN diagnostic containing `text`, the problem counter `reason`
  /// goes up, no disparity is published; then good frames are served again.
  static void expectRefused(const StereoFrame& frame, const std::string& reason,
                            const std::string& text) {
    SCOPED_TRACE(reason + ": " + text);
    expectServing();
    const std::uint64_t problems = valueOf(*diagnostics_, "problem: " + reason);
    diagnostics_->clear();
    const int before = disparity_->count();
    pub_->publish(frame, ros::Time::now());
    EXPECT_TRUE(waitFor([&] { return diagnostics_->seen(kNode, kWarn, text); }, 10.0))
        << "no WARN diagnostic saying '" << text << "'";
    EXPECT_TRUE(
        waitFor([&] { return valueOf(*diagnostics_, "problem: " + reason) >= problems + 1; }, 5.0))
        << "'problem: " << reason << "' not counted";
    test_util::sleepFor(0.3);
    EXPECT_EQ(disparity_->count(), before) << "a disparity was published for a bad frame";
    expectServing();
  }

  static ros::NodeHandle* nh_;
  static disparity_test::StereoPublisher* pub_;
  static Latest<stereo_msgs::DisparityImage>* disparity_;
  static test_util::DiagnosticsWatcher* diagnostics_;
  static bool subscribed_;
};
ros::NodeHandle* BadInput::nh_ = nullptr;
disparity_test::StereoPublisher* BadInput::pub_ = nullptr;
Latest<stereo_msgs::DisparityImage>* BadInput::disparity_ = nullptr;
test_util::DiagnosticsWatcher* BadInput::diagnostics_ = nullptr;
bool BadInput::subscribed_ = false;

// First, while no problem is recent (a recent problem takes the diagnostic's summary).
TEST_F(BadInput, FramesFasterThanProcessingAreDroppedAndCounted) {
  expectServing();
  diagnostics_->clear();
  ros::Time stamp = ros::Time::now();
  for (int i = 0; i < 100; ++i) {
    pub_->publishScene(stamp);
    stamp += ros::Duration(0.001);
  }
  EXPECT_TRUE(waitFor(
      [&] { return valueOf(*diagnostics_, "frames dropped (input faster than processing)") > 0; },
      15.0))
      << "no dropped frame counted";
  EXPECT_TRUE(waitFor([&] { return diagnostics_->seen(kNode, kWarn, "dropping frames"); }, 10.0))
      << "no WARN diagnostic about dropped frames";
  test_util::sleepFor(1.0);
  // The newest frame won: the last disparity is the last frame's.
  ASSERT_TRUE(disparity_->get());
  EXPECT_EQ(disparity_->get()->header.stamp, stamp - ros::Duration(0.001));
  expectServing();
}

TEST_F(BadInput, LeftAndRightImageSizesDiffer) {
  StereoFrame f = disparity_test::sceneFrame();
  f.right = resized(f.right, 160, 120);
  expectRefused(f, "size mismatch", "differ in size");
}

TEST_F(BadInput, ImageSizeDiffersFromCameraInfo) {
  StereoFrame f = disparity_test::sceneFrame();
  f.left = resized(f.left, 160, 120);
  f.right = resized(f.right, 160, 120);
  expectRefused(f, "size mismatch", "the CameraInfo says 320x240");
}

TEST_F(BadInput, CameraInfoSizesDiffer) {
  StereoFrame f = disparity_test::sceneFrame();
  f.right_info = resized(f.right_info, 160, 120);
  expectRefused(f, "bad camera info", "CameraInfo sizes differ");
}

TEST_F(BadInput, UnsupportedEncodings) {
  StereoFrame f = disparity_test::sceneFrame();
  for (sensor_msgs::Image* img : {&f.left, &f.right}) {
    img->encoding = "16UC1";
    img->step *= 2;
    img->data.resize(img->data.size() * 2, 0);
  }
  expectRefused(f, "unsupported encoding", "unsupported encoding '16UC1'");
  f = disparity_test::sceneFrame();
  f.right.encoding = "bayer_rggb8";
  expectRefused(f, "unsupported encoding", "unsupported encoding 'bayer_rggb8'");
}

TEST_F(BadInput, TruncatedImageData) {
  StereoFrame f = disparity_test::sceneFrame();
  f.left.data.resize(f.left.data.size() / 2);
  expectRefused(f, "bad image", "left image data has");
}

TEST_F(BadInput, ZeroFocalLength) {
  StereoFrame f = disparity_test::sceneFrame();
  f.left_info.K[0] = f.left_info.P[0] = 0.0;
  expectRefused(f, "bad camera info", "zero focal length");
}

TEST_F(BadInput, ZeroBaseline) {
  StereoFrame f = disparity_test::sceneFrame();
  f.right_info.P[3] = 0.0;
  expectRefused(f, "bad camera info", "zero baseline");
}

TEST_F(BadInput, NaNInCameraInfo) {
  StereoFrame f = disparity_test::sceneFrame();
  f.left_info.P[2] = std::numeric_limits<double>::quiet_NaN();
  expectRefused(f, "bad camera info", "non-finite");
}

TEST_F(BadInput, ImagesTooNarrowForTheDisparityRange) {
  StereoFrame f = disparity_test::sceneFrame();
  f.left = resized(f.left, 64, 48);
  f.right = resized(f.right, 64, 48);
  f.left_info = resized(f.left_info, 64, 48);
  f.right_info = resized(f.right_info, 64, 48);
  expectRefused(f, "disparity failed", "too small");
}

TEST_F(BadInput, DiagnosticsCountEveryRejection) {
  EXPECT_GE(valueOf(*diagnostics_, "frames rejected (bad input)"), 10u);
  EXPECT_GE(valueOf(*diagnostics_, "frames processed"), 10u);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "disparity_bad_input_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
