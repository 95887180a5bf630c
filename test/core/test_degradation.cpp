// Tests of the dataset degradations (dataset/degradation.h): the presets and their parser, none()
// bit-identical to the undegraded path, the odometry model's drift and chassis statistics against
// its config, and image degradations measured on rendered and synthetic images whose answer is
// known (a 0.5 px vertical shift of an edge, the right gain, vignetting, exposure, motion blur
// and its noise top-up).
#include "stereo_safety_map/dataset/degradation.h"

#include "stereo_safety_map/dataset/scene_loader.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <vector>

namespace ds = stereo_safety_map::dataset;

namespace {

constexpr double kDeg = M_PI / 180.0;

// A plain dark floor and a bright wall 4 m ahead: the wall's foot is a horizontal edge in the
// image of a level camera (pitch 0).
ds::SceneFile wallScene(const std::string& camera = "{pitch_deg: 0, noise_sigma: 0}") {
  const std::string yaml =
      "name: t\nlook: indoor\ncamera: " + camera +
      "\nmaterials:\n"
      "  dark: {texture: plain, colour: 0.2}\n"
      "  bright: {texture: noise, scale: 0.3, contrast: 0.2, colour: 0.7}\n"
      "primitives:\n"
      "  - {type: floor, min: [-1, -5], max: [10, 5], material: dark}\n"
      "  - {type: wall, from: [4, -5], to: [4, 5], height: 3, material: bright}\n";
  ds::SceneFile sf;
  EXPECT_EQ(ds::loadSceneFromString(yaml, "", &sf), "");
  return sf;
}

ds::TrajectoryConfig straight(double length, double speed, double rate) {
  ds::TrajectoryConfig t;
  t.rate_hz = rate;
  t.speed = speed;
  ds::TrajectoryStep go;
  go.kind = ds::TrajectoryStep::Kind::kGo;
  go.x = length;
  t.steps = {go};
  return t;
}

// Sub-pixel row of the strongest vertical gradient in column x, rows [y0, y1): centroid of
// |I(y + 1) - I(y)| around the maximum.
double edgeRow(const cv::Mat& img, int x, int y0, int y1) {
  int best = y0;
  double bv = -1.0;
  for (int y = y0; y < y1; ++y) {
    const double g = std::abs(img.at<std::uint8_t>(y + 1, x) - img.at<std::uint8_t>(y, x));
    if (g > bv) {
      bv = g;
      best = y;
    }
  }
  double s = 0.0, w = 0.0;
  for (int y = best - 4; y <= best + 4; ++y) {
    const double g = std::abs(img.at<std::uint8_t>(y + 1, x) - img.at<std::uint8_t>(y, x));
    s += g * (y + 0.5);
    w += g;
  }
  return s / w;
}

ds::RobotPose still() {
  return ds::RobotPose();
}

}  // namespace

