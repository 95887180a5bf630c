// The one-slot frame queue between a nodelet's message callbacks and its worker thread.
//
// Callbacks put() a frame and never wait for the pipeline; the worker take()s it. A frame that
// arrives while another waits replaces it (put() says so, the nodelet counts it as dropped): the
// newest frame wins and the latency stays one frame. max_rate throttles by letting the slot be
// overwritten while the worker waits for its next start. stop() wakes the worker for good.
//
// Thread-safe. putIf()'s `accept` runs under the slot's lock, so that state deciding the order
// of frames (e.g. the newest stamp) changes with the slot, atomically.
#pragma once

#include <chrono>
#include <condition_variable>
#include <exception>
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

  /// Puts `frame` into the slot, replacing a waiting one: kQueued, kReplaced or kStopped.
  Put put(std::unique_ptr<Frame> frame) {
    return putIf(std::move(frame), [](Frame&, const Frame*) { return true; });
  }

  /// As put(), if accept(frame, waiting frame or nullptr) says yes (else kRefused). `accept`
  /// runs under the slot's lock and may change the incoming frame.
  template <class Accept>
  Put putIf(std::unique_ptr<Frame> frame, Accept&& accept) {
    Put result;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stop_) return Put::kStopped;
      if (!accept(*frame, slot_.get())) return Put::kRefused;
      result = slot_ ? Put::kReplaced : Put::kQueued;
      slot_ = std::move(frame);
    }
    cv_.notify_one();
    return result;
  }

  /// Waits for a frame; with max_rate > 0 not before 1 / max_rate s after `last_start` (frames
  /// arriving meanwhile replace the waiting one). nullptr once stop() was called.
  std::unique_ptr<Frame> take(double max_rate, Clock::time_point last_start) {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return stop_ || slot_; });
    if (stop_) return nullptr;
    if (max_rate > 0.0) {
      const auto next = last_start + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(1.0 / max_rate));
      cv_.wait_until(lock, next, [this] { return stop_; });
      if (stop_) return nullptr;
    }
    return std::move(slot_);
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
  std::mutex mutex_;
  std::condition_variable cv_;
  std::unique_ptr<Frame> slot_;
  bool stop_ = false;
};

}  // namespace stereo_safety_map
