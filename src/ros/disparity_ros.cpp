#include "stereo_safety_map/ros/disparity_ros.h"

#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/param_reader.h"
#include "stereo_safety_map/ros/reconfigure_fields.h"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <stereo_msgs/DisparityImage.h>

#include <boost/bind/bind.hpp>
#include <boost/make_shared.hpp>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

namespace stereo_safety_map {

namespace {

constexpr char kDroppedReason[] = "input faster than processing";

std::string sizeString(unsigned width, unsigned height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

/// Filter steps reported in /diagnostics, with the paper section they implement.
struct StepLabel {
  DisparityStep step;
  const char* label;
};
constexpr StepLabel kFilterSteps[] = {
    {DisparityStep::kUniqueness, "uniqueness (002 Sec. 2.2)"},
    {DisparityStep::kTexture, "texture (002 Sec. 2.2)"},
    {DisparityStep::kLeftRight, "left-right check"},
    {DisparityStep::kNeighbourConsistency, "neighbour consistency (000 Sec. III)"},
    {DisparityStep::kSpikeRemoval, "spike removal (002 Sec. 4.2)"},
};

}  // namespace

DisparityRos::DisparityRos(ros::NodeHandle nh, ros::NodeHandle pnh) : FrameNodeletShell(nh, pnh) {
  // A wall timer: it reports while a bag is paused (nodelet_diagnostics.h).
  startDiagnostics(
      "stereo camera", "disparity",
      [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); },
      NodeletDiagnostics::Clock::kWall);

  std::string err = fromRosParam(pnh_, &ros_config_);
  if (err.empty()) err = fromRosParam(pnh_, &pipeline_config_);
  if (!acceptParams(err, disparityParameterNames())) return;
  pipeline_.setConfig(pipeline_config_);
  StereoInputCheckConfig check;
  check.min_contrast = ros_config_.min_image_contrast;
  check.reject_frozen = ros_config_.reject_frozen_images;
  input_check_.setConfig(check);  // validated above: does not throw
  matcher_in_use_ = matcherName(pipeline_config_.matcher);

  // Synchronize the inputs; the topics are subscribed on demand in connectCb().
  const int q = ros_config_.queue_size;
  if (ros_config_.approximate_sync) {
    approximate_sync_ = std::make_unique<message_filters::Synchronizer<ApproximatePolicy>>(
        ApproximatePolicy(q), left_image_sub_, left_info_sub_, right_image_sub_, right_info_sub_);
    approximate_sync_->registerCallback(
        boost::bind(&DisparityRos::imageCb, this, boost::placeholders::_1, boost::placeholders::_2,
                    boost::placeholders::_3, boost::placeholders::_4));
  } else {
    exact_sync_ = std::make_unique<message_filters::Synchronizer<ExactPolicy>>(
        ExactPolicy(q), left_image_sub_, left_info_sub_, right_image_sub_, right_info_sub_);
    exact_sync_->registerCallback(boost::bind(&DisparityRos::imageCb, this, boost::placeholders::_1,
                                              boost::placeholders::_2, boost::placeholders::_3,
                                              boost::placeholders::_4));
  }

  // The server reads the (already validated) start-up values from the parameter server and calls
  // reconfigureCb once with them.
  reconfigure_.start(
      pnh_, [this](DisparityConfig& config, std::uint32_t level) { reconfigureCb(config, level); });

  slot_.setCapacity(static_cast<std::size_t>(ros_config_.frame_queue));
  startWorker([this](const Frame& frame) { processFrame(frame); }, [] { return 0.0; });

