// evaluate_safety_map: the picture of the hybrid 3D model (000 Fig. 4(b)).
#include "evaluate_safety_map.h"

#include <opencv2/imgproc.hpp>

#include <array>
#include <cmath>

namespace evaluate_safety_map {

// The hybrid 3D model of 000 Fig. 4(b): occupied voxels of Non-ground cells as grey cubes, safe
// segments as their planes over their cells (Level green, Inclined yellow), rendered with a
// painter's algorithm from behind and above the robot.
cv::Mat render3dModel(const ssm::SafetyMapper& mapper, const Eigen::Vector3d& robot, double yaw) {
  const ssm::SafetyMap& map = mapper.safetyMap();
  const ssm::VoxelGrid& grid = mapper.grid();
  const double l = grid.config().voxel_size;
  struct Face {
    std::array<Eigen::Vector3d, 4> p;
    cv::Vec3b colour;
    Eigen::Vector3d normal;
    double depth = 0.0;
  };
  std::vector<Face> faces;
  const Eigen::Vector3d fwd(std::cos(yaw), std::sin(yaw), 0.0);
  const Eigen::Vector3d eye = robot - 4.5 * fwd + Eigen::Vector3d(0, 0, 5.0);
  const Eigen::Vector3d target = robot + 2.5 * fwd;
  const Eigen::Vector3d zc = (target - eye).normalized();
  const Eigen::Vector3d xc = zc.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d yc = zc.cross(xc);
  const double top = robot.z() + mapper.config().height_map.robot_height;

  for (int k = 0; k < map.width * map.height; ++k) {
    const int u = map.min_u + k % map.width, v = map.min_v + k / map.width;
    const SafetyLabel lab = map.labels[k];
    const Eigen::Vector3d cc(u * l, v * l, 0.0);
    if (ssm::isSafe(lab) && map.segment[k] >= 0 &&
        map.segment[k] < static_cast<int>(map.segments.size())) {
      const ssm::GroundPlane& pl = map.segments[map.segment[k]].plane;
      if (!pl.valid) continue;
      Face f;
      const double h = 0.5 * l;
      const double dx[4] = {-h, h, h, -h}, dy[4] = {-h, -h, h, h};
      for (int i = 0; i < 4; ++i) {
        const double x = cc.x() + dx[i], y = cc.y() + dy[i];
        f.p[i] = Eigen::Vector3d(x, y, pl.heightAt(x, y));
      }
      f.normal = pl.normal;
      f.colour = lab == SafetyLabel::kLevel ? cv::Vec3b(60, 200, 60) : cv::Vec3b(0, 220, 240);
      faces.push_back(f);
    } else if (lab == SafetyLabel::kNonGround) {
      const ssm::VoxelIndex gmin = grid.minIndex();
      for (int w = gmin.w; w < gmin.w + grid.sizeW(); ++w) {
        const ssm::VoxelIndex i{u, v, w};
        if (!grid.isOccupied(i) || w * l > top) continue;
        const Eigen::Vector3d c(u * l, v * l, w * l);
        // Six faces; skip those between two occupied voxels and those facing away.
        const int du[6] = {1, -1, 0, 0, 0, 0}, dv[6] = {0, 0, 1, -1, 0, 0},
                  dw[6] = {0, 0, 0, 0, 1, -1};
        for (int fi = 0; fi < 6; ++fi) {
          const Eigen::Vector3d n(du[fi], dv[fi], dw[fi]);
          if (grid.isOccupied({u + du[fi], v + dv[fi], w + dw[fi]})) continue;
          const Eigen::Vector3d fc = c + 0.5 * l * n;
          if ((eye - fc).dot(n) <= 0.0) continue;
          Eigen::Vector3d a1, a2;
          if (fi < 2) {
            a1 = Eigen::Vector3d::UnitY();
            a2 = Eigen::Vector3d::UnitZ();
          } else if (fi < 4) {
            a1 = Eigen::Vector3d::UnitX();
            a2 = Eigen::Vector3d::UnitZ();
          } else {
            a1 = Eigen::Vector3d::UnitX();
            a2 = Eigen::Vector3d::UnitY();
          }
          Face f;
          const double h = 0.5 * l;
          f.p = {fc - h * a1 - h * a2, fc + h * a1 - h * a2, fc + h * a1 + h * a2,
                 fc - h * a1 + h * a2};
          f.normal = n;
          f.colour = cv::Vec3b(150, 150, 150);
          faces.push_back(f);
        }
      }
    }
  }
  const int W = 960, H = 720;
  const double focal = 700.0;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(250, 245, 240));
  for (Face& f : faces) {
    f.depth = 0.0;
    for (const auto& p : f.p)
      f.depth += 0.25 * (p - eye).dot(zc);
  }
  std::sort(faces.begin(), faces.end(),
            [](const Face& a, const Face& b) { return a.depth > b.depth; });
  const Eigen::Vector3d light = Eigen::Vector3d(-0.4, -0.3, 1.0).normalized();
  for (const Face& f : faces) {
    std::vector<cv::Point> poly;
    bool ok = true;
    for (const auto& p : f.p) {
      const Eigen::Vector3d q = p - eye;
      const double z = q.dot(zc);
      if (z < 0.2) {
        ok = false;
        break;
      }
      poly.emplace_back(static_cast<int>(W / 2 + focal * q.dot(xc) / z),
                        static_cast<int>(H / 2 + focal * q.dot(yc) / z));
    }
    if (!ok) continue;
    const double shade = 0.55 + 0.45 * std::abs(f.normal.dot(light));
    const cv::Scalar col(f.colour[0] * shade, f.colour[1] * shade, f.colour[2] * shade);
    cv::fillConvexPoly(img, poly, col, cv::LINE_AA);
    cv::polylines(img, poly, true, col * 0.8, 1, cv::LINE_AA);
  }
  // The robot: a red marker at its base.
  const Eigen::Vector3d q = robot - eye;
  if (q.dot(zc) > 0.2) {
    cv::circle(img,
               cv::Point(static_cast<int>(W / 2 + focal * q.dot(xc) / q.dot(zc)),
                         static_cast<int>(H / 2 + focal * q.dot(yc) / q.dot(zc))),
               8, cv::Scalar(0, 0, 255), cv::FILLED, cv::LINE_AA);
  }
  cv::putText(img,
              "hybrid 3D model (000 Fig. 4(b)): Level planes green, Inclined yellow, Non-ground "
              "voxels grey",
              cv::Point(10, 24), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  return img;
}

}  // namespace evaluate_safety_map
