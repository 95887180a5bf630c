// The single-pair check behind the real-data evaluation (real_pair_check.h) on worlds whose answer
// is known: planes given in the camera frame, hand-made safety maps, synthetic point sets and a
// rendered stereo pair of a camera 1.1 m above a floor pitched 22 deg down.
#include "stereo_safety_map/core/image_labels.h"
#include "stereo_safety_map/core/real_pair_check.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Camera (optical frame) at height h above the world floor z = 0, looking along world +x, pitched
// down by `pitch` and rolled by `roll` about its optical axis. Returns T_world_camera.
Eigen::Isometry3d cameraPose(double h, double pitch_deg, double roll_deg) {
  const Eigen::Matrix3d link_to_optical = dataset::linkToOpticalRotation();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(pitch_deg * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix() *
               link_to_optical *
               Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.0, 0.0, h);
  return T;
}

// The world floor z = 0 as n . p + d = 0 in the camera frame.
void floorInCamera(const Eigen::Isometry3d& T_world_camera, Eigen::Vector3d* n, double* d) {
  const Eigen::Vector3d n_w = Eigen::Vector3d::UnitZ();
  *n = T_world_camera.linear().transpose() * n_w;
  *d = n_w.dot(T_world_camera.translation());
}

TEST(CameraPoseFromPlane, HeightPitchAndRollOfAKnownCamera) {
  for (double pitch : {0.0, 5.0, 22.0}) {
    for (double roll : {0.0, 3.0, -2.0}) {
      Eigen::Vector3d n;
      double d;
      floorInCamera(cameraPose(1.1, pitch, roll), &n, &d);
      GroundPlaneEstimate e = cameraPoseFromPlane(n, d);
      ASSERT_TRUE(e.found);
      EXPECT_NEAR(e.camera_height, 1.1, 1e-9);
      EXPECT_NEAR(e.pitch_deg, pitch, 1e-6) << pitch << " " << roll;
      EXPECT_NEAR(std::abs(e.roll_deg),
                  std::abs(std::asin(std::sin(roll * kDeg) * std::cos(pitch * kDeg)) / kDeg), 1e-6);
      // The sign and the scale of (n, d) do not matter.
      e = cameraPoseFromPlane(-3.0 * n, -3.0 * d);
      EXPECT_NEAR(e.camera_height, 1.1, 1e-9);
      EXPECT_NEAR(e.pitch_deg, pitch, 1e-6);
    }
  }
  EXPECT_FALSE(cameraPoseFromPlane(Eigen::Vector3d::Zero(), 1.0).found);
  EXPECT_FALSE(cameraPoseFromPlane(Eigen::Vector3d::UnitY(), NAN).found);
}

