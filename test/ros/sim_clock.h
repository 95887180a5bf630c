// Helpers for rostests that run on simulated time (/use_sim_time true): a /clock publisher that
// runs at wall speed and can be jumped forward or back, one that steps, a moving robot's tf, and a
// /rosout counter.
#pragma once

#include "test_util.h"

#include <rosgraph_msgs/Clock.h>
#include <rosgraph_msgs/Log.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <mutex>
#include <string>
#include <thread>

namespace test_util {

/// Publishes /clock every 10 ms: start + (wall time since start) + the sum of jumps. now() is
/// the time it publishes (read it here: ros::Time::now() in the test node lags by a round trip).
class SimClock {
 public:
  SimClock(ros::NodeHandle& nh, const ros::Time& start) : start_(start) {
    pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
    wall_start_ = ros::WallTime::now();
    thread_ = std::thread([this] {
      while (!stop_) {
        rosgraph_msgs::Clock c;
        c.clock = now();
        pub_.publish(c);
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    });
  }
  ~SimClock() {
    stop_ = true;
    thread_.join();
  }
  ros::Time now() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return start_ + offset_ + ros::Duration((ros::WallTime::now() - wall_start_).toSec());
  }
  /// Moves the clock by `d` (negative: back in time, as a bag played again).
  void jump(const ros::Duration& d) {
    std::lock_guard<std::mutex> lock(mutex_);
    offset_ += d;
  }

 private:
  ros::Publisher pub_;
  ros::Time start_;
  ros::WallTime wall_start_;
  mutable std::mutex mutex_;
  ros::Duration offset_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

/// Publishes /clock in steps: the time set last, repeated every 20 ms (late subscribers get it
/// too). For tests that advance the clock in lockstep with their input (e.g. one camera frame per
/// step): nothing on the ROS clock moves between two set() calls.
class SteppedClock {
 public:
  explicit SteppedClock(ros::NodeHandle& nh) {
    pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
    thread_ = std::thread([this] {
      while (!stop_) {
        publish();
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    });
  }
  ~SteppedClock() {
    stop_ = true;
    thread_.join();
  }
  void set(const ros::Time& t) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      now_ = t;
    }
    publish();
  }
  ros::Time now() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return now_;
  }

 private:
  void publish() {
    rosgraph_msgs::Clock c;
    c.clock = now();
    if (!c.clock.isZero()) pub_.publish(c);
  }
  ros::Publisher pub_;
  mutable std::mutex mutex_;
  ros::Time now_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

/// Counts /rosout messages containing a text.
class RosoutCounter {
 public:
  RosoutCounter(ros::NodeHandle& nh, const std::string& text) : text_(text) {
    sub_ = nh.subscribe<rosgraph_msgs::Log>("/rosout", 200,
                                            [this](const rosgraph_msgs::LogConstPtr& m) {
                                              if (m->msg.find(text_) != std::string::npos) ++count_;
                                            });
  }
  int count() const { return count_; }

 private:
  std::string text_;
  ros::Subscriber sub_;
  std::atomic<int> count_{0};
};

}  // namespace test_util
