// ObservationAge: when each column was last observed, in a ring that scrolls with the window,
// and the aging policy on hand-built safety maps whose answer is known by construction.
#include "stereo_safety_map/core/observation_age.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace stereo_safety_map {
namespace {

using L = SafetyLabel;

// A 4 x 3 map at (min_u, min_v) = (-2, 5): one cell of each label, two drop-off edges.
SafetyMap smallMap() {
  SafetyMap m;
  m.min_u = -2;
  m.min_v = 5;
  m.width = 4;
  m.height = 3;
  m.labels = {L::kLevel,      L::kInclined, L::kNonGround, L::kUnknown,     //  v = 5
              L::kUnexamined, L::kLevel,    L::kInclined,  L::kNonGround,   //  v = 6
              L::kLevel,      L::kLevel,    L::kUnknown,   L::kNonGround};  //  v = 7
  m.drop_off.assign(12, 0);
  m.drop_off[m.index(-1, 6)] = 1;  // Level, drop-off edge
  m.drop_off[m.index(-2, 7)] = 1;
  m.segment.assign(12, -1);
  m.column_height.assign(12, SafetyMap::kNoHeight);
  return m;
}

TEST(ObservationAge, NeverObservedUntilObserved) {
  ObservationAge a;
  EXPECT_EQ(a.lastObserved(0, 0), ObservationAge::kNever);  // empty ring
  a.observe(0, 0, 1.0);                                     // ignored: no ring
  EXPECT_EQ(a.lastObserved(0, 0), ObservationAge::kNever);
  a.resize(4, 3);
  EXPECT_EQ(a.sizeU(), 4);
  EXPECT_EQ(a.sizeV(), 3);
  EXPECT_EQ(a.lastObserved(1, 1), ObservationAge::kNever);
  a.observe(1, 1, 5.0);
  EXPECT_EQ(a.lastObserved(1, 1), 5.0);
  EXPECT_EQ(a.lastObserved(1, 2), ObservationAge::kNever);
}

TEST(ObservationAge, OlderAndNonFiniteTimesDoNotMakeAColumnOlder) {
  ObservationAge a;
  a.resize(4, 3);
  a.observe(-7, 11, 5.0);
  a.observe(-7, 11, 3.0);
  EXPECT_EQ(a.lastObserved(-7, 11), 5.0);
  a.observe(-7, 11, std::numeric_limits<double>::quiet_NaN());
  a.observe(-7, 11, std::numeric_limits<double>::infinity());
  EXPECT_EQ(a.lastObserved(-7, 11), 5.0);
  a.observe(-7, 11, 6.5);
  EXPECT_EQ(a.lastObserved(-7, 11), 6.5);
}

TEST(ObservationAge, AColumnThatScrolledOutReadsAsNeverObserved) {
  // (u, v) and (u + 4, v - 3) share a slot of a 4 x 3 ring: they are never in the window at once.
  ObservationAge a;
  a.resize(4, 3);
  a.observe(-1, 2, 10.0);
  a.observe(3, -1, 1.0);  // a column that entered the window later, even with an older stamp
  EXPECT_EQ(a.lastObserved(3, -1), 1.0);
  EXPECT_EQ(a.lastObserved(-1, 2), ObservationAge::kNever);
  // Negative indices land in their own slots.
  a.observe(-4, -3, 2.0);
  a.observe(0, 0, 3.0);
  EXPECT_EQ(a.lastObserved(0, 0), 3.0);
  EXPECT_EQ(a.lastObserved(-4, -3), ObservationAge::kNever);
  a.clear();
  EXPECT_EQ(a.lastObserved(0, 0), ObservationAge::kNever);
  EXPECT_EQ(a.sizeU(), 4);
}

TEST(ObservationAge, StaleSafeCellsBecomeUnknownAndNothingElseChanges) {
  ObservationAge a;
  a.resize(8, 8);
  SafetyMap m = smallMap();
  // Every cell observed at t = 0, the middle row again at t = 8.
  for (int v = 5; v <= 7; ++v)
    for (int u = -2; u <= 1; ++u)
      a.observe(u, v, 0.0);
  for (int u = -2; u <= 1; ++u)
    a.observe(u, 6, 8.0);

  EXPECT_EQ(a.apply(5.0, 5.0, &m), 0u);  // observed exactly max_age ago: still vouched for
  EXPECT_EQ(m.labels, smallMap().labels);

  const SafetyMap before = m;
  EXPECT_EQ(a.apply(10.0, 5.0, &m), 4u);
  // Rows 5 and 7: safe -> Unknown, the rest as it was.
  EXPECT_EQ(m.labelAt(-2, 5), L::kUnknown);
  EXPECT_EQ(m.labelAt(-1, 5), L::kUnknown);
  EXPECT_EQ(m.labelAt(0, 5), L::kNonGround);
  EXPECT_EQ(m.labelAt(1, 5), L::kUnknown);
  EXPECT_EQ(m.labelAt(-2, 7), L::kUnknown);
  EXPECT_EQ(m.drop_off[m.index(-2, 7)], 0);  // an edge of a safe cell only
  EXPECT_EQ(m.labelAt(-1, 7), L::kUnknown);
  EXPECT_EQ(m.labelAt(0, 7), L::kUnknown);
  EXPECT_EQ(m.labelAt(1, 7), L::kNonGround);
  // Row 6 was re-observed at t = 8: unchanged, drop-off edge kept.
  for (int u = -2; u <= 1; ++u)
    EXPECT_EQ(m.labelAt(u, 6), before.labelAt(u, 6)) << u;
  EXPECT_EQ(m.drop_off[m.index(-1, 6)], 1);
  EXPECT_EQ(m.segment, before.segment);
  EXPECT_EQ(m.column_height, before.column_height);

  // Later still, everything safe is gone; Non-ground, Unknown, Unexamined are untouched.
  EXPECT_EQ(a.apply(100.0, 5.0, &m), 2u);
  for (std::size_t k = 0; k < m.labels.size(); ++k) {
    EXPECT_FALSE(isSafe(m.labels[k])) << k;
    if (!isSafe(before.labels[k])) {
      EXPECT_EQ(m.labels[k], before.labels[k]) << k;
    }
  }
  EXPECT_EQ(a.apply(1000.0, 5.0, &m), 0u);
}

TEST(ObservationAge, NeverObservedSafeCellsAreStaleAtOnce) {
  ObservationAge a;
  a.resize(8, 8);
  SafetyMap m = smallMap();
  EXPECT_EQ(a.apply(0.0, 1.0, &m), 6u);  // every safe cell of the map
}

TEST(ObservationAge, OffOrUnreadableDoesNothing) {
  ObservationAge a;
  a.resize(8, 8);
  SafetyMap m = smallMap();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(a.apply(100.0, 0.0, &m), 0u);
  EXPECT_EQ(a.apply(100.0, -1.0, &m), 0u);
  EXPECT_EQ(a.apply(100.0, nan, &m), 0u);
  EXPECT_EQ(a.apply(100.0, inf, &m), 0u);
  EXPECT_EQ(a.apply(nan, 1.0, &m), 0u);
  EXPECT_EQ(a.apply(inf, 1.0, &m), 0u);
  EXPECT_EQ(m.labels, smallMap().labels);
  m.labels.resize(5);  // inconsistent map: left alone
  EXPECT_EQ(a.apply(100.0, 1.0, &m), 0u);
  SafetyMap empty;
  EXPECT_EQ(a.apply(100.0, 1.0, &empty), 0u);
}

}  // namespace
}  // namespace stereo_safety_map
