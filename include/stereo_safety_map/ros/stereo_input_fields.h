// The parameters of a stereo nodelet's input (ros/stereo_input.h; StereoInput::Options::of reads
// fixed_frame, queue_size and approximate_sync) as fields of the nodelet's list
// (core/param_fields.h): one name, range and doc for every nodelet that reads them, added in the
// nodelet's README order. The hybrid nodelet, whose input is a laser scan, takes its frame, queue
// and time-jump fields from here too. What differs from nodelet to nodelet (what `input` takes,
// what the frames are for) is the nodelet's `doc`. The nodelets' validate() checks the same ranges
// with the ...Error() functions below (the fields' ranges describe validate(): test_param_fields).
#pragma once

#include "stereo_safety_map/core/param_fields.h"

#include <initializer_list>
#include <string>
#include <utility>

namespace stereo_safety_map {

/// `input`: "disparity" or "cloud"; `doc` says what each carries for the nodelet.
template <class R>
void addInputField(ParamFieldList<R>& l, std::string doc) {
  l.add("input", &R::input).oneOf({"disparity", "cloud"}).doc(std::move(doc));
}

/// `fixed_frame` (a tf frame, non-empty); `doc` says what the nodelet builds or measures in it.
template <class R>
void addFixedFrameField(ParamFieldList<R>& l, std::string doc) {
  l.add("fixed_frame", &R::fixed_frame).rangeText("non-empty").doc(std::move(doc));
}

/// `base_frame` (the robot's tf frame, non-empty); `doc` says what the nodelet takes from it.
template <class R>
void addBaseFrameField(ParamFieldList<R>& l, std::string doc) {
  l.add("base_frame", &R::base_frame).rangeText("non-empty").doc(std::move(doc));
}

/// `queue_size` [1, 1000]; `doc` says which queues (the hybrid nodelet's scan queue, unsynced).
template <class R>
void addQueueSizeField(ParamFieldList<R>& l, std::string doc) {
  l.add("queue_size", &R::queue_size).closed(1, 1000).doc(std::move(doc));
}

/// `queue_size` [1, 1000] and `approximate_sync`: the queues and the sync of a disparity with its
/// CameraInfo. The disparity nodelet, which syncs images, passes its own docs.
template <class R>
void addSyncFields(ParamFieldList<R>& l,
                   std::string queue_doc =
                       "subscriber / tf filter / sync queue (exact sync: disparities waiting for "
                       "their CameraInfo).",
                   std::string sync_doc =
                       "approximate (message_filters' ApproximateTime) instead of exact "
                       "DisparityImage-CameraInfo sync (our matcher, see the safety map's Bad "
                       "input).") {
  addQueueSizeField(l, std::move(queue_doc));
  l.add("approximate_sync", &R::approximate_sync).doc(std::move(sync_doc));
}

/// `max_rate` [0, 1000] Hz, 0 = every frame (frame_slot.h: a newer frame replaces a waiting one);
/// the returned field takes the nodelet's doc and, where it is live, its level.
template <class R>
ParamField<R>& addMaxRateField(ParamFieldList<R>& l) {
  return l.add("max_rate", &R::max_rate).closed(0, 1000).unit("Hz");
}

/// `tf_timeout` [0, 10] s: the wait for the base frame's transform.
template <class R>
void addTfTimeoutField(ParamFieldList<R>& l) {
  l.add("tf_timeout", &R::tf_timeout)
      .closed(0, 10)
      .unit("s")
      .doc("wait for the base frame's transform.");
}

/// `time_jump_reset` [0, 3600] s; `doc` says what the nodelet resets.
template <class R>
void addTimeJumpResetField(ParamFieldList<R>& l, std::string doc) {
  l.add("time_jump_reset", &R::time_jump_reset).closed(0, 3600).unit("s").doc(std::move(doc));
}

// The range checks of these fields as a validate() reports them: "" when in range, else the
// parameter, its value and its range.

/// `input`: "disparity" or "cloud".
std::string inputError(const std::string& input);
/// `name` (a frame parameter) non-empty; `must_name` says what, e.g. "a tf frame (e.g. odom)".
std::string frameError(const char* name, const std::string& frame, const char* must_name);
/// [1, 1000].
std::string queueSizeError(int queue_size);
/// [0, 1000] Hz.
std::string maxRateError(double max_rate);
/// [0, 10] s.
std::string tfTimeoutError(double tf_timeout);
/// [0, 3600] s.
std::string timeJumpResetError(double time_jump_reset);
/// The first non-empty one of `errors` (in the order validate() checks them), "" if none.
std::string firstError(std::initializer_list<std::string> errors);

}  // namespace stereo_safety_map
