// evaluate_hybrid: the runs over a bag. Table 2 of 001 (every LaserScan ray cast into the LaserGrid
// the hybrid nodelet uses, the stereo safety map, the three hybrid maps of each integrated frame)
// and the landmark filter off / on.
#include "evaluate_hybrid.h"

#include "stereo_safety_map/core/laser_grid.h"
#include "stereo_safety_map/core/map_image.h"
#include "stereo_safety_map/ros/hybrid_conversions.h"

#include <cv_bridge/cv_bridge.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Image.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

namespace evaluate_hybrid {

// 001 Fig. 5 colours (BGR): obstacles black, hazards dark grey, unknown light grey, safe white;
// caution (not in 001's figure) yellow.
cv::Vec3b hybridColour(HybridLabel l) {
  switch (l) {
    case HybridLabel::kObstacle:
      return {0, 0, 0};
    case HybridLabel::kHazard:
      return {90, 90, 90};
    case HybridLabel::kCaution:
      return {80, 210, 235};
    case HybridLabel::kSafe:
      return {255, 255, 255};
    default:
      return {200, 200, 200};
  }
}

ssm::SafetyMap geometryOf(const HybridSafetyMap& h) {
  ssm::SafetyMap g;
  g.min_u = h.min_u;
  g.min_v = h.min_v;
  g.width = h.width;
  g.height = h.height;
  g.resolution = h.resolution;
  return g;
}

cv::Mat hybridPanel(const HybridSafetyMap& h, const Eigen::Vector3d& robot, double yaw,
                    const std::string& title) {
  const ssm::SafetyMap g = geometryOf(h);
  cv::Mat img = ssm::mapPanel(g, [&h](int, int, int k) { return hybridColour(h.labels[k]); });
  ssm::drawRobot(&img, g, robot, yaw);
  return ssm::titled(img, title);
}

// ---------------------------------------------------------------------------------------------
// Every LaserScan of a bag in stamp order with its pose from the bag's tf, as the hybrid nodelet
// receives them (the dataset reader keeps only the newest scan per stereo pair, and in the
// package's bags half of the scans are replaced before the next pair is complete).

class ScanReader {
 public:
  bool open(const std::string& bag, const std::string& topic) {
    try {
      bag_.open(bag, rosbag::bagmode::Read);
      view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery(topic));
    } catch (const std::exception&) {
      return false;
    }
    it_ = view_->begin();
    return view_->size() > 0;
  }
  // The next scan stamped at or before `stamp`; false when there is none (yet).
  bool next(const ros::Time& stamp, sensor_msgs::LaserScanConstPtr* scan) {
    while (view_ && it_ != view_->end()) {
      if (it_->getTime() > stamp) return false;
      *scan = it_->instantiate<sensor_msgs::LaserScan>();
      ++it_;
      if (*scan) return true;
    }
    return false;
  }

 private:
  rosbag::Bag bag_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
};

// ---------------------------------------------------------------------------------------------
// Ground-truth depth of a bag rendered with --depth, read alongside the stereo pairs.

class DepthReader {
 public:
  bool open(const std::string& bag) {
    try {
      bag_.open(bag, rosbag::bagmode::Read);
      view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery("/ground_truth/depth"));
    } catch (const std::exception&) {
      return false;
    }
    if (view_->size() == 0) return false;
    it_ = view_->begin();
    return true;
  }
  // The depth image stamped `stamp` (CV_32FC1), empty when there is none.
  cv::Mat at(const ros::Time& stamp) {
    if (!view_) return {};
    while (it_ != view_->end()) {
      sensor_msgs::ImageConstPtr m = it_->instantiate<sensor_msgs::Image>();
      if (!m || m->header.stamp < stamp) {
        ++it_;
        continue;
      }
      if (m->header.stamp > stamp) return {};
      try {
        return cv_bridge::toCvShare(m, "32FC1")->image.clone();
      } catch (const std::exception&) {
        return {};
      }
    }
    return {};
  }

 private:
  rosbag::Bag bag_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
};

