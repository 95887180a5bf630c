// Tests of the landmark filter (001 Sec. 4.2): Kalman update, Mahalanobis association, false
// positive removal, and the keep mask that gates the point stream.
#include "stereo_safety_map/core/landmark_filter.h"
#include "stereo_safety_map/core/safety_mapper.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>
#include <stdexcept>

// Counts heap allocations, to check that a warmed-up update() does not allocate. Not inlined, so
// that the compiler pairs new with delete rather than with the malloc / free inside.
namespace {
std::atomic<long> g_allocations{0};
}  // namespace
__attribute__((noinline)) void* operator new(std::size_t size) {
  ++g_allocations;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
__attribute__((noinline)) void operator delete(void* p) noexcept {
  std::free(p);
}
__attribute__((noinline)) void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}

namespace stereo_safety_map {
namespace {

StereoCameraModel testCamera() {
  StereoCameraModel c;
  c.fx = 500.0;
  c.fy = 500.0;
  c.cx = 320.0;
  c.cy = 240.0;
  c.cx_right = 320.0;
  c.baseline = 0.12;
  c.width = 640;
  c.height = 480;
  return c;
}

// A camera-frame point observed through the pixel noise model of 001 Sec. 4.1: project to
// (row, col, disparity), perturb each by its sigma, triangulate again.
Eigen::Vector3f observe(const StereoCameraModel& cam, const StereoErrorModelConfig& noise,
                        const Eigen::Vector3d& p, std::mt19937* rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  const double col = cam.fx * p.x() / p.z() + cam.cx + noise.sigma_col * n01(*rng);
  const double row = cam.fy * p.y() / p.z() + cam.cy + noise.sigma_row * n01(*rng);
  const double d = cam.fx * cam.baseline / p.z() + noise.sigma_disparity * n01(*rng);
  const double z = cam.fx * cam.baseline / d;
  return Eigen::Vector3f(static_cast<float>((col - cam.cx) * z / cam.fx),
                         static_cast<float>((row - cam.cy) * z / cam.fy), static_cast<float>(z));
}

// Camera looking along fixed +x (optical z), from a robot at (x, y, 1 m) with yaw.
Eigen::Isometry3f cameraPose(double x, double y, double yaw) {
  Eigen::Matrix3d optical_to_robot;
  optical_to_robot << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() =
      Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * optical_to_robot;
  T.translation() = Eigen::Vector3d(x, y, 1.0);
  return T.cast<float>();
}

int countPermanent(const LandmarkFilter& f) {
  int n = 0;
  for (const Landmark& l : f.landmarks())
    n += l.status == LandmarkStatus::kPermanent;
  return n;
}

TEST(LandmarkFilter, StaticPointObservedWithNoiseConvergesAndBecomesPermanent) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilterConfig cfg;
  LandmarkFilter filter(cam, cfg);
  std::mt19937 rng(3);
  const Eigen::Vector3d world(4.0, 0.3, 0.6);  // fixed frame
  std::vector<Eigen::Vector3f> pts(1);
  std::vector<std::uint8_t> keep;
  const int frames = 40;
  for (int k = 0; k < frames; ++k) {
    // The robot drives forward and turns a little: the point is seen from changing poses.
    const Eigen::Isometry3f T = cameraPose(0.02 * k, 0.01 * k, 0.005 * k);
    const Eigen::Vector3d p_cam = (T.cast<double>().inverse() * world);
    pts[0] = observe(cam, cfg.error_model, p_cam, &rng);
    const LandmarkFilterStats st = filter.update(pts, T, 0.1 * k, &keep);
    ASSERT_FALSE(st.rejected);
    if (k == 0) {
      EXPECT_EQ(st.landmarks_created, 1u);
      EXPECT_EQ(filter.numTemporary(), 1u);
      EXPECT_EQ(keep[0], 0);  // not confirmed yet
    }
    if (k == cfg.min_matches - 1) {
      EXPECT_EQ(filter.numPermanent(), 0u);
    }
  }
  // The landmark with most matches is the point's.
  const Landmark* best = nullptr;
  for (const Landmark& l : filter.landmarks()) {
    if (l.status != LandmarkStatus::kFree && (!best || l.matches > best->matches)) best = &l;
  }
  ASSERT_NE(best, nullptr);
  EXPECT_EQ(best->status, LandmarkStatus::kPermanent);
  EXPECT_GT(best->matches, frames * 3 / 4);
  const StereoErrorModel model(cam, cfg.error_model);
  const double single_sigma_z = model.depthSigma(4.0);  // ~0.13 m for one observation
  const double error = (best->mean.cast<double>() - world).norm();
  EXPECT_LT(error, 0.3 * single_sigma_z) << "mean " << best->mean.transpose();
  // The Kalman update shrinks the covariance about 1/n.
  EXPECT_LT(best->covariance.trace(), 0.1 * single_sigma_z * single_sigma_z);
  EXPECT_EQ(keep[0], 1);  // the last observation is confirmed
  std::vector<Eigen::Vector3f> cloud;
  filter.permanentLandmarks(&cloud);
  ASSERT_GE(cloud.size(), 1u);
  EXPECT_EQ(static_cast<std::size_t>(countPermanent(filter)), cloud.size());
}

TEST(LandmarkFilter, UpdateIsTheInformationWeightedMeanOfEq2) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilter filter(cam);
  // Two observations of one point from two poses: their covariances are elongated along
  // different rays, so Eq. (2) is not a plain average.
  const Eigen::Isometry3f T0 = cameraPose(0.0, 0.0, 0.0);
  const Eigen::Isometry3f T1 = cameraPose(0.5, -0.8, 0.3);
  const Eigen::Vector3d a(3.0, 0.2, 0.9), b(3.03, 0.203, 0.898);  // fixed frame
  const Eigen::Vector3f a_cam = (T0.inverse() * a.cast<float>());
  const Eigen::Vector3f b_cam = (T1.inverse() * b.cast<float>());
  filter.update({a_cam}, T0, 0.0);
  filter.update({b_cam}, T1, 0.1);
  ASSERT_EQ(filter.associations()[0], 0);
  const StereoErrorModel model(cam);
  const Eigen::Matrix3d sa = model.covarianceFixed(a_cam.cast<double>(), T0.cast<double>());
  const Eigen::Matrix3d sb = model.covarianceFixed(b_cam.cast<double>(), T1.cast<double>());
  const Eigen::Matrix3d info = sa.inverse() + sb.inverse();
  const Eigen::Matrix3d cov = info.inverse();
  const Eigen::Vector3d mean = cov * (sa.inverse() * a + sb.inverse() * b);
  const Landmark& l = filter.landmarks()[0];
  EXPECT_LT((l.mean.cast<double>() - mean).norm(), 1e-4)
      << l.mean.transpose() << " vs " << mean.transpose();
  EXPECT_LT((l.covariance.cast<double>() - cov).norm(), 1e-3 * cov.norm());
  // Seen from two directions, the estimate is better than either observation along each ray.
  EXPECT_LT(cov.trace(), 0.6 * std::min(sa.trace(), sb.trace()));
}

