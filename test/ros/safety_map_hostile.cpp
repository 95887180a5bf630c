// A hostile publisher beside a valid stream. Four safety-map nodelets share one multi-threaded
// manager: /clean (disparity) and /clean_cloud (cloud) get the valid stream of a robot driving
// over the synthetic scene (test_util.h); /hostile and /hostile_cloud get the same valid stream
// and, all the while, a flood of malformed messages from a second thread (hundreds per second:
// wrong encodings and steps, short data, absurd sizes, NaN / inf, zero focal length or baseline,
// CameraInfo that does not match, missing and duplicated fields, empty frame ids, stamps from
// the past and the future).
//
// The valid stream goes in lockstep (the next frame once every nodelet has published the map of
// the last), so that the test does not depend on timing. What must hold: the hostile nodelets
// stay up, publish a map for every valid frame and for nothing else, and each map EQUALS the
// clean nodelet's map of the same frame, label for label; the malformed messages are counted in
// /diagnostics.
#include "test_util.h"

#include "stereo_safety_map/ros/msgs.h"

#include <gtest/gtest.h>

#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using stereo_safety_map::SafetyMapMsg;
using test_util::waitFor;

namespace {

constexpr double kStep = 0.05;  // [m] per frame

// Valid frames: 30 in CI; more for a long local run (SSM_HOSTILE_FRAMES=3000 rostest ...).
int frames() {
  const char* env = std::getenv("SSM_HOSTILE_FRAMES");
  return env != nullptr && std::atoi(env) > 0 ? std::atoi(env) : 30;
}

// The robot drives back and forth between x = -1 and x = 0.5 (the box stays in view).
double robotX(int k) {
  const int phase = k % 60;
  return -1.0 + kStep * (phase < 30 ? phase : 60 - phase);
}

// Every map a nodelet publishes, by stamp.
class MapRecorder {
 public:
  MapRecorder(ros::NodeHandle& nh, const std::string& topic) {
    sub_ = nh.subscribe<SafetyMapMsg>(topic, 100, [this](const SafetyMapMsg::ConstPtr& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      maps_[m->header.stamp] = m;
      ++received_;
    });
  }
  SafetyMapMsg::ConstPtr at(const ros::Time& t) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = maps_.find(t);
    return it == maps_.end() ? nullptr : it->second;
  }
  /// Removes and returns the map of stamp t (null when there is none).
  SafetyMapMsg::ConstPtr take(const ros::Time& t) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = maps_.find(t);
    if (it == maps_.end()) return nullptr;
    SafetyMapMsg::ConstPtr m = it->second;
    maps_.erase(it);
    return m;
  }
  /// Maps received so far, and those whose stamp was not taken.
  int received() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return received_;
  }
  std::size_t left() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return maps_.size();
  }

 private:
  ros::Subscriber sub_;
  mutable std::mutex mutex_;
  std::map<ros::Time, SafetyMapMsg::ConstPtr> maps_;
  int received_ = 0;
};

// The malformed messages, built once; the flood stamps and sends them in turn.
struct Hostile {
  std::vector<std::function<void(const ros::Time&)>> disparity;  // per kind, publishes
  std::vector<std::function<void(const ros::Time&)>> cloud;
  // Full-size ones (320 x 240), sent less often: the flood is about many messages, and a few
  // hundred megabytes per second would only measure the loopback interface.
  std::vector<std::function<void(const ros::Time&)>> large;
};

class HostileTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    static_tf_ = new tf2_ros::StaticTransformBroadcaster;
    tf_ = new tf2_ros::TransformBroadcaster;
    for (const char* ns : {"/clean", "/hostile", "/clean_cloud", "/hostile_cloud"}) {
      pubs_[ns] = new test_util::ScenePublisher(*nh_, ns);
      maps_[ns] = new MapRecorder(*nh_, std::string(ns) + "/safety_map_labels");
    }
    diagnostics_ = new test_util::DiagnosticsWatcher(*nh_);
    auto t = synthetic_scene::toMsg(synthetic_scene::baseToCamera(), "base_link",
                                    synthetic_scene::kCameraFrame);
    t.header.stamp = ros::Time::now();
    static_tf_->sendTransform(t);
    raw_disparity_ = nh_->advertise<stereo_msgs::DisparityImage>("/hostile/stereo/disparity", 50);
    raw_left_ = nh_->advertise<sensor_msgs::CameraInfo>("/hostile/stereo/left/camera_info", 50);
    raw_right_ = nh_->advertise<sensor_msgs::CameraInfo>("/hostile/stereo/right/camera_info", 50);
    raw_cloud_ = nh_->advertise<sensor_msgs::PointCloud2>("/hostile_cloud/points", 50);
    ASSERT_TRUE(pubs_["/clean"]->waitForSubscribers(20.0));
    ASSERT_TRUE(pubs_["/hostile"]->waitForSubscribers(20.0));
    ASSERT_TRUE(pubs_["/clean_cloud"]->waitForCloudSubscriber(20.0));
    ASSERT_TRUE(pubs_["/hostile_cloud"]->waitForCloudSubscriber(20.0));
    ASSERT_TRUE(waitFor(
        [] {
          return raw_disparity_.getNumSubscribers() > 0 && raw_left_.getNumSubscribers() > 0 &&
                 raw_right_.getNumSubscribers() > 0 && raw_cloud_.getNumSubscribers() > 0;
        },
        20.0));
    test_util::sleepFor(0.5);
    buildHostile();
  }

  // ---- the valid stream

  // One frame of the robot at x, to every nodelet; waits until each has published its map.
  static bool validFrame(double x, ros::Time* stamp) {
    *stamp = ros::Time::now();
    Eigen::Isometry3d T_odom_base = Eigen::Isometry3d::Identity();
    T_odom_base.translation().x() = x;
    auto t = synthetic_scene::toMsg(T_odom_base, "odom", "base_link");
    t.header.stamp = *stamp;
    tf_->sendTransform(t);
    test_util::sleepFor(0.02);  // the transform first, so that no frame waits for it
    std_msgs::Header h;
    h.stamp = *stamp;
    h.frame_id = synthetic_scene::kCameraFrame;
    const Eigen::Isometry3d T = T_odom_base * synthetic_scene::baseToCamera();
    const auto d = synthetic_scene::disparityImage(T, h);
    const auto l = synthetic_scene::cameraInfo(false, h);
    const auto r = synthetic_scene::cameraInfo(true, h);
    const auto c = synthetic_scene::pointCloud(T, h);
    pubs_["/clean"]->publishDisparity(d, l, r, *stamp);
    pubs_["/hostile"]->publishDisparity(d, l, r, *stamp);
    pubs_["/clean_cloud"]->publishCloud(c, *stamp);
    pubs_["/hostile_cloud"]->publishCloud(c, *stamp);
    const ros::Time s = *stamp;
    return waitFor(
        [s] {
          for (const auto& m : maps_)
            if (!m.second->at(s)) return false;
          return true;
        },
        30.0);
  }

  // ---- the hostile stream

  static void buildHostile() {
    std_msgs::Header h;
    h.frame_id = synthetic_scene::kCameraFrame;
    const Eigen::Isometry3d T = synthetic_scene::baseToCamera();
    const stereo_msgs::DisparityImage good_d = synthetic_scene::disparityImage(T, h);
    const sensor_msgs::CameraInfo good_l = synthetic_scene::cameraInfo(false, h);
    const sensor_msgs::CameraInfo good_r = synthetic_scene::cameraInfo(true, h);
    const sensor_msgs::PointCloud2 good_c = synthetic_scene::pointCloud(T, h);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();

    // A disparity alone (refused on its own, before the tf filter and the sync).
    auto alone = [](stereo_msgs::DisparityImage d) {
      return [d](const ros::Time& t) mutable {
        d.header.stamp = d.image.header.stamp = t;
        raw_disparity_.publish(d);
      };
    };
    // A CameraInfo alone.
    auto info_alone = [](sensor_msgs::CameraInfo info, bool right) {
      return [info, right](const ros::Time& t) mutable {
        info.header.stamp = t;
        (right ? raw_right_ : raw_left_).publish(info);
      };
    };
    // A whole frame whose parts are each valid but do not fit together.
    auto triple = [](stereo_msgs::DisparityImage d, sensor_msgs::CameraInfo l,
                     sensor_msgs::CameraInfo r) {
      return [d, l, r](const ros::Time& t) mutable {
        d.header.stamp = d.image.header.stamp = l.header.stamp = r.header.stamp = t;
        raw_left_.publish(l);
        raw_right_.publish(r);
        raw_disparity_.publish(d);
      };
    };
    // Small messages for the structural cases: the sizes in the fields are what is wrong.
    stereo_msgs::DisparityImage small = good_d;
    small.image.data.resize(64);
    // A well-formed 4 x 3 disparity, for the cases where something else is wrong.
    stereo_msgs::DisparityImage tiny = good_d;
    tiny.image.width = 4;
    tiny.image.height = 3;
    tiny.image.step = 16;
    tiny.image.data.assign(48, 0);
    for (int i = 0; i < 12; ++i) {
      const float v = 20.0f;
      std::memcpy(&tiny.image.data[4 * i], &v, sizeof(float));
    }
    auto& D = hostile_.disparity;
    {
      auto d = small;
      d.image.encoding = "16UC1";
      D.push_back(alone(d));
    }
    D.push_back(alone(small));  // data much shorter than width x height
    {
      auto d = small;
      d.image.step = 17;  // shorter than width x 4, not a multiple of 4
      D.push_back(alone(d));
    }
    {
      auto d = small;
      d.image.width = 1u << 31;  // absurd size
      d.image.height = 1u << 20;
      d.image.step = 0xFFFFFFFCu;
      D.push_back(alone(d));
    }
    {
      auto d = small;
      d.image.width = d.image.height = 0;
      D.push_back(alone(d));
    }
    {
      auto d = small;
      d.image.is_bigendian = 1;
      D.push_back(alone(d));
    }
    {
      auto d = small;
      d.f = 0.0f;
      D.push_back(alone(d));
    }
    {
      auto d = small;
      d.T = nan;
      D.push_back(alone(d));
    }
    {
      auto d = good_d;  // every pixel NaN or inf
      float* px = reinterpret_cast<float*>(d.image.data.data());
      for (std::size_t i = 0; i < d.image.width * d.image.height; ++i)
        px[i] = (i % 2) ? nan : -inf;
      hostile_.large.push_back(alone(d));
      auto e = tiny;
      px = reinterpret_cast<float*>(e.image.data.data());
      for (std::size_t i = 0; i < 12; ++i)
        px[i] = (i % 2) ? nan : -inf;
      D.push_back(alone(e));
    }
    {
      auto d = tiny;  // every pixel invalid (below min_disparity)
      float* px = reinterpret_cast<float*>(d.image.data.data());
      for (std::size_t i = 0; i < d.image.width * d.image.height; ++i)
        px[i] = -1.0f;
      D.push_back(alone(d));
    }
    {
      auto l = good_l;
      l.K.fill(0.0);
      l.P.fill(0.0);
      D.push_back(info_alone(l, false));
    }
    {
      auto r = good_r;
      r.P[5] = std::numeric_limits<double>::quiet_NaN();
      D.push_back(info_alone(r, true));
    }
    {
      auto r = good_r;
      r.P[3] = 0.0;  // zero baseline
      D.push_back(info_alone(r, true));
    }
    {
      auto l = good_l;
      l.width = 0;
      D.push_back(info_alone(l, false));
    }
    {
      // Each part fine, together not: the CameraInfo pair says 640 x 480.
      auto l = good_l, r = good_r;
      l.width = r.width = 640;
      l.height = r.height = 480;
      D.push_back(triple(good_d, l, r));
      D.push_back(triple(tiny, good_l, good_r));  // the disparity is 4 x 3
    }
    {
      // Left and right CameraInfo of different sizes.
      auto r = good_r;
      r.width = 300;
      D.push_back(triple(tiny, good_l, r));
    }
    {
      // cy differs: image_geometry's StereoCameraModel asserts on it, which aborted the manager.
      auto r = good_r;
      r.P[6] += 5.0;
      r.K[5] += 5.0;
      D.push_back(triple(good_d, good_l, r));
    }
    {
      // An ROI to rectify with an unknown distortion model: image_geometry throws from
      // reducedResolution(), in the sync callback.
      auto l = good_l, r = good_r;
      l.distortion_model = r.distortion_model = "no_such_model";
      l.roi.x_offset = r.roi.x_offset = 10;
      l.roi.width = r.roi.width = 100;
      l.roi.height = r.roi.height = 100;
      l.roi.do_rectify = r.roi.do_rectify = true;
      D.push_back(triple(good_d, l, r));
    }
    {
      auto d = tiny;  // an empty frame id: the tf filter refuses it at once
      d.header.frame_id = d.image.header.frame_id = "";
      D.push_back(alone(d));
    }

    // Clouds.
    auto cloud = [](sensor_msgs::PointCloud2 c) {
      return [c](const ros::Time& t) mutable {
        c.header.stamp = t;
        raw_cloud_.publish(c);
      };
    };
    sensor_msgs::PointCloud2 small_c = good_c;
    small_c.data.resize(96);
    // A well-formed cloud of 4 x 3 points at 1 m, for the cases where something else is wrong.
    sensor_msgs::PointCloud2 tiny_c = good_c;
    tiny_c.width = 4;
    tiny_c.height = 3;
    tiny_c.row_step = 4 * tiny_c.point_step;
    tiny_c.data.assign(static_cast<std::size_t>(tiny_c.row_step) * 3, 0);
    for (std::size_t i = 0; i < 12; ++i) {
      const float z = 1.0f;
      std::memcpy(&tiny_c.data[i * tiny_c.point_step + 8], &z, sizeof(float));
    }
    auto& C = hostile_.cloud;
    {
      auto c = small_c;
      c.fields[2].name = "intensity";  // no z
      C.push_back(cloud(c));
    }
    {
      auto c = small_c;
      for (auto& f : c.fields)
        f.datatype = sensor_msgs::PointField::FLOAT64;
      C.push_back(cloud(c));
    }
    C.push_back(cloud(small_c));  // data shorter than row_step x height
    {
      auto c = small_c;
      c.point_step = 0;
      C.push_back(cloud(c));
    }
    {
      auto c = small_c;
      c.row_step = 7;
      C.push_back(cloud(c));
    }
    {
      auto c = small_c;
      c.width = 0xFFFFFFFFu;  // absurd size
      c.height = 0xFFFFFFFFu;
      C.push_back(cloud(c));
    }
    {
      auto c = small_c;
      c.is_bigendian = true;
      C.push_back(cloud(c));
    }
    {
      auto c = small_c;
      c.fields[0].count = 3;
      C.push_back(cloud(c));
    }
    {
      auto c = small_c;
      c.fields[1].offset = 1u << 30;  // outside the point
      C.push_back(cloud(c));
    }
    {
      // A second 'x' far outside the point, rows padded: was read out of bounds once; now
      // refused as ambiguous.
      auto c = tiny_c;
      sensor_msgs::PointField f = c.fields[0];
      f.offset = 1u << 30;
      c.fields.push_back(f);
      c.row_step += 4;
      c.data.resize(static_cast<std::size_t>(c.row_step) * c.height);
      C.push_back(cloud(c));
    }
    {
      auto c = good_c;  // every point NaN or inf
      float* p = reinterpret_cast<float*>(c.data.data());
      for (std::size_t i = 0; i < c.data.size() / sizeof(float); ++i)
        p[i] = (i % 3) ? nan : inf;
      hostile_.large.push_back(cloud(c));
      auto e = tiny_c;
      p = reinterpret_cast<float*>(e.data.data());
      for (std::size_t i = 0; i < e.data.size() / sizeof(float); ++i)
        p[i] = (i % 3) ? nan : inf;
      C.push_back(cloud(e));
    }
    {
      auto c = small_c;
      c.width = c.height = 0;
      C.push_back(cloud(c));
    }
    {
      auto c = tiny_c;
      c.header.frame_id = "";
      C.push_back(cloud(c));
    }
  }

  // Sends the malformed messages in turn until stopped; stamps: now, a bit before or after
  // now (never a valid frame's stamp: those are taken by the other thread), far in the past or
  // the future.
  static void flood() {
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> pick(0, 9);
    std::size_t k = 0;
    while (!stop_flood_) {
      ros::Time t = ros::Time::now();
      switch (pick(rng)) {
        case 0:
          t -= ros::Duration(100.0);
          break;
        case 1:
          t += ros::Duration(100.0);
          break;
        case 2:
          t -= ros::Duration(0.013);
          break;
        default:
          break;
      }
      const auto& d = hostile_.disparity;
      const auto& c = hostile_.cloud;
      d[k % d.size()](t);
      c[k % c.size()](t);
      sent_ += 2;
      if (k % 25 == 0) {
        hostile_.large[(k / 25) % hostile_.large.size()](t);
        ++sent_;
      }
      ++k;
      std::this_thread::sleep_for(std::chrono::microseconds(2500));  // ~800 messages / s
    }
  }

  static ros::NodeHandle* nh_;
  static tf2_ros::StaticTransformBroadcaster* static_tf_;
  static tf2_ros::TransformBroadcaster* tf_;
  static std::map<std::string, test_util::ScenePublisher*> pubs_;
  static std::map<std::string, MapRecorder*> maps_;
  static test_util::DiagnosticsWatcher* diagnostics_;
  static ros::Publisher raw_disparity_, raw_left_, raw_right_, raw_cloud_;
  static Hostile hostile_;
  static std::atomic<bool> stop_flood_;
  static std::atomic<long> sent_;
};
ros::NodeHandle* HostileTest::nh_ = nullptr;
tf2_ros::StaticTransformBroadcaster* HostileTest::static_tf_ = nullptr;
tf2_ros::TransformBroadcaster* HostileTest::tf_ = nullptr;
std::map<std::string, test_util::ScenePublisher*> HostileTest::pubs_;
std::map<std::string, MapRecorder*> HostileTest::maps_;
test_util::DiagnosticsWatcher* HostileTest::diagnostics_ = nullptr;
ros::Publisher HostileTest::raw_disparity_, HostileTest::raw_left_, HostileTest::raw_right_,
    HostileTest::raw_cloud_;