TEST(DegradationConfig, PresetsAndValidation) {
  const ds::DegradationConfig none = ds::DegradationConfig::none();
  const ds::DegradationConfig def = ds::DegradationConfig::defaults();
  const ds::DegradationConfig strong = ds::DegradationConfig::strong();
  EXPECT_EQ(none.validate(), "");
  EXPECT_EQ(def.validate(), "");
  EXPECT_EQ(strong.validate(), "");
  EXPECT_TRUE(none.isNone());
  EXPECT_FALSE(def.isNone());
  // The documented defaults.
  EXPECT_DOUBLE_EQ(def.chassis_jitter_deg, 0.5);
  EXPECT_DOUBLE_EQ(def.heading_walk_deg, 0.05);
  EXPECT_DOUBLE_EQ(def.distance_scale_error, 0.02);
  EXPECT_DOUBLE_EQ(def.noise_sigma, 3.0);
  EXPECT_DOUBLE_EQ(def.right_gain_mismatch, 0.04);
  EXPECT_DOUBLE_EQ(def.vertical_misrect_px, 0.2);
  EXPECT_DOUBLE_EQ(def.exposure_time_s, 0.008);
  EXPECT_DOUBLE_EQ(def.vignetting, 0.15);
  EXPECT_DOUBLE_EQ(def.exposure_jitter, 0.03);
  EXPECT_FALSE(def.no_grain);
  EXPECT_DOUBLE_EQ(strong.chassis_jitter_deg, 1.5);
  EXPECT_DOUBLE_EQ(strong.heading_walk_deg, 0.2);
  EXPECT_DOUBLE_EQ(strong.distance_scale_error, 0.05);
  EXPECT_DOUBLE_EQ(strong.noise_sigma, 8.0);
  EXPECT_DOUBLE_EQ(strong.right_gain_mismatch, 0.10);
  EXPECT_DOUBLE_EQ(strong.vertical_misrect_px, 0.5);
  EXPECT_DOUBLE_EQ(strong.exposure_time_s, 0.020);
  EXPECT_DOUBLE_EQ(strong.vignetting, 0.35);
  EXPECT_DOUBLE_EQ(strong.exposure_jitter, 0.10);
  EXPECT_TRUE(strong.no_grain);
  ds::DegradationConfig bad = def;
  bad.vignetting = 1.5;
  EXPECT_NE(bad.validate().find("vignetting"), std::string::npos);
  bad = def;
  bad.noise_sigma = -0.5;
  EXPECT_NE(bad.validate().find("noise_sigma"), std::string::npos);
  bad = def;
  bad.heading_walk_deg = std::nan("");
  EXPECT_NE(bad.validate().find("heading_walk_deg"), std::string::npos);
}

TEST(DegradationConfig, Parse) {
  ds::DegradationConfig d;
  ASSERT_EQ(ds::parseDegradation("none", &d), "");
  EXPECT_TRUE(d.isNone());
  ASSERT_EQ(ds::parseDegradation("strong,no_grain=false, noise_sigma=5", &d), "");
  EXPECT_FALSE(d.no_grain);
  EXPECT_DOUBLE_EQ(d.noise_sigma, 5.0);
  EXPECT_DOUBLE_EQ(d.vignetting, 0.35);
  ASSERT_EQ(ds::parseDegradation("vertical_misrect_px=0.5", &d), "");  // on the defaults
  EXPECT_DOUBLE_EQ(d.vertical_misrect_px, 0.5);
  EXPECT_DOUBLE_EQ(d.noise_sigma, 3.0);
  ASSERT_EQ(ds::parseDegradation("default,exposure_step=0.3,exposure_step_period=25", &d), "");
  EXPECT_EQ(d.exposure_step_period, 25);
  // describe() reads back.
  ds::DegradationConfig back;
  ASSERT_EQ(ds::parseDegradation(d.describe(), &back), "");
  EXPECT_EQ(back.describe(), d.describe());
  ASSERT_EQ(ds::parseDegradation(ds::DegradationConfig::strong().describe(), &back), "");
  EXPECT_EQ(back.describe(), ds::DegradationConfig::strong().describe());
  // Errors name the token; the output is left alone.
  const ds::DegradationConfig before = d;
  EXPECT_NE(ds::parseDegradation("medium", &d).find("medium"), std::string::npos);
  EXPECT_NE(ds::parseDegradation("none,fog=1", &d).find("fog"), std::string::npos);
  EXPECT_NE(ds::parseDegradation("none,vignetting=abc", &d).find("vignetting"), std::string::npos);
  EXPECT_NE(ds::parseDegradation("none,vignetting=2", &d).find("vignetting"), std::string::npos);
  EXPECT_NE(ds::parseDegradation("none,no_grain=maybe", &d).find("no_grain"), std::string::npos);
  EXPECT_NE(ds::parseDegradation("none,exposure_step_period=2.5", &d).find("integer"),
            std::string::npos);
  EXPECT_EQ(d.describe(), before.describe());
}