TEST(LandmarkFilter, PermanentLandmarksInViewThatStopMatchingGoStale) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilterConfig cfg;
  cfg.stale_time = 0.5;
  LandmarkFilter filter(cam, cfg);
  const Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  const Eigen::Vector3f in_view(0.2f, 0.1f, 3.0f), leaves_view(1.0f, 0.0f, 3.0f);
  for (int k = 0; k < 5; ++k) {
    filter.update({in_view, leaves_view}, T, 0.1 * k);
  }
  ASSERT_EQ(filter.numPermanent(), 2u);
  // Turn so that the second landmark leaves the image, and show nothing.
  Eigen::Isometry3f turned = Eigen::Isometry3f::Identity();
  turned.linear() = Eigen::AngleAxisf(-0.45f, Eigen::Vector3f::UnitY()).toRotationMatrix();
  ASSERT_LT(500.0f * (turned.inverse() * in_view).x() / (turned.inverse() * in_view).z() + 320.f,
            640.f);
  ASSERT_GT(
      500.0f * (turned.inverse() * leaves_view).x() / (turned.inverse() * leaves_view).z() + 320.f,
      640.f);
  for (int k = 5; k < 12; ++k) {
    filter.update({}, turned, 0.1 * k);
  }
  ASSERT_EQ(filter.numPermanent(), 1u);
  std::vector<Eigen::Vector3f> cloud;
  filter.permanentLandmarks(&cloud);
  ASSERT_EQ(cloud.size(), 1u);
  EXPECT_LT((cloud[0] - leaves_view).norm(), 1e-3f);  // the one out of view is kept
}

