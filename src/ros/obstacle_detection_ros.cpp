#include "stereo_safety_map/ros/obstacle_detection_ros.h"

#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/param_reader.h"

#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <visualization_msgs/MarkerArray.h>

#include <boost/make_shared.hpp>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <vector>

namespace stereo_safety_map {

namespace {

constexpr char kDroppedReason[] = "input faster than processing";

std::string str(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// A distinct colour per label (golden-ratio hue steps, a table of 97), BGR.
cv::Vec3b labelColour(int label) {
  static const std::vector<cv::Vec3b> palette = [] {
    std::vector<cv::Vec3b> p;
    for (int k = 0; k < 97; ++k) {
      const double h = std::fmod(k * 0.618033988749895, 1.0) * 180.0;  // OpenCV hue: 0..180
      cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(h, 210, 255)), bgr;
      cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
      p.push_back(bgr.at<cv::Vec3b>(0, 0));
    }
    return p;
  }();
  return palette[static_cast<std::size_t>(std::abs(label)) % palette.size()];
}

}  // namespace

std::string organisedCloudToMat(const sensor_msgs::PointCloud2& msg, cv::Mat* xyz,
                                std::size_t* non_finite) {
  if (msg.height < 2 || msg.width < 2) {
    return "PointCloud2 is not organised (height " + str(msg.height) + ", width " + str(msg.width) +
           "): the range-image detector needs one point per pixel";
  }
  if (msg.is_bigendian) return "PointCloud2 is big-endian (unsupported)";
  int offsets[3] = {0, 0, 0};
  const char* names[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    const auto it =
        std::find_if(msg.fields.begin(), msg.fields.end(),
                     [&](const sensor_msgs::PointField& f) { return f.name == names[k]; });
    if (it == msg.fields.end()) return std::string("PointCloud2 has no field '") + names[k] + "'";
    if (it->datatype != sensor_msgs::PointField::FLOAT32 || it->count != 1) {
      return std::string("PointCloud2 field '") + names[k] + "' is not a single FLOAT32";
    }
    if (static_cast<std::size_t>(it->offset) + sizeof(float) > msg.point_step) {
      return std::string("PointCloud2 field '") + names[k] + "' lies outside point_step " +
             str(msg.point_step);
    }
    offsets[k] = static_cast<int>(it->offset);
  }
  if (static_cast<std::size_t>(msg.width) * msg.point_step > msg.row_step) {
    return "PointCloud2 row_step " + str(msg.row_step) + " is smaller than width x point_step";
  }
  if (msg.data.size() < static_cast<std::size_t>(msg.row_step) * msg.height) {
    return "PointCloud2 data has " + str(msg.data.size()) +
           " bytes, row_step x height = " + str(static_cast<double>(msg.row_step) * msg.height) +
           " needed";
  }
  xyz->create(static_cast<int>(msg.height), static_cast<int>(msg.width), CV_32FC3);
  std::size_t bad = 0;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int r = 0; r < xyz->rows; ++r) {
    const std::uint8_t* row = msg.data.data() + static_cast<std::size_t>(r) * msg.row_step;
    cv::Vec3f* out = xyz->ptr<cv::Vec3f>(r);
    for (int c = 0; c < xyz->cols; ++c) {
      const std::uint8_t* pt = row + static_cast<std::size_t>(c) * msg.point_step;
      float p[3];
      for (int k = 0; k < 3; ++k)
        std::memcpy(&p[k], pt + offsets[k], sizeof(float));
      if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) {
        out[c] = cv::Vec3f(p[0], p[1], p[2]);
      } else {
        out[c] = cv::Vec3f(nan, nan, nan);
        ++bad;
      }
    }
  }
  if (non_finite != nullptr) *non_finite = bad;
  return "";
}

ObstacleDetectionRos::ObstacleDetectionRos(ros::NodeHandle nh, ros::NodeHandle pnh)
    : FrameNodeletShell(nh, pnh) {
  startDiagnostics(
      "stereo camera", "obstacle detection",
      [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); },
      NodeletDiagnostics::Clock::kRos);

  std::string err = fromRosParam(pnh_, &ros_config_);
  if (err.empty()) err = fromRosParam(pnh_, &detector_config_);
  if (!acceptParams(err, obstacleDetectionParameterNames())) return;
  detector_ = std::make_unique<ObstacleDetector>(detector_config_);  // validated: does not throw

  startWorker([this](const Frame& frame) { processFrame(frame); },
              [this] { return ros_config_.max_rate; });
  setUpInputs();

  // Advertise last: connectCb may run as soon as a publisher exists.
  std::lock_guard<std::mutex> lock(connect_mutex_);
  const ros::SubscriberStatusCallback connect_cb = [this](const ros::SingleSubscriberPublisher&) {
    connectCb();
  };
  label_image_pub_ =
      nh_.advertise<sensor_msgs::Image>("obstacle_labels", 1, connect_cb, connect_cb);
  obstacles_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("obstacles", 1, connect_cb, connect_cb);
  markers_pub_ =
      nh_.advertise<visualization_msgs::MarkerArray>("obstacle_markers", 1, connect_cb, connect_cb);
  ROS_INFO_STREAM(
      name_ << ": " << (ros_config_.method == "3d" ? "3D" : "column-wise")
            << " obstacle detection (003) from "
            << (ros_config_.input == "cloud" ? "organised point clouds" : "disparity images")
            << ", gravity from '" << ros_config_.fixed_frame << "'");
}