TEST(DegradationConfig, ApplyToRender) {
  ds::SceneFile sf = wallScene("{noise_sigma: 2.5, right_gain: 1.1}");
  ds::StereoHeadConfig cam = sf.camera;
  ds::Scene scene = sf.scene;
  ds::applyToRender(ds::DegradationConfig::none(), &cam, &scene);
  EXPECT_EQ(cam.noise_sigma, 2.5);  // the camera's own value is kept
  EXPECT_EQ(cam.right_gain, 1.1);
  for (std::size_t i = 0; i < scene.materials.size(); ++i)
    EXPECT_EQ(scene.materials[i].grain, sf.scene.materials[i].grain);
  ds::applyToRender(ds::DegradationConfig::defaults(), &cam, &scene);
  EXPECT_EQ(cam.noise_sigma, 3.0);
  EXPECT_NEAR(cam.right_gain, 1.1 * 1.04, 1e-12);
  EXPECT_GT(scene.materials[1].effectiveGrain(), 0.0);
  ds::applyToRender(ds::DegradationConfig::strong(), nullptr, &scene);
  for (const ds::Material& m : scene.materials)
    EXPECT_EQ(m.effectiveGrain(), 0.0);
}

TEST(Degradation, NoneIsBitIdentical) {
  ds::SceneFile sf = wallScene("{pitch_deg: 20}");  // default noise 2
  const ds::DegradationConfig none = ds::DegradationConfig::none();
  ds::StereoHeadConfig cam = sf.camera;
  ds::Scene scene = sf.scene;
  ds::applyToRender(none, &cam, &scene);
  const ds::TrajectoryConfig t = straight(1.0, 0.5, 10.0);
  const std::vector<ds::RobotPose> poses = ds::sampleTrajectory(t);
  ds::StereoRenderer plain(sf.scene, sf.camera, 7), degraded(scene, cam, 7);
  ds::OdometryErrorModel odom(none, 7);
  ds::ImageDegrader images(none, 7);
  const Eigen::Isometry3d T_base_opt = sf.camera.baseToLeftOptical();
  for (std::size_t i = 0; i < poses.size(); i += 4) {
    const ds::RobotPose& p = poses[i];
    const Eigen::Isometry3d truth = ds::basePose(p.x, p.y, t.base_z, p.yaw) * T_base_opt;
    const ds::OdometryErrorModel::FramePoses f = odom.next(p, cam);
    EXPECT_TRUE(f.true_left_optical.matrix() == truth.matrix());
    EXPECT_TRUE(f.reported_left_optical.matrix() == truth.matrix());
    EXPECT_TRUE(f.reported_base.matrix() == ds::basePose(p.x, p.y, t.base_z, p.yaw).matrix());
    cv::Mat l0, r0, l1, r1;
    plain.render(truth, i, &l0, &r0);
    degraded.render(f.true_left_optical, i, &l1, &r1);
    images.apply(i, p, cam, &l1, &r1);
    EXPECT_EQ(cv::norm(l0, l1, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(r0, r1, cv::NORM_INF), 0.0);
  }
}

TEST(OdometryErrorModel, HeadingWalkGrowsWithTheSquareRootOfTheFrames) {
  ds::DegradationConfig d = ds::DegradationConfig::none();
  d.heading_walk_deg = 0.05;
  const std::vector<ds::RobotPose> poses = ds::sampleTrajectory(straight(5.0, 0.5, 10.0));
  ASSERT_EQ(poses.size(), 101u);
  ds::StereoHeadConfig head;
  const int runs = 400;
  double sum = 0.0, sum2 = 0.0, sum_half2 = 0.0;
  for (int s = 0; s < runs; ++s) {
    ds::OdometryErrorModel m(d, 1000 + s);
    double err = 0.0, err_half = 0.0;
    for (std::size_t i = 0; i < poses.size(); ++i) {
      const ds::OdometryErrorModel::FramePoses f = m.next(poses[i], head);
      const Eigen::Vector3d x = f.reported_base.linear().col(0);
      const double e = std::atan2(x.y(), x.x()) - poses[i].yaw;
      if (i == 0) {
        EXPECT_TRUE(f.reported_base.matrix() == f.true_base.matrix());
      }
      if (i == 25) err_half = e;
      err = e;
    }
    sum += err;
    sum2 += err * err;
    sum_half2 += err_half * err_half;
  }
  const double sd = std::sqrt(sum2 / runs - (sum / runs) * (sum / runs)) / kDeg;
  EXPECT_NEAR(sd, 0.05 * std::sqrt(100.0), 0.05);  // 0.5 deg after 100 moving frames, +-10 %
  EXPECT_NEAR(std::sqrt(sum_half2 / runs) / kDeg, 0.05 * std::sqrt(25.0), 0.025);
  EXPECT_NEAR(sum / runs / kDeg, 0.0, 3.0 * 0.5 / std::sqrt(runs));
}

TEST(OdometryErrorModel, DistanceScaleAndPauses) {
  ds::DegradationConfig d = ds::DegradationConfig::none();
  d.distance_scale_error = 0.02;
  ds::TrajectoryConfig t = straight(4.0, 0.5, 10.0);
  ds::TrajectoryStep pause;
  pause.kind = ds::TrajectoryStep::Kind::kPause;
  pause.value = 2.0;
  ds::TrajectoryStep turn;
  turn.kind = ds::TrajectoryStep::Kind::kTurnBy;
  turn.value = 90.0;
  ds::TrajectoryStep go2;
  go2.kind = ds::TrajectoryStep::Kind::kGo;
  go2.x = 4.0;
  go2.y = 2.0;
  t.steps = {pause, t.steps[0], pause, turn, go2};
  ds::OdometryErrorModel m(d, 3);
  ds::StereoHeadConfig head;
  ds::OdometryErrorModel::FramePoses f, prev;
  bool first = true;
  for (const ds::RobotPose& p : ds::sampleTrajectory(t)) {
    f = m.next(p, head);
    if (!first && p.stationary) {  // standing still: odometry does not move
      EXPECT_TRUE(f.reported_base.matrix() == prev.reported_base.matrix());
    }
    first = false;
    prev = f;
  }
  // 4 m along x, then 2 m along y (no heading error): each leg 2 % long.
  EXPECT_NEAR(f.reported_base.translation().x(), 4.0 * 1.02, 1e-9);
  EXPECT_NEAR(f.reported_base.translation().y(), 2.0 * 1.02, 1e-9);
  EXPECT_NEAR(f.true_base.translation().x(), 4.0, 1e-9);
}

TEST(OdometryErrorModel, ChassisJitterAndOffsetTiltOnlyTheTrueCamera) {
  ds::DegradationConfig d = ds::DegradationConfig::none();
  d.chassis_jitter_deg = 0.5;
  d.chassis_pitch_offset_deg = 1.0;
  d.chassis_roll_offset_deg = -0.5;
  ds::TrajectoryConfig t = straight(30.0, 0.5, 10.0);
  ds::TrajectoryStep pause;
  pause.kind = ds::TrajectoryStep::Kind::kPause;
  pause.value = 1.0;
  t.steps.push_back(pause);
  const std::vector<ds::RobotPose> poses = ds::sampleTrajectory(t);
  ds::OdometryErrorModel m(d, 11);
  ds::StereoHeadConfig head;
  const Eigen::Isometry3d T_base_opt = head.baseToLeftOptical();
  double sp = 0.0, sp2 = 0.0, sr = 0.0, sr2 = 0.0;
  int n = 0;
  ds::OdometryErrorModel::FramePoses prev;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const ds::OdometryErrorModel::FramePoses f = m.next(poses[i], head);
    // The reported camera is the reported base times the mount: no tilt.
    EXPECT_TRUE(f.reported_left_optical.matrix() == (f.reported_base * T_base_opt).matrix());
    // The true camera's optical axis is pitched by the tilt: its depression below the horizon
    // is the mount pitch plus the chassis pitch (roll is small).
    const Eigen::Vector3d z = f.true_left_optical.linear().col(2);
    const double depression = -std::asin(z.z()) / kDeg;
    EXPECT_NEAR(depression, head.pitch_deg + f.chassis_pitch_deg, 0.05);
    if (poses[i].stationary && i > 0) {  // held while standing still
      EXPECT_EQ(f.chassis_pitch_deg, prev.chassis_pitch_deg);
      EXPECT_TRUE(f.true_left_optical.matrix() == prev.true_left_optical.matrix());
    } else {
      sp += f.chassis_pitch_deg;
      sp2 += f.chassis_pitch_deg * f.chassis_pitch_deg;
      sr += f.chassis_roll_deg;
      sr2 += f.chassis_roll_deg * f.chassis_roll_deg;
      ++n;
    }
    prev = f;
  }
  ASSERT_GT(n, 500);
  EXPECT_NEAR(sp / n, 1.0, 0.06);
  EXPECT_NEAR(sr / n, -0.5, 0.06);
  EXPECT_NEAR(std::sqrt(sp2 / n - (sp / n) * (sp / n)), 0.5, 0.05);
  EXPECT_NEAR(std::sqrt(sr2 / n - (sr / n) * (sr / n)), 0.5, 0.05);
  // reset() starts the same sequence again.
  m.reset();
  ds::OdometryErrorModel fresh(d, 11);
  EXPECT_EQ(m.next(poses[0], head).chassis_pitch_deg, fresh.next(poses[0], head).chassis_pitch_deg);
}