TEST(LevelledCameraPose, PutsThePlaneAtZeroAndTheCameraAboveTheOrigin) {
  Eigen::Vector3d n;
  double d;
  const Eigen::Isometry3d T_true = cameraPose(1.3, 12.0, 2.0);
  floorInCamera(T_true, &n, &d);
  const Eigen::Isometry3d T = levelledCameraPose(n, d);
  EXPECT_NEAR((T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-9);
  EXPECT_NEAR(T.translation().z(), 1.3, 1e-9);
  EXPECT_NEAR(T.translation().head<2>().norm(), 0.0, 1e-12);
  // Floor points seen by the camera land on z = 0.
  for (const Eigen::Vector3d& pw : {Eigen::Vector3d(3, 1, 0), Eigen::Vector3d(5, -2, 0)}) {
    const Eigen::Vector3d pc = T_true.inverse() * pw;
    EXPECT_NEAR((T * pc).z(), 0.0, 1e-9);
  }
  // Looks along +x: the optical axis has no y component and points down by the pitch.
  const Eigen::Vector3d axis = T.linear() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(axis.y(), 0.0, 1e-9);
  EXPECT_GT(axis.x(), 0.0);
  EXPECT_NEAR(std::asin(-axis.z()) / kDeg, 12.0, 1e-6);
}

SegmentInfo segment(int id, SafetyLabel label, int cells, double a, double b, double c) {
  SegmentInfo s;
  s.id = id;
  s.label = label;
  for (int k = 0; k < cells; ++k)
    s.cells.push_back(k);
  s.plane.valid = true;
  s.plane.a = a;
  s.plane.b = b;
  s.plane.c = c;
  return s;
}

TEST(DominantGroundPlane, LargestSafeSegmentRelativeToTheCamera) {
  SafetyMap map;
  map.segments.push_back(segment(0, SafetyLabel::kNonGround, 500, 0.0, 0.0, 0.5));
  map.segments.push_back(segment(1, SafetyLabel::kLevel, 200, 0.0, 0.0, 0.1));
  map.segments.push_back(segment(2, SafetyLabel::kInclined, 100, 0.1, 0.0, 0.0));
  // Camera 1.2 m above the fixed origin pitched 8 deg down, plane of segment 1 at z = 0.1.
  const Eigen::Isometry3d T = cameraPose(1.2, 8.0, 0.0);
  GroundPlaneEstimate e = dominantGroundPlane(map, T);
  ASSERT_TRUE(e.found);
  EXPECT_EQ(e.segment, 1);
  EXPECT_EQ(e.cells, 200);
  EXPECT_EQ(e.label, SafetyLabel::kLevel);
  EXPECT_NEAR(e.camera_height, 1.1, 1e-9);
  EXPECT_NEAR(e.pitch_deg, 8.0, 1e-6);
  EXPECT_NEAR(e.slope_deg, 0.0, 1e-9);

  // Without a safe segment the largest valid plane is reported with its label.
  map.segments[1].label = SafetyLabel::kUnknown;
  map.segments[2].plane.valid = false;
  e = dominantGroundPlane(map, T);
  ASSERT_TRUE(e.found);
  EXPECT_EQ(e.segment, 0);
  EXPECT_EQ(e.label, SafetyLabel::kNonGround);
  for (auto& s : map.segments)
    s.plane.valid = false;
  EXPECT_FALSE(dominantGroundPlane(map, T).found);
  EXPECT_FALSE(dominantGroundPlane(SafetyMap(), T).found);
}

TEST(DominantGroundPlane, TheBasesPlaneIsNoMeasurement) {
  // A robot segment of footprint cells with the base's plane (SafetyMapper's fallback) is larger
  // than the measured floor: levelling on it would return the pose guess it came from.
  SafetyMap map;
  map.segments.push_back(segment(0, SafetyLabel::kLevel, 40, 0.0, 0.0, 0.3));
  map.segments.push_back(segment(1, SafetyLabel::kLevel, 30, 0.0, 0.0, 0.1));
  map.segments[0].plane.from_base = true;
  const Eigen::Isometry3d T = cameraPose(1.2, 8.0, 0.0);
  GroundPlaneEstimate e = dominantGroundPlane(map, T);
  ASSERT_TRUE(e.found);
  EXPECT_EQ(e.segment, 1);
  EXPECT_NEAR(e.camera_height, 1.1, 1e-9);
  map.segments[1].plane.valid = false;
  EXPECT_FALSE(dominantGroundPlane(map, T).found);
}

TEST(FitGroundPlaneRansac, FindsTheFloorAmongWallPoints) {
  const Eigen::Isometry3d T = cameraPose(1.05, 6.0, 1.0);
  const Eigen::Isometry3d T_inv = T.inverse();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(1.5, 5.5), uy(-2.0, 2.0), uz(0.0, 2.5);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 3000; ++i)  // floor
    pts.push_back((T_inv * Eigen::Vector3d(ux(rng), uy(rng), noise(rng))).cast<float>());
  for (int i = 0; i < 4000; ++i)  // a wall ahead, more points than the floor
    pts.push_back((T_inv * Eigen::Vector3d(4.0 + noise(rng), uy(rng), uz(rng))).cast<float>());
  pts.push_back(Eigen::Vector3f(NAN, 1.0f, 2.0f));
  Eigen::Vector3d n;
  double d;
  ASSERT_TRUE(fitGroundPlaneRansac(pts, RealPairCheckConfig(), &n, &d));
  const GroundPlaneEstimate e = cameraPoseFromPlane(n, d);
  EXPECT_NEAR(e.camera_height, 1.05, 0.005);
  EXPECT_NEAR(e.pitch_deg, 6.0, 0.2);

  // Only a wall, or too few points: no ground plane.
  std::vector<Eigen::Vector3f> wall(pts.begin() + 3000, pts.end());
  EXPECT_FALSE(fitGroundPlaneRansac(wall, RealPairCheckConfig(), &n, &d));
  std::vector<Eigen::Vector3f> few(pts.begin(), pts.begin() + 20);
  EXPECT_FALSE(fitGroundPlaneRansac(few, RealPairCheckConfig(), &n, &d));
  EXPECT_FALSE(fitGroundPlaneRansac({}, RealPairCheckConfig(), &n, &d));
  EXPECT_FALSE(fitGroundPlaneRansac(pts, RealPairCheckConfig(), nullptr, &d));
}