std::string runFusion(const std::string& bag, const ssm::StereoFrameProcessorConfig& config,
                      const Options& opt, bool pictures, FusionResult* r) {
  ssm::Dataset d;
  std::string e = ssm::loadDataset(bag, false, &d);
  if (!e.empty()) return e;
  r->name = d.name;
  r->scene = d.scene;
  const HybridSafetyMap truth = hybridTruth(d.gt);

  ssm::StereoBagReader reader;
  ssm::StereoBagReaderOptions ro;
  ro.max_frames = opt.max_frames;
  e = reader.open(bag, ro);
  if (!e.empty()) return e;
  ScanReader scans;
  if (!scans.open(bag, ro.scan_topic)) return d.name + ": no " + ro.scan_topic + " in " + bag;

  ssm::StereoFrameProcessor proc(config);
  // The laser grid of the hybrid nodelet: its defaults (config/hybrid_safety_map.yaml), cells of
  // the voxel grid's size, a window 2 m larger than the stereo map.
  ssm::LaserGridConfig lc;
  lc.resolution = config.mapper.grid.voxel_size;
  lc.width = static_cast<int>(std::lround((config.mapper.grid.size_x + 2.0) / lc.resolution));
  lc.height = static_cast<int>(std::lround((config.mapper.grid.size_y + 2.0) / lc.resolution));
  ssm::LaserGrid laser(lc);
  ssm::HybridSafetyMapBuilder builder;
  ssm::HybridSafetyMapConfig fill_config;
  fill_config.laser_free_vision_unknown_is_safe = true;
  ssm::HybridSafetyMapBuilder fill_builder(fill_config);
  HybridSafetyMap maps[kSources], common[kSources];
  sensor_msgs::LaserScanConstPtr scan;
  ssm::StereoBagFrame f;
  Eigen::Vector3d last_robot = Eigen::Vector3d::Zero();
  double last_yaw = kNaN;
  bool blind_ready = false;

  while (reader.next(&f)) {
    ++r->pairs;
    const Clock::time_point t0 = Clock::now();
    // Every scan up to this pair, as the nodelet integrates them.
    while (scans.next(f.stamp, &scan)) {
      ssm::LaserScanInfo info;
      if (!ssm::laserScanInfoFromMsg(*scan, &info).empty()) continue;
      Eigen::Isometry3f T;
      try {
        T = tf2::transformToEigen(reader.tf().lookupTransform(ro.fixed_frame, scan->header.frame_id,
                                                              scan->header.stamp))
                .cast<float>();
      } catch (const tf2::TransformException&) {
        continue;
      }
      const Clock::time_point tl = Clock::now();
      laser.recenter(T.translation().x(), T.translation().y());
      laser.integrate(info, scan->ranges, T);
      r->laser_ms.push_back(msSince(tl));
      ++r->scans;
      if (!blind_ready) {
        r->laser_z = T.translation().z();
        r->blind = laserBlindCells(d, r->laser_z, config.mapper.height_map.robot_height);
        blind_ready = true;
      }
    }
    if (!f.error.empty() || f.index % opt.every != 0) continue;
    ssm::StereoFrameResult res;
    std::string err;
    if (!proc.processImages(f.left, f.right, f.camera, f.T_fixed_sensor.cast<float>(),
                            f.robot.cast<float>(), f.stamp.toSec(), &res, &err)) {
      continue;
    }
    ++r->integrated;
    const Clock::time_point tb = Clock::now();
    for (int s = 0; s < kSources; ++s) {
      (s == 3 ? fill_builder : builder)
          .build(kSourceOrder[s], proc.mapper().safetyMap(), laser, &maps[s]);
    }
    r->build_ms.push_back(msSince(tb) / kSources);
    commonCells(maps, &common);
    for (int s = 0; s < kSources; ++s) {
      e = ssm::countHybridConfusion(maps[s], truth, &r->own[s]);
      if (e.empty()) e = ssm::countHybridConfusion(common[s], truth, &r->common[s]);
      if (!e.empty()) return d.name + ": " + e;
    }
    if (blind_ready) {
      for (int k = 0; k < kBlindKinds; ++k)
        r->blind_counts[k].add(maps, r->blind.cells[k]);
    }
    last_robot = f.robot;
    last_yaw = ssm::yawOfOpticalAxis(f.T_fixed_sensor);
    r->frame_ms.push_back(msSince(t0));
    if (!opt.quiet && r->integrated % 50 == 0) {
      std::fprintf(stderr, "  %s: %d pairs, %d integrated\n", d.name.c_str(), r->pairs,
                   r->integrated);
    }
  }
  if (r->integrated == 0) return d.name + ": no frame was integrated";

  if (pictures) {
    // Last frame: laser-only | stereo-only | merged | ground truth, 001 Fig. 5 colours.
    HybridSafetyMap gt_window = maps[0];
    for (int row = 0; row < gt_window.height; ++row) {
      for (int col = 0; col < gt_window.width; ++col) {
        gt_window.labels[static_cast<std::size_t>(row) * gt_window.width + col] =
            truth.labelAt(gt_window.min_u + col, gt_window.min_v + row);
      }
    }
    // In the truth panel, the laser-blind cells as hazards (what 001's annotator would mark).
    for (int k = 0; k < kBlindKinds; ++k) {
      for (const auto& c : r->blind.cells[k]) {
        if (gt_window.inside(c.first, c.second)) {
          gt_window.labels[gt_window.index(c.first, c.second)] = HybridLabel::kHazard;
        }
      }
    }
    std::vector<cv::Mat> panels;
    panels.push_back(hybridPanel(maps[0], last_robot, last_yaw, "laser only"));
    panels.push_back(hybridPanel(maps[1], last_robot, last_yaw, "stereo only"));
    panels.push_back(hybridPanel(maps[2], last_robot, last_yaw, "merged (001)"));
    panels.push_back(hybridPanel(gt_window, last_robot, last_yaw, "ground truth"));
    cv::Mat row;
    cv::hconcat(panels, row);
    const std::string file = d.name + "_last_frame.png";
    if (cv::imwrite(opt.out + "/" + file, row)) r->images.push_back(file);
  }
  return "";
}

