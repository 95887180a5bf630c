#include "stereo_safety_map/tools/dataset_reader.h"

#include "stereo_safety_map/ros/conversions.h"

#include <cv_bridge/cv_bridge.h>
#include <nav_msgs/OccupancyGrid.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>
#include <yaml-cpp/yaml.h>

#include <opencv2/imgcodecs.hpp>

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

Eigen::Vector3d vec3(const YAML::Node& n) {
  return Eigen::Vector3d(n[0].as<double>(), n[1].as<double>(), n[2].as<double>());
}

BoardBox boxOf(const YAML::Node& o) {
  BoardBox b;
  b.center = vec3(o["center"]);
  b.half_size = 0.5 * vec3(o["size"]);
  const YAML::Node q = o["rotation"];
  b.rotation =
      Eigen::Quaterniond(q[3].as<double>(), q[0].as<double>(), q[1].as<double>(), q[2].as<double>())
          .normalized()
          .toRotationMatrix();
  return b;
}

std::string loadLabelsFromBag(const std::string& bag_path, LabelGrid* gt) {
  rosbag::Bag bag;
  try {
    bag.open(bag_path, rosbag::bagmode::Read);
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{"/ground_truth/labels"}));
    for (const rosbag::MessageInstance& m : view) {
      auto g = m.instantiate<nav_msgs::OccupancyGrid>();
      if (!g) continue;
      const double res = g->info.resolution;
      if (!(res > 0.0)) return "ground-truth grid has no resolution";
      gt->resolution = res;
      gt->width = static_cast<int>(g->info.width);
      gt->height = static_cast<int>(g->info.height);
      // The origin is the corner of cell (min_u, min_v), cell (u, v) centred at (u l, v l).
      gt->min_u = static_cast<int>(std::lround(g->info.origin.position.x / res + 0.5));
      gt->min_v = static_cast<int>(std::lround(g->info.origin.position.y / res + 0.5));
      gt->labels.resize(g->data.size());
      for (std::size_t k = 0; k < g->data.size(); ++k) {
        const int v = g->data[k];
        gt->labels[k] = v >= 0 && v <= 4 ? static_cast<SafetyLabel>(v) : SafetyLabel::kUnknown;
      }
      return gt->validate();
    }
  } catch (const std::exception& e) {
    return std::string("cannot read ") + bag_path + ": " + e.what();
  }
  return "no /ground_truth/labels in " + bag_path;
}

std::string loadLabelsFromDir(const std::string& dir, LabelGrid* gt) {
  YAML::Node y;
  try {
    y = YAML::LoadFile(dir + "/gt_map.yaml");
  } catch (const std::exception& e) {
    return "cannot read " + dir + "/gt_map.yaml";
  }
  const cv::Mat img = cv::imread(dir + "/gt_labels.pgm", cv::IMREAD_UNCHANGED);
  if (img.empty() || img.type() != CV_8UC1) return "cannot read " + dir + "/gt_labels.pgm";
  gt->resolution = y["resolution"].as<double>();
  gt->min_u = y["grid"]["min_u"].as<int>();
  gt->min_v = y["grid"]["min_v"].as<int>();
  gt->width = img.cols;
  gt->height = img.rows;
  gt->labels.assign(static_cast<std::size_t>(img.cols) * img.rows, SafetyLabel::kUnknown);
  for (int r = 0; r < img.rows; ++r) {  // image rows run from the largest v down
    for (int c = 0; c < img.cols; ++c) {
      const int v = img.at<std::uint8_t>(r, c);
      gt->labels[static_cast<std::size_t>(img.rows - 1 - r) * img.cols + c] =
          v <= 4 ? static_cast<SafetyLabel>(v) : SafetyLabel::kUnknown;
    }
  }
  return gt->validate();
}