ObstacleDetectionRos::~ObstacleDetectionRos() {
  {
    std::lock_guard<std::mutex> lock(connect_mutex_);
    if (input_) input_->shutdown();  // none when the parameters were refused
    subscribed_ = false;
  }
  stopWorker();
  diagnostics_->stop();
}

void ObstacleDetectionRos::setUpInputs() {
  auto options = StereoInput::Options::of(ros_config_);
  options.cloud = ros_config_.input == "cloud";
  options.right_info = false;
  options.lazy = true;
  options.tf_hint = "Gravity is that frame's z axis: is the tf tree complete?";
  input_ = std::make_unique<StereoInput>(nh_, options, books_, [this](StereoFrame&& in) {
    enqueue(std::make_unique<Frame>(std::move(in)));
  });
}

void ObstacleDetectionRos::connectCb() {
  std::lock_guard<std::mutex> lock(connect_mutex_);
  const bool listened = label_image_pub_.getNumSubscribers() > 0 ||
                        obstacles_pub_.getNumSubscribers() > 0 ||
                        markers_pub_.getNumSubscribers() > 0;
  if (!listened && subscribed_) {
    input_->unsubscribe();
    subscribed_ = false;
  } else if (listened && !subscribed_) {
    input_->subscribe();
    subscribed_ = true;
  }
}

void ObstacleDetectionRos::enqueue(std::unique_ptr<Frame> frame) {
  if (!putFrame(std::move(frame))) return;
  if (problems_.shouldLog(kDroppedReason)) {
    ROS_WARN_STREAM(name_ << ": frames arrive faster than obstacles are detected: the waiting "
                             "frame was replaced by a newer one");
  }
}

void ObstacleDetectionRos::processFrame(const Frame& frame) {
  const auto t0 = std::chrono::steady_clock::now();

  // Gravity: the fixed frame's z axis, from the camera's pose at the frame's stamp (the tf
  // filter has waited for it).
  FramePose pose;
  if (!input_->lookUp(frame.header, "", "", 0.0, &pose)) return;
  const Eigen::Isometry3f& T_fixed_camera = pose.T_fixed_sensor;

  // The range image (camera optical frame, NaN = missing), limited to [min_depth, max_depth].
  double f = 0.0;
  std::size_t non_finite = 0;
  if (frame.disparity) {
    DisparityImageStats stats;
    if (!input_->toCore(frame, &camera_, &disparity_, &stats)) return;
    non_finite = stats.non_finite;
    reprojectDisparityOrganized(disparity_, camera_, ros_config_.max_depth, &xyz_);
    f = std::max(camera_.fx, camera_.fy);
  } else {
    const std::string err = organisedCloudToMat(*frame.cloud, &xyz_, &non_finite);
    if (!err.empty()) {
      books_.reject("bad point cloud", "dropped a cloud: " + err);
      return;
    }
    f = ros_config_.focal_length > 0.0 ? ros_config_.focal_length : estimateFocalLength(xyz_);
    if (!(f > 0.0)) {
      books_.reject(
          "unknown focal length",
          "dropped a cloud: too few valid points to estimate the focal length from it (set "
          "~focal_length)");
      return;
    }
  }
  const std::size_t valid =
      limitRangeImageDepth(ros_config_.min_depth, ros_config_.max_depth, &xyz_);
  if (non_finite > 0) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.non_finite += non_finite;
  }
  if (valid == 0) {
    books_.reject(non_finite > 0 ? "non-finite input" : "no valid data",
                  "dropped a frame without a valid point within [min_depth, max_depth] (" +
                      str(static_cast<double>(non_finite)) + " NaN / inf of " +
                      str(static_cast<double>(xyz_.total())) + ")");
    return;
  }

  const auto t1 = std::chrono::steady_clock::now();
  // The stereo baseline for the detector's noise margin (noise_sigmas); a cloud's is unknown.
  // ~decimation: the detector on every n-th pixel, with f / n and the full image's margin.
  const int n = ros_config_.decimation;
  const double baseline = frame.disparity ? camera_.baseline * n : 0.0;
  decimateRangeImage(xyz_, n, &xyz_detect_);
  f /= n;
  const bool ok =
      ros_config_.method == "columnwise"
          ? detector_->detectColumnwise(xyz_detect_, f, T_fixed_camera, &result_, baseline)
          : detector_->detect(xyz_detect_, f, T_fixed_camera, &result_, baseline);
  const double detect_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  if (!ok) {
    books_.reject("refused by the core", "dropped a frame: " + result_.error);
    return;
  }

  std_msgs::Header fixed_header;
  fixed_header.stamp = frame.header.stamp;
  fixed_header.frame_id = ros_config_.fixed_frame;
  if (label_image_pub_.getNumSubscribers() > 0) publishLabelImage(frame.header);
  if (obstacles_pub_.getNumSubscribers() > 0) publishObstacles(fixed_header, T_fixed_camera);
  if (markers_pub_.getNumSubscribers() > 0) publishMarkers(fixed_header);

  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  counts_.countProcessed(ms);
  detection_ms_last_ = detect_ms;
  focal_length_last_ = f;
  valid_points_last_ = result_.valid_points;
  obstacle_points_last_ = static_cast<std::size_t>(cv::countNonZero(result_.mask));
  accepted_last_ = result_.num_accepted;
  rejected_last_ = static_cast<int>(result_.obstacles.size()) - result_.num_accepted;
}