// A floor with a box, rendered from a camera 1.1 m high pitched 22 deg down (320 x 240).
struct RenderedBoxPair {
  cv::Mat left, right;
  StereoCameraModel camera;
  Eigen::Isometry3d T_world_left = Eigen::Isometry3d::Identity();
  Eigen::Vector3d box_center{3.5, -1.0, 0.4};
  Eigen::Vector3d box_size{0.6, 0.6, 0.8};
  double mount_z = 0.0, pitch_deg = 0.0;
};

RenderedBoxPair renderBoxPair() {
  namespace ds = dataset;
  RenderedBoxPair out;
  ds::Scene scene;
  ds::Material m;
  m.texture = ds::TextureKind::kNoise;
  m.scale = 0.15;
  m.contrast = 0.7;
  const int mat = scene.addMaterial("floor", m);
  ds::Primitive floor = ds::makeBox({4.0, 0.0, -0.5}, {12.0, 12.0, 1.0});
  floor.material = mat;
  floor.ground = true;
  floor.name = "floor";
  scene.add(floor);
  ds::Primitive box = ds::makeBox(out.box_center, out.box_size);
  box.material = mat;
  box.name = "box";
  scene.add(box);

  ds::StereoHeadConfig head;  // 1.1 m high, pitched 22 deg down
  head = head.scaledTo(320, 240);
  head.threads = 1;
  ds::StereoRenderer renderer(scene, head, 5);
  out.T_world_left = head.baseToLeftOptical();
  renderer.render(out.T_world_left, 0, &out.left, &out.right);
  out.camera.fx = out.camera.fy = head.fx();
  out.camera.cx = out.camera.cx_right = head.cx();
  out.camera.cy = head.cy();
  out.camera.baseline = head.baseline;
  out.camera.width = head.width;
  out.camera.height = head.height;
  out.mount_z = head.mount_z;
  out.pitch_deg = head.pitch_deg;
  return out;
}

TEST(CheckRealPair, RenderedPairGivesTheKnownMountingHeightAndPitch) {
  const RenderedBoxPair p = renderBoxPair();
  const cv::Mat& left = p.left;
  const cv::Mat& right = p.right;
  const StereoCameraModel& camera = p.camera;
  RealPairResult r;
  ASSERT_TRUE(checkRealPair(left, right, camera, RealPairCheckConfig(), &r)) << r.error;
  std::printf("rendered: %.3f m / %.2f deg, roll %.2f, %d cells %s, non-ground %d\n",
              r.map_plane.camera_height, r.map_plane.pitch_deg, r.map_plane.roll_deg,
              r.map_plane.cells, toString(r.map_plane.label), r.non_ground_cells);
  EXPECT_NEAR(r.map_plane.camera_height, p.mount_z, 0.02);
  EXPECT_NEAR(r.map_plane.pitch_deg, p.pitch_deg, 0.5);
  EXPECT_NEAR(r.map_plane.roll_deg, 0.0, 0.5);
  EXPECT_EQ(r.map_plane.label, SafetyLabel::kLevel);
  EXPECT_GT(r.non_ground_cells, 5);  // the box
  EXPECT_EQ(r.disparity.size(), left.size());
  EXPECT_EQ(r.disparity.type(), CV_32FC1);

  // Bad input is refused with a reason.
  EXPECT_FALSE(checkRealPair(cv::Mat(), right, camera, RealPairCheckConfig(), &r));
  EXPECT_NE(r.error, "");
  StereoCameraModel bad = camera;
  bad.baseline = 0.0;
  EXPECT_FALSE(checkRealPair(left, right, bad, RealPairCheckConfig(), &r));
  EXPECT_NE(r.error.find("camera"), std::string::npos);
  RealPairCheckConfig bad_config;
  bad_config.seed_radius = -1.0;
  EXPECT_FALSE(checkRealPair(left, right, camera, bad_config, &r));
  EXPECT_NE(r.error.find("seed_radius"), std::string::npos);
  const cv::Mat flat(camera.height, camera.width, CV_8UC1, cv::Scalar(128));
  EXPECT_FALSE(checkRealPair(flat, flat, camera, RealPairCheckConfig(), &r));  // no texture
  EXPECT_FALSE(checkRealPair(left, right, camera, RealPairCheckConfig(), nullptr));
}

