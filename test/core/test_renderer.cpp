// Tests of the synthetic-dataset sensors: stereo renderer geometry (depth and disparity against
// the analytic values fB/Z, 002 Sec. 3.2), determinism, the laser simulator and trajectories with
// stationary frames (000 Sec. IV).
#include "stereo_safety_map/dataset/laser.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene.h"
#include "stereo_safety_map/dataset/texture.h"
#include "stereo_safety_map/dataset/trajectory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace ds = stereo_safety_map::dataset;

namespace {

ds::Material textured(double scale = 0.25, double contrast = 0.6) {
  ds::Material m;
  m.texture = ds::TextureKind::kNoise;
  m.scale = scale;
  m.contrast = contrast;
  m.colour = Eigen::Vector3f(0.5f, 0.5f, 0.5f);
  m.seed = 42;
  return m;
}

ds::Primitive solid(ds::Primitive p, int material, bool ground, const std::string& name) {
  p.material = material;
  p.ground = ground;
  p.name = name;
  return p;
}

// A wall facing the camera whose front face is the plane world x = x_front.
ds::Scene wallScene(double x_front, const ds::Material& m) {
  ds::Scene s;
  const int mat = s.addMaterial("wall", m);
  s.add(solid(ds::makeBox(Eigen::Vector3d(x_front + 0.05, 0, 0), Eigen::Vector3d(0.1, 40, 40)), mat,
              false, "wall"));
  return s;
}

// Left optical frame at `position` looking along world +x (no pitch).
Eigen::Isometry3d lookAlongX(const Eigen::Vector3d& position) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = ds::linkToOpticalRotation();
  T.translation() = position;
  return T;
}

ds::StereoHeadConfig smallHead(double noise = 0.0, double blur = 0.0) {
  ds::StereoHeadConfig c;
  c.width = 320;
  c.height = 240;
  c.hfov_deg = 60.0;
  c.baseline = 0.12;
  c.noise_sigma = noise;
  c.blur_sigma = blur;
  c.threads = 1;
  return c;
}

// Sub-pixel disparity of left pixel (x, y): SSD block matching along the row, integer search and
// then a 0.02 px search around the best shift with the right image linearly interpolated.
double matchDisparity(const cv::Mat& left, const cv::Mat& right, int x, int y, int half, int dmax,
                      int half_y = -1) {
  if (half_y < 0) half_y = half;
  auto cost = [&](double d) {
    double c = 0.0;
    for (int dy = -half_y; dy <= half_y; ++dy)
      for (int dx = -half; dx <= half; ++dx) {
        const double xr = x + dx - d;
        const int x0 = static_cast<int>(std::floor(xr));
        const double a = xr - x0;
        const double r =
            (1.0 - a) * right.at<uchar>(y + dy, x0) + a * right.at<uchar>(y + dy, x0 + 1);
        const double diff = left.at<uchar>(y + dy, x + dx) - r;
        c += diff * diff;
      }
    return c;
  };
  double best = std::numeric_limits<double>::infinity(), best_d = -1.0;
  for (int d = 1; d <= dmax && x - d - half - 2 >= 0; ++d) {
    const double c = cost(d);
    if (c < best) {
      best = c;
      best_d = d;
    }
  }
  const double center = best_d;
  for (double d = center - 1.0; d <= center + 1.0; d += 0.02) {
    const double c = cost(d);
    if (c < best) {
      best = c;
      best_d = d;
    }
  }
  return best_d;
}

}  // namespace