TEST(LandmarkFilter, RandomOneFramePointsAreRemovedAndTheStreamIsGated) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilterConfig cfg;
  LandmarkFilter filter(cam, cfg);
  std::mt19937 rng(11);
  // A wall 3 m ahead (camera frame), 20 x 15 points 10 cm apart.
  std::vector<Eigen::Vector3d> wall;
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 15; ++j)
      wall.emplace_back(-1.0 + 0.1 * i, -0.7 + 0.1 * j, 3.0);
  }
  // One-frame clutter in the field of view, in front of and behind the wall but not within
  // 0.5 m of it (a point on a wall pixel's ray near the wall is consistent with the wall, and
  // may be confirmed by it, as 001 intends).
  std::uniform_real_distribution<double> ux(-0.6, 0.6), uy(-0.4, 0.4), uz(1.0, 7.0);
  std::vector<Eigen::Vector3d> clutter;
  while (clutter.size() < 300) {
    const double z = uz(rng);
    if (std::abs(z - 3.0) < 0.5) continue;
    clutter.emplace_back(ux(rng) * z, uy(rng) * z, z);
  }

  const Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  std::vector<Eigen::Vector3f> pts;
  std::vector<std::uint8_t> keep;
  for (int k = 0; k < 20; ++k) {
    pts.clear();
    for (const auto& w : wall)
      pts.push_back(observe(cam, cfg.error_model, w, &rng));
    if (k == 0) {
      for (const auto& c : clutter)
        pts.push_back(c.cast<float>());
    }
    filter.update(pts, T, 0.1 * k, &keep);
    if (k == 0) {
      EXPECT_EQ(filter.numTemporary(), wall.size() + clutter.size());
      EXPECT_EQ(filter.numPermanent(), 0u);
    }
  }
  // Every clutter landmark has expired (time_window = 1 s, 20 frames at 10 Hz): whatever is
  // left from frame 0, and whatever is permanent, lies on the wall. (Temporary landmarks of
  // recent frames, started by wall points in the noise tail, may still wait for matches.)
  for (const Landmark& l : filter.landmarks()) {
    if (l.status == LandmarkStatus::kFree) continue;
    if (l.status == LandmarkStatus::kTemporary && l.first_stamp > 0.0) continue;
    double nearest_wall = 1e9;
    for (const auto& w : wall) {
      nearest_wall = std::min(nearest_wall, (l.mean.cast<double>() - w).norm());
    }
    EXPECT_LT(nearest_wall, 0.1) << "left-over landmark at " << l.mean.transpose();
  }
  EXPECT_GE(filter.numPermanent(), wall.size() * 95 / 100);

  // Gating: wall points pass, a fresh one-frame point does not.
  pts.clear();
  for (const auto& w : wall)
    pts.push_back(observe(cam, cfg.error_model, w, &rng));
  pts.push_back(Eigen::Vector3f(0.05f, 0.05f, 1.7f));
  const LandmarkFilterStats st = filter.update(pts, T, 2.0, &keep);
  ASSERT_EQ(keep.size(), pts.size());
  EXPECT_EQ(keep.back(), 0);
  std::size_t kept_wall = 0;
  for (std::size_t i = 0; i < wall.size(); ++i)
    kept_wall += keep[i];
  EXPECT_GE(kept_wall, wall.size() * 95 / 100);
  EXPECT_EQ(st.points_kept, kept_wall);
  std::vector<Eigen::Vector3f> filtered;
  applyKeepMask(pts, keep, &filtered);
  EXPECT_EQ(filtered.size(), kept_wall);
}