TEST(ImageDegrader, VerticalMisrectificationShiftsAnEdgeByHalfAPixel) {
  ds::SceneFile sf = wallScene();
  ds::StereoRenderer r(sf.scene, sf.camera, 1);
  const Eigen::Isometry3d T = ds::basePose(0, 0, 0, 0) * sf.camera.baseToLeftOptical();
  cv::Mat l, rgt;
  ASSERT_TRUE(r.render(T, 0, &l, &rgt));
  cv::Mat l2 = l.clone(), r2 = rgt.clone();
  ds::DegradationConfig d = ds::DegradationConfig::none();
  d.vertical_misrect_px = 0.5;
  ds::ImageDegrader deg(d, 1);
  deg.apply(0, still(), sf.camera, &l2, &r2);
  EXPECT_EQ(cv::norm(l, l2, cv::NORM_INF), 0.0);  // the left image is the reference
  // The wall's foot: 4 m - 0.075 m - 0.25 m ahead, 1.1 m below the camera.
  const double row = sf.camera.cy() + sf.camera.fx() * 1.1 / (4.0 - 0.075 - 0.25);
  double shift = 0.0;
  int n = 0;
  for (int x = 100; x < 540; x += 10) {
    const double a = edgeRow(rgt, x, static_cast<int>(row) - 10, static_cast<int>(row) + 10);
    const double b = edgeRow(r2, x, static_cast<int>(row) - 10, static_cast<int>(row) + 10);
    EXPECT_NEAR(a, row, 1.5);
    shift += b - a;
    ++n;
  }
  EXPECT_NEAR(shift / n, 0.5, 0.05);
}

