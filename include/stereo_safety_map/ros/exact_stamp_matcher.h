// Exact-stamp matching of a frame's parts: one primary message (a disparity image, after the tf
// filter) and its companions (CameraInfo), all with the same header stamp.
//
// Why not message_filters' ExactTime: it keeps `queue_size` incomplete tuples and evicts the
// oldest stamp first, and clears every older tuple when a newer one completes. So
//  - a flood of CameraInfo without a disparity (a hostile or misconfigured publisher) evicts a
//    valid frame's CameraInfo while its disparity is still waiting in the tf filter: the valid
//    frame is lost without a word (safety_map_hostile with 3000 frames lost one near frame 100);
//  - frames that waited in the tf filter during a tf stall are cleared by the first frame after
//    it: they never reach the nodelet, which cannot say "stale tf" about them.
// Here an incomplete frame is kept for `keep` seconds (the tf buffer's cache: a disparity that
// waited longer could not be placed anyway), at most `max_partial` of them (a flood cannot grow
// memory without bound); a frame whose primary arrived but whose companions do not is dropped
// with a reason once `max_waiting_primary` newer primaries wait (primaries are large images).
// Every drop of a frame that had its primary is reported: nothing is lost silently.
//
// Thread-safe: add() may be called from several callback threads; the callbacks run outside the
// lock, in the caller's thread.
#pragma once

#include <ros/time.h>

#include <boost/shared_ptr.hpp>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace stereo_safety_map {

/// [s] The cache of the nodelets' tf2 buffers, and so how long a frame may usefully wait.
constexpr double kTfCacheTime = 30.0;

template <class Primary, class... Companions>
class ExactStampMatcher {
 public:
  using Clock = std::chrono::steady_clock;
  using Messages =
      std::tuple<boost::shared_ptr<const Primary>, boost::shared_ptr<const Companions>...>;
  static constexpr std::size_t kParts = 1 + sizeof...(Companions);

  struct Limits {
    double keep = kTfCacheTime;           ///< [s] an incomplete frame is kept this long
    std::size_t max_partial = 4096;       ///< incomplete frames kept at most
    std::size_t max_waiting_primary = 5;  ///< incomplete frames holding their primary, at most

    /// The nodelets' limits: frames kept as long as a tf buffer of `tf_cache` s keeps
    /// transforms (a disparity that waited longer in the tf filter could not be placed anyway),
    /// `queue_size` disparities waiting for their CameraInfo.
    static Limits forNodelet(int queue_size, double tf_cache = kTfCacheTime) {
      Limits l;
      l.keep = tf_cache;
      l.max_waiting_primary = static_cast<std::size_t>(queue_size < 1 ? 1 : queue_size);
      return l;
    }
  };

  /// A complete frame (every part with the same stamp).
  using MatchCallback = std::function<void(const boost::shared_ptr<const Primary>&,
                                           const boost::shared_ptr<const Companions>&...)>;
  /// A frame dropped with its primary: its stamp and why.
  using DropCallback = std::function<void(const ros::Time&, const std::string&)>;

  ExactStampMatcher(const Limits& limits, MatchCallback on_match, DropCallback on_drop)
      : limits_(sane(limits)), on_match_(std::move(on_match)), on_drop_(std::move(on_drop)) {}

