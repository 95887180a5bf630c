// make_dataset: renders a synthetic benchmark dataset (000 Sec. VII) from a scene file into a
// rosbag plus plain-file ground truth, without a roscore.
//
//   make_dataset --scene scenes/x.yaml [--scene ...] --out DIR [--small] [--frames N] [--seed S]
//                [--variant NAME|all] [--threads N] [--colour] [--depth] [--no-bag] [--preview]
//                [--info] [--compress none|lz4|bz2]
//
// Writes per scene (and variant) DIR/<name>.bag and DIR/<name>_gt/ (gt_map.pgm + gt_map.yaml in
// map_server format, gt_labels.pgm, gt_drop_off.pgm, gt_planes.yaml, gt_obstacles.yaml,
// dataset.yaml). Bag topics (stamps start at 1e9 s):
//   /stereo/left/image_rect, /stereo/right/image_rect      sensor_msgs/Image (mono8 or bgr8)
//   /stereo/left/camera_info, /stereo/right/camera_info    sensor_msgs/CameraInfo (right P has
//                                                          Tx = -fx * baseline; both in the left
//                                                          optical frame, ROS stereo convention)
//   /tf        odom -> base_link at 2x the frame rate
//   /tf_static base_link -> stereo_camera_link -> stereo_camera_optical_frame
//              (-> stereo_camera_right_optical_frame), base_link -> laser
//   /odom      nav_msgs/Odometry, /scan sensor_msgs/LaserScan (horizontal, in frame laser)
//   /ground_truth/safety_map  nav_msgs/OccupancyGrid (latched; level 0, inclined 30,
//                             non-ground 100, unknown -1)
//   /ground_truth/labels      nav_msgs/OccupancyGrid (latched; raw SafetyMap label values)
//   /ground_truth/obstacles, /ground_truth/planes  visualization_msgs/MarkerArray (latched)
//   /ground_truth/depth       sensor_msgs/Image 32FC1, left depth Z [m] (with --depth)
#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/laser.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene_loader.h"
#include "stereo_safety_map/dataset/trajectory.h"
#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/tools/args.h"

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

namespace ds = stereo_safety_map::dataset;
namespace ssm = stereo_safety_map;
using stereo_safety_map::SafetyLabel;