  // Monitor whether anyone listens; connectCb must not run between advertising and assigning
  // the publishers.
  it_ = std::make_unique<image_transport::ImageTransport>(nh_);
  std::lock_guard<std::mutex> lock(connect_mutex_);
  const ros::SubscriberStatusCallback connect_cb = [this](const ros::SingleSubscriberPublisher&) {
    connectCb();
  };
  const image_transport::SubscriberStatusCallback image_connect_cb =
      [this](const image_transport::SingleSubscriberPublisher&) { connectCb(); };
  disparity_pub_ =
      nh_.advertise<stereo_msgs::DisparityImage>("disparity", 1, connect_cb, connect_cb);
  cloud_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("points2", 1, connect_cb, connect_cb);
  debug_pub_ = it_->advertise("disparity_debug", 1, image_connect_cb, image_connect_cb);
  ROS_INFO_STREAM(name_ << ": disparity with " << matcher_in_use_ << ", "
                        << pipeline_config_.num_disparities << " disparities, block "
                        << pipeline_config_.block_size << "; "
                        << (ros_config_.approximate_sync ? "approximate" : "exact") << " sync");
}

DisparityRos::~DisparityRos() {
  // Inputs first, so that no callback enqueues while the worker stops.
  {
    std::lock_guard<std::mutex> lock(connect_mutex_);
    left_image_sub_.unsubscribe();
    left_info_sub_.unsubscribe();
    right_image_sub_.unsubscribe();
    right_info_sub_.unsubscribe();
    subscribed_ = false;
  }
  stopWorker();
  diagnostics_->stop();
}

void DisparityRos::connectCb() {
  std::lock_guard<std::mutex> lock(connect_mutex_);
  const bool listened = disparity_pub_.getNumSubscribers() > 0 ||
                        cloud_pub_.getNumSubscribers() > 0 || debug_pub_.getNumSubscribers() > 0;
  if (!listened && subscribed_) {
    left_image_sub_.unsubscribe();
    left_info_sub_.unsubscribe();
    right_image_sub_.unsubscribe();
    right_info_sub_.unsubscribe();
    subscribed_ = false;
  } else if (listened && !subscribed_) {
    // The synchronizer's queue is the one that matters; the subscribers get the same size so
    // that roscpp does not drop frames silently before the sync sees them.
    const int q = ros_config_.queue_size;
    const image_transport::TransportHints hints("raw", ros::TransportHints(), pnh_);
    left_image_sub_.subscribe(*it_, "left/image_rect", q, hints);
    left_info_sub_.subscribe(nh_, "left/camera_info", q);
    right_image_sub_.subscribe(*it_, "right/image_rect", q, hints);
    right_info_sub_.subscribe(nh_, "right/camera_info", q);
    subscribed_ = true;
  }
}

void DisparityRos::imageCb(const sensor_msgs::ImageConstPtr& left_image,
                           const sensor_msgs::CameraInfoConstPtr& left_info,
                           const sensor_msgs::ImageConstPtr& right_image,
                           const sensor_msgs::CameraInfoConstPtr& right_info) {
  auto frame = std::make_unique<Frame>();
  frame->left_image = left_image;
  frame->left_info = left_info;
  frame->right_image = right_image;
  frame->right_info = right_info;
  const auto put = slot_.put(std::move(frame));
  if (put == FrameSlot<Frame>::Put::kStopped) return;
  const bool dropped = put == FrameSlot<Frame>::Put::kReplaced;

  std::uint64_t total_dropped = 0;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.countReceived();
    if (dropped) {
      counts_.countDropped();
      total_dropped = counts_.dropped;
    }
  }
  if (dropped && problems_.shouldLog(kDroppedReason)) {
    ROS_WARN_STREAM(name_ << ": stereo frames arrive faster than the disparity is computed: the "
                             "oldest waiting frame was dropped for a newer one ("
                          << total_dropped << " dropped so far; reduce the camera rate, "
                          << "num_disparities or the image size, or use matcher bm)");
  }
}