std::string runLandmarks(const std::string& bag, const ssm::StereoFrameProcessorConfig& config,
                         const Options& opt, LandmarkResult* r) {
  ssm::Dataset d;
  std::string e = ssm::loadDataset(bag, false, &d);
  if (!e.empty()) return e;
  r->name = d.name;
  ssm::StereoBagReader reader;
  ssm::StereoBagReaderOptions ro;
  ro.max_frames = opt.max_frames;
  ro.scan_topic = "";
  e = reader.open(bag, ro);
  if (!e.empty()) return e;
  DepthReader depth;
  r->has_depth = depth.open(bag);

  ssm::StereoFrameProcessorConfig c_off = config, c_on = config;
  c_off.landmark_filter.enabled = false;
  c_on.landmark_filter.enabled = true;
  ssm::StereoFrameProcessor off(c_off), on(c_on);
  ssm::StereoBagFrame f;
  std::vector<ssm::CellOutcome> outcomes;
  while (reader.next(&f)) {
    ++r->pairs;
    if (!f.error.empty() || f.index % opt.every != 0) continue;
    const Eigen::Isometry3f T = f.T_fixed_sensor.cast<float>();
    const Eigen::Vector3f robot = f.robot.cast<float>();
    const double stamp = f.stamp.toSec();
    ssm::StereoFrameResult res;
    std::string err;
    const Clock::time_point t0 = Clock::now();
    const bool ok_off = off.processImages(f.left, f.right, f.camera, T, robot, stamp, &res, &err);
    if (off.disparity().empty()) continue;  // bad pair: neither run sees it
    const double disparity_ms = res.timings.disparity_ms;
    const cv::Mat dmap = depth.at(f.stamp);
    if (ok_off) {
      LandmarkRun& run = r->off;
      ++run.integrated;
      run.frame_ms.push_back(msSince(t0));
      run.points_reprojected += res.points_reprojected;
      run.points_to_grid += res.points;
      countGhosts(off.points(), dmap, f.camera, opt.ghost_px, &run.checked_to_grid,
                  &run.ghosts_to_grid);
      e = ssm::countConfusion(off.mapper().safetyMap(), d.gt, &run.map);
      if (!e.empty()) return d.name + ": " + e;
    }
    const Clock::time_point t1 = Clock::now();
    ssm::StereoFrameResult res_on;
    const bool ok_on = on.processDisparity(off.disparity(), off.disparityCamera(), T, robot, stamp,
                                           &res_on, &err, off.coarseDisparity());
    LandmarkRun& run = r->on;
    if (res_on.landmark_filter_ran) {
      run.landmark_ms.push_back(res_on.timings.landmark_ms);
      run.landmark_cpu_ms.push_back(res_on.timings.landmark_cpu_ms);
      run.points_reprojected += res_on.points_reprojected;
      run.points_to_grid += res_on.points;
      countGhosts(on.points(), dmap, f.camera, opt.ghost_px, &run.checked_to_grid,
                  &run.ghosts_to_grid);
      run.permanent = res_on.landmarks.permanent;
    }
    if (ok_on) {
      ++run.integrated;
      run.frame_ms.push_back(msSince(t1) + disparity_ms);
      e = ssm::countConfusion(on.mapper().safetyMap(), d.gt, &run.map);
      if (!e.empty()) return d.name + ": " + e;
    }
    if (!opt.quiet && r->pairs % 100 == 0) {
      std::fprintf(stderr, "  %s (landmarks): %d pairs\n", d.name.c_str(), r->pairs);
    }
  }
  return "";
}

}  // namespace evaluate_hybrid