namespace {

constexpr double kEpoch = 1.0e9;  // first stamp [s], fixed for determinism
const char* kOdom = "odom";
const char* kBase = "base_link";
const char* kCamLink = "stereo_camera_link";
const char* kOptical = "stereo_camera_optical_frame";
const char* kRightOptical = "stereo_camera_right_optical_frame";
const char* kLaser = "laser";

struct Options {
  std::vector<std::string> scenes;
  std::string out;
  bool small = false;
  long frames = -1;
  long long seed = -1;
  std::string variant;  // "" = all the file offers (or none)
  int threads = 2;
  bool colour = false;
  bool depth = false;
  bool bag = true;
  bool preview = false;
  bool info = false;
  std::string compress = "none";
};

void usage() {
  std::fprintf(stderr,
               "usage: make_dataset --scene FILE [--scene FILE ...] --out DIR [--small] "
               "[--frames N] [--seed S]\n"
               "                    [--variant NAME|all] [--threads N] [--colour] [--depth] "
               "[--no-bag] [--preview]\n"
               "                    [--info] [--compress none|lz4|bz2]\n"
               "  --small    320x240 images and 40 frames spread over the trajectory (tests)\n"
               "  --frames N keep N frames evenly spread over the trajectory\n"
               "  --info     print trajectory and ground-truth statistics, render nothing\n");
}

bool parseArgs(int argc, char** argv, Options* o) {
  ssm::tools::Args a(argc, argv);
  while (a.next()) {
    if (a.value("--scene", &o->scenes) || a.value("--out", &o->out) ||
        a.flag("--small", &o->small) || a.value("--variant", &o->variant) ||
        a.flag("--colour", &o->colour) || a.flag("--color", &o->colour) ||
        a.flag("--depth", &o->depth) || a.flag("--no-bag", &o->bag, false) ||
        a.flag("--preview", &o->preview) || a.flag("--info", &o->info))
      continue;
    if (a.value("--frames", &o->frames)) {
      if (o->frames < 1) return false;
    } else if (a.value("--seed", &o->seed)) {
      if (o->seed < 0) return false;
    } else if (a.value("--threads", &o->threads)) {
      if (o->threads < 1 || o->threads > 64) return false;
    } else if (a.value("--compress", &o->compress)) {
      if (o->compress != "none" && o->compress != "lz4" && o->compress != "bz2") return false;
    } else if (a.missingValue()) {
      std::fprintf(stderr, "missing value for %s\n", a.arg().c_str());
      return false;
    } else {
      std::fprintf(stderr, "unknown argument %s\n", a.arg().c_str());
      return false;
    }
  }
  return !o->scenes.empty() && !o->out.empty();
}

bool makeDir(const std::string& d) {
  if (mkdir(d.c_str(), 0775) == 0) return true;
  struct stat st;
  return stat(d.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

geometry_msgs::TransformStamped toMsg(const Eigen::Isometry3d& T, const ros::Time& stamp,
                                      const std::string& parent, const std::string& child) {
  geometry_msgs::TransformStamped m = tf2::eigenToTransform(T);
  m.header.stamp = stamp;
  m.header.frame_id = parent;
  m.child_frame_id = child;
  return m;
}

ros::Time stampAt(double t) {
  return ros::Time(kEpoch) + ros::Duration(t);
}

// Connection header of a latched topic. A custom header replaces rosbag's own, so it must carry
// the message type, md5sum and definition too.
template <class M>
boost::shared_ptr<ros::M_string> latched(const M&) {
  auto h = boost::make_shared<ros::M_string>();
  (*h)["type"] = ros::message_traits::datatype<M>();
  (*h)["md5sum"] = ros::message_traits::md5sum<M>();
  (*h)["message_definition"] = ros::message_traits::definition<M>();
  (*h)["latching"] = "1";
  (*h)["callerid"] = "/make_dataset";
  return h;
}

template <class M>
void writeLatched(rosbag::Bag* bag, const std::string& topic, const ros::Time& t, const M& msg) {
  bag->write(topic, t, msg, latched(msg));
}

void fillImage(const cv::Mat& img, const std::string& encoding, sensor_msgs::Image* msg) {
  msg->header.frame_id = kOptical;
  msg->height = img.rows;
  msg->width = img.cols;
  msg->encoding = encoding;
  msg->is_bigendian = 0;
  msg->step = static_cast<std::uint32_t>(img.cols * img.elemSize());
  msg->data.resize(static_cast<std::size_t>(msg->step) * img.rows);
  for (int r = 0; r < img.rows; ++r)
    std::memcpy(&msg->data[static_cast<std::size_t>(r) * msg->step], img.ptr(r), msg->step);
}

nav_msgs::OccupancyGrid gridMsg(const ds::GroundTruthMap& m, bool raw) {
  nav_msgs::OccupancyGrid g;
  g.header.frame_id = kOdom;
  g.header.stamp = stampAt(0.0);
  g.info.map_load_time = g.header.stamp;
  g.info.resolution = static_cast<float>(m.resolution);
  g.info.width = m.width;
  g.info.height = m.height;
  g.info.origin.position.x = (m.min_u - 0.5) * m.resolution;
  g.info.origin.position.y = (m.min_v - 0.5) * m.resolution;
  g.info.origin.orientation.w = 1.0;
  g.data.resize(m.labels.size());
  for (std::size_t k = 0; k < m.labels.size(); ++k) {
    const SafetyLabel l = m.labels[k];
    if (raw) {
      g.data[k] = static_cast<std::int8_t>(l);
    } else {
      g.data[k] = l == SafetyLabel::kLevel       ? 0
                  : l == SafetyLabel::kInclined  ? 30
                  : l == SafetyLabel::kNonGround ? 100
                                                 : -1;
    }
  }
  return g;
}

visualization_msgs::MarkerArray obstacleMarkers(const std::vector<ds::GroundTruthObstacle>& obs) {
  visualization_msgs::MarkerArray arr;
  int id = 0;
  for (const auto& o : obs) {
    visualization_msgs::Marker mk;
    mk.header.frame_id = kOdom;
    mk.header.stamp = stampAt(0.0);
    mk.ns = "gt_obstacles";
    mk.id = id++;
    mk.type = o.shape == "cylinder" ? visualization_msgs::Marker::CYLINDER
                                    : visualization_msgs::Marker::CUBE;
    mk.action = visualization_msgs::Marker::ADD;
    mk.pose.position = tf2::toMsg(o.obb.center);
    mk.pose.orientation = tf2::toMsg(Eigen::Quaterniond(o.obb.rotation));
    mk.scale.x = 2.0 * o.obb.half_size.x();
    mk.scale.y = 2.0 * o.obb.half_size.y();
    mk.scale.z = 2.0 * o.obb.half_size.z();
    mk.color = ssm::colorMsg(0.8f, 0.2f, 0.2f, 0.6f);
    mk.text = o.name;
    arr.markers.push_back(mk);
  }
  return arr;
}

visualization_msgs::MarkerArray planeMarkers(const std::vector<ds::GroundTruthPlane>& planes) {
  visualization_msgs::MarkerArray arr;
  int id = 0;
  for (const auto& p : planes) {
    visualization_msgs::Marker mk;
    mk.header.frame_id = kOdom;
    mk.header.stamp = stampAt(0.0);
    mk.ns = "gt_planes";
    mk.id = id++;
    mk.type = visualization_msgs::Marker::TRIANGLE_LIST;
    mk.action = visualization_msgs::Marker::ADD;
    mk.pose.orientation.w = 1.0;
    mk.scale.x = mk.scale.y = mk.scale.z = 1.0;
    mk.color = p.label == SafetyLabel::kLevel      ? ssm::colorMsg(0.2f, 0.8f, 0.2f, 0.7f)
               : p.label == SafetyLabel::kInclined ? ssm::colorMsg(0.9f, 0.9f, 0.1f, 0.7f)
                                                   : ssm::colorMsg(0.8f, 0.1f, 0.1f, 0.7f);
    for (std::size_t i = 1; i + 1 < p.polygon.size(); ++i) {
      for (std::size_t k : {std::size_t(0), i, i + 1}) {
        geometry_msgs::Point pt;
        pt.x = p.polygon[k].x();
        pt.y = p.polygon[k].y();
        pt.z = p.polygon[k].z();
        mk.points.push_back(pt);
      }
    }
    mk.text = p.name;
    arr.markers.push_back(mk);
  }
  return arr;
}

cv::Mat colourMap(const ds::GroundTruthMap& m, const std::vector<ds::RobotPose>& poses) {
  cv::Mat img(m.height, m.width, CV_8UC3);
  for (int r = 0; r < m.height; ++r) {
    for (int c = 0; c < m.width; ++c) {
      const int k = (m.height - 1 - r) * m.width + c;
      cv::Vec3b col;
      switch (m.labels[k]) {  // 000 Fig. 4(a) colours (BGR)
        case SafetyLabel::kLevel:
          col = cv::Vec3b(255, 255, 255);
          break;
        case SafetyLabel::kInclined:
          col = cv::Vec3b(0, 230, 255);
          break;
        case SafetyLabel::kNonGround:
          col = cv::Vec3b(0, 0, 0);
          break;
        case SafetyLabel::kUnexamined:
          col = cv::Vec3b(90, 90, 90);
          break;
        default:
          col = cv::Vec3b(190, 190, 190);
          break;
      }
      if (m.drop_off[k]) col = cv::Vec3b(255, 0, 0);
      img.at<cv::Vec3b>(r, c) = col;
    }
  }
  cv::Mat big;
  cv::resize(img, big, cv::Size(), 4, 4, cv::INTER_NEAREST);
  for (const auto& p : poses) {
    const int c = m.cellOf(p.x) - m.min_u, r = m.height - 1 - (m.cellOf(p.y) - m.min_v);
    cv::circle(big, cv::Point(4 * c + 2, 4 * r + 2), 1, cv::Scalar(0, 0, 255), -1);
  }
  return big;
}

struct Stats {
  std::vector<double> ms;
  void add(double v) { ms.push_back(v); }
  std::string str() const {
    if (ms.empty()) return "n/a";
    std::vector<double> s = ms;
    std::sort(s.begin(), s.end());
    char buf[128];
    std::snprintf(buf, sizeof(buf), "min %.1f / median %.1f / max %.1f ms", s.front(),
                  s[s.size() / 2], s.back());
    return buf;
  }
};

int runOne(const std::string& path, const std::string& variant, const Options& opt) {
  ds::SceneFile sf;
  std::string e = ds::loadSceneFromFile(path, variant, &sf);
  if (!e.empty()) {
    std::fprintf(stderr, "error: %s\n", e.c_str());
    return 1;
  }
  ds::StereoHeadConfig head = sf.camera;
  if (opt.small) head = head.scaledTo(320, 240);
  head.threads = opt.threads;
  head.colour = head.colour || opt.colour;
  const std::uint64_t seed = opt.seed >= 0 ? static_cast<std::uint64_t>(opt.seed) : sf.seed;
  const std::string name = sf.scene.name;

  const std::vector<ds::RobotPose> poses = ds::sampleTrajectory(sf.trajectory);
  if (poses.empty()) {
    std::fprintf(stderr, "error: %s: empty or invalid trajectory\n", name.c_str());
    return 1;
  }
  const long want = opt.frames > 0 ? opt.frames : (opt.small ? 40 : -1);
  const std::vector<std::size_t> idx =
      ds::subsampleFrames(poses.size(), want > 0 ? static_cast<std::size_t>(want) : poses.size());
  // Stationary: same pose as the previous frame written (which differs from the trajectory's own
  // flag when frames are subsampled).
  std::vector<std::uint8_t> still(idx.size(), 0);
  std::size_t stationary = 0;
  for (std::size_t i = 1; i < idx.size(); ++i) {
    const ds::RobotPose &a = poses[idx[i]], &b = poses[idx[i - 1]];
    still[i] = std::abs(a.x - b.x) < 1e-12 && std::abs(a.y - b.y) < 1e-12 &&
               std::abs(std::remainder(a.yaw - b.yaw, 2.0 * M_PI)) < 1e-12;
    stationary += still[i];
  }

  ds::GroundTruthConfig gtc;
  ds::GroundTruthMap gt;
  e = ds::computeGroundTruth(sf.scene, gtc,
                             Eigen::Vector2d(sf.trajectory.start_x, sf.trajectory.start_y), &gt);
  if (!e.empty()) {
    std::fprintf(stderr, "error: %s: ground truth: %s\n", name.c_str(), e.c_str());
    return 1;
  }
  const auto planes = ds::groundTruthPlanes(sf.scene, gt);
  const auto obstacles = ds::groundTruthObstacles(sf.scene);
  int counts[5] = {0, 0, 0, 0, 0};
  for (SafetyLabel l : gt.labels)
    ++counts[static_cast<int>(l)];
  // The robot must stay on safe ground (the paper's robot drove level surfaces, 000 Sec. I-A).
  int unsafe_poses = 0;
  for (const auto& p : poses)
    if (!stereo_safety_map::isSafe(gt.labelAtPoint(p.x, p.y))) ++unsafe_poses;

  std::printf(
      "%s: %zu frames (%zu stationary, %.0f%%), %.1f s, %dx%d, %zu primitives; GT %dx%d "
      "cells: level %d inclined %d non-ground %d unknown %d%s\n",
      name.c_str(), idx.size(), stationary, 100.0 * stationary / idx.size(), poses.back().t,
      head.width, head.height, sf.scene.primitives.size(), gt.width, gt.height, counts[2],
      counts[3], counts[4], counts[1],
      unsafe_poses ? " (WARNING: trajectory leaves safe ground)" : "");
  if (opt.info) return unsafe_poses ? 1 : 0;

  const std::string gt_dir = opt.out + "/" + name + "_gt";
  if (!makeDir(gt_dir)) {
    std::fprintf(stderr, "error: cannot create %s\n", gt_dir.c_str());
    return 1;
  }
  e = ds::writeGroundTruthFiles(gt_dir, sf.scene, gtc, gt, planes, obstacles);
  if (!e.empty()) {
    std::fprintf(stderr, "error: %s\n", e.c_str());
    return 1;
  }
  {
    std::ofstream f(gt_dir + "/dataset.yaml");
    f << std::setprecision(12);
    f << "# Dataset description written by make_dataset.\nscene: " << name
      << "\nscene_file: " << path << "\nvariant: '" << sf.variant << "'\nseed: " << seed
      << "\nframes: " << idx.size() << "\nstationary_frames: " << stationary
      << "\nrate_hz: " << sf.trajectory.rate_hz << "\nfirst_stamp: " << kEpoch
      << "\nimage: {width: " << head.width << ", height: " << head.height
      << ", encoding: " << (head.colour ? "bgr8" : "mono8") << "}\ncamera: {fx: " << head.fx()
      << ", fy: " << head.fx() << ", cx: " << head.cx() << ", cy: " << head.cy()
      << ", baseline: " << head.baseline << ", hfov_deg: " << head.hfov_deg << ", mount: ["
      << head.mount_x << ", " << head.mount_y << ", " << head.mount_z
      << "], pitch_deg: " << head.pitch_deg << ", noise_sigma: " << head.noise_sigma
      << ", blur_sigma: " << head.blur_sigma << "}\nframes_list:  # [index, stamp, x, y, yaw, "
      << "stationary]\n";
    for (std::size_t i = 0; i < idx.size(); ++i) {
      const auto& p = poses[idx[i]];
      f << "  - [" << i << ", " << std::fixed << std::setprecision(6) << kEpoch + p.t << ", " << p.x
        << ", " << p.y << ", " << p.yaw << ", " << int(still[i]) << "]\n";
      f.unsetf(std::ios::floatfield);
    }
  }

  ds::StereoRenderer renderer(sf.scene, head, seed);
  const Eigen::Isometry3d T_base_opt = head.baseToLeftOptical();
  const Eigen::Isometry3d T_base_laser = sf.laser.baseToLaser();
  cv::Mat left, right, depth;

  if (opt.preview) {  // first, middle and last frame, and the GT map with the trajectory
    const std::size_t picks[3] = {0, idx.size() / 2, idx.size() - 1};
    const char* tags[3] = {"first", "middle", "last"};
    for (int k = 0; k < 3; ++k) {
      const auto& p = poses[idx[picks[k]]];
      renderer.render(ds::basePose(p.x, p.y, sf.trajectory.base_z, p.yaw) * T_base_opt,
                      idx[picks[k]], &left, &right);
      cv::imwrite(opt.out + "/" + name + "_preview_" + tags[k] + "_left.png", left);
      if (k == 0) cv::imwrite(opt.out + "/" + name + "_preview_first_right.png", right);
    }
    cv::imwrite(opt.out + "/" + name + "_preview_gt.png", colourMap(gt, poses));
  }
  if (!opt.bag) return 0;

  rosbag::Bag bag;
  try {
    bag.open(opt.out + "/" + name + ".bag", rosbag::bagmode::Write);
    if (opt.compress == "lz4") bag.setCompression(rosbag::compression::LZ4);
    if (opt.compress == "bz2") bag.setCompression(rosbag::compression::BZ2);

    const ros::Time t0 = stampAt(0.0);
    tf2_msgs::TFMessage statics;
    statics.transforms.push_back(toMsg(head.baseToCameraLink(), t0, kBase, kCamLink));
    Eigen::Isometry3d T_link_opt = Eigen::Isometry3d::Identity();
    T_link_opt.linear() = ds::linkToOpticalRotation();
    statics.transforms.push_back(toMsg(T_link_opt, t0, kCamLink, kOptical));
    Eigen::Isometry3d T_l_r = Eigen::Isometry3d::Identity();
    T_l_r.translation() = Eigen::Vector3d(head.baseline, 0.0, 0.0);
    statics.transforms.push_back(toMsg(T_l_r, t0, kOptical, kRightOptical));
    statics.transforms.push_back(toMsg(T_base_laser, t0, kBase, kLaser));
    writeLatched(&bag, "/tf_static", t0, statics);
    writeLatched(&bag, "/ground_truth/safety_map", t0, gridMsg(gt, false));
    writeLatched(&bag, "/ground_truth/labels", t0, gridMsg(gt, true));
    writeLatched(&bag, "/ground_truth/obstacles", t0, obstacleMarkers(obstacles));
    writeLatched(&bag, "/ground_truth/planes", t0, planeMarkers(planes));

    const std::string enc = head.colour ? "bgr8" : "mono8";
    std_msgs::Header info_header;
    info_header.frame_id = kOptical;
    sensor_msgs::CameraInfo info_l =
        ssm::toCameraInfo(ds::stereoCameraModel(head), false, info_header);
    sensor_msgs::CameraInfo info_r =
        ssm::toCameraInfo(ds::stereoCameraModel(head), true, info_header);
    sensor_msgs::Image img_l, img_r, img_d;
    sensor_msgs::LaserScan scan;
    scan.header.frame_id = kLaser;
    scan.angle_min = static_cast<float>(sf.laser.angle_min_deg * M_PI / 180.0);
    scan.angle_increment = static_cast<float>(sf.laser.angle_increment_deg * M_PI / 180.0);
    scan.angle_max = scan.angle_min + scan.angle_increment * (sf.laser.beamCount() - 1);
    scan.time_increment = 0.0f;
    scan.scan_time = static_cast<float>(1.0 / sf.trajectory.rate_hz);
    scan.range_min = static_cast<float>(sf.laser.range_min);
    scan.range_max = static_cast<float>(sf.laser.range_max);
    std::vector<float> ranges;

    Stats render_ms, total_ms;
    const auto t_start = std::chrono::steady_clock::now();
    const double half = 0.5 / sf.trajectory.rate_hz;
    for (std::size_t i = 0; i < idx.size(); ++i) {
      const auto t_frame = std::chrono::steady_clock::now();
      const ds::RobotPose& p = poses[idx[i]];
      const ros::Time stamp = stampAt(p.t);
      const Eigen::Isometry3d T_odom_base = ds::basePose(p.x, p.y, sf.trajectory.base_z, p.yaw);
      // odom -> base_link at the frame and half a frame later (for interpolating lookups).
      for (double dt : {0.0, half}) {
        const ds::RobotPose q = dt == 0.0 ? p : ds::poseAt(sf.trajectory, p.t + dt);
        tf2_msgs::TFMessage tf;
        tf.transforms.push_back(toMsg(ds::basePose(q.x, q.y, sf.trajectory.base_z, q.yaw),
                                      stampAt(p.t + dt), kOdom, kBase));
        bag.write("/tf", stampAt(p.t + dt), tf);
      }
      nav_msgs::Odometry odom;
      odom.header.stamp = stamp;
      odom.header.frame_id = kOdom;
      odom.child_frame_id = kBase;
      odom.pose.pose = tf2::toMsg(T_odom_base);
      odom.twist.twist.linear.x = p.v;
      odom.twist.twist.angular.z = p.omega;
      bag.write("/odom", stamp, odom);

      const auto t_r = std::chrono::steady_clock::now();
      renderer.render(T_odom_base * T_base_opt, idx[i], &left, &right,
                      opt.depth ? &depth : nullptr);
      render_ms.add(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_r)
              .count());
      fillImage(left, enc, &img_l);
      fillImage(right, enc, &img_r);
      img_l.header.stamp = img_r.header.stamp = info_l.header.stamp = info_r.header.stamp = stamp;
      bag.write("/stereo/left/image_rect", stamp, img_l);
      bag.write("/stereo/right/image_rect", stamp, img_r);
      bag.write("/stereo/left/camera_info", stamp, info_l);
      bag.write("/stereo/right/camera_info", stamp, info_r);
      if (opt.depth) {
        fillImage(depth, "32FC1", &img_d);
        img_d.header.stamp = stamp;
        bag.write("/ground_truth/depth", stamp, img_d);
      }
      ds::simulateScan(sf.scene, sf.laser, T_odom_base * T_base_laser, seed, idx[i], &ranges);
      scan.header.stamp = stamp;
      scan.ranges = ranges;
      bag.write("/scan", stamp, scan);
      total_ms.add(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_frame)
              .count());
    }
    bag.close();
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf("  wrote %s/%s.bag in %.1f s; stereo pair render %s; per frame %s\n",
                opt.out.c_str(), name.c_str(), wall, render_ms.str().c_str(),
                total_ms.str().c_str());
    std::fflush(stdout);
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "error: writing bag for %s: %s\n", name.c_str(), ex.what());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parseArgs(argc, argv, &opt)) return ssm::tools::usageError(usage);
  if (!opt.info && !makeDir(opt.out)) {
    std::fprintf(stderr, "error: cannot create output directory %s\n", opt.out.c_str());
    return 1;
  }
  ros::Time::init();
  int failures = 0;
  for (const std::string& path : opt.scenes) {
    std::vector<std::string> variants;
    if (!opt.variant.empty() && opt.variant != "all") {
      variants.push_back(opt.variant);
    } else {
      ds::SceneFile probe;
      const std::string e = ds::loadSceneFromFile(path, "", &probe);
      if (!e.empty()) {
        std::fprintf(stderr, "error: %s\n", e.c_str());
        ++failures;
        continue;
      }
      variants = probe.variants;
      if (variants.empty()) variants.push_back("");
    }
    for (const std::string& v : variants)
      failures += runOne(path, v, opt) != 0 ? 1 : 0;
  }
  return failures == 0 ? 0 : 1;
}