TEST(StereoHeadConfig, DefaultsAreAWheelchairHead) {
  const ds::StereoHeadConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  EXPECT_GE(c.hfov_deg, 50.0);
  EXPECT_LE(c.hfov_deg, 70.0);
  EXPECT_NEAR(c.baseline, 0.12, 1e-12);
  EXPECT_NEAR(c.mount_z, 1.1, 1e-12);
  EXPECT_GT(c.pitch_deg, 0.0);
  EXPECT_NEAR(c.fx(), 320.0 / std::tan(30.0 * M_PI / 180.0), 1e-9);
  EXPECT_NEAR(c.cx(), 319.5, 1e-12);
  EXPECT_NEAR(c.cy(), 239.5, 1e-12);
  // The small test version keeps the field of view.
  const ds::StereoHeadConfig s = c.scaledTo(320, 240);
  EXPECT_NEAR(s.fx(), 0.5 * c.fx(), 1e-9);
}

TEST(StereoHeadConfig, RejectsBadValues) {
  ds::StereoHeadConfig c;
  c.width = 0;
  EXPECT_NE(c.validate().find("width"), std::string::npos);
  c = ds::StereoHeadConfig();
  c.baseline = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(c.validate().find("baseline"), std::string::npos);
  c = ds::StereoHeadConfig();
  c.hfov_deg = 0.0;
  EXPECT_NE(c.validate().find("hfov"), std::string::npos);
  c = ds::StereoHeadConfig();
  c.threads = 0;
  EXPECT_NE(c.validate().find("threads"), std::string::npos);
  c = ds::StereoHeadConfig();
  c.noise_sigma = -1.0;
  EXPECT_NE(c.validate().find("noise_sigma"), std::string::npos);
}

TEST(StereoHeadConfig, MountLooksForwardAndDown) {
  ds::StereoHeadConfig c;
  c.pitch_deg = 20.0;
  const Eigen::Isometry3d T = c.baseToLeftOptical();
  const Eigen::Vector3d z = T.linear() * Eigen::Vector3d::UnitZ();  // optical axis in base
  const double p = 20.0 * M_PI / 180.0;
  EXPECT_NEAR(z.x(), std::cos(p), 1e-12);
  EXPECT_NEAR(z.y(), 0.0, 1e-12);
  EXPECT_NEAR(z.z(), -std::sin(p), 1e-12);
  const Eigen::Vector3d x = T.linear() * Eigen::Vector3d::UnitX();  // image right = robot right
  EXPECT_NEAR(x.y(), -1.0, 1e-12);
  EXPECT_NEAR((T.translation() - Eigen::Vector3d(c.mount_x, c.mount_y, c.mount_z)).norm(), 0.0,
              1e-12);
}

TEST(StereoRenderer, InvalidInputThrows) {
  ds::Scene s = wallScene(3.0, textured());
  ds::StereoHeadConfig c = smallHead();
  c.width = -5;
  EXPECT_THROW(ds::StereoRenderer(s, c, 1), std::invalid_argument);
  s.primitives[0].material = 7;  // no such material
  EXPECT_THROW(ds::StereoRenderer(s, smallHead(), 1), std::invalid_argument);
}

TEST(StereoRenderer, NonFinitePoseIsRejected) {
  ds::StereoRenderer r(wallScene(4.0, textured()), smallHead(), 1);
  cv::Mat left, right;
  Eigen::Isometry3d T = lookAlongX(Eigen::Vector3d(0, 0, 1));
  T.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(r.render(T, 0, &left, &right));
  EXPECT_TRUE(left.empty());
  EXPECT_TRUE(r.render(lookAlongX(Eigen::Vector3d(0, 0, 1)), 0, &left, &right));
  EXPECT_FALSE(left.empty());
  // A camera inside a solid (on the near plane of the wall) still renders.
  EXPECT_TRUE(r.render(lookAlongX(Eigen::Vector3d(4.03, 0, 1)), 0, &left, &right));
}