// The Mahalanobis effect (001 Sec. 4.2, Fig. 4): with depth noise far larger than lateral
// noise, the point displaced along the viewing ray is the consistent one, although a point
// displaced sideways is closer in Euclidean terms.
TEST(LandmarkFilter, MahalanobisPicksTheRightPointWhereEuclideanPicksTheWrongOne) {
  const StereoCameraModel cam = testCamera();
  const Eigen::Vector3f p0(0.0f, 0.0f, 4.0f);
  const Eigen::Vector3f along_ray(0.0f, 0.0f, 4.15f);  // right: 0.15 m along the ray
  const Eigen::Vector3f sideways(0.02f, 0.0f, 4.0f);   // wrong: 0.02 m (2.5 px) sideways

  // The geometry is what the test claims it is.
  const StereoErrorModel model(cam);
  const Eigen::Matrix3d s_l = model.covarianceCamera(p0.cast<double>());
  const auto d2 = [&](const Eigen::Vector3f& p) {
    const Eigen::Vector3d e = (p - p0).cast<double>();
    return e.dot((s_l + model.covarianceCamera(p.cast<double>())).inverse() * e);
  };
  LandmarkFilterConfig cfg;
  ASSERT_LT(d2(along_ray), cfg.gate_chi2);
  ASSERT_GT(d2(sideways), cfg.gate_chi2);
  ASSERT_LT((sideways - p0).norm(), (along_ray - p0).norm());

  for (bool mahalanobis : {true, false}) {
    cfg.use_mahalanobis = mahalanobis;
    cfg.euclidean_gate = 0.2;
    LandmarkFilter filter(cam, cfg);
    const Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
    filter.update({p0}, T, 0.0);
    ASSERT_EQ(filter.numTemporary(), 1u);
    const std::vector<Eigen::Vector3f> frame{sideways, along_ray};
    const LandmarkFilterStats st = filter.update(frame, T, 0.1);
    const std::vector<std::int32_t>& a = filter.associations();
    ASSERT_EQ(a.size(), 2u);
    if (mahalanobis) {
      EXPECT_EQ(a[1], 0) << "Mahalanobis should take the point along the ray";
      EXPECT_EQ(a[0], -1);
      EXPECT_EQ(st.landmarks_created, 1u);  // the sideways point is outside every gate
      // The update moved the estimate along the ray only.
      EXPECT_GT(filter.landmarks()[0].mean.z(), 4.0f);
      EXPECT_NEAR(filter.landmarks()[0].mean.x(), 0.0f, 1e-4f);
    } else {
      EXPECT_EQ(a[0], 0) << "Euclidean takes the nearest point";
      EXPECT_EQ(a[1], -1);
      EXPECT_EQ(st.landmarks_created, 0u);  // both within 0.2 m
    }
  }
}

TEST(LandmarkFilter, DescriptorTermDecidesBetweenEquallyPlacedPoints) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilterConfig cfg;
  cfg.descriptor_dim = 2;
  cfg.descriptor_sigma = 1.0;
  const Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  for (int right : {0, 1}) {
    LandmarkFilter filter(cam, cfg);
    const std::vector<float> d0{10.f, -3.f};
    filter.update({Eigen::Vector3f(0.2f, 0.1f, 3.0f)}, T, 0.0, nullptr, &d0);
    // Two points straddling the landmark along the ray, both well inside the gate; the one
    // nearer in location gets the wrong descriptor.
    const std::vector<Eigen::Vector3f> frame{Eigen::Vector3f(0.2f, 0.1f, 3.0f) * (1.0f + 0.004f),
                                             Eigen::Vector3f(0.2f, 0.1f, 3.0f) * (1.0f - 0.006f)};
    std::vector<float> desc{0.f, 0.f, 0.f, 0.f};
    desc[2 * right] = 10.f;
    desc[2 * right + 1] = -3.f;
    const LandmarkFilterStats st = filter.update(frame, T, 0.1, nullptr, &desc);
    EXPECT_FALSE(st.descriptors_ignored);
    EXPECT_EQ(filter.associations()[right], 0) << "right = " << right;
    EXPECT_EQ(filter.associations()[1 - right], -1);
  }
}

