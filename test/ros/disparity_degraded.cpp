// Degraded cameras for the disparity nodelet (core/stereo_input_check.h): a black, a saturated
// and a covered (dark, noisy) camera, one camera frozen, both frozen. Each pair is refused with a
// WARN diagnostic naming the camera and what is wrong, no disparity is published for it, and live
// pairs around it are served. Live pairs differ from each other in one pixel, as a real camera's
// noise does; the frozen ones repeat the previous image byte for byte.
#include "disparity_test_util.h"

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <gtest/gtest.h>

#include <random>
#include <string>

using disparity_test::StereoFrame;
using test_util::Latest;
using test_util::waitFor;

namespace {

constexpr int kWarn = diagnostic_msgs::DiagnosticStatus::WARN;
constexpr char kNode[] = "/stereo/disparity";

class Degraded : public ::testing::Test {
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

  // The scene pair with pixel (0, 0) of each image set from a counter: a live camera.
  static StereoFrame live() {
    StereoFrame f = disparity_test::sceneFrame();
    ++noise_;
    f.left.data[0] = static_cast<std::uint8_t>(noise_);
    f.right.data[0] = static_cast<std::uint8_t>(noise_ * 7);
    return f;
  }

  // Publishes `f`; true when a disparity with its stamp came out.
  static bool served(const StereoFrame& f) {
    const ros::Time t = ros::Time::now();
    pub_->publish(f, t);
    return waitFor([t] { return disparity_->get() && disparity_->get()->header.stamp == t; }, 5.0);
  }

  // Publishes `bad` three times after a live pair: no disparity for it, a WARN containing
  // `text`; then a live pair is served again.
  static void expectRefused(const std::function<StereoFrame(const StereoFrame&)>& bad,
                            const std::string& text) {
    StereoFrame previous = live();
    ASSERT_TRUE(served(previous));
    diagnostics_->clear();
    const int before = disparity_->count();
    for (int i = 0; i < 3; ++i) {
      const StereoFrame f = bad(previous);
      pub_->publish(f, ros::Time::now());
      previous = f;
      test_util::sleepFor(0.2);
    }
    EXPECT_TRUE(waitFor([&] { return diagnostics_->seen(kNode, kWarn, text); }, 5.0))
        << "no WARN containing '" << text << "'";
    test_util::sleepFor(0.3);
    EXPECT_EQ(disparity_->count(), before) << "a disparity was published for '" << text << "'";
    EXPECT_TRUE(served(live())) << "not served after '" << text << "'";
  }

  static ros::NodeHandle* nh_;
  static disparity_test::StereoPublisher* pub_;
  static Latest<stereo_msgs::DisparityImage>* disparity_;
  static test_util::DiagnosticsWatcher* diagnostics_;
  static bool subscribed_;
  static int noise_;
};
ros::NodeHandle* Degraded::nh_ = nullptr;
disparity_test::StereoPublisher* Degraded::pub_ = nullptr;
Latest<stereo_msgs::DisparityImage>* Degraded::disparity_ = nullptr;
test_util::DiagnosticsWatcher* Degraded::diagnostics_ = nullptr;
bool Degraded::subscribed_ = false;
int Degraded::noise_ = 0;

TEST_F(Degraded, LivePairsAreServed) {
  for (int i = 0; i < 3; ++i)
    EXPECT_TRUE(served(live()));
}

TEST_F(Degraded, BlackLeftCamera) {
  expectRefused(
      [](const StereoFrame&) {
        StereoFrame f = live();
        std::fill(f.left.data.begin(), f.left.data.end(), 0);
        return f;
      },
      "left image has no contrast");
}

TEST_F(Degraded, SaturatedRightCamera) {
  expectRefused(
      [](const StereoFrame&) {
        StereoFrame f = live();
        std::fill(f.right.data.begin(), f.right.data.end(), 255);
        return f;
      },
      "right image has no contrast");
}

TEST_F(Degraded, CoveredLeftLensDarkAndNoisy) {
  static std::mt19937 rng(5);
  expectRefused(
      [](const StereoFrame&) {
        StereoFrame f = live();
        std::bernoulli_distribution one(0.3);
        for (auto& p : f.left.data)
          p = one(rng) ? 4 : 3;
        return f;
      },
      "left image has no contrast");
}

TEST_F(Degraded, FrozenRightCamera) {
  expectRefused(
      [](const StereoFrame& previous) {
        StereoFrame f = live();
        f.right = previous.right;  // the right driver re-sends its last image
        return f;
      },
      "right camera frozen");
}

TEST_F(Degraded, FrozenLeftCamera) {
  expectRefused(
      [](const StereoFrame& previous) {
        StereoFrame f = live();
        f.left = previous.left;
        return f;
      },
      "left camera frozen");
}

TEST_F(Degraded, BothCamerasFrozen) {
  expectRefused([](const StereoFrame& previous) { return previous; }, "both cameras");
}

TEST_F(Degraded, CountedByProblem) {
  auto count = [](const std::string& key) {
    const std::string v = diagnostics_->lastValue(kNode, key);
    return v.empty() ? 0L : std::stol(v);
  };
  EXPECT_TRUE(waitFor([&] { return count("problem: left image without contrast") >= 6; }, 5.0));
  EXPECT_GE(count("problem: right image without contrast"), 3);
  EXPECT_GE(count("problem: right camera frozen"), 3);
  EXPECT_GE(count("problem: left camera frozen"), 3);
  EXPECT_GE(count("problem: both cameras frozen"), 3);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "disparity_degraded_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