TEST(StereoRenderer, DepthOfAFrontoParallelWallIsItsDistance) {
  ds::StereoRenderer r(wallScene(4.0, textured()), smallHead(), 1);
  cv::Mat left, right, depth, ids;
  r.render(lookAlongX(Eigen::Vector3d(0, 0, 1)), 0, &left, &right, &depth, &ids);
  ASSERT_EQ(depth.type(), CV_32F);
  ASSERT_EQ(ids.type(), CV_32S);
  ASSERT_EQ(left.type(), CV_8UC1);
  ASSERT_EQ(left.size(), cv::Size(320, 240));
  for (int y = 0; y < depth.rows; y += 7)
    for (int x = 0; x < depth.cols; x += 7) {
      ASSERT_NEAR(depth.at<float>(y, x), 4.0f, 1e-5f) << x << "," << y;
      ASSERT_EQ(ids.at<int>(y, x), 0);
    }
}

TEST(StereoRenderer, DepthOfTheFloorMatchesTheAnalyticRayPlaneIntersection) {
  ds::Scene s;
  const int m = s.addMaterial("floor", textured());
  s.add(solid(ds::makeBox(Eigen::Vector3d(5, 0, -0.15), Eigen::Vector3d(20, 20, 0.3)), m, true,
              "floor"));
  const ds::StereoHeadConfig c = smallHead();
  ds::StereoRenderer r(s, c, 1);
  const Eigen::Isometry3d T = ds::basePose(0.5, -0.2, 0.0, 0.3) * c.baseToLeftOptical();
  cv::Mat left, right, depth;
  r.render(T, 0, &left, &right, &depth);
  int checked = 0;
  for (int y = 0; y < c.height; y += 5) {
    for (int x = 0; x < c.width; x += 5) {
      const Eigen::Vector3d d =
          T.linear() * Eigen::Vector3d((x - c.cx()) / c.fx(), (y - c.cy()) / c.fx(), 1.0);
      if (d.z() >= -1e-6) {
        EXPECT_TRUE(std::isinf(depth.at<float>(y, x))) << "sky at " << x << "," << y;
        continue;
      }
      const double t = -T.translation().z() / d.z();  // optical z of d is 1, so t = Z
      const Eigen::Vector3d p = T.translation() + t * d;
      if (std::abs(p.x() - 5) > 9.9 || std::abs(p.y()) > 9.9) continue;  // off the slab
      EXPECT_NEAR(depth.at<float>(y, x), t, 1e-4 * t) << x << "," << y;
      ++checked;
    }
  }
  EXPECT_GT(checked, 500);
}

TEST(StereoRenderer, RightImageIsTheLeftShiftedByTheIntegerDisparity) {
  // Rectified by construction: at depth Z = f B / d a point moves d pixels left in the right image.
  const ds::StereoHeadConfig c = smallHead();
  const int d = 12;
  const double Z = c.fx() * c.baseline / d;
  ds::StereoRenderer r(wallScene(Z, textured(0.15, 0.8)), c, 3);
  cv::Mat left, right;
  r.render(lookAlongX(Eigen::Vector3d(0, 0, 1)), 0, &left, &right);
  double sum = 0.0;
  int n = 0, worst = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = d; x < c.width; ++x) {
      const int diff = std::abs(int(left.at<uchar>(y, x)) - int(right.at<uchar>(y, x - d)));
      worst = std::max(worst, diff);
      sum += diff;
      ++n;
    }
  EXPECT_LE(worst, 2);
  EXPECT_LT(sum / n, 0.3);
  // ...and not a pattern that matches at every shift.
  double off = 0.0;
  for (int y = 0; y < c.height; ++y)
    for (int x = d + 3; x < c.width; ++x)
      off += std::abs(int(left.at<uchar>(y, x)) - int(right.at<uchar>(y, x - d - 3)));
  EXPECT_GT(off / n, 5.0);
}