void DisparityRos::processFrame(const Frame& frame) {
  const auto t0 = std::chrono::steady_clock::now();

  // A configuration from dynamic_reconfigure, and the debug image only while someone looks at
  // it (it costs an extra matcher pass when the uniqueness test is on).
  {
    DisparityPipelineConfig config = pipeline_.config();
    bool changed = false;
    {
      std::lock_guard<std::mutex> lock(pending_mutex_);
      if (pending_config_) {
        config = *pending_config_;
        pending_config_.reset();
        changed = true;
      }
    }
    const bool debug = debug_pub_.getNumSubscribers() > 0;
    if (changed || config.debug != debug) {
      config.debug = debug;
      pipeline_.setConfig(config);
    }
  }

  const sensor_msgs::Image& left = *frame.left_image;
  const sensor_msgs::Image& right = *frame.right_image;

  // Geometry: zero / non-finite focal length or baseline, NaN in P, info sizes that differ.
  std::string err = cameraModelFromCameraInfo(*frame.left_info, *frame.right_info, &camera_);
  if (!err.empty()) {
    books_.reject("bad camera info", "dropped a stereo frame: " + err);
    return;
  }
  if (left.width != right.width || left.height != right.height) {
    books_.reject("size mismatch", "dropped a stereo frame: left image " +
                                       sizeString(left.width, left.height) + " and right image " +
                                       sizeString(right.width, right.height) + " differ in size");
    return;
  }
  if (static_cast<int>(left.width) != camera_.width ||
      static_cast<int>(left.height) != camera_.height) {
    books_.reject("size mismatch",
                  "dropped a stereo frame: images are " + sizeString(left.width, left.height) +
                      " but the CameraInfo says " + sizeString(camera_.width, camera_.height) +
                      " (binning / ROI applied); are the images rectified?");
    return;
  }
  cv::Mat left_grey, right_grey;
  err = rectifiedImageToGrey(left, "left", &left_buffer_, &left_grey);
  if (err.empty()) err = rectifiedImageToGrey(right, "right", &right_buffer_, &right_grey);
  if (!err.empty()) {
    const bool encoding = err.find("encoding") != std::string::npos;
    books_.reject(encoding ? "unsupported encoding" : "bad image",
                  "dropped a stereo frame: " + err);
    return;
  }
  // A covered, black or frozen camera: matching would give confident-looking wrong disparities.
  const StereoInputProblem problem = input_check_.check(left_grey, right_grey, &err);
  if (problem != StereoInputProblem::kNone) {
    books_.reject(toString(problem), "dropped a stereo frame: " + err);
    return;
  }

  DisparityStats stats;
  pipeline_.setFocalBaseline(camera_.fx * camera_.baseline);
  if (!pipeline_.compute(left_grey, right_grey, &disparity_, &stats, &err)) {
    books_.reject("disparity failed", "dropped a stereo frame: " + toParameterNames(err));
    return;
  }

  std_msgs::Header header = left.header;
  if (disparity_pub_.getNumSubscribers() > 0) publishDisparity(header);
  if (cloud_pub_.getNumSubscribers() > 0) publishCloud(header);
  if (debug_pub_.getNumSubscribers() > 0 && !pipeline_.debugImage().empty()) {
    debug_pub_.publish(
        cv_bridge::CvImage(header, sensor_msgs::image_encodings::BGR8, pipeline_.debugImage())
            .toImageMsg());
  }

  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  counts_.countProcessed(ms);
  last_stats_ = stats;
  matcher_in_use_ = matcherName(pipeline_.config().matcher);
}

void DisparityRos::publishDisparity(const std_msgs::Header& header) {
  const DisparityPipelineConfig& c = pipeline_.config();
  auto msg = boost::make_shared<stereo_msgs::DisparityImage>();
  msg->header = header;
  // DisparityImage's convention: d = x_l - x_r - (cx_l - cx_r), so Z = f T / d; anything below
  // min_disparity is invalid (stereo_image_proc writes min_disparity - 1 there, as we do). The
  // geometry is the core's definition (stereo_camera_model.h), which the offline path uses too.
  const DisparityMessageGeometry g =
      disparityMessageGeometry(camera_, c.min_disparity, c.num_disparities);
  msg->f = g.f;
  msg->T = g.T;
  msg->min_disparity = g.min_disparity;
  msg->max_disparity = g.max_disparity;
  msg->delta_d = 1.0f / 16.0f;  // OpenCV's matchers: 4 fractional bits

  // The window where the matcher can find anything (as stereo_image_proc computes it).
  const int border = c.block_size / 2;
  const int left = std::min(c.min_disparity + c.num_disparities + border - 1, disparity_.cols);
  const int right = std::max(disparity_.cols - 1 - border - c.min_disparity, left);
  const int top = std::min(border, disparity_.rows);
  const int bottom = std::max(disparity_.rows - 1 - border, top);
  msg->valid_window.x_offset = static_cast<std::uint32_t>(left);
  msg->valid_window.y_offset = static_cast<std::uint32_t>(top);
  msg->valid_window.width = static_cast<std::uint32_t>(right - left);
  msg->valid_window.height = static_cast<std::uint32_t>(bottom - top);

  sensor_msgs::Image& image = msg->image;
  image.header = header;
  image.height = static_cast<std::uint32_t>(disparity_.rows);
  image.width = static_cast<std::uint32_t>(disparity_.cols);
  image.encoding = sensor_msgs::image_encodings::TYPE_32FC1;
  image.is_bigendian = 0;
  image.step = image.width * sizeof(float);
  image.data.resize(static_cast<std::size_t>(image.step) * image.height);
  for (int y = 0; y < disparity_.rows; ++y) {
    const float* in = disparity_.ptr<float>(y);
    // std::vector's storage is aligned for any fundamental type.
    float* out =
        reinterpret_cast<float*>(image.data.data() + static_cast<std::size_t>(y) * image.step);
    for (int x = 0; x < disparity_.cols; ++x)
      out[x] = g.toMessage(in[x]);
  }
  disparity_pub_.publish(msg);
}