// The scoring of image_labels.h end to end on the rendered pair: labels made by projecting the box
// into the left image (its convex hull obstacle, everything else floor) must find the box's cells
// Non-ground and the floor safe in the single-frame map, i.e. the pixels vote for the cells the
// mapper put their points in.
TEST(CheckRealPair, RenderedPairScoredAgainstProjectedLabels) {
  const RenderedBoxPair p = renderBoxPair();
  RealPairResult r;
  ASSERT_TRUE(checkRealPair(p.left, p.right, p.camera, RealPairCheckConfig(), &r)) << r.error;

  std::vector<cv::Point> corners;
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c =
        p.box_center + 0.5 * Eigen::Vector3d((k & 1) ? p.box_size.x() : -p.box_size.x(),
                                             (k & 2) ? p.box_size.y() : -p.box_size.y(),
                                             (k & 4) ? p.box_size.z() : -p.box_size.z());
    const Eigen::Vector3d q = p.T_world_left.inverse() * c;
    ASSERT_GT(q.z(), 0.0);
    corners.emplace_back(static_cast<int>(std::lround(p.camera.fx * q.x() / q.z() + p.camera.cx)),
                         static_cast<int>(std::lround(p.camera.fy * q.y() / q.z() + p.camera.cy)));
  }
  std::vector<cv::Point> hull;
  cv::convexHull(corners, hull);
  std::string text = "size " + std::to_string(p.camera.width) + " " +
                     std::to_string(p.camera.height) + "\nfloor 0,0 " +
                     std::to_string(p.camera.width) + ",0 " + std::to_string(p.camera.width) + "," +
                     std::to_string(p.camera.height) + " 0," + std::to_string(p.camera.height) +
                     "\nobstacle";
  for (const cv::Point& h : hull) {
    ASSERT_TRUE(h.x >= 0 && h.y >= 0 && h.x <= p.camera.width && h.y <= p.camera.height);
    text += " " + std::to_string(h.x) + "," + std::to_string(h.y);
  }
  ImageLabels labels;
  ASSERT_EQ(parseImageLabels(text + "\n", &labels), "");
  cv::Mat label_image;
  ASSERT_EQ(rasteriseImageLabels(labels, &label_image), "");
  const RealPairCheckConfig config;
  ImageLabelScore s;
  ASSERT_EQ(
      scoreAgainstImageLabels(label_image, r.disparity, p.camera, r.T_fixed_camera, r.map,
                              LabelScoringConfig::forGrid(config.processor.mapper.grid.min_range,
                                                          config.processor.mapper.grid.max_range),
                              &s),
      "");
  const LabelClassScore& floor = s.classes[static_cast<int>(ImageLabel::kFloor)];
  const LabelClassScore& box = s.classes[static_cast<int>(ImageLabel::kObstacle)];
  const ErrorRates e0 = errorRates(s.exact), e1 = errorRates(s.tolerant);
  std::printf(
      "rendered vs projected labels: %d truth cells, coverage %.3f, FN %.3f FP %.3f "
      "(1 cell: %.3f / %.3f); box %d cells recall %.3f (%.3f); floor %d cells recall "
      "%.3f (%.3f)\n",
      s.truth_cells, s.coverage(), e0.fn, e0.fp, e1.fn, e1.fp, box.cells, box.recall(),
      box.recallTolerant(), floor.cells, floor.recall(), floor.recallTolerant());
  // Geometry: every obstacle truth cell lies on the box's footprint, give or take a cell (the
  // levelled frame is the map's, found from the rendered pair; stereo smears the box's edges).
  const Eigen::Isometry3d T_world_fixed = p.T_world_left * r.T_fixed_camera.inverse();
  for (std::size_t k = 0; k < s.truth.size(); ++k) {
    if (s.truth[k] != ImageLabel::kObstacle) continue;
    const int u = r.map.min_u + static_cast<int>(k) % r.map.width;
    const int v = r.map.min_v + static_cast<int>(k) / r.map.width;
    const Eigen::Vector3d w =
        T_world_fixed * Eigen::Vector3d(u * r.map.resolution, v * r.map.resolution, 0.0);
    EXPECT_LE(std::abs(w.x() - p.box_center.x()), 0.5 * p.box_size.x() + 0.2) << u << " " << v;
    EXPECT_LE(std::abs(w.y() - p.box_center.y()), 0.5 * p.box_size.y() + 0.2) << u << " " << v;
  }
  // The box's top (0.6 x 0.6 m) and front face: about 6 x 6 cells. The map calls none of them
  // safe; it leaves some of the top's cells Unknown (small segments, 000 Alg. 2 step 3).
  EXPECT_GE(box.cells, 20);
  EXPECT_LE(box.cells, 60);
  EXPECT_EQ(box.map_safe, 0);
  EXPECT_GE(box.recall(), 0.7);
  EXPECT_GE(floor.cells, 200);
  EXPECT_GE(floor.recallTolerant(), 0.9);
  EXPECT_GE(s.coverage(), 0.9);
  EXPECT_LE(e0.fn, 0.05);
  EXPECT_LE(e1.fp, 0.05);
}

