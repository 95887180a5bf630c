// FrameSlot (frame_slot.h): the frame queue between a nodelet's callbacks and its worker.
#include "stereo_safety_map/ros/frame_slot.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

namespace {

using stereo_safety_map::FrameSlot;

struct Frame {
  int id = 0;
  bool mark = false;
};
using Slot = FrameSlot<Frame>;

std::unique_ptr<Frame> frame(int id) {
  auto f = std::make_unique<Frame>();
  f->id = id;
  return f;
}

TEST(FrameSlot, TheNewestFrameWinsAndReplacingIsReported) {
  Slot slot;
  EXPECT_EQ(slot.put(frame(1)), Slot::Put::kQueued);
  EXPECT_EQ(slot.put(frame(2)), Slot::Put::kReplaced);
  const auto f = slot.take(0.0, Slot::Clock::now());
  ASSERT_TRUE(f);
  EXPECT_EQ(f->id, 2);
  EXPECT_EQ(slot.put(frame(3)), Slot::Put::kQueued);  // the slot was emptied by take()
}

TEST(FrameSlot, TwoSlotsKeepOneLateFrameAndDropTheOldestWhenFull) {
  Slot slot;
  EXPECT_EQ(slot.capacity(), 1u);
  slot.setCapacity(2);
  EXPECT_EQ(slot.capacity(), 2u);
  EXPECT_EQ(slot.put(frame(1)), Slot::Put::kQueued);
  EXPECT_EQ(slot.put(frame(2)), Slot::Put::kQueued);    // absorbed, not dropped
  EXPECT_EQ(slot.put(frame(3)), Slot::Put::kReplaced);  // full: 1, the oldest, is dropped
  auto f = slot.take(0.0, Slot::Clock::now());
  ASSERT_TRUE(f);
  EXPECT_EQ(f->id, 2);  // oldest first
  f = slot.take(0.0, Slot::Clock::now());
  ASSERT_TRUE(f);
  EXPECT_EQ(f->id, 3);
  // Shrinking drops the oldest waiting frames; 0 is taken as 1.
  slot.put(frame(4));
  slot.put(frame(5));
  slot.setCapacity(0);
  EXPECT_EQ(slot.capacity(), 1u);
  f = slot.take(0.0, Slot::Clock::now());
  ASSERT_TRUE(f);
  EXPECT_EQ(f->id, 5);
}

TEST(FrameSlot, AThrottledTakeReturnsTheNewestAndCountsTheOlder) {
  Slot slot;
  slot.setCapacity(3);
  slot.put(frame(1));
  slot.put(frame(2));
  slot.put(frame(3));
  std::size_t discarded = 0;
  const auto f = slot.take(1000.0, Slot::Clock::now(), &discarded);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->id, 3);
  EXPECT_EQ(discarded, 2u);
}

TEST(FrameSlot, AcceptDecidesUnderTheLockAndSeesTheWaitingFrame) {
  Slot slot;
  int newest = 0;  // what a nodelet keeps beside the slot (e.g. the newest stamp)
  const auto inOrder = [&](Frame& in, const Frame* waiting) {
    if (in.id <= newest) return false;
    newest = in.id;
    if (waiting && waiting->mark) in.mark = true;  // a waiting mark is carried on
    return true;
  };
  auto marked = frame(5);
  marked->mark = true;
  EXPECT_EQ(slot.putIf(std::move(marked), inOrder), Slot::Put::kQueued);
  EXPECT_EQ(slot.putIf(frame(4), inOrder), Slot::Put::kRefused);
  EXPECT_EQ(slot.putIf(frame(6), inOrder), Slot::Put::kReplaced);
  const auto f = slot.take(0.0, Slot::Clock::now());
  ASSERT_TRUE(f);
  EXPECT_EQ(f->id, 6);
  EXPECT_TRUE(f->mark);
}

