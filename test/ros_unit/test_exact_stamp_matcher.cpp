// ExactStampMatcher (exact_stamp_matcher.h): a frame's disparity and CameraInfo matched by stamp,
// whatever else arrives meanwhile, with bounded memory and every dropped frame reported.
#include "stereo_safety_map/ros/exact_stamp_matcher.h"

#include <gtest/gtest.h>
#include <message_filters/pass_through.h>
#include <sensor_msgs/CameraInfo.h>
#include <stereo_msgs/DisparityImage.h>
#include <boost/make_shared.hpp>

#include <atomic>
#include <set>
#include <thread>

namespace {

using sensor_msgs::CameraInfo;
using stereo_msgs::DisparityImage;
using Matcher = stereo_safety_map::ExactStampMatcher<DisparityImage, CameraInfo, CameraInfo>;

ros::Time stamp(int i) {
  return ros::Time(1000.0 + 0.1 * i);
}

DisparityImage::ConstPtr disparity(int i) {
  auto m = boost::make_shared<DisparityImage>();
  m->header.stamp = stamp(i);
  m->header.seq = i;
  return m;
}

CameraInfo::ConstPtr info(int i, const char* frame) {
  auto m = boost::make_shared<CameraInfo>();
  m->header.stamp = stamp(i);
  m->header.seq = i;
  m->header.frame_id = frame;
  return m;
}

struct Recorder {
  std::vector<ros::Time> matched;
  std::vector<std::pair<ros::Time, std::string>> dropped;
  bool consistent = true;  // every match's parts carry the same stamp, the right part in each slot