TEST(ImageDegrader, RightGainMismatchScalesTheRightImage) {
  ds::SceneFile sf = wallScene("{pitch_deg: 10, noise_sigma: 0}");
  ds::DegradationConfig d = ds::DegradationConfig::none();
  d.right_gain_mismatch = 0.1;
  ds::StereoHeadConfig cam = sf.camera;
  ds::applyToRender(d, &cam, nullptr);
  ds::StereoRenderer plain(sf.scene, sf.camera, 1), gained(sf.scene, cam, 1);
  const Eigen::Isometry3d T = ds::basePose(0, 0, 0, 0) * sf.camera.baseToLeftOptical();
  cv::Mat l0, r0, l1, r1;
  plain.render(T, 0, &l0, &r0);
  gained.render(T, 0, &l1, &r1);
  EXPECT_EQ(cv::norm(l0, l1, cv::NORM_INF), 0.0);
  const double m0 = cv::mean(r0)[0], m1 = cv::mean(r1)[0];
  ASSERT_GT(m0, 30.0);
  EXPECT_NEAR(m1 / m0, 1.1, 0.005);
}

TEST(ImageDegrader, VignettingAndExposure) {
  ds::DegradationConfig d = ds::DegradationConfig::none();
  d.vignetting = 0.2;
  ds::StereoHeadConfig head;
  head.noise_sigma = 0.0;
  cv::Mat l(480, 640, CV_8UC1, cv::Scalar(200)), r = l.clone();
  ds::ImageDegrader vig(d, 1);
  vig.apply(0, still(), head, &l, &r);
  EXPECT_NEAR(l.at<std::uint8_t>(240, 320), 200, 1);
  EXPECT_NEAR(l.at<std::uint8_t>(0, 0), 160, 1);  // 20 % lost in the corners
  EXPECT_NEAR(r.at<std::uint8_t>(479, 639), 160, 1);
  EXPECT_NEAR(l.at<std::uint8_t>(240, 0),
              200 * (1.0 - 0.2 * 319.5 * 319.5 / (319.5 * 319.5 + 239.5 * 239.5)), 1);
  // Colour (bgr8) images: every channel alike, also through the motion blur.
  cv::Mat lc(48, 64, CV_8UC3, cv::Scalar(200, 100, 50)), rc = lc.clone();
  ds::RobotPose turning;
  turning.omega = 0.5;
  d.exposure_time_s = 0.02;
  ds::ImageDegrader colour(d, 1);
  colour.apply(0, turning, head, &lc, &rc);
  const cv::Vec3b corner = lc.at<cv::Vec3b>(0, 0), centre = lc.at<cv::Vec3b>(24, 32);
  EXPECT_NEAR(corner[0], 160, 1);
  EXPECT_NEAR(corner[1], 80, 1);
  EXPECT_NEAR(corner[2], 40, 1);
  EXPECT_NEAR(centre[1], 100, 1);
  // Exposure jitter: per frame, the same for both cameras, sd as configured, deterministic.
  d = ds::DegradationConfig::none();
  d.exposure_jitter = 0.05;
  ds::ImageDegrader exp1(d, 5), exp2(d, 5);
  double s = 0.0, s2 = 0.0;
  for (std::uint64_t f = 0; f < 4000; ++f) {
    const double g = exp1.exposureGain(f);
    EXPECT_EQ(g, exp2.exposureGain(f));
    s += g;
    s2 += g * g;
  }
  EXPECT_NEAR(s / 4000, 1.0, 0.005);
  EXPECT_NEAR(std::sqrt(s2 / 4000 - (s / 4000) * (s / 4000)), 0.05, 0.004);
  cv::Mat a(48, 64, CV_8UC1, cv::Scalar(100)), b = a.clone();
  exp1.apply(17, still(), head, &a, &b);
  EXPECT_NEAR(a.at<std::uint8_t>(10, 10), 100 * exp1.exposureGain(17), 0.51);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  // Auto-exposure steps: a square wave of the given period.
  d = ds::DegradationConfig::none();
  d.exposure_step = 0.25;
  d.exposure_step_period = 10;
  ds::ImageDegrader step(d, 1);
  EXPECT_EQ(step.exposureGain(0), 1.0);
  EXPECT_EQ(step.exposureGain(9), 1.0);
  EXPECT_EQ(step.exposureGain(10), 1.25);
  EXPECT_EQ(step.exposureGain(19), 1.25);
  EXPECT_EQ(step.exposureGain(20), 1.0);
}