// setCarry: what a dropped frame carries (the safety map's reset_map) reaches the frame after it,
// whichever way the queue drops it; frames not after a dropped marked one stay unmarked.
TEST(FrameSlot, ADroppedFramesMarkPassesToTheFrameAfterIt) {
  const auto carryMark = [](const Frame& dropped, Frame& successor) {
    if (dropped.mark) successor.mark = true;
  };
  auto marked = [](int id) {
    auto f = frame(id);
    f->mark = true;
    return f;
  };
  {  // one slot: the incoming frame replaces the marked one and takes its mark
    Slot slot;
    slot.setCarry(carryMark);
    slot.put(marked(1));
    EXPECT_EQ(slot.put(frame(2)), Slot::Put::kReplaced);
    const auto f = slot.take(0.0, Slot::Clock::now());
    ASSERT_TRUE(f);
    EXPECT_EQ(f->id, 2);
    EXPECT_TRUE(f->mark);
  }
  {  // two slots, full: the oldest (marked) is dropped, the next waiting one takes the mark
    Slot slot;
    slot.setCapacity(2);
    slot.setCarry(carryMark);
    slot.put(marked(1));
    slot.put(frame(2));
    EXPECT_EQ(slot.put(frame(3)), Slot::Put::kReplaced);
    const auto a = slot.take(0.0, Slot::Clock::now());
    const auto b = slot.take(0.0, Slot::Clock::now());
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->id, 2);
    EXPECT_TRUE(a->mark);
    EXPECT_EQ(b->id, 3);
    EXPECT_FALSE(b->mark);
  }
  // Three slots holding frames 1 (marked), 2 and 3.
  const auto fillThree = [&](Slot& slot) {
    slot.setCapacity(3);
    slot.setCarry(carryMark);
    slot.put(marked(1));
    slot.put(frame(2));
    slot.put(frame(3));
  };
  {  // a throttled take discards the older frames: the newest takes their mark
    Slot slot;
    fillThree(slot);
    const auto f = slot.take(1000.0, Slot::Clock::now());
    ASSERT_TRUE(f);
    EXPECT_EQ(f->id, 3);
    EXPECT_TRUE(f->mark);
  }
  {  // a smaller capacity cuts the oldest: the mark stays with what is kept
    Slot slot;
    fillThree(slot);
    slot.setCapacity(1);
    const auto f = slot.take(0.0, Slot::Clock::now());
    ASSERT_TRUE(f);
    EXPECT_EQ(f->id, 3);
    EXPECT_TRUE(f->mark);
  }
  {  // without a carry nothing is handed on
    Slot slot;
    slot.put(marked(1));
    slot.put(frame(2));
    const auto f = slot.take(0.0, Slot::Clock::now());
    ASSERT_TRUE(f);
    EXPECT_FALSE(f->mark);
  }
}

TEST(FrameSlot, StopEndsTakeAndRefusesLaterFrames) {
  Slot slot;
  std::unique_ptr<Frame> got = frame(-1);
  std::thread worker([&] { got = slot.take(0.0, Slot::Clock::now()); });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  slot.stop();
  worker.join();
  EXPECT_FALSE(got);
  EXPECT_EQ(slot.put(frame(1)), Slot::Put::kStopped);
}

TEST(FrameSlot, MaxRateDelaysTheNextTakeAndNewerFramesReplaceMeanwhile) {
  Slot slot;
  const auto last_start = Slot::Clock::now();
  slot.put(frame(1));
  std::thread late([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    slot.put(frame(2));  // arrives while the worker waits for its next start
  });
  const auto f = slot.take(5.0, last_start);  // at most 5 frames / s: not before 200 ms
  const double waited = std::chrono::duration<double>(Slot::Clock::now() - last_start).count();
  late.join();
  ASSERT_TRUE(f);
  EXPECT_EQ(f->id, 2);
  EXPECT_GE(waited, 0.19);
}

TEST(FrameSlot, WorkProcessesFramesAndSurvivesExceptions) {
  Slot slot;
  std::vector<int> processed;
  std::vector<std::string> errors;
  std::atomic<int> done{0};
  std::thread worker([&] {
    slot.work(
        [&](const Frame& f) {
          if (f.id == 2) throw std::runtime_error("bad frame");
          processed.push_back(f.id);
          ++done;
        },
        [] { return 0.0; },
        [&](const std::string& what) {
          errors.push_back(what);
          ++done;
        });
  });
  for (int id = 1; id <= 3; ++id) {
    slot.put(frame(id));
    while (done < id)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  slot.stop();
  worker.join();
  EXPECT_EQ(processed, (std::vector<int>{1, 3}));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "bad frame");
}

}  // namespace