TEST(LandmarkFilter, APointUpdatesOnlyOneLandmark) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilter filter(cam);
  const Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  // Two landmarks on one viewing ray, 0.9 m apart: each outside the other's gate.
  filter.update({Eigen::Vector3f(0.f, 0.f, 4.0f)}, T, 0.0);
  filter.update({Eigen::Vector3f(0.f, 0.f, 4.0f), Eigen::Vector3f(0.f, 0.f, 4.9f)}, T, 0.1);
  ASSERT_EQ(filter.numTemporary(), 2u);
  ASSERT_EQ(filter.landmarks()[0].matches, 1);
  ASSERT_EQ(filter.landmarks()[1].matches, 0);
  // A point between them lies in both gates; it may update only one of them.
  const LandmarkFilterStats st = filter.update({Eigen::Vector3f(0.f, 0.f, 4.45f)}, T, 0.2);
  EXPECT_EQ(st.points_matched, 1u);
  EXPECT_EQ(st.landmarks_created, 0u);
  const int gained = (filter.landmarks()[0].matches - 1) + filter.landmarks()[1].matches;
  EXPECT_EQ(gained, 1);
  ASSERT_GE(filter.associations()[0], 0);
  EXPECT_EQ(filter.landmarks()[filter.associations()[0]].matches,
            filter.associations()[0] == 0 ? 2 : 1);
}

TEST(LandmarkFilter, PointsInTheGateOfANewLandmarkStartNoOther) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilter filter(cam);
  // A dense 21 x 21 pixel patch of a wall 3 m away: far fewer landmarks than points, and every
  // later point of the patch falls into some landmark's gate.
  std::vector<Eigen::Vector3f> patch;
  for (int r = -10; r <= 10; ++r) {
    for (int c = -10; c <= 10; ++c)
      patch.emplace_back(3.0f * c / 500.f, 3.0f * r / 500.f, 3.0f);
  }
  const LandmarkFilterStats st = filter.update(patch, Eigen::Isometry3f::Identity(), 0.0);
  EXPECT_GT(st.landmarks_created, 4u);
  EXPECT_LT(st.landmarks_created, patch.size() / 5);
  const LandmarkFilterStats st2 = filter.update(patch, Eigen::Isometry3f::Identity(), 0.1);
  EXPECT_EQ(st2.landmarks_created, 0u);
  EXPECT_EQ(st2.points_in_gate, patch.size());
  EXPECT_EQ(st2.points_matched, st.landmarks_created);
}

TEST(LandmarkFilter, AWarmedUpUpdateDoesNotAllocate) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilter filter(cam);
  std::vector<Eigen::Vector3f> patch;
  for (int r = -40; r <= 40; ++r) {
    for (int c = -60; c <= 60; ++c)
      patch.emplace_back(3.0f * c / 500.f, 3.0f * r / 500.f, 3.0f);
  }
  std::vector<std::uint8_t> keep;
  for (int k = 0; k < 5; ++k)
    filter.update(patch, Eigen::Isometry3f::Identity(), 0.1 * k, &keep);
  ASSERT_GT(filter.numPermanent(), 0u);
  const long before = g_allocations.load();
  for (int k = 5; k < 10; ++k)
    filter.update(patch, Eigen::Isometry3f::Identity(), 0.1 * k, &keep);
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_EQ(filter.stats().points_kept, patch.size());
}