TEST(ImageDegrader, MotionBlurFollowsTheMotionAndKeepsTheNoiseLevel) {
  ds::DegradationConfig d = ds::DegradationConfig::none();
  d.exposure_time_s = 0.02;
  ds::StereoHeadConfig head;
  head.noise_sigma = 0.0;
  ds::ImageDegrader deg(d, 3);
  // Turning at 30 deg/s: every row blurred horizontally by fx * omega * T px.
  ds::RobotPose turn;
  turn.omega = 30.0 * kDeg;
  const double L = head.fx() * turn.omega * 0.02;
  EXPECT_NEAR(deg.blurAt(turn, head, 0).x(), L, 1e-9);
  EXPECT_NEAR(deg.blurAt(turn, head, 0).y(), 0.0, 1e-12);
  // Driving forwards: no blur above the horizon, growing towards the bottom of the image.
  ds::RobotPose drive;
  drive.v = 0.8;
  head.pitch_deg = 10.0;
  EXPECT_EQ(deg.blurAt(drive, head, 0).y(), 0.0);
  EXPECT_GT(deg.blurAt(drive, head, 479).y(), deg.blurAt(drive, head, 300).y());
  EXPECT_GT(deg.blurAt(drive, head, 300).y(), 0.0);
  // Against the geometry: the image row of a ground point D m ahead, when the camera moves by
  // v T (centred on the frame's stamp), at the row where the point is seen.
  const double h = head.mount_z, pitch = 10.0 * kDeg;
  auto rowOf = [&](double D) { return head.cy() + head.fx() * std::tan(std::atan(h / D) - pitch); };
  for (double D : {2.0, 3.5, 6.0}) {
    const double moved = rowOf(D - 0.5 * 0.8 * 0.02) - rowOf(D + 0.5 * 0.8 * 0.02);
    const int row = static_cast<int>(std::lround(rowOf(D)));
    EXPECT_NEAR(deg.blurAt(drive, head, row).y(), moved, 0.02 * moved + 0.01) << D;
  }
  // A vertical step edge spreads over ~L px when turning; standing still leaves it.
  cv::Mat l(60, 200, CV_8UC1, cv::Scalar(50)), r;
  l(cv::Rect(100, 0, 100, 60)).setTo(200);
  r = l.clone();
  cv::Mat orig = l.clone();
  deg.apply(0, still(), head, &l, &r);
  EXPECT_EQ(cv::norm(l, orig, cv::NORM_INF), 0.0);
  deg.apply(0, turn, head, &l, &r);
  int ramp = 0;
  for (int x = 0; x < 200; ++x) {
    const int v = l.at<std::uint8_t>(30, x);
    ramp += v > 55 && v < 195;
  }
  EXPECT_NEAR(ramp, L, 2.5);
  // The rendered noise, averaged down by the blur, is topped back up to its sigma.
  head.noise_sigma = 4.0;
  cv::Mat flat(200, 200, CV_32F), noisy;
  cv::randn(flat, 128.0, 4.0);
  flat.convertTo(noisy, CV_8U);
  cv::Mat noisy_r = noisy.clone();
  deg.apply(1, turn, head, &noisy, &noisy_r);
  cv::Scalar mean, sd;
  cv::meanStdDev(noisy(cv::Rect(20, 20, 160, 160)), mean, sd);
  EXPECT_NEAR(sd[0], 4.0, 0.4);
  EXPECT_NEAR(mean[0], 128.0, 0.5);
}

TEST(ImageDegrader, DeterministicPerFrame) {
  const ds::DegradationConfig d = ds::DegradationConfig::strong();
  ds::SceneFile sf = wallScene("{pitch_deg: 15}");
  ds::StereoHeadConfig cam = sf.camera;
  ds::Scene scene = sf.scene;
  ds::applyToRender(d, &cam, &scene);
  ds::StereoRenderer r(scene, cam, 2);
  cv::Mat l, rr;
  r.render(ds::basePose(0, 0, 0, 0) * cam.baseToLeftOptical(), 3, &l, &rr);
  ds::RobotPose motion;
  motion.v = 0.5;
  motion.omega = 0.2;
  cv::Mat a = l.clone(), b = rr.clone(), c = l.clone(), e = rr.clone(), g = l.clone(),
          h = rr.clone();
  ds::ImageDegrader d1(d, 9), d2(d, 9);
  d1.apply(3, motion, cam, &a, &b);
  d2.apply(3, motion, cam, &c, &e);
  d1.apply(4, motion, cam, &g, &h);
  EXPECT_EQ(cv::norm(a, c, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(b, e, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, g, cv::NORM_L1), 0.0);
  EXPECT_GT(cv::norm(a, l, cv::NORM_L1), 0.0);
}
