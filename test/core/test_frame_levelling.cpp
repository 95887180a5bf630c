// Re-levelling of a frame on the robot's ground (frame_levelling.h), on worlds whose answer is
// known: a level floor seen by a camera whose reported pose is off by a known pitch, roll and
// height; a ramp ahead that is not reference ground; errors too large to be chassis bobbing.
#include "stereo_safety_map/core/frame_levelling.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

namespace stereo_safety_map {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The true camera: 1.1 m above the floor at the origin, looking along +x, pitched down 22 deg
// (optical frame: x right, y down, z forward).
Eigen::Isometry3d trueCamera() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d link_to_optical;
  link_to_optical << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  T.linear() =
      Eigen::AngleAxisd(22.0 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix() * link_to_optical;
  T.translation() = Eigen::Vector3d(0.0, 0.0, 1.1);
  return T;
}

// Points (sensor frame) of the floor z = 0 for x in [1, 5], |y| <= 2, and of a ramp rising 10
// deg from x = 3 for |y| <= 0.5 when `ramp`; 1 cm noise.
std::vector<Eigen::Vector3f> floorPoints(const Eigen::Isometry3d& T_true, bool ramp) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Eigen::Vector3f> pts;
  for (double x = 1.0; x <= 5.0; x += 0.03) {
    for (double y = -2.0; y <= 2.0; y += 0.03) {
      double z = 0.0;
      if (ramp && x > 3.0 && std::abs(y) <= 0.5) z = std::tan(10.0 * kDeg) * (x - 3.0);
      const Eigen::Vector3d p(x, y, z + noise(rng));
      pts.push_back((T_true.inverse() * p).cast<float>());
    }
  }
  return pts;
}

// Reference ground: the robot's level floor at z = 0, except the ramp's cells.
float reference(float x, float y) {
  if (x > 2.9f && std::abs(y) <= 0.6f) return std::numeric_limits<float>::quiet_NaN();
  return 0.0f;
}