TEST(LandmarkFilter, CapacityAndLocalityBoundTheMap) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilterConfig cfg;
  cfg.max_landmarks = 10;
  LandmarkFilter filter(cam, cfg);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 50; ++i)
    pts.emplace_back(-1.0f + 0.04f * i, 0.0f, 3.0f);
  const LandmarkFilterStats st = filter.update(pts, Eigen::Isometry3f::Identity(), 0.0);
  EXPECT_EQ(st.landmarks_created, 10u);
  EXPECT_EQ(st.landmarks_refused, 40u);
  EXPECT_EQ(filter.landmarks().size(), 10u);

  // Drive 20 m away: every landmark leaves the local map.
  Eigen::Isometry3f far = Eigen::Isometry3f::Identity();
  far.translation() = Eigen::Vector3f(0.f, 0.f, -20.f);
  const LandmarkFilterStats st2 = filter.update({}, far, 0.1);
  EXPECT_EQ(st2.landmarks_dropped_far, 10u);
  EXPECT_EQ(filter.numTemporary() + filter.numPermanent(), 0u);
}

TEST(LandmarkFilter, BadInputIsSkippedWithoutCrashing) {
  const StereoCameraModel cam = testCamera();
  LandmarkFilter filter(cam);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<std::uint8_t> keep{7, 7, 7, 7, 7, 7, 7, 7, 7};
  const std::vector<Eigen::Vector3f> bad{
      Eigen::Vector3f(nan, 0, 3), Eigen::Vector3f(0, 0, nan), Eigen::Vector3f(0, inf, 3),
      Eigen::Vector3f(0, 0, -2),  Eigen::Vector3f(0, 0, 0),   Eigen::Vector3f(0, 0, 50),
      Eigen::Vector3f(10, 0, 1),  // projects far outside the image
      Eigen::Vector3f(0, 0, 0.1f)};
  const LandmarkFilterStats st = filter.update(bad, Eigen::Isometry3f::Identity(), 0.0, &keep);
  EXPECT_EQ(st.points_invalid, bad.size());
  EXPECT_EQ(st.landmarks_created, 0u);
  ASSERT_EQ(keep.size(), bad.size());
  for (auto k : keep)
    EXPECT_EQ(k, 0);

  // Empty frame.
  EXPECT_EQ(filter.update({}, Eigen::Isometry3f::Identity(), 0.1, &keep).points_in, 0u);
  EXPECT_TRUE(keep.empty());

  // Non-finite pose or stamp: the frame is rejected and the map untouched.
  filter.update({Eigen::Vector3f(0, 0, 3)}, Eigen::Isometry3f::Identity(), 0.2);
  ASSERT_EQ(filter.numTemporary(), 1u);
  Eigen::Isometry3f broken = Eigen::Isometry3f::Identity();
  broken.translation().x() = nan;
  EXPECT_TRUE(filter.update({Eigen::Vector3f(0, 0, 3)}, broken, 0.3, &keep).rejected);
  EXPECT_TRUE(
      filter.update({Eigen::Vector3f(0, 0, 3)}, Eigen::Isometry3f::Identity(), std::nan(""), &keep)
          .rejected);
  EXPECT_EQ(filter.numTemporary(), 1u);
  EXPECT_EQ(filter.landmarks()[0].matches, 0);

  // Descriptors of the wrong size are ignored, not read out of bounds.
  const std::vector<float> short_desc{1.f};
  EXPECT_TRUE(filter
                  .update({Eigen::Vector3f(0, 0, 3)}, Eigen::Isometry3f::Identity(), 0.4, nullptr,
                          &short_desc)
                  .descriptors_ignored);

  // Time going backwards (a bag restarted) clears the filter.
  const LandmarkFilterStats st2 =
      filter.update({Eigen::Vector3f(1, 0, 3)}, Eigen::Isometry3f::Identity(), 0.0);
  EXPECT_TRUE(st2.reset);
  EXPECT_EQ(filter.numTemporary(), 1u);

  std::vector<Eigen::Vector3f> out{Eigen::Vector3f::Zero()};
  applyKeepMask({Eigen::Vector3f::Zero()}, {1, 1}, &out);  // wrong mask size
  EXPECT_TRUE(out.empty());
}