bool toMat(const sensor_msgs::ImageConstPtr& msg, cv::Mat* out, std::string* err) {
  try {
    cv_bridge::CvImageConstPtr cv = cv_bridge::toCvShare(msg);
    if (cv->image.depth() == CV_8U &&
        (cv->image.channels() == 1 || cv->image.channels() == 3 || cv->image.channels() == 4)) {
      *out = cv->image;
    } else {
      *out = cv_bridge::toCvCopy(msg, "mono8")->image;
    }
    return true;
  } catch (const std::exception& e) {
    *err = std::string("image: ") + e.what();
    return false;
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------

std::string loadDataset(const std::string& bag, bool latency_only, Dataset* d) {
  d->bag = bag;
  d->name = bagBaseName(bag);
  const bool has_ext = bag.size() > 4 && bag.compare(bag.size() - 4, 4, ".bag") == 0;
  d->gt_dir = bag.substr(0, bag.size() - (has_ext ? 4 : 0)) + "_gt";
  d->latency_only = latency_only;
  std::string e = loadLabelsFromBag(bag, &d->gt);
  if (!e.empty()) {
    const std::string e2 = loadLabelsFromDir(d->gt_dir, &d->gt);
    if (!e2.empty()) return e + "; " + e2;
  }
  try {
    if (fileExists(d->gt_dir + "/gt_planes.yaml")) {
      const YAML::Node y = YAML::LoadFile(d->gt_dir + "/gt_planes.yaml");
      for (const auto& p : y["planes"]) {
        ReferencePlane r;
        r.name = p["name"].as<std::string>();
        r.a = p["a"].as<double>();
        r.b = p["b"].as<double>();
        r.c = p["c"].as<double>();
        for (const auto& q : p["polygon"])
          r.footprint.emplace_back(q[0].as<double>(), q[1].as<double>());
        d->planes.push_back(r);
      }
    } else {
      d->note += "no gt_planes.yaml: no plane accuracy. ";
    }
    if (fileExists(d->gt_dir + "/gt_obstacles.yaml")) {
      const YAML::Node y = YAML::LoadFile(d->gt_dir + "/gt_obstacles.yaml");
      for (const auto& o : y["obstacles"]) {
        DatasetObstacle ob;
        ob.name = o["name"].as<std::string>();
        ob.type = o["type"].as<std::string>();
        ob.box = boxOf(o);
        d->obstacles.push_back(ob);
        if (ob.type == "board") d->boards.push_back(DatasetBoard{ob.name, ob.box});
      }
    }
    if (fileExists(d->gt_dir + "/dataset.yaml")) {
      const YAML::Node y = YAML::LoadFile(d->gt_dir + "/dataset.yaml");
      d->scene = y["scene"] ? y["scene"].as<std::string>() : d->name;
      d->untextured = d->scene.find("untextured") != std::string::npos;
    }
  } catch (const std::exception& ex) {
    return "bad ground-truth files in " + d->gt_dir + ": " + ex.what();
  }
  if (latency_only && d->boards.empty()) return "no board (type: board) in " + d->gt_dir;
  return "";
}

// ---------------------------------------------------------------------------------------------

double yawOfOpticalAxis(const Eigen::Isometry3d& T_fixed_sensor) {
  const Eigen::Vector3d z = T_fixed_sensor.linear() * Eigen::Vector3d::UnitZ();
  return std::atan2(z.y(), z.x());
}

StereoBagReader::StereoBagReader() = default;
StereoBagReader::~StereoBagReader() = default;

std::string StereoBagReader::open(const std::string& bag, const StereoBagReaderOptions& options) {
  options_ = options;
  pending_.clear();
  left_info_.reset();
  right_info_.reset();
  scan_.reset();
  index_ = -1;
  try {
    bag_.close();
    bag_.open(bag, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    return "cannot open " + bag + ": " + e.what();
  }
  const std::string ns = "/" + options_.camera;
  t_left_ = ns + "/left/image_rect";
  t_right_ = ns + "/right/image_rect";
  t_linfo_ = ns + "/left/camera_info";
  t_rinfo_ = ns + "/right/camera_info";
  {
    rosbag::View all(bag_);
    bag_seconds_ = (all.getEndTime() - all.getBeginTime()).toSec();
  }
  tf_ = std::make_unique<tf2::BufferCore>(ros::Duration(std::max(60.0, bag_seconds_ + 60.0)));
  std::size_t n = 0;
  {
    rosbag::View view(bag_, rosbag::TopicQuery(std::vector<std::string>{"/tf", "/tf_static"}));
    for (const rosbag::MessageInstance& m : view) {
      auto msg = m.instantiate<tf2_msgs::TFMessage>();
      if (!msg) continue;
      const bool is_static = m.getTopic() == "/tf_static";
      for (const auto& t : msg->transforms) {
        tf_->setTransform(t, "bag", is_static);
        ++n;
      }
    }
  }
  if (n == 0) return bag + ": no /tf or /tf_static in the bag";
  pair_count_ = static_cast<int>(
      rosbag::View(bag_, rosbag::TopicQuery(std::vector<std::string>{t_left_})).size());
  if (pair_count_ == 0) return bag + ": no " + t_left_;
  if (options_.max_frames > 0)
    pair_count_ = static_cast<int>(std::min<long>(pair_count_, options_.max_frames));
  std::vector<std::string> topics = {t_left_, t_right_, t_linfo_, t_rinfo_};
  if (!options_.scan_topic.empty()) topics.push_back(options_.scan_topic);
  view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery(topics));
  it_ = view_->begin();
  return "";
}

bool StereoBagReader::next(StereoBagFrame* f) {
  if (!view_) return false;
  for (; it_ != view_->end(); ++it_) {
    const rosbag::MessageInstance& m = *it_;
    const std::string& topic = m.getTopic();
    if (topic == t_linfo_ || topic == t_rinfo_) {
      auto info = m.instantiate<sensor_msgs::CameraInfo>();
      if (info) (topic == t_linfo_ ? left_info_ : right_info_) = info;
      continue;
    }
    if (!options_.scan_topic.empty() && topic == options_.scan_topic) {
      auto scan = m.instantiate<sensor_msgs::LaserScan>();
      if (scan) scan_ = scan;
      continue;
    }
    auto img = m.instantiate<sensor_msgs::Image>();
    if (!img) continue;
    const ros::Time stamp = img->header.stamp;
    Pending& p = pending_[stamp];
    (topic == t_left_ ? p.left : p.right) = img;
    if (!p.left || !p.right) continue;
    const Pending pair = p;
    pending_.erase(pending_.begin(), pending_.upper_bound(stamp));  // this and older incomplete
    ++it_;
    ++index_;
    if (options_.max_frames > 0 && index_ >= options_.max_frames) {
      it_ = view_->end();
      return false;
    }
    *f = StereoBagFrame();
    f->index = index_;
    f->stamp = stamp;
    f->frame_id = pair.left->header.frame_id;
    f->left_msg = pair.left;
    f->right_msg = pair.right;
    f->left_info = left_info_;
    f->right_info = right_info_;
    f->scan = scan_;
    if (!left_info_ || !right_info_) {
      f->error = "no camera_info yet";
      return true;
    }
    std::string e = cameraModelFromCameraInfo(*left_info_, *right_info_, &f->camera);
    if (!e.empty()) {
      f->error = "camera model: " + e;
      return true;
    }
    try {
      f->T_fixed_sensor = tf2::transformToEigen(
          tf_->lookupTransform(options_.fixed_frame, pair.left->header.frame_id, stamp));
      f->T_fixed_base = tf2::transformToEigen(
          tf_->lookupTransform(options_.fixed_frame, options_.base_frame, stamp));
      f->robot = f->T_fixed_base.translation();
    } catch (const tf2::TransformException& ex) {
      f->error = std::string("tf: ") + ex.what();
      return true;
    }
    if (scan_) {
      try {
        f->T_fixed_scan = tf2::transformToEigen(tf_->lookupTransform(
            options_.fixed_frame, scan_->header.frame_id, scan_->header.stamp));
        f->scan_pose_ok = true;
      } catch (const tf2::TransformException&) {
        f->scan_pose_ok = false;
      }
    }
    if (!toMat(pair.left, &f->left, &e) || !toMat(pair.right, &f->right, &e)) {
      f->error = e;
      return true;
    }
    return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------

bool makeDirs(const std::string& path) {
  std::string cur;
  std::stringstream ss(path);
  std::string part;
  if (!path.empty() && path[0] == '/') cur = "/";
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    cur += part + "/";
    if (mkdir(cur.c_str(), 0775) != 0 && errno != EEXIST) return false;
  }
  return true;
}

bool fileExists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}

std::string bagBaseName(const std::string& path) {
  std::string b = path.substr(path.find_last_of('/') + 1);
  if (b.size() > 4 && b.compare(b.size() - 4, 4, ".bag") == 0) b.resize(b.size() - 4);
  return b;
}

}  // namespace stereo_safety_map