  Matcher make(Matcher::Limits limits = Matcher::Limits()) {
    return Matcher(
        limits,
        [this](const DisparityImage::ConstPtr& d, const CameraInfo::ConstPtr& l,
               const CameraInfo::ConstPtr& r) {
          consistent = consistent && d->header.stamp == l->header.stamp &&
                       d->header.stamp == r->header.stamp && l->header.frame_id == "left" &&
                       r->header.frame_id == "right";
          matched.push_back(d->header.stamp);
        },
        [this](const ros::Time& t, const std::string& why) { dropped.emplace_back(t, why); });
  }
};

void addFrame(Matcher& m, int i, const std::string& order) {
  for (char c : order) {
    if (c == 'd') m.add<0>(stamp(i), disparity(i));
    if (c == 'l') m.add<1>(stamp(i), info(i, "left"));
    if (c == 'r') m.add<2>(stamp(i), info(i, "right"));
  }
}

TEST(ExactStampMatcher, MatchesThePartsOfAFrameInAnyOrderOnce) {
  Recorder rec;
  Matcher m = rec.make();
  const char* orders[] = {"dlr", "drl", "ldr", "lrd", "rdl", "rld"};
  for (int i = 0; i < 6; ++i)
    addFrame(m, i, orders[i]);
  ASSERT_EQ(rec.matched.size(), 6u);
  for (int i = 0; i < 6; ++i)
    EXPECT_EQ(rec.matched[i], stamp(i));
  EXPECT_TRUE(rec.consistent);
  EXPECT_EQ(m.size(), 0u);
  EXPECT_TRUE(rec.dropped.empty());
}

TEST(ExactStampMatcher, AFloodOfCameraInfoDoesNotEvictAFrameWhoseDisparityIsOnItsWay) {
  // ExactTime(queue_size 5) loses frame 0 here: its CameraInfo are the oldest of 1001 tuples.
  Recorder rec;
  Matcher m = rec.make();
  addFrame(m, 0, "lr");
  for (int i = 1; i <= 1000; ++i)
    m.add<1>(stamp(1000 + i), info(1000 + i, "left"));  // no disparity will ever come for these
  addFrame(m, 0, "d");
  ASSERT_EQ(rec.matched.size(), 1u);
  EXPECT_EQ(rec.matched[0], stamp(0));
  EXPECT_TRUE(rec.dropped.empty());  // CameraInfo-only frames go without a report
  EXPECT_EQ(m.size(), 1000u);
}

TEST(ExactStampMatcher, FramesHeldUpInTheTfFilterStillMatchAfterNewerOnes) {
  // A tf stall: frames 0-4 have their CameraInfo; their disparities wait in the tf filter until
  // after frame 10 has completed. ExactTime clears them when frame 10 completes.
  Recorder rec;
  Matcher m = rec.make();
  for (int i = 0; i < 5; ++i)
    addFrame(m, i, "lr");
  addFrame(m, 10, "lrd");
  for (int i = 0; i < 5; ++i)
    addFrame(m, i, "d");
  ASSERT_EQ(rec.matched.size(), 6u);
  EXPECT_EQ(rec.matched[0], stamp(10));
  EXPECT_EQ(rec.matched[5], stamp(4));
  EXPECT_EQ(m.size(), 0u);
}

TEST(ExactStampMatcher, IncompleteFramesAreBoundedOldestFirst) {
  Recorder rec;
  Matcher::Limits limits;
  limits.max_partial = 100;
  Matcher m = rec.make(limits);
  for (int i = 0; i < 1000; ++i) {
    m.add<1>(stamp(i), info(i, "left"));
    ASSERT_LE(m.size(), 100u);
  }
  // The newest 100 are kept: frame 999 completes, frame 0 does not.
  addFrame(m, 999, "rd");
  addFrame(m, 0, "rd");
  ASSERT_EQ(rec.matched.size(), 1u);
  EXPECT_EQ(rec.matched[0], stamp(999));
}

TEST(ExactStampMatcher, ADisparityWithoutItsCameraInfoIsDroppedWithAReason) {
  Recorder rec;
  Matcher::Limits limits;
  limits.max_waiting_primary = 5;
  Matcher m = rec.make(limits);
  for (int i = 0; i < 5; ++i)
    addFrame(m, i, "dl");  // the right CameraInfo never comes
  EXPECT_TRUE(rec.dropped.empty());
  addFrame(m, 5, "d");
  ASSERT_EQ(rec.dropped.size(), 1u);
  EXPECT_EQ(rec.dropped[0].first, stamp(0));
  EXPECT_NE(rec.dropped[0].second.find("5 newer frames"), std::string::npos)
      << rec.dropped[0].second;
  EXPECT_NE(rec.dropped[0].second.find("has 2 of 3 parts"), std::string::npos)
      << rec.dropped[0].second;
  // The others still complete; the dropped one does not come back with a late CameraInfo.
  addFrame(m, 3, "r");
  addFrame(m, 0, "r");
  ASSERT_EQ(rec.matched.size(), 1u);
  EXPECT_EQ(rec.matched[0], stamp(3));
}

TEST(ExactStampMatcher, AWaitingDisparityNeverEvictsItself) {
  // Frame 0's CameraInfo came long before the disparities of frames 1-5: its own disparity,
  // arriving last, must evict frame 1 (the oldest waiting disparity), not frame 0.
  Recorder rec;
  Matcher::Limits limits;
  limits.max_waiting_primary = 5;
  Matcher m = rec.make(limits);
  addFrame(m, 0, "l");
  for (int i = 1; i <= 5; ++i)
    addFrame(m, i, "d");
  addFrame(m, 0, "d");
  ASSERT_EQ(rec.dropped.size(), 1u);
  EXPECT_EQ(rec.dropped[0].first, stamp(1));
  addFrame(m, 0, "r");
  ASSERT_EQ(rec.matched.size(), 1u);
  EXPECT_EQ(rec.matched[0], stamp(0));
}

TEST(ExactStampMatcher, IncompleteFramesExpireAfterKeep) {
  Recorder rec;
  Matcher::Limits limits;
  limits.keep = 2.0;
  Matcher m = rec.make(limits);
  const auto t0 = Matcher::Clock::now();
  m.add<0>(stamp(0), disparity(0), t0);
  m.add<1>(stamp(1), info(1, "left"), t0 + std::chrono::milliseconds(1500));
  EXPECT_EQ(m.size(), 2u);
  // 2.5 s after frame 0 began: it expires (reported: it had its disparity), frame 1 does not.
  m.add<1>(stamp(2), info(2, "left"), t0 + std::chrono::milliseconds(2500));
  ASSERT_EQ(rec.dropped.size(), 1u);
  EXPECT_EQ(rec.dropped[0].first, stamp(0));
  EXPECT_NE(rec.dropped[0].second.find("more than 2 s"), std::string::npos);
  EXPECT_EQ(m.size(), 2u);
  // 4 s: frame 1 expires without a report (no disparity).
  m.add<2>(stamp(3), info(3, "right"), t0 + std::chrono::milliseconds(4000));
  EXPECT_EQ(rec.dropped.size(), 1u);
  EXPECT_EQ(m.size(), 2u);  // frames 2 and 3
}

TEST(ExactStampMatcher, ConnectInputFeedsItFromMessageFilters) {
  ros::Time::init();  // MessageEvent stamps its receipt time
  Recorder rec;
  Matcher m = rec.make();
  message_filters::PassThrough<DisparityImage> d;
  message_filters::PassThrough<CameraInfo> l, r;
  m.connectInput<0>(d);
  m.connectInput<1>(l);
  m.connectInput<2>(r);
  r.add(info(7, "right"));
  d.add(disparity(7));
  EXPECT_TRUE(rec.matched.empty());
  l.add(info(7, "left"));
  ASSERT_EQ(rec.matched.size(), 1u);
  EXPECT_EQ(rec.matched[0], stamp(7));
  EXPECT_TRUE(rec.consistent);
}

TEST(ExactStampMatcher, ConcurrentPartsMatchEachFrameExactlyOnce) {
  std::mutex mutex;
  std::multiset<ros::Time> matched;
  std::atomic<int> dropped{0};
  Matcher m(
      Matcher::Limits(),
      [&](const DisparityImage::ConstPtr& d, const CameraInfo::ConstPtr&,
          const CameraInfo::ConstPtr&) {
        std::lock_guard<std::mutex> lock(mutex);
        matched.insert(d->header.stamp);
      },
      [&](const ros::Time&, const std::string&) { ++dropped; });
  constexpr int kFrames = 3000;
  std::thread a([&] {
    for (int i = 0; i < kFrames; ++i)
      m.add<0>(stamp(i), disparity(i));
  });
  std::thread b([&] {
    for (int i = 0; i < kFrames; ++i)
      m.add<1>(stamp(i), info(i, "left"));
  });
  std::thread c([&] {
    for (int i = kFrames - 1; i >= 0; --i)
      m.add<2>(stamp(i), info(i, "right"));
  });
  a.join();
  b.join();
  c.join();
  // max_waiting_primary (5) may drop disparities that ran ahead of their CameraInfo: each such
  // frame is reported, every other frame matched once.
  EXPECT_EQ(matched.size() + static_cast<std::size_t>(dropped.load()), std::size_t(kFrames));
  for (const auto& t : matched)
    EXPECT_EQ(matched.count(t), 1u);
}

}  // namespace