// The stream filter in front of the voxel grid: confirmed points pass in their order, others
// do not; bad frames leave the points untouched; a new camera restarts the filter.
TEST(LandmarkStreamFilter, PassesConfirmedPointsOnlyAndRestartsForANewCamera) {
  const StereoCameraModel cam = testCamera();
  LandmarkStreamConfig config;
  config.skip_stationary_frames = false;  // one pose throughout
  LandmarkStreamFilter stream(config);
  std::vector<Eigen::Vector3f> wall;
  for (int i = 0; i < 10; ++i)
    wall.emplace_back(-0.5f + 0.1f * i, 0.1f, 3.0f);
  std::vector<Eigen::Vector3f> pts;
  for (int k = 0; k < 4; ++k) {
    pts = wall;
    pts.emplace_back(0.3f, -0.2f, 1.0f + 0.5f * k);  // a one-frame point, elsewhere each frame
    std::string err;
    ASSERT_EQ(stream.apply(cam, Eigen::Isometry3f::Identity(), 0.1 * k, &pts, &err),
              LandmarkStreamStatus::kFiltered)
        << err;
    if (k < 3) {
      EXPECT_TRUE(pts.empty()) << "frame " << k;  // min_matches = 3
    }
  }
  ASSERT_EQ(pts.size(), wall.size());
  for (std::size_t i = 0; i < wall.size(); ++i)
    EXPECT_EQ(pts[i], wall[i]);  // in order, untouched
  EXPECT_EQ(stream.stats().permanent, wall.size());
  std::vector<Eigen::Vector3f> cloud;
  stream.permanentLandmarks(&cloud);
  EXPECT_EQ(cloud.size(), wall.size());

  // Bad frames: refused with a reason, points untouched, landmarks kept.
  pts = wall;
  std::string err;
  EXPECT_EQ(stream.apply(cam, Eigen::Isometry3f::Identity(), std::nan(""), &pts, &err),
            LandmarkStreamStatus::kRejected);
  EXPECT_NE(err.find("stamp"), std::string::npos);
  EXPECT_EQ(pts.size(), wall.size());
  StereoCameraModel broken = cam;
  broken.baseline = 0.0;
  EXPECT_EQ(stream.apply(broken, Eigen::Isometry3f::Identity(), 0.5, &pts, &err),
            LandmarkStreamStatus::kRejected);
  EXPECT_NE(err.find("baseline"), std::string::npos);
  EXPECT_EQ(pts.size(), wall.size());
  stream.permanentLandmarks(&cloud);
  EXPECT_EQ(cloud.size(), wall.size());

  // Another camera: the landmarks (kept in its image) start again.
  StereoCameraModel other = cam;
  other.fx = other.fy = 400.0;
  pts = wall;
  ASSERT_EQ(stream.apply(other, Eigen::Isometry3f::Identity(), 0.6, &pts, &err),
            LandmarkStreamStatus::kFiltered)
      << err;
  EXPECT_TRUE(pts.empty());
  EXPECT_EQ(stream.cameraChanges(), 1u);
  EXPECT_EQ(stream.stats().permanent, 0u);
}

// A camera that does not move repeats its mismatches frame after frame; they must not confirm
// each other (001: noise is removed "using motion"). Only moving frames count.
TEST(LandmarkStreamFilter, StationaryFramesDoNotConfirmTheirOwnPoints) {
  const StereoCameraModel cam = testCamera();
  LandmarkStreamFilter stream;  // skips frames that moved < 2 cm and < 1 deg
  const std::vector<Eigen::Vector3f> ghost{Eigen::Vector3f(0.1f, 0.1f, 2.0f)};
  std::vector<Eigen::Vector3f> pts;
  for (int k = 0; k < 6; ++k) {
    pts = ghost;
    const LandmarkStreamStatus st =
        stream.apply(cam, Eigen::Isometry3f::Identity(), 0.1 * k, &pts, nullptr);
    EXPECT_EQ(st, k == 0 ? LandmarkStreamStatus::kFiltered : LandmarkStreamStatus::kStationary);
    EXPECT_TRUE(pts.empty() || st == LandmarkStreamStatus::kStationary);
  }
  EXPECT_EQ(stream.stats().permanent, 0u);
  // Moving 5 cm a frame, a static point is confirmed after min_matches frames.
  const Eigen::Vector3f world(0.1f, 0.1f, 2.0f);
  for (int k = 1; k <= 3; ++k) {
    Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
    T.translation().z() = 0.05f * k;
    pts = {T.inverse() * world};
    ASSERT_EQ(stream.apply(cam, T, 0.6 + 0.1 * k, &pts, nullptr), LandmarkStreamStatus::kFiltered);
  }
  EXPECT_EQ(pts.size(), 1u);
  EXPECT_EQ(stream.stats().permanent, 1u);
  // After a reset the next frame counts as the first, whatever the pose.
  stream.reset();
  pts = ghost;
  EXPECT_EQ(stream.apply(cam, Eigen::Isometry3f::Identity(), 2.0, &pts, nullptr),
            LandmarkStreamStatus::kFiltered);
}