void ObstacleDetectionRos::publishLabelImage(const std_msgs::Header& header) {
  // Valid pixels grey (brighter = nearer), missing ones black; points of accepted obstacles in
  // their label's colour (feet, the lower ends only, at half brightness); points of obstacles the
  // Sec. 5 rules rejected dark red (as 003 Fig. 8(d) shows them).
  // At the detector's resolution (1 / ~decimation of the camera's).
  const int rows = xyz_detect_.rows, cols = xyz_detect_.cols;
  colour_.create(rows, cols, CV_8UC3);
  const float max_depth = static_cast<float>(ros_config_.max_depth);
  const bool labelled = !result_.obstacles.empty();
  for (int r = 0; r < rows; ++r) {
    const cv::Vec3f* p = xyz_detect_.ptr<cv::Vec3f>(r);
    const std::uint8_t* m = result_.mask.ptr<std::uint8_t>(r);
    const std::int32_t* l = result_.labels.ptr<std::int32_t>(r);
    cv::Vec3b* out = colour_.ptr<cv::Vec3b>(r);
    for (int c = 0; c < cols; ++c) {
      const float z = p[c][2];
      if (!(z == z)) {
        out[c] = cv::Vec3b(0, 0, 0);
        continue;
      }
      const auto g =
          static_cast<std::uint8_t>(40.0f + 120.0f * (1.0f - std::min(1.0f, z / max_depth)));
      out[c] = cv::Vec3b(g, g, g);
      if (labelled && l[c] > 0 && result_.obstacles[l[c] - 1].rejected) {
        out[c] = cv::Vec3b(0, 0, 140);
      } else if (m[c] != ObstacleDetectionResult::kNone) {
        cv::Vec3b col = labelled ? labelColour(l[c]) : cv::Vec3b(255, 128, 0);
        if (m[c] == ObstacleDetectionResult::kFoot) col /= 2;
        out[c] = col;
      }
    }
  }
  auto img = boost::make_shared<sensor_msgs::Image>();
  img->header = header;
  img->height = static_cast<std::uint32_t>(rows);
  img->width = static_cast<std::uint32_t>(cols);
  img->encoding = sensor_msgs::image_encodings::BGR8;
  img->is_bigendian = 0;
  img->step = img->width * 3;
  img->data.resize(static_cast<std::size_t>(img->step) * img->height);
  for (int r = 0; r < rows; ++r) {
    std::memcpy(img->data.data() + static_cast<std::size_t>(r) * img->step, colour_.ptr(r),
                img->step);
  }
  label_image_pub_.publish(img);
}