Hostile HostileTest::hostile_;
std::atomic<bool> HostileTest::stop_flood_{false};
std::atomic<long> HostileTest::sent_{0};

TEST_F(HostileTest, MapsEqualThoseOfTheValidStreamAlone) {
  const int n = frames();
  std::thread flooder(&HostileTest::flood);
  const ros::WallTime start = ros::WallTime::now();
  int compared = 0;
  for (int k = 0; k < n; ++k) {
    ros::Time t;
    if (!validFrame(robotX(k), &t)) {
      // Which nodelet, and what its diagnostics counted (why the frame went missing).
      std::ostringstream why;
      for (const auto& m : maps_) {
        if (m.second->at(t)) continue;
        why << "\n  " << m.first << ":";
        for (const char* key :
             {"frames received", "frames dropped (missing tf)",
              "frames dropped (processing slower than input)", "problem: out of order",
              "problem: bad camera model", "problem: stale tf", "frames skipped (stationary)",
              "problem: frozen input", "frames processed", "last problem"}) {
          why << " [" << key << ": " << diagnostics_->lastValue(m.first + "/safety_map", key)
              << "]";
        }
      }
      ADD_FAILURE() << "no map for valid frame " << k << " at " << t << " from" << why.str();
      break;
    }
    // The maps of this frame, hostile against clean, label for label.
    for (const auto& pair :
         {std::make_pair("/clean", "/hostile"), std::make_pair("/clean_cloud", "/hostile_cloud")}) {
      const auto c = maps_[pair.first]->take(t);
      const auto h = maps_[pair.second]->take(t);
      ASSERT_TRUE(c && h);
      ASSERT_EQ(h->info.width, c->info.width) << pair.second << " at " << t;
      ASSERT_EQ(h->info.height, c->info.height);
      EXPECT_EQ(h->info.origin.position.x, c->info.origin.position.x);
      EXPECT_EQ(h->info.origin.position.y, c->info.origin.position.y);
      EXPECT_EQ(h->labels, c->labels) << pair.second << ": labels differ at " << t;
      EXPECT_EQ(h->drop_off, c->drop_off) << pair.second << ": drop-off edges differ at " << t;
      if (k + 1 == n) {
        // And the maps are maps: the floor ahead Level, the box Non-ground.
        const int floor = test_util::cellAt(h->info, robotX(k) + 2.0, 0.8);
        const int box = test_util::cellAt(h->info, 2.3, 0.0);
        ASSERT_GE(floor, 0);
        ASSERT_GE(box, 0);
        EXPECT_EQ(h->labels[floor], SafetyMapMsg::LEVEL) << pair.second;
        EXPECT_EQ(h->labels[box], SafetyMapMsg::NON_GROUND) << pair.second;
      }
      ++compared;
    }
  }
  stop_flood_ = true;
  flooder.join();
  const double seconds = (ros::WallTime::now() - start).toSec();
  std::printf(
      "[hostile] %ld malformed messages sent in %.1f s beside %d valid frames; %d maps "
      "compared, all equal unless reported above\n",
      sent_.load(), seconds, n, compared);
  EXPECT_EQ(compared, 2 * n);
  EXPECT_GT(sent_.load(), 10 * n);
  // A map for every valid frame and for nothing else.
  test_util::sleepFor(0.5);
  for (const auto& m : maps_) {
    EXPECT_EQ(m.second->received(), n) << m.first;
    EXPECT_EQ(m.second->left(), 0u) << m.first << " published maps for no valid frame";
  }

  // The malformed messages were seen and counted, by kind.
  auto count = [](const std::string& node, const std::string& key) {
    const std::string v = diagnostics_->lastValue(node, key);
    return v.empty() ? 0L : std::stol(v);
  };
  EXPECT_TRUE(waitFor(
      [&] { return count("/hostile/safety_map", "frames rejected (bad input)") > n; }, 5.0));
  for (const char* key : {"problem: bad disparity image", "problem: bad camera model",
                          "problem: non-finite input", "problem: no valid data"}) {
    EXPECT_GT(count("/hostile/safety_map", key), 0) << key;
  }
  for (const char* key : {"problem: bad point cloud", "problem: non-finite input"}) {
    EXPECT_GT(count("/hostile_cloud/safety_map", key), 0) << key;
  }
  EXPECT_EQ(count("/clean/safety_map", "frames rejected (bad input)"), 0);
  EXPECT_EQ(count("/hostile/safety_map", "map resets"), 0);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_map_hostile_test");
  ros::AsyncSpinner spinner(4);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
