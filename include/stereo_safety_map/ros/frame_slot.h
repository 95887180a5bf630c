// The frame queue between a nodelet's message callbacks and its worker thread.
//
// Callbacks put() a frame and never wait for the pipeline; the worker take()s it. The queue holds
// capacity() frames (1 by default, setCapacity()). A frame that arrives while the queue is full
// replaces the oldest waiting one (put() says so, the nodelet counts it as dropped): with one
// slot the newest frame wins and the latency stays one frame; with two, one frame whose
// processing took longer than the camera period (the other nodelets of the manager had the
// cores) is absorbed instead of dropped, at one frame of latency then. The worker takes the
// oldest waiting frame. max_rate throttles: while the worker waits for its next start, frames
// replace the waiting ones and take() returns the newest, dropping the older (counted by
// take()'s `discarded`). stop() wakes the worker for good. setCarry() names what a dropped frame
// hands on to the frame after it (the safety map's "reset the map first" mark), so that dropping
// a frame never drops a decision that frame carried.
//
// Thread-safe. putIf()'s `accept` runs under the queue's lock, so that state deciding the order
// of frames (e.g. the newest stamp) changes with the queue, atomically.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

namespace stereo_safety_map {

template <class Frame>
class FrameSlot {
 public:
  using Clock = std::chrono::steady_clock;
  enum class Put { kQueued, kReplaced, kRefused, kStopped };

  /// How many frames may wait, >= 1 (smaller values are taken as 1). Frames waiting beyond a
  /// smaller capacity are dropped, the oldest first.
  void setCapacity(std::size_t capacity) {
    std::lock_guard<std::mutex> lock(mutex_);
    capacity_ = capacity < 1 ? 1 : capacity;
    while (queue_.size() > capacity_)
      dropFront(nullptr);
  }
  std::size_t capacity() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return capacity_;
  }

  /// carry(dropped, successor) runs, under the queue's lock, for every frame the queue drops
  /// (full on put(), discarded by a throttled take(), cut by setCapacity()), with the frame that
  /// now comes after it: the next waiting one, or the incoming one of put(). Empty = nothing.
  void setCarry(std::function<void(const Frame& dropped, Frame& successor)> carry) {
    std::lock_guard<std::mutex> lock(mutex_);
    carry_ = std::move(carry);
  }

  /// Puts `frame` into the queue: kQueued, kReplaced (the queue was full: the oldest waiting frame
  /// was dropped) or kStopped.
  Put put(std::unique_ptr<Frame> frame) {
    return putIf(std::move(frame), [](Frame&, const Frame*) { return true; });
  }

  /// As put(), if accept(frame, newest waiting frame or nullptr) says yes (else kRefused).
  /// `accept` runs under the queue's lock and may change the incoming frame.
  template <class Accept>
  Put putIf(std::unique_ptr<Frame> frame, Accept&& accept) {
    Put result;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stop_) return Put::kStopped;
      if (!accept(*frame, queue_.empty() ? nullptr : queue_.back().get())) return Put::kRefused;
      result = Put::kQueued;
      if (queue_.size() >= capacity_) {
        dropFront(frame.get());
        result = Put::kReplaced;
      }
      queue_.push_back(std::move(frame));
    }
    cv_.notify_one();
    return result;
  }

  /// Waits for a frame and returns the oldest waiting one; with max_rate > 0 not before
  /// 1 / max_rate s after `last_start`, and then the newest, the older ones dropped (their number
  /// added to *discarded when given). nullptr once stop() was called.
  std::unique_ptr<Frame> take(double max_rate, Clock::time_point last_start,
                              std::size_t* discarded = nullptr) {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
    if (stop_) return nullptr;
    if (max_rate > 0.0) {
      const auto next = last_start + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(1.0 / max_rate));
      cv_.wait_until(lock, next, [this] { return stop_; });
      if (stop_) return nullptr;
      while (queue_.size() > 1) {
        dropFront(nullptr);
        if (discarded != nullptr) ++*discarded;
      }
    }
    std::unique_ptr<Frame> frame = std::move(queue_.front());
    queue_.pop_front();
    return frame;
  }

  /// The worker's loop, until stop(): take() at max_rate() frames per second at most (0: no
  /// limit), process(frame); an exception from process goes to on_error(what), and on.
  template <class Process, class MaxRate, class OnError>
  void work(Process&& process, MaxRate&& max_rate, OnError&& on_error) {
    Clock::time_point last_start;
    while (std::unique_ptr<Frame> frame = take(max_rate(), last_start)) {
      last_start = Clock::now();
      try {
        process(*frame);
      } catch (const std::exception& e) {
        on_error(std::string(e.what()));
      }
    }
  }

  /// Ends take() and work() for good; later frames are refused (kStopped).
  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
  }

 private:
  // Drops the oldest waiting frame, handing what it carries to the next waiting one (or to
  // `incoming` when none waits). Under the lock.
  void dropFront(Frame* incoming) {
    std::unique_ptr<Frame> dropped = std::move(queue_.front());
    queue_.pop_front();
    Frame* successor = queue_.empty() ? incoming : queue_.front().get();
    if (carry_ && successor != nullptr) carry_(*dropped, *successor);
  }

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::unique_ptr<Frame>> queue_;
  std::size_t capacity_ = 1;
  std::function<void(const Frame&, Frame&)> carry_;
  bool stop_ = false;
};

}  // namespace stereo_safety_map