TEST(StereoRenderer, MatchedDisparityOnAWallIsFBOverZ) {
  // Optical blur as in the datasets; no image noise, so that the error is the renderer's.
  const ds::StereoHeadConfig c = smallHead(0.0, 0.5);
  const double Z = 2.7;  // a non-integer disparity
  const double expected = c.fx() * c.baseline / Z;
  ds::StereoRenderer r(wallScene(Z, textured(0.1, 0.6)), c, 5);
  cv::Mat left, right;
  r.render(lookAlongX(Eigen::Vector3d(0, 0, 1)), 0, &left, &right);
  int n = 0;
  double sum_abs = 0.0;
  for (int y = 20; y < c.height - 20; y += 20)
    for (int x = 60; x < c.width - 20; x += 20) {
      const double dm = matchDisparity(left, right, x, y, 7, 40);
      EXPECT_NEAR(dm, expected, 0.25) << x << "," << y;
      sum_abs += std::abs(dm - expected);
      ++n;
    }
  EXPECT_LT(sum_abs / n, 0.08);
}

TEST(StereoRenderer, MatchedDisparityOnTheFloorMatchesItsDepthBuffer) {
  ds::Scene s;
  const int m = s.addMaterial("floor", textured(0.1, 0.7));
  s.add(solid(ds::makeBox(Eigen::Vector3d(5, 0, -0.15), Eigen::Vector3d(20, 20, 0.3)), m, true,
              "floor"));
  const ds::StereoHeadConfig c = smallHead(0.0, 0.5);
  ds::StereoRenderer r(s, c, 9);
  cv::Mat left, right, depth;
  r.render(ds::basePose(0, 0, 0, 0) * c.baseToLeftOptical(), 0, &left, &right, &depth);
  int n = 0;
  for (int y = 150; y < c.height - 10; y += 15)
    for (int x = 70; x < c.width - 20; x += 25) {
      const double Z = depth.at<float>(y, x);
      ASSERT_TRUE(std::isfinite(Z));
      // Wide, 3-row window: on the floor the disparity changes by ~0.1 px per row but not along
      // a row.
      const double dm = matchDisparity(left, right, x, y, 12, 50, 1);
      EXPECT_NEAR(dm, c.fx() * c.baseline / Z, 0.25) << x << "," << y << " Z=" << Z;
      ++n;
    }
  EXPECT_GT(n, 20);
}

TEST(StereoRenderer, OcclusionKeepsTheNearestSurface) {
  ds::Scene s = wallScene(5.0, textured());
  s.add(solid(ds::makeBox(Eigen::Vector3d(2.0, 0, 1.0), Eigen::Vector3d(0.4, 0.4, 0.4)), 0, false,
              "box"));
  ds::StereoRenderer r(s, smallHead(), 1);
  cv::Mat left, right, depth, ids;
  r.render(lookAlongX(Eigen::Vector3d(0, 0, 1)), 0, &left, &right, &depth, &ids);
  const ds::StereoHeadConfig c = smallHead();
  const int cx = static_cast<int>(c.cx()), cy = static_cast<int>(c.cy());
  EXPECT_NEAR(depth.at<float>(cy, cx), 1.8f, 1e-5f);  // front face of the box
  EXPECT_EQ(ids.at<int>(cy, cx), 1);
  EXPECT_NEAR(depth.at<float>(5, 5), 5.0f, 1e-5f);
  EXPECT_EQ(ids.at<int>(5, 5), 0);
}

