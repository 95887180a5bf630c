#include "stereo_safety_map/core/observation_age.h"

#include <algorithm>
#include <cmath>

namespace stereo_safety_map {

namespace {

int positiveModulo(int a, int n) {
  const int r = a % n;
  return r < 0 ? r + n : r;
}

}  // namespace

void ObservationAge::resize(int size_u, int size_v) {
  size_u_ = std::max(0, size_u);
  size_v_ = std::max(0, size_v);
  entries_.assign(static_cast<std::size_t>(size_u_) * size_v_, Entry());
}

void ObservationAge::clear() {
  std::fill(entries_.begin(), entries_.end(), Entry());
}

std::size_t ObservationAge::slot(int u, int v) const {
  return static_cast<std::size_t>(positiveModulo(v, size_v_)) * size_u_ +
         static_cast<std::size_t>(positiveModulo(u, size_u_));
}

void ObservationAge::observe(int u, int v, double t) {
  if (entries_.empty() || !std::isfinite(t)) return;
  // A slot holding another column holds one that has left the window (one column per slot
  // inside it): this column takes the slot over.
  Entry& e = entries_[slot(u, v)];
  if (e.u == u && e.v == v && e.t >= t) return;
  e.u = u;
  e.v = v;
  e.t = t;
}

double ObservationAge::lastObserved(int u, int v) const {
  if (entries_.empty()) return kNever;
  const Entry& e = entries_[slot(u, v)];
  return (e.u == u && e.v == v) ? e.t : kNever;
}

std::size_t ObservationAge::apply(double now, double max_age, SafetyMap* map) const {
  if (!(max_age > 0.0) || !std::isfinite(max_age) || !std::isfinite(now)) return 0;
  const std::size_t cells = static_cast<std::size_t>(std::max(map->width, 0)) *
                            static_cast<std::size_t>(std::max(map->height, 0));
  if (map->labels.size() < cells) return 0;  // not a map this policy can read
  const double oldest = now - max_age;
  std::size_t changed = 0;
  for (int v = map->min_v; v < map->min_v + map->height; ++v) {
    for (int u = map->min_u; u < map->min_u + map->width; ++u) {
      const int k = map->index(u, v);
      if (!isSafe(map->labels[k])) continue;
      // Strictly older than the limit: a cell observed exactly max_age ago is still vouched for.
      if (lastObserved(u, v) >= oldest) continue;
      map->labels[k] = SafetyLabel::kUnknown;
      if (static_cast<std::size_t>(k) < map->drop_off.size()) map->drop_off[k] = 0;
      ++changed;
    }
  }
  return changed;
}

}  // namespace stereo_safety_map