TEST(LandmarkStreamConfig, ForMapperUsesTheGridsRangeAndFrameThresholds) {
  LandmarkStreamConfig c;
  SafetyMapperConfig m;
  m.grid.min_range = 0.0;
  m.grid.max_range = 12.0;
  m.skip_stationary_frames = false;
  m.stationary_translation = 0.3;
  const LandmarkStreamConfig r = c.forMapper(m);
  EXPECT_GT(r.filter.min_depth, 0.0);
  EXPECT_DOUBLE_EQ(r.filter.max_depth, 12.0);
  EXPECT_GE(r.filter.max_landmark_distance, 12.0);
  EXPECT_FALSE(r.skip_stationary_frames);
  EXPECT_DOUBLE_EQ(r.stationary_translation, 0.3);
  EXPECT_EQ(r.validate(), "");
  c.filter.gate_chi2 = -1.0;
  EXPECT_NE(c.validate().find("gate_chi2"), std::string::npos);
  EXPECT_THROW(LandmarkStreamFilter{c}, std::invalid_argument);
  c = LandmarkStreamConfig();
  c.stationary_rotation_deg = -1.0;
  EXPECT_NE(c.validate().find("stationary_rotation_deg"), std::string::npos);
}

TEST(LandmarkFilter, ConfigValidation) {
  EXPECT_TRUE(LandmarkFilterConfig().validate().empty());
  const auto expectBad = [](const LandmarkFilterConfig& c, const char* name) {
    const std::string why = c.validate();
    EXPECT_NE(why.find(name), std::string::npos) << why;
    EXPECT_THROW(LandmarkFilter(testCamera(), c), std::invalid_argument);
  };
  LandmarkFilterConfig c;
  c.gate_chi2 = 0.0;
  expectBad(c, "gate_chi2");
  c = LandmarkFilterConfig();
  c.min_matches = 0;
  expectBad(c, "min_matches");
  c = LandmarkFilterConfig();
  c.time_window = -1.0;
  expectBad(c, "time_window");
  c = LandmarkFilterConfig();
  c.max_search_radius_px = 0.5;
  expectBad(c, "max_search_radius_px");
  c = LandmarkFilterConfig();
  c.stale_time = 0.0;
  expectBad(c, "stale_time");
  c = LandmarkFilterConfig();
  c.min_depth = 9.0;
  expectBad(c, "min_depth");
  c = LandmarkFilterConfig();
  c.max_landmark_distance = 1.0;
  expectBad(c, "max_landmark_distance");
  c = LandmarkFilterConfig();
  c.descriptor_dim = 5;
  expectBad(c, "descriptor_dim");
  c = LandmarkFilterConfig();
  c.error_model.sigma_col = -1.0;
  expectBad(c, "sigma_col");

  StereoCameraModel cam = testCamera();
  cam.width = 0;
  EXPECT_THROW(LandmarkFilter{cam}, std::invalid_argument);
  cam = testCamera();
  cam.baseline = 0.0;
  EXPECT_THROW(LandmarkFilter{cam}, std::invalid_argument);
}

}  // namespace
}  // namespace stereo_safety_map