TEST(RealPairCheckConfig, ValidateNamesTheParameter) {
  EXPECT_EQ(RealPairCheckConfig().validate(), "");
  RealPairCheckConfig c;
  c.ransac_iterations = 0;
  EXPECT_NE(c.validate().find("ransac_iterations"), std::string::npos);
  c = RealPairCheckConfig();
  c.max_tilt_deg = 95.0;
  EXPECT_NE(c.validate().find("max_tilt_deg"), std::string::npos);
  c = RealPairCheckConfig();
  c.processor.disparity_step = 0;
  EXPECT_NE(c.validate().find("disparity_step"), std::string::npos);
}

TEST(Calibration, ReadsRosYamlAndKeyValueFiles) {
  const std::string dir = ::testing::TempDir();
  const std::string l = dir + "/ssm_left.yaml", r = dir + "/ssm_right.yaml", t = dir + "/ssm.txt";
  const char* fmt =
      "%%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\nprojection_matrix:\n"
      "   rows: 3\n   cols: 4\n   data: [ 500., 0., 320.5, %s, 0., 501., 240.5, 0., 0., 0., 1., 0. "
      "]\n";
  char buf[512];
  std::snprintf(buf, sizeof(buf), fmt, "0.");
  std::ofstream(l) << buf;
  std::snprintf(buf, sizeof(buf), fmt, "-60.");
  std::ofstream(r) << buf;
  StereoCameraModel m;
  ASSERT_EQ(loadStereoCalibration(l, r, &m), "");
  EXPECT_DOUBLE_EQ(m.fx, 500.0);
  EXPECT_DOUBLE_EQ(m.fy, 501.0);
  EXPECT_DOUBLE_EQ(m.cx, 320.5);
  EXPECT_DOUBLE_EQ(m.cy, 240.5);
  EXPECT_DOUBLE_EQ(m.baseline, 0.12);
  EXPECT_EQ(m.width, 640);
  EXPECT_NE(loadStereoCalibration(l, l, &m), "");  // zero baseline
  EXPECT_NE(loadStereoCalibration(dir + "/missing.yaml", r, &m), "");

  std::ofstream(t) << "f=494.1 cx=317.2 cy=248.8 baseline_m=0.12 (comment)\n";
  ASSERT_EQ(loadRectifiedCalibText(t, 640, 480, &m), "");
  EXPECT_DOUBLE_EQ(m.fx, 494.1);
  EXPECT_DOUBLE_EQ(m.cx_right, 317.2);
  EXPECT_DOUBLE_EQ(m.baseline, 0.12);
  std::ofstream(t) << "f=494.1 cx=317.2\n";
  EXPECT_NE(loadRectifiedCalibText(t, 640, 480, &m), "");
  EXPECT_NE(loadRectifiedCalibText(dir + "/missing.txt", 640, 480, &m), "");
}

}  // namespace
}  // namespace stereo_safety_map