// The reported pose: the true one rotated about the camera by (roll, pitch) and raised by dz.
Eigen::Isometry3d reported(const Eigen::Isometry3d& T_true, double roll_deg, double pitch_deg,
                           double dz) {
  Eigen::Isometry3d T = T_true;
  T.linear() = (Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(pitch_deg * kDeg, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix() *
               T_true.linear();
  T.translation().z() += dz;
  return T;
}

// Largest height error of the floor points through a pose.
double worstFloorError(const std::vector<Eigen::Vector3f>& pts, const Eigen::Isometry3f& T) {
  double worst = 0.0;
  for (const Eigen::Vector3f& p : pts) {
    const Eigen::Vector3f q = T * p;
    if (std::isfinite(reference(q.x(), q.y()))) worst = std::max(worst, std::abs(q.z() * 1.0));
  }
  return worst;
}

// relevel is off by default (config/safety_map.yaml says why); these tests switch it on.
FrameLevellingConfig enabledConfig() {
  FrameLevellingConfig c;
  c.enabled = true;
  return c;
}

TEST(FrameLevellingConfig, Validate) {
  EXPECT_EQ(FrameLevellingConfig().validate(), "");
  FrameLevellingConfig c;
  c.max_correction_deg = 0.0;
  EXPECT_NE(c.validate().find("relevel_max_deg"), std::string::npos);
  c = FrameLevellingConfig();
  c.stride = 0;
  EXPECT_NE(c.validate().find("relevel_stride"), std::string::npos);
  c = FrameLevellingConfig();
  c.near_radius = -0.1;
  EXPECT_NE(c.validate().find("relevel_near_radius"), std::string::npos);
  c.near_radius = std::nan("");
  EXPECT_NE(c.validate().find("relevel_near_radius"), std::string::npos);
  c = FrameLevellingConfig();
  c.filter_frames = 1001;
  EXPECT_NE(c.validate().find("relevel_filter_frames"), std::string::npos);
}

TEST(FrameLevelling, UndoesAnUnreportedPitchRollAndHeightOnTheRobotsFloor) {
  const Eigen::Isometry3d T_true = trueCamera();
  const std::vector<Eigen::Vector3f> pts = floorPoints(T_true, true);
  const Eigen::Isometry3f T_rep = reported(T_true, 0.6, -0.9, 0.02).cast<float>();
  ASSERT_GT(worstFloorError(pts, T_rep), 0.06);  // 0.9 deg at 5 m
  Eigen::Isometry3f T_fixed;
  FrameLevellingResult r;
  ASSERT_TRUE(levelFrame(pts, T_rep, reference, enabledConfig(), &T_fixed, &r));
  EXPECT_TRUE(r.applied);
  EXPECT_NEAR(r.roll_deg, -0.6, 0.05);
  EXPECT_NEAR(r.pitch_deg, 0.9, 0.05);
  EXPECT_NEAR(r.dz, -0.02, 0.005);
  EXPECT_LT(r.rms_after, r.rms_before);
  EXPECT_LT(worstFloorError(pts, T_fixed), 0.045);  // the noise (1 cm, 4.5 sigma)
  // The ramp (not reference ground) keeps its slope: its points through the corrected pose.
  for (const Eigen::Vector3f& p : pts) {
    const Eigen::Vector3f q = T_fixed * p;
    if (q.x() > 3.5f && q.x() < 4.5f && std::abs(q.y()) < 0.4f) {
      EXPECT_NEAR(q.z(), std::tan(10.0 * kDeg) * (q.x() - 3.0), 0.05);
    }
  }
}

// The ground within 3 m of the robot as the safety mapper's near_radius reference sees it: the
// base's level plane everywhere, though a sunken area 5.6 cm lower lies on the right (y < -0.4,
// x in [1.4, 3]) and a ramp falls 10 deg on the left from x = 2 (y > 0.6); 1 cm noise.
std::vector<Eigen::Vector3f> nearGroundPoints(const Eigen::Isometry3d& T_true) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Eigen::Vector3f> pts;
  for (double x = 1.2; x <= 3.0; x += 0.02) {
    for (double y = -1.5; y <= 1.5; y += 0.02) {
      double z = 0.0;
      if (y < -0.4 && x >= 1.4) z = -0.056;
      if (y > 0.6 && x >= 2.0) z = -std::tan(10.0 * kDeg) * (x - 2.0);
      const Eigen::Vector3d p(x, y, z + noise(rng));
      pts.push_back((T_true.inverse() * p).cast<float>());
    }
  }
  return pts;
}

TEST(FrameLevelling, TiltAloneWithThePinnedOffsetIgnoresLowerGroundNearTheRobot) {
  const Eigen::Isometry3d T_true = trueCamera();
  const std::vector<Eigen::Vector3f> pts = nearGroundPoints(T_true);
  const GroundReference plane = [](float, float) { return 0.0f; };
  const Eigen::Isometry3f T_rep = reported(T_true, 0.4, -0.5, 0.0).cast<float>();
  FrameLevellingConfig pinned = enabledConfig();
  pinned.estimate_offset = false;
  Eigen::Isometry3f T_fixed;
  FrameLevellingResult r;
  ASSERT_TRUE(levelFrame(pts, T_rep, plane, pinned, &T_fixed, &r));
  // Within 0.1 deg (the ramp's first 14 cm lie inside the 2.5 cm gate): 5 mm at 3 m.
  EXPECT_NEAR(r.roll_deg, -0.4, 0.1);
  EXPECT_NEAR(r.pitch_deg, 0.5, 0.1);
  EXPECT_EQ(r.dz, 0.0);
  // The first rule (offset free, a gate of 10 then 5 cm) takes the sunken area's and the ramp's
  // points into its fit and lands farther off.
  FrameLevellingResult r_free;
  ASSERT_TRUE(levelFrame(pts, T_rep, plane, enabledConfig(), &T_fixed, &r_free));
  const double err_pinned = std::hypot(r.roll_deg + 0.4, r.pitch_deg - 0.5);
  const double err_free = std::hypot(r_free.roll_deg + 0.4, r_free.pitch_deg - 0.5);
  EXPECT_GT(err_free, 2.0 * err_pinned) << err_free << " vs " << err_pinned;
  std::printf("tilt error: pinned %.3f deg, offset free %.3f deg (dz %.3f m)\n", err_pinned,
              err_free, r_free.dz);
}

TEST(FrameLevelling, RefusesWhatIsNotChassisBobbingOrHasNoGround) {
  const Eigen::Isometry3d T_true = trueCamera();
  const std::vector<Eigen::Vector3f> pts = floorPoints(T_true, false);
  Eigen::Isometry3f T_fixed;
  FrameLevellingResult r;
  // 5 deg: beyond max_correction_deg.
  const Eigen::Isometry3f far = reported(T_true, 0.0, 5.0, 0.0).cast<float>();
  EXPECT_FALSE(levelFrame(pts, far, reference, enabledConfig(), &T_fixed, &r));
  EXPECT_FALSE(r.applied);
  EXPECT_TRUE(T_fixed.isApprox(far));
  // No reference ground, or off.
  const Eigen::Isometry3f near = reported(T_true, 0.3, 0.3, 0.0).cast<float>();
  const GroundReference none = [](float, float) { return std::numeric_limits<float>::quiet_NaN(); };
  EXPECT_FALSE(levelFrame(pts, near, none, enabledConfig(), &T_fixed, &r));
  FrameLevellingConfig off;
  off.enabled = false;
  EXPECT_FALSE(levelFrame(pts, near, reference, off, &T_fixed, &r));
  // Too few points, or a strip too narrow to tell the roll.
  const std::vector<Eigen::Vector3f> few(pts.begin(), pts.begin() + 100);
  EXPECT_FALSE(levelFrame(few, near, reference, enabledConfig(), &T_fixed, &r));
  const GroundReference strip = [](float, float y) {
    return std::abs(y) < 0.2f ? 0.0f : std::numeric_limits<float>::quiet_NaN();
  };
  EXPECT_FALSE(levelFrame(pts, near, strip, enabledConfig(), &T_fixed, &r));
}

}  // namespace
}  // namespace stereo_safety_map