void DisparityRos::publishCloud(const std_msgs::Header& header) {
  reprojectDisparityOrganized(disparity_, camera_, ros_config_.cloud_max_depth, &xyz_);
  if (xyz_.empty()) return;
  auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
  cloud->header = header;
  sensor_msgs::PointCloud2Modifier modifier(*cloud);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(static_cast<std::size_t>(xyz_.rows) * xyz_.cols);
  cloud->height = static_cast<std::uint32_t>(xyz_.rows);  // organised: one point per pixel
  cloud->width = static_cast<std::uint32_t>(xyz_.cols);
  cloud->row_step = cloud->width * cloud->point_step;
  cloud->is_dense = false;
  sensor_msgs::PointCloud2Iterator<float> it(*cloud, "x");
  for (int y = 0; y < xyz_.rows; ++y) {
    const cv::Vec3f* row = xyz_.ptr<cv::Vec3f>(y);
    for (int x = 0; x < xyz_.cols; ++x, ++it) {
      it[0] = row[x][0];
      it[1] = row[x][1];
      it[2] = row[x][2];
    }
  }
  cloud_pub_.publish(cloud);
}

void DisparityRos::reconfigureCb(DisparityConfig& config, uint32_t /*level*/) {
  // Make window sizes valid, as stereo_image_proc's disparity nodelet does.
  config.block_size |= 1;
  if (config.matcher == "bm" && config.block_size < 5) config.block_size = 5;
  config.num_disparities = std::max(16, config.num_disparities / 16 * 16);
  if (config.texture_window_size != 0) config.texture_window_size |= 1;

  // The live fields of the pipeline's list (core/config_fields.h), by name.
  DisparityPipelineConfig c = pipeline_config_;
  std::string err = fromReconfigure(config, disparityPipelineFields(), &c);
  if (err.empty()) err = disparityPipelineFields().validate(c);
  if (!err.empty()) {
    ROS_ERROR_STREAM(name_ << ": reconfiguration refused, keeping the previous values: " << err);
    // Hand the current values back to the server (and so to rqt_reconfigure).
    toReconfigure(pipeline_config_, disparityPipelineFields(), &config);
    return;
  }
  pipeline_config_ = c;
  std::lock_guard<std::mutex> lock(pending_mutex_);
  pending_config_ = std::make_unique<DisparityPipelineConfig>(c);
}

void DisparityRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  const ros::WallTime now = ros::WallTime::now();
  const double window = counts_.window(now);
  stat.add("matcher", matcher_in_use_);
  counts_.addTo(stat, window, "frames dropped (input faster than processing)", false);
  stat.addf("processing time, mean [ms]", "%.1f", counts_.meanProcessingMs());
  if (counts_.processed > 0) {
    const DisparityStats& s = last_stats_;
    stat.addf("valid pixels, last frame [%]", "%.1f",
              s.pixels > 0 ? 100.0 * s.valid / s.pixels : 0.0);
    stat.addf("disparity time, last frame [ms]", "%.1f", s.total_ms);
    const DisparityStepStats& match = s.step(DisparityStep::kMatching);
    stat.add("matched pixels, last frame", match.valid_after);
    for (const StepLabel& f : kFilterSteps) {
      const DisparityStepStats& st = s.step(f.step);
      stat.add(std::string("removed by ") + f.label + ", last frame",
               st.ran ? std::to_string(st.valid_before - st.valid_after) : std::string("off"));
    }
  }
  problems_.addTo(stat);
  counts_.summarize(stat, problems_, now, window,
                    "the input is faster than the disparity computation",
                    "waiting for input (subscribed while an output is)", "disparity up to date");
  counts_.nextWindow(now, window);
}

}  // namespace stereo_safety_map