void ObstacleDetectionRos::publishObstacles(const std_msgs::Header& header,
                                            const Eigen::Isometry3f& T_fixed_camera) {
  // The raised points (upper ends of compatible pairs) of the accepted obstacles, in the fixed
  // frame, with their label: the obstacle cue of the safety map (core/obstacle_cue.h). The feet
  // are the ground around an obstacle and are left out.
  raisedObstaclePoints(result_, xyz_detect_, T_fixed_camera, &raised_points_, &raised_labels_);
  const std::size_t n = raised_points_.size();
  auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
  cloud->header = header;
  sensor_msgs::PointCloud2Modifier mod(*cloud);
  mod.setPointCloud2Fields(
      4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, "label", 1, sensor_msgs::PointField::UINT32);
  mod.resize(n);
  cloud->height = 1;
  cloud->width = static_cast<std::uint32_t>(n);
  cloud->row_step = cloud->width * cloud->point_step;
  cloud->is_dense = true;
  if (n == 0) {  // an iterator over an empty cloud reads data.front() of an empty vector (UBSan)
    obstacles_pub_.publish(cloud);
    return;
  }
  sensor_msgs::PointCloud2Iterator<float> x(*cloud, "x");
  sensor_msgs::PointCloud2Iterator<std::uint32_t> label(*cloud, "label");
  for (std::size_t i = 0; i < n; ++i, ++x, ++label) {
    x[0] = raised_points_[i].x();
    x[1] = raised_points_[i].y();
    x[2] = raised_points_[i].z();
    *label = raised_labels_[i];
  }
  obstacles_pub_.publish(cloud);
}

void ObstacleDetectionRos::publishMarkers(const std_msgs::Header& header) {
  // Per accepted obstacle its 3D bounding box (003 Sec. 5: all its points, the ring of ground at
  // its foot included) and its measures as text. DELETEALL first: obstacles come and go.
  auto markers = boost::make_shared<visualization_msgs::MarkerArray>();
  visualization_msgs::Marker clear;
  clear.header = header;
  clear.action = visualization_msgs::Marker::DELETEALL;
  markers->markers.push_back(clear);
  for (const ObstacleInfo& o : result_.obstacles) {
    if (o.rejected) continue;
    const cv::Vec3b bgr = labelColour(o.label);
    visualization_msgs::Marker box;
    box.header = header;
    box.ns = "obstacle_boxes";
    box.id = o.label;
    box.type = visualization_msgs::Marker::CUBE;
    box.action = visualization_msgs::Marker::ADD;
    const Eigen::Vector3f c = 0.5f * (o.bbox_min + o.bbox_max);
    const Eigen::Vector3f e = (o.bbox_max - o.bbox_min).cwiseMax(0.01f);
    box.pose.position.x = c.x();
    box.pose.position.y = c.y();
    box.pose.position.z = c.z();
    box.pose.orientation.w = 1.0;
    box.scale.x = e.x();
    box.scale.y = e.y();
    box.scale.z = e.z();
    box.color.r = bgr[2] / 255.0f;
    box.color.g = bgr[1] / 255.0f;
    box.color.b = bgr[0] / 255.0f;
    box.color.a = 0.35f;
    markers->markers.push_back(box);

    visualization_msgs::Marker text = box;
    text.ns = "obstacle_measures";
    text.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    text.pose.position.z = o.bbox_max.z() + 0.15;
    text.scale.x = text.scale.y = 0.0;
    text.scale.z = 0.12;
    text.color.a = 1.0f;
    char buf[128];
    std::snprintf(buf, sizeof(buf), "#%d h %.2f m, slope %.0f/%.0f deg", o.label, o.max_height,
                  o.avg_slope_deg, o.max_slope_deg);
    text.text = buf;
    markers->markers.push_back(text);
  }
  markers_pub_.publish(markers);
}

void ObstacleDetectionRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  const ros::WallTime now = ros::WallTime::now();
  const double window = counts_.window(now);
  stat.add("input", ros_config_.input);
  stat.add("method", ros_config_.method);
  stat.add("fixed frame (gravity)", ros_config_.fixed_frame);
  counts_.addTo(stat, window, "frames dropped (input faster than processing)", true);
  stat.addf("processing time, mean [ms]", "%.1f", counts_.meanProcessingMs());
  stat.addf("detection time, last frame [ms]", "%.1f", detection_ms_last_);
  stat.addf("focal length, last frame [px]", "%.1f", focal_length_last_);
  stat.add("valid points, last frame", valid_points_last_);
  stat.add("obstacle points, last frame", obstacle_points_last_);
  stat.add("obstacles accepted, last frame", accepted_last_);
  stat.add("obstacles rejected (Sec. 5 rules), last frame", rejected_last_);
  problems_.addTo(stat);
  counts_.summarize(stat, problems_, now, window, "the input is faster than the detection",
                    "waiting for input (subscribed while an output is)", "obstacles up to date");
  counts_.nextWindow(now, window);
}

}  // namespace stereo_safety_map