TEST(StereoRenderer, RenderDepthCastsWhatRenderCasts) {
  ds::Scene s = wallScene(5.0, textured());
  s.add(solid(ds::makeBox(Eigen::Vector3d(2.0, 0.1, 0.9), Eigen::Vector3d(0.4, 0.4, 0.4)), 0, false,
              "box"));
  ds::StereoRenderer r(s, smallHead(), 1);
  const Eigen::Isometry3d T = lookAlongX(Eigen::Vector3d(0, 0, 1));
  cv::Mat left, right, depth, ids, depth_only, ids_only;
  ASSERT_TRUE(r.renderDepth(T, &depth_only, &ids_only));
  r.render(T, 0, &left, &right, &depth, &ids);
  ASSERT_EQ(depth_only.size(), depth.size());
  EXPECT_EQ(cv::countNonZero(depth_only != depth), 0);  // the same values, +inf included
  EXPECT_EQ(cv::countNonZero(ids_only != ids), 0);
  EXPECT_GT(cv::countNonZero(ids_only == 1), 0);  // the box is seen
  // A render after renderDepth still shades: its images are those of a fresh renderer.
  ds::StereoRenderer fresh(s, smallHead(), 1);
  cv::Mat l2, r2;
  fresh.render(T, 0, &l2, &r2);
  ASSERT_TRUE(r.renderDepth(T, &depth_only));
  r.render(T, 0, &left, &right);
  EXPECT_EQ(cv::countNonZero(left != l2), 0);
  EXPECT_EQ(cv::countNonZero(right != r2), 0);
  Eigen::Isometry3d bad = T;
  bad(0, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(r.renderDepth(bad, &depth_only));
}

TEST(StereoRenderer, DeterministicWhateverTheThreadCount) {
  ds::StereoHeadConfig c1 = smallHead(2.0, 0.5), c2 = c1;
  c2.threads = 2;
  const ds::Scene s = wallScene(3.0, textured());
  ds::StereoRenderer r1(s, c1, 77), r2(s, c2, 77), r3(s, c1, 78);
  const Eigen::Isometry3d T = lookAlongX(Eigen::Vector3d(0, 0, 1));
  cv::Mat a_l, a_r, b_l, b_r, c_l, c_r, d_l, d_r;
  r1.render(T, 10, &a_l, &a_r);
  r2.render(T, 10, &b_l, &b_r);
  EXPECT_EQ(cv::norm(a_l, b_l, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a_r, b_r, cv::NORM_INF), 0.0);
  r1.render(T, 11, &c_l, &c_r);  // another frame: same scene, new image noise
  EXPECT_GT(cv::norm(a_l, c_l, cv::NORM_L1), 0.0);
  EXPECT_LT(cv::norm(a_l, c_l, cv::NORM_L1) / a_l.total(), 6.0);
  r3.render(T, 10, &d_l, &d_r);  // another seed: new noise
  EXPECT_GT(cv::norm(a_l, d_l, cv::NORM_L1), 0.0);
}

TEST(StereoRenderer, TexturelessSurfaceHasOnlyImageNoise) {
  ds::Material plain;
  plain.texture = ds::TextureKind::kPlain;
  plain.colour = Eigen::Vector3f(0.6f, 0.6f, 0.6f);
  {
    ds::StereoRenderer r(wallScene(3.0, plain), smallHead(0.0, 0.0), 1);
    cv::Mat left, right;
    r.render(lookAlongX(Eigen::Vector3d(0, 0, 1)), 0, &left, &right);
    double mn, mx;
    cv::minMaxLoc(left, &mn, &mx);
    EXPECT_EQ(mn, mx);  // nothing for stereo to match
  }
  ds::StereoRenderer r(wallScene(3.0, plain), smallHead(3.0, 0.0), 1);
  cv::Mat left, right;
  r.render(lookAlongX(Eigen::Vector3d(0, 0, 1)), 0, &left, &right);
  cv::Scalar mean, sd;
  cv::meanStdDev(left, mean, sd);
  EXPECT_NEAR(sd[0], 3.0, 0.3);
}

TEST(StereoRenderer, EmptySceneShowsTheSkyAndColourWorks) {
  ds::Scene s;
  ds::StereoHeadConfig c = smallHead();
  c.colour = true;
  ds::StereoRenderer r(s, c, 1);
  cv::Mat left, right, depth;
  r.render(lookAlongX(Eigen::Vector3d(0, 0, 1)), 0, &left, &right, &depth);
  ASSERT_EQ(left.type(), CV_8UC3);
  ASSERT_EQ(right.type(), CV_8UC3);
  EXPECT_TRUE(std::isinf(depth.at<float>(120, 160)));
  // Looking up shows more of the zenith colour than at the horizon (blue channel dominates).
  const cv::Vec3b top = left.at<cv::Vec3b>(0, 160);
  EXPECT_GT(top[0], top[2]);
}

TEST(StereoRenderer, ReusesOutputBuffers) {
  ds::StereoRenderer r(wallScene(3.0, textured()), smallHead(), 1);
  cv::Mat left, right;
  const Eigen::Isometry3d T = lookAlongX(Eigen::Vector3d(0, 0, 1));
  r.render(T, 0, &left, &right);
  const uchar* p = left.data;
  r.render(T, 1, &left, &right);
  EXPECT_EQ(p, left.data);
}

TEST(Texture, BandLimitedAndBounded) {
  ds::Material m = textured(0.3, 0.5);
  for (ds::TextureKind k :
       {ds::TextureKind::kPlain, ds::TextureKind::kNoise, ds::TextureKind::kSpeckle,
        ds::TextureKind::kTiles, ds::TextureKind::kBricks, ds::TextureKind::kStripes,
        ds::TextureKind::kChecker}) {
    m.texture = k;
    double lo = 1e9, hi = -1e9;
    for (int i = 0; i < 2000; ++i) {
      const double t = ds::evaluateTexture(m, 0.0137 * i, 0.0071 * i - 3.0, 0.002);
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
    EXPECT_GE(lo, -1.0);
    EXPECT_LE(hi, 1.0);
    if (k != ds::TextureKind::kPlain) {
      EXPECT_GT(hi - lo, 0.3) << ds::toString(k);
    }
    // Seen from far away (footprint far above the pattern size) the pattern averages out.
    double far_lo = 1e9, far_hi = -1e9;
    for (int i = 0; i < 200; ++i) {
      const double t = ds::evaluateTexture(m, 0.37 * i, 0.21 * i, 10.0);
      far_lo = std::min(far_lo, t);
      far_hi = std::max(far_hi, t);
    }
    EXPECT_LT(far_hi - far_lo, 1e-9) << ds::toString(k);
  }
  ds::TextureKind k;
  EXPECT_TRUE(ds::parseTextureKind("tiles", &k));
  EXPECT_EQ(k, ds::TextureKind::kTiles);
  EXPECT_FALSE(ds::parseTextureKind("marble", &k));
}

TEST(Laser, RangesToAWallAndNothingBeyondADropOff) {
  ds::Scene s = wallScene(5.0, textured());
  // Floor that ends in a drop-off to the left: a horizontal laser cannot see it (001 Sec. 1).
  s.add(solid(ds::makeBox(Eigen::Vector3d(2, -2, -0.15), Eigen::Vector3d(8, 8, 0.3)), 0, true,
              "floor"));
  ds::LaserConfig c;
  c.noise_sigma = 0.0;
  ASSERT_EQ(c.validate(), "");
  EXPECT_EQ(c.beamCount(), 361);
  std::vector<float> ranges;
  const Eigen::Isometry3d T = ds::basePose(0, 0, 0, 0) * c.baseToLaser();
  ds::simulateScan(s, c, T, 1, 0, &ranges);
  ASSERT_EQ(ranges.size(), 361u);
  EXPECT_NEAR(ranges[180], 5.0 - c.mount_x, 1e-5);  // straight ahead
  const double a = 30.0 * M_PI / 180.0;             // beam 240 = +30 deg
  EXPECT_NEAR(ranges[240], (5.0 - c.mount_x) / std::cos(a), 1e-4);
  EXPECT_TRUE(std::isinf(ranges[360]));  // +90 deg: open side
  // With noise the ranges scatter around the truth, reproducibly.
  c.noise_sigma = 0.01;
  std::vector<float> n1, n2;
  ds::simulateScan(s, c, T, 1, 3, &n1);
  ds::simulateScan(s, c, T, 1, 3, &n2);
  EXPECT_EQ(n1, n2);
  EXPECT_NEAR(n1[180], 5.0 - c.mount_x, 0.06);
  EXPECT_NE(n1[180], ranges[180]);
  c.angle_increment_deg = 0.0;
  EXPECT_NE(c.validate().find("angle_increment"), std::string::npos);
}

TEST(Trajectory, PausesGiveStationaryFrames) {
  ds::TrajectoryConfig t;
  t.rate_hz = 10.0;
  t.speed = 0.5;
  ds::TrajectoryStep pause;
  pause.kind = ds::TrajectoryStep::Kind::kPause;
  pause.value = 1.0;
  ds::TrajectoryStep go;
  go.kind = ds::TrajectoryStep::Kind::kGo;
  go.x = 2.0;
  go.y = 0.0;
  t.steps = {pause, go, pause};
  ASSERT_EQ(t.validate(), "");
  EXPECT_NEAR(ds::trajectoryDuration(t), 1.0 + 4.0 + 1.0, 1e-12);
  const auto poses = ds::sampleTrajectory(t);
  ASSERT_EQ(poses.size(), 61u);
  int stationary = 0;
  for (const auto& p : poses)
    stationary += p.stationary ? 1 : 0;
  EXPECT_EQ(stationary, 20);  // frames 1..10 and 51..60 repeat the previous pose
  EXPECT_TRUE(poses[5].stationary);
  EXPECT_FALSE(poses[25].stationary);
  EXPECT_NEAR(poses[30].x, 1.0, 1e-9);  // t = 3 s: 2 s into the drive at 0.5 m/s
  EXPECT_NEAR(poses[30].v, 0.5, 1e-9);
  EXPECT_NEAR(poses.back().x, 2.0, 1e-9);
}

TEST(Trajectory, TurnsInPlaceBeforeDriving) {
  ds::TrajectoryConfig t;
  t.turn_rate_deg = 45.0;
  t.speed = 1.0;
  ds::TrajectoryStep go;
  go.kind = ds::TrajectoryStep::Kind::kGo;
  go.x = 0.0;
  go.y = 3.0;
  t.steps = {go};
  EXPECT_NEAR(ds::trajectoryDuration(t), 2.0 + 3.0, 1e-12);  // 90 deg at 45 deg/s, 3 m at 1 m/s
  const ds::RobotPose mid_turn = ds::poseAt(t, 1.0);
  EXPECT_NEAR(mid_turn.yaw, M_PI / 4.0, 1e-12);
  EXPECT_NEAR(mid_turn.x, 0.0, 1e-12);
  const ds::RobotPose end = ds::poseAt(t, 100.0);  // clamped
  EXPECT_NEAR(end.y, 3.0, 1e-12);
  EXPECT_NEAR(end.yaw, M_PI / 2.0, 1e-12);
  ds::TrajectoryStep by;
  by.kind = ds::TrajectoryStep::Kind::kTurnBy;
  by.value = -30.0;
  t.steps.push_back(by);
  EXPECT_NEAR(ds::poseAt(t, 100.0).yaw, M_PI / 3.0, 1e-12);
}

TEST(Trajectory, InvalidConfigsAndSubsampling) {
  ds::TrajectoryConfig t;
  t.rate_hz = 0.0;
  EXPECT_NE(t.validate().find("rate_hz"), std::string::npos);
  EXPECT_TRUE(ds::sampleTrajectory(t).empty());
  t = ds::TrajectoryConfig();
  ds::TrajectoryStep p;
  p.kind = ds::TrajectoryStep::Kind::kPause;
  p.value = std::numeric_limits<double>::quiet_NaN();
  t.steps = {p};
  EXPECT_NE(t.validate(), "");
  t.steps.clear();
  EXPECT_EQ(ds::sampleTrajectory(t).size(), 1u);  // no motion: the start pose only

  const auto idx = ds::subsampleFrames(100, 5);
  ASSERT_EQ(idx.size(), 5u);
  EXPECT_EQ(idx.front(), 0u);
  EXPECT_EQ(idx.back(), 99u);
  EXPECT_EQ(ds::subsampleFrames(3, 10).size(), 3u);
  EXPECT_TRUE(ds::subsampleFrames(0, 10).empty());
}
