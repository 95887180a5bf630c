// SafetyMapRos's inputs (safety_map_ros.h, "Threading model"): the shared stereo input
// (stereo_input.h: the subscribers' checks of each message, the tf2 MessageFilter, the stamp
// matcher or approximate sync, the tf wait measurement), and enqueue(), which puts a checked frame
// into the worker's queue (frame_slot.h, `frame_queue` frames). What the worker does with a frame
// is in safety_map_ros.cpp.
#include "stereo_safety_map/ros/safety_map_ros.h"

#include <sstream>

namespace stereo_safety_map {

void SafetyMapRos::setUpInputs() {
  auto options = StereoInput::Options::of(ros_config_);
  options.cloud = ros_config_.input == "cloud";
  options.check_messages = true;
  input_ = std::make_unique<StereoInput>(nh_, options, books_,
                                         [this](StereoFrame&& in) { frameIn(std::move(in)); });
}

void SafetyMapRos::frameIn(StereoFrame&& in) {
  auto frame = std::make_unique<Frame>();
  static_cast<StereoFrame&>(*frame) = std::move(in);
  if (frame->disparity) {
    ROS_DEBUG_STREAM_NAMED("frames", name_ << ": synced disparity frame " << frame->header.stamp
                                           << ", tf wait " << frame->tf_wait_ms << " ms");
  }
  enqueue(std::move(frame));
}

void SafetyMapRos::enqueue(std::unique_ptr<Frame> frame) {
  const ros::Time enqueued_stamp = frame->header.stamp;
  // A transform that came long after its frame: tf stalled, and the pose of a frame in the gap
  // would be interpolated between samples seconds apart, not measured. Refused here, before the
  // slot, so that it never replaces a waiting frame and is always named, in whatever order the
  // frames of the gap and those after it come out of the tf filter.
  if (frame->tf_wait_ms > 1000.0 * ros_config_.max_tf_wait) {
    std::ostringstream os;
    os << "dropped a frame at t = " << enqueued_stamp << ": its transform came "
       << frame->tf_wait_ms / 1000.0
       << " s after it (more than max_tf_wait = " << ros_config_.max_tf_wait
       << " s): tf stalled, the pose would be interpolated across the gap";
    books_.reject("stale tf", os.str());
    return;
  }
  std::string out_of_order;
  // Under the slot's lock: newest_stamp_ changes with the slot.
  const auto put = slot_.putIf(std::move(frame), [&](Frame& incoming, const Frame*) {
    const ros::Time stamp = incoming.header.stamp;
    if (!newest_stamp_.isZero() && stamp <= newest_stamp_) {
      // Time went back. A restart (a bag played again) moves the clock back as well: the map is
      // reset once. A frame from the past while the clock runs on is stale: dropped, the map
      // kept, whatever its age (one stale message must not wipe the map).
      const double back = (newest_stamp_ - stamp).toSec();
      const ros::Time now = ros::Time::now();
      const ros::Duration jump(ros_config_.time_jump_reset);
      const bool clock_back = now.isZero() || now + jump < newest_stamp_;
      if (back > ros_config_.time_jump_reset && clock_back) {
        incoming.reset_map = true;
      } else {
        std::ostringstream os;
        os << "dropped a frame out of order: stamp " << stamp << " is " << back
           << " s older than the newest frame ("
           << (back > ros_config_.time_jump_reset
                   ? "the clock did not go back with it: a stale message"
                   : "less than time_jump_reset = " + std::to_string(ros_config_.time_jump_reset) +
                         " s")
           << "; the map is kept)";
        out_of_order = os.str();
        return false;
      }
    }
    newest_stamp_ = stamp;
    // A waiting restart dropped by the queue passes to the frame after it (slot_'s carry).
    return true;
  });
  if (put == FrameSlot<Frame>::Put::kStopped) return;
  if (put == FrameSlot<Frame>::Put::kRefused) {
    books_.reject("out of order", out_of_order);
    return;
  }
  const bool dropped = put == FrameSlot<Frame>::Put::kReplaced;
  ROS_DEBUG_STREAM_NAMED("frames", name_ << ": enqueued frame " << enqueued_stamp
                                         << (dropped ? " (replaced a waiting frame)" : ""));
  if (dropped) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.countDropped();
  }
}

}  // namespace stereo_safety_map