  /// Adds part I (0: the primary) of the frame stamped `stamp`. `now` is for tests.
  template <std::size_t I>
  void add(const ros::Time& stamp, const typename std::tuple_element<I, Messages>::type& message,
           Clock::time_point now = Clock::now()) {
    static_assert(I < kParts, "no such part");
    if (!message) return;
    Messages complete;
    bool matched = false;
    std::vector<std::pair<ros::Time, std::string>> drops;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      expire(now, &drops);
      auto it = partial_.find(stamp);
      if (it == partial_.end()) {
        it = partial_.emplace(stamp, Partial()).first;
        it->second.id = next_id_++;
        it->second.began = now;
        arrival_.emplace(it->second.id, stamp);
      }
      Partial& p = it->second;
      std::get<I>(p.parts) = message;      // a second message for the same part replaces the first
      if (I == 0 && p.primary_seq == 0) {  // ordered by the primary's arrival: never evicts p
        p.primary_seq = ++primary_seq_;
        waiting_primary_.emplace(p.primary_seq, stamp);
        trimWaitingPrimary(&drops);
      }
      if (isComplete(p.parts)) {
        complete = std::move(p.parts);
        erase(it);
        matched = true;
      } else {
        trimPartial(&drops);
      }
    }
    for (const auto& d : drops)
      if (on_drop_) on_drop_(d.first, d.second);
    if (matched) callMatch(complete, std::make_index_sequence<kParts>());
  }

  /// Feeds part I from a message_filters source (a Subscriber, PassThrough, tf2 MessageFilter):
  /// messages with a header, keyed by its stamp. Disconnect the source before destroying this.
  template <std::size_t I, class Source>
  void connectInput(Source& source) {
    using Ptr = typename std::tuple_element<I, Messages>::type;
    source.registerCallback([this](const Ptr& m) {
      if (m) add<I>(m->header.stamp, m);
    });
  }

  /// Incomplete frames kept now.
  std::size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return partial_.size();
  }

 private:
  struct Partial {
    Messages parts;
    std::uint64_t id = 0;
    std::uint64_t primary_seq = 0;  ///< 0: no primary yet
    Clock::time_point began;
  };
  using PartialMap = std::map<ros::Time, Partial>;

  static Limits sane(Limits l) {
    if (l.max_waiting_primary < 1) l.max_waiting_primary = 1;
    if (l.max_partial < 1) l.max_partial = 1;
    return l;
  }

  static bool isComplete(const Messages& parts) {
    return std::apply([](const auto&... p) { return (static_cast<bool>(p) && ...); }, parts);
  }

  template <std::size_t... Is>
  void callMatch(const Messages& m, std::index_sequence<Is...>) {
    if (on_match_) on_match_(std::get<Is>(m)...);
  }

  void erase(typename PartialMap::iterator it) {
    arrival_.erase(it->second.id);
    if (it->second.primary_seq) waiting_primary_.erase(it->second.primary_seq);
    partial_.erase(it);
  }

  // Drops the incomplete frame stamped `stamp`; reports it if it had its primary.
  void drop(const ros::Time& stamp, const std::string& why,
            std::vector<std::pair<ros::Time, std::string>>* drops) {
    const auto it = partial_.find(stamp);
    if (it == partial_.end()) return;
    if (std::get<0>(it->second.parts)) drops->emplace_back(stamp, why + missing(it->second));
    erase(it);
  }

  std::string missing(const Partial& p) const {
    std::ostringstream os;
    os << " (has " << present(p.parts, std::make_index_sequence<kParts>()) << " of " << kParts
       << " parts: no message with the same stamp arrived for the others)";
    return os.str();
  }

  template <std::size_t... Is>
  static std::size_t present(const Messages& m, std::index_sequence<Is...>) {
    return (std::size_t(0) + ... + static_cast<std::size_t>(static_cast<bool>(std::get<Is>(m))));
  }

  void expire(Clock::time_point now, std::vector<std::pair<ros::Time, std::string>>* drops) {
    const auto keep =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(limits_.keep));
    while (!arrival_.empty()) {
      const ros::Time stamp = arrival_.begin()->second;
      const auto it = partial_.find(stamp);
      if (now - it->second.began <= keep) break;
      std::ostringstream os;
      os << "incomplete for more than " << limits_.keep << " s";
      drop(stamp, os.str(), drops);
    }
  }

  void trimPartial(std::vector<std::pair<ros::Time, std::string>>* drops) {
    while (partial_.size() > limits_.max_partial) {
      std::ostringstream os;
      os << "more than " << limits_.max_partial << " incomplete frames wait (a flood?)";
      drop(arrival_.begin()->second, os.str(), drops);
    }
  }

  void trimWaitingPrimary(std::vector<std::pair<ros::Time, std::string>>* drops) {
    while (waiting_primary_.size() > limits_.max_waiting_primary) {
      std::ostringstream os;
      os << limits_.max_waiting_primary << " newer frames arrived while it waited";
      drop(waiting_primary_.begin()->second, os.str(), drops);
    }
  }

  const Limits limits_;
  const MatchCallback on_match_;
  const DropCallback on_drop_;
  mutable std::mutex mutex_;
  PartialMap partial_;                                  ///< incomplete frames by stamp
  std::map<std::uint64_t, ros::Time> arrival_;          ///< the same, oldest first
  std::map<std::uint64_t, ros::Time> waiting_primary_;  ///< holding their primary, by its arrival
  std::uint64_t next_id_ = 0;
  std::uint64_t primary_seq_ = 0;
};

/// The nodelets' message for a disparity frame the matcher dropped (its DropCallback).
inline std::string unmatchedDisparityMessage(const ros::Time& stamp, const std::string& why) {
  std::ostringstream os;
  os << "dropped a disparity frame at t = " << stamp << ": " << why
     << ". Is the CameraInfo published with the disparity's stamp? (if not: approximate_sync)";
  return os.str();
}

}  // namespace stereo_safety_map
