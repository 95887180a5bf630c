// The velocity safety gate on small hand-built safety maps whose answers are known by
// construction: a chair at the origin facing +x (footprint x -0.45..0.75, y -0.35..0.35, padding
// 0.05 m), 0.1 m cells, deceleration 1 m/s^2, reaction time 0.3 s, margin 0.2 m (the defaults).
#include "stereo_safety_map/core/safety_gate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>

using namespace stereo_safety_map;

namespace {

constexpr double kRes = 0.1;
constexpr double kFront = 0.75;  // footprint front [m]
constexpr double kHalfWidth = 0.35;

int cellOf(double x) {
  return static_cast<int>(std::lround(x / kRes));
}

/// Level map over [x0, x1] x [y0, y1] (cell centres), one Level segment of slope 0.
SafetyMap levelMap(double x0 = -4.0, double y0 = -4.0, double x1 = 4.0, double y1 = 4.0) {
  SafetyMap m;
  m.resolution = kRes;
  m.min_u = cellOf(x0);
  m.min_v = cellOf(y0);
  m.width = cellOf(x1) - m.min_u + 1;
  m.height = cellOf(y1) - m.min_v + 1;
  const std::size_t n = static_cast<std::size_t>(m.width) * m.height;
  m.labels.assign(n, SafetyLabel::kLevel);
  m.segment.assign(n, 0);
  m.drop_off.assign(n, 0);
  SegmentInfo s;
  s.id = 0;
  s.label = SafetyLabel::kLevel;
  s.plane.valid = true;
  s.plane.slope_deg = 0.0;
  m.segments.push_back(s);
  return m;
}

int addSegment(SafetyMap* m, SafetyLabel label, double slope_deg, bool plane_valid = true) {
  SegmentInfo s;
  s.id = static_cast<int>(m->segments.size());
  s.label = label;
  s.plane.valid = plane_valid;
  s.plane.slope_deg = slope_deg;
  m->segments.push_back(s);
  return s.id;
}

/// Cells whose centres lie in [x0, x1] x [y0, y1] get `label` (and `drop_off`, `segment`).
void setRect(SafetyMap* m, double x0, double y0, double x1, double y1, SafetyLabel label,
             bool drop_off = false, int segment = -1) {
  for (int v = cellOf(y0); v <= cellOf(y1); ++v) {
    for (int u = cellOf(x0); u <= cellOf(x1); ++u) {
      if (!m->inside(u, v)) continue;
      const int i = m->index(u, v);
      m->labels[i] = label;
      m->drop_off[i] = drop_off ? 1 : 0;
      m->segment[i] = segment;
    }
  }
}

/// Stopping distance of the footprint origin at speed v (straight): reaction + braking + margin.
double stopDistance(const SafetyGateConfig& c, double v) {
  return v * c.reaction_time + v * v / (2.0 * c.deceleration) + c.margin;
}

const Pose2D kOrigin{0.0, 0.0, 0.0};

TEST(SafetyGateConfig, DefaultsAreValidAndErrorsNameTheParameter) {
  SafetyGateConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_EQ(c.max_incline_deg, 10.0);  // theta_max of 000 Alg. 2 step 2
  c.deceleration = 0.0;
  EXPECT_NE(c.validate().find("deceleration"), std::string::npos) << c.validate();
  c = SafetyGateConfig();
  c.max_map_age = -1.0;
  EXPECT_NE(c.validate().find("max_map_age"), std::string::npos);
  c = SafetyGateConfig();
  c.footprint = {{0, 0}, {1, 0}};
  EXPECT_NE(c.validate().find("footprint"), std::string::npos);
  c.footprint = {{0, 0}, {2, 2}, {2, 0}, {0, 1}};  // a bow tie
  EXPECT_NE(c.validate().find("cross"), std::string::npos) << c.validate();
  c = SafetyGateConfig();
  c.max_incline_deg = 90.0;
  EXPECT_NE(c.validate().find("max_incline_deg"), std::string::npos);
  c = SafetyGateConfig();
  c.footprint_padding = std::nan("");
  EXPECT_NE(c.validate().find("footprint_padding"), std::string::npos);
  EXPECT_THROW(SafetyGate{c}, std::invalid_argument);
}

TEST(SafetyGateGeometry, SquareAndPolygon) {
  const std::vector<Eigen::Vector2d> sq = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  EXPECT_TRUE(squareTouchesPolygon(sq, {0.5, 0.5}, 0.01));   // inside
  EXPECT_TRUE(squareTouchesPolygon(sq, {1.04, 0.5}, 0.05));  // across an edge
  EXPECT_FALSE(squareTouchesPolygon(sq, {1.06, 0.5}, 0.05));
  EXPECT_TRUE(squareTouchesPolygon(sq, {0.5, 0.5}, 5.0));  // polygon inside the square
  EXPECT_NEAR(signedDistanceToPolygon(sq, {0.5, 0.5}), -0.5, 1e-12);
  EXPECT_NEAR(signedDistanceToPolygon(sq, {2.0, 0.5}), 1.0, 1e-12);
}

TEST(SafetyGate, OpenLevelFloorAllowsTheCommand) {
  SafetyGate gate;
  const SafetyMap map = levelMap();
  const GateDecision d = gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kAllowed) << d.text;
  EXPECT_EQ(d.reason, GateReason::kClear);
  EXPECT_DOUBLE_EQ(d.v, 1.0);
  EXPECT_DOUBLE_EQ(d.omega, 0.0);
  EXPECT_FALSE(d.hazard);
  EXPECT_NEAR(d.stop_distance, stopDistance(gate.config(), 1.0), 1e-9);  // 1.0 m
  EXPECT_GT(d.cells_checked, 0);
  EXPECT_EQ(d.footprint.size(), 4u);
  EXPECT_GE(d.stop_zone.size(), 4u);
}

// A potential drop-off edge across the path, its near side `gap` metres ahead of the footprint.
SafetyMap dropOffAhead(double gap) {
  SafetyMap map = levelMap();
  const double x = kFront + gap;  // near side of the first edge cell
  setRect(&map, x + 0.5 * kRes, -2.0, x + 0.5 * kRes, 2.0, SafetyLabel::kLevel, true, 0);
  setRect(&map, x + 1.5 * kRes, -2.0, 4.0, 2.0, SafetyLabel::kUnknown);
  return map;
}

TEST(SafetyGate, DropOffEdgeOneMetreAheadSlowsToTheRightSpeed) {
  SafetyGate gate;
  const SafetyGateConfig& c = gate.config();
  const double gap = 1.0;
  const GateDecision d = gate.evaluate(dropOffAhead(gap), kOrigin, 1.0, 0.0, 0.1);
  ASSERT_TRUE(d.hazard) << d.text;
  EXPECT_EQ(d.reason, GateReason::kDropOff) << d.text;
  EXPECT_EQ(d.state, GateState::kSlowed) << d.text;
  EXPECT_TRUE(d.cell.valid);
  EXPECT_TRUE(d.cell.drop_off);
  EXPECT_NEAR(d.cell.x, kFront + gap + 0.5 * kRes, 1e-9);
  // The free distance is the gap less the padding, less at most one sweep step (half a cell)
  // and the half-step growth of the padding.
  const double free_max = gap - c.footprint_padding;
  EXPECT_LE(d.free_distance, free_max);
  EXPECT_GE(d.free_distance,
            free_max - c.step_fraction * kRes - 0.5 * c.step_fraction * kRes - 1e-9);
  // The gated speed stops (with its margin) within the free distance, and is the largest such
  // speed on the sampled path: the exact speed for the free distance.
  EXPECT_LE(stopDistance(c, d.v), d.free_distance + 1e-9);
  EXPECT_NEAR(stopDistance(c, d.v), d.free_distance, 1e-6);
  EXPECT_GT(d.v, 0.8);
  EXPECT_LT(d.v, 1.0);
}

TEST(SafetyGate, DropOffEdgeCloseAheadStops) {
  SafetyGate gate;
  const GateDecision d = gate.evaluate(dropOffAhead(0.3), kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  EXPECT_EQ(d.reason, GateReason::kDropOff);
  EXPECT_DOUBLE_EQ(d.v, 0.0);
  // 0.1 m/s needs 0.03 + 0.005 + 0.2 m: it fits before an edge 0.4 m ahead, but not before
  // one 0.3 m ahead (less the padding and the sweep's steps).
  EXPECT_EQ(gate.evaluate(dropOffAhead(0.3), kOrigin, 0.1, 0.0, 0.1).state, GateState::kStopped);
  const GateDecision slow = gate.evaluate(dropOffAhead(0.4), kOrigin, 0.1, 0.0, 0.1);
  EXPECT_EQ(slow.state, GateState::kAllowed) << slow.text;
}

TEST(SafetyGate, SlowDownOffOnlyStops) {
  SafetyGateConfig c;
  c.slow_down = false;
  SafetyGate gate(c);
  const GateDecision d = gate.evaluate(dropOffAhead(1.0), kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  EXPECT_EQ(d.reason, GateReason::kDropOff);
}

TEST(SafetyGate, SlowerThanACreepIsAStop) {
  SafetyGateConfig c;
  c.min_speed = 0.5;
  SafetyGate gate(c);
  // The drop-off 0.45 m ahead leaves room for about 0.3 m/s, below min_speed.
  const GateDecision d = gate.evaluate(dropOffAhead(0.45), kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  SafetyGate defaults;
  EXPECT_EQ(defaults.evaluate(dropOffAhead(0.45), kOrigin, 1.0, 0.0, 0.1).state,
            GateState::kSlowed);
}

TEST(SafetyGate, NonGroundBesideThePathIsAllowed) {
  SafetyGate gate;
  SafetyMap map = levelMap();
  // A wall whose cells start 0.1 m beside the footprint (outside it and its padding).
  setRect(&map, -2.0, kHalfWidth + 0.15, 3.0, kHalfWidth + 0.5, SafetyLabel::kNonGround);
  const GateDecision d = gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kAllowed) << d.text;
  // Turning into it is not.
  const GateDecision turn = gate.evaluate(map, kOrigin, 0.5, 1.0, 0.1);
  EXPECT_NE(turn.state, GateState::kAllowed) << turn.text;
  EXPECT_EQ(turn.reason, GateReason::kNonGround);
}

TEST(SafetyGate, HazardInThePaddingWhereItStandsMayBeLeftNotApproached) {
  SafetyGate gate;
  SafetyMap map = levelMap();
  // A pole cell whose near side is 0.05 m ahead of the footprint: inside its padding already.
  setRect(&map, kFront + 0.1, 0.0, kFront + 0.1, 0.0, SafetyLabel::kNonGround);
  GateDecision d = gate.evaluate(map, kOrigin, 0.3, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  EXPECT_EQ(d.reason, GateReason::kNonGround);
  EXPECT_EQ(d.cell.u, cellOf(kFront + 0.1));
  // Backing away is allowed (the cells behind are remembered Level here).
  d = gate.evaluate(map, kOrigin, -0.2, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kAllowed) << d.text;
  // Rotating in place swings the front edge closer to it: refused.
  EXPECT_EQ(gate.evaluate(map, kOrigin, 0.0, 0.5, 0.1).state, GateState::kStopped);
  // A wall 0.05 m beside the chair: new wall cells would enter the padding, forwards and back.
  map = levelMap();
  setRect(&map, -2.0, kHalfWidth + 0.05, 3.0, kHalfWidth + 0.5, SafetyLabel::kNonGround);
  EXPECT_EQ(gate.evaluate(map, kOrigin, 0.5, 0.0, 0.1).state, GateState::kStopped);
  EXPECT_EQ(gate.evaluate(map, kOrigin, -0.2, 0.0, 0.1).state, GateState::kStopped);
}

TEST(SafetyGate, PoleInTheSweepOfATurn) {
  SafetyGate gate;
  SafetyMap map = levelMap();
  setRect(&map, 1.0, 0.8, 1.0, 0.8, SafetyLabel::kNonGround);  // one cell, a thin pole
  // Straight on it is beside the path.
  EXPECT_EQ(gate.evaluate(map, kOrigin, 0.5, 0.0, 0.1).state, GateState::kAllowed);
  // On a left arc of radius 1 m the front-left corner sweeps over it.
  const GateDecision d = gate.evaluate(map, kOrigin, 0.5, 0.5, 0.1);
  EXPECT_NE(d.state, GateState::kAllowed) << d.text;
  EXPECT_EQ(d.reason, GateReason::kNonGround);
  EXPECT_EQ(d.cell.u, 10);
  EXPECT_EQ(d.cell.v, 8);
  // Slowing keeps the curvature.
  if (d.state == GateState::kSlowed) {
    EXPECT_NEAR(d.omega / d.v, 1.0, 1e-12);
  }
  // A right arc sweeps away from it.
  EXPECT_EQ(gate.evaluate(map, kOrigin, 0.5, -0.5, 0.1).state, GateState::kAllowed);
}

TEST(SafetyGate, RotationInPlaceWhereTheSweptFootprintIsSafe) {
  SafetyGate gate;
  SafetyMap map = levelMap();
  GateDecision d = gate.evaluate(map, kOrigin, 0.0, 1.0, 0.1);
  EXPECT_EQ(d.state, GateState::kAllowed) << d.text;
  EXPECT_GT(d.stop_angle, 0.0);
  // The braking turn: |w| t_r + w^2 / (2 alpha) + margin angle.
  const SafetyGateConfig& c = gate.config();
  EXPECT_NEAR(d.stop_angle,
              1.0 * c.reaction_time + 1.0 / (2.0 * c.angular_deceleration) +
                  c.margin_angle_deg * M_PI / 180.0,
              1e-9);
  // A pole where the front-left corner (radius 0.83 m) swings to at +40 deg.
  const double a = std::atan2(kHalfWidth, kFront) + 40.0 * M_PI / 180.0;
  const double r = std::hypot(kFront, kHalfWidth);
  setRect(&map, r * std::cos(a), r * std::sin(a), r * std::cos(a), r * std::sin(a),
          SafetyLabel::kNonGround);
  d = gate.evaluate(map, kOrigin, 0.0, 1.0, 0.1);
  EXPECT_NE(d.state, GateState::kAllowed) << d.text;
  EXPECT_EQ(d.reason, GateReason::kNonGround);
  EXPECT_GT(d.free_angle, 0.0);
  EXPECT_LT(d.free_angle, 40.0 * M_PI / 180.0);
  // Turning the other way is clear.
  EXPECT_EQ(gate.evaluate(map, kOrigin, 0.0, -1.0, 0.1).state, GateState::kAllowed);
  // A speed below any physical meaning (the smallest denormal, CI's fuzz_safety_gate crash) is a
  // rotation in place: both parts get the one scale, and the speed may round to zero.
  const double tiny = std::numeric_limits<double>::denorm_min();
  const GateDecision dt = gate.evaluate(map, kOrigin, tiny, 1.0, 0.1);
  ASSERT_EQ(d.state, GateState::kSlowed) << d.text;
  EXPECT_EQ(dt.state, GateState::kSlowed) << dt.text;
  EXPECT_GT(dt.scale, 0.0);
  EXPECT_LT(dt.scale, 1.0);
  EXPECT_EQ(dt.v, dt.scale * tiny);
  EXPECT_EQ(dt.omega, dt.scale * 1.0);
  EXPECT_NEAR(dt.omega, d.omega, 1e-9);
  EXPECT_NE(dt.text.find("deg of turn"), std::string::npos) << dt.text;  // not "0.00 m"
  // Rotation in place over unseen cells (the sides of a chair that just started) stops.
  SafetyMap unseen = levelMap();
  setRect(&unseen, -4.0, -4.0, 4.0, -kHalfWidth - 0.15, SafetyLabel::kUnknown);
  d = gate.evaluate(unseen, kOrigin, 0.0, 1.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  EXPECT_EQ(d.reason, GateReason::kUnknown);
}

TEST(SafetyGate, InclinedSteeperThanTheLimitStopsGentlerIsAllowed) {
  SafetyGate gate;
  for (const double slope : {12.0, 6.0}) {
    SafetyMap map = levelMap();
    const int s = addSegment(&map, SafetyLabel::kInclined, slope);
    setRect(&map, kFront + 0.35, -2.0, 4.0, 2.0, SafetyLabel::kInclined, false, s);
    const GateDecision d = gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1);
    if (slope > 10.0) {
      EXPECT_EQ(d.state, GateState::kStopped) << d.text;
      EXPECT_EQ(d.reason, GateReason::kTooSteep);
      EXPECT_NEAR(d.cell.slope_deg, 12.0, 1e-9);
    } else {
      EXPECT_EQ(d.state, GateState::kAllowed) << d.text;
    }
  }
  // A comfort limit below the map's theta_max.
  SafetyGateConfig c;
  c.max_incline_deg = 5.0;
  SafetyGate comfort(c);
  SafetyMap map = levelMap();
  const int s = addSegment(&map, SafetyLabel::kInclined, 6.0);
  setRect(&map, kFront + 0.35, -2.0, 4.0, 2.0, SafetyLabel::kInclined, false, s);
  EXPECT_EQ(comfort.evaluate(map, kOrigin, 1.0, 0.0, 0.1).reason, GateReason::kTooSteep);
  // Inclined without a plane: the slope is unknown.
  const int bad = addSegment(&map, SafetyLabel::kInclined, 0.0, false);
  setRect(&map, kFront + 0.35, -2.0, 4.0, 2.0, SafetyLabel::kInclined, false, bad);
  EXPECT_EQ(gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1).reason, GateReason::kUnknown);
}

TEST(SafetyGate, TheFootOfASteepRampBeforeItsFirstSteepCellIsAHazard) {
  // A 14 deg ramp up along +x whose first cells the map calls Non-ground 0.9 m ahead of the
  // footprint: its foot (where it has not yet risen a voxel layer) is Level in the map.
  auto rampMap = [](double slope_deg, SafetyLabel label) {
    SafetyMap map = levelMap();
    const int s = addSegment(&map, label, slope_deg);
    map.segments[s].plane.a = std::tan(slope_deg * M_PI / 180.0);
    setRect(&map, kFront + 0.95, -2.0, 4.0, 2.0, label, false, s);
    for (int k = 0; k < static_cast<int>(map.labels.size()); ++k) {
      if (map.segment[k] == s) map.segments[s].cells.push_back(k);
    }
    return map;
  };
  SafetyGate gate;  // ramp_foot_height 0.1 m: 0.40 m of foot at 14 deg
  GateDecision d = gate.evaluate(rampMap(14.0, SafetyLabel::kNonGround), kOrigin, 0.5, 0.0, 0.1);
  EXPECT_NE(d.state, GateState::kAllowed) << d.text;
  EXPECT_EQ(d.reason, GateReason::kTooSteep) << d.text;
  EXPECT_LT(d.cell.x, kFront + 0.9);
  EXPECT_NEAR(d.cell.slope_deg, 14.0, 1e-6);
  // Without it, 0.5 m/s fits before the first Non-ground cell.
  SafetyGateConfig off;
  off.ramp_foot_height = 0.0;
  SafetyGate plain(off);
  EXPECT_EQ(plain.evaluate(rampMap(14.0, SafetyLabel::kNonGround), kOrigin, 0.5, 0.0, 0.1).state,
            GateState::kAllowed);
  // A gentle ramp has no such foot, nor has a flat unreachable segment (a lower level), nor the
  // plane of a segment too small to judge (Unknown).
  EXPECT_EQ(gate.evaluate(rampMap(5.0, SafetyLabel::kInclined), kOrigin, 0.5, 0.0, 0.1).state,
            GateState::kAllowed);
  EXPECT_EQ(gate.evaluate(rampMap(0.5, SafetyLabel::kNonGround), kOrigin, 0.5, 0.0, 0.1).state,
            GateState::kAllowed);
  // An unreachable slope whose plane came out flatter than the ramp (Alg. 1's height bands)
  // still has a foot, as long as a ramp at the gate's limit.
  d = gate.evaluate(rampMap(7.0, SafetyLabel::kNonGround), kOrigin, 0.5, 0.0, 0.1);
  EXPECT_EQ(d.reason, GateReason::kTooSteep) << d.text;
  SafetyMap noise = rampMap(30.0, SafetyLabel::kUnknown);
  setRect(&noise, kFront + 0.95, -2.0, 4.0, 2.0, SafetyLabel::kLevel, false, 0);  // only its plane
  EXPECT_EQ(gate.evaluate(noise, kOrigin, 0.5, 0.0, 0.1).state, GateState::kAllowed);
}

TEST(SafetyGate, UnknownInsideTheStopZoneStops) {
  SafetyGate gate;
  SafetyMap map = levelMap();
  // Unseen ground across the path (a region too large to be a hole in the map).
  setRect(&map, kFront + 0.35, -1.0, kFront + 0.45, 1.0, SafetyLabel::kUnknown);
  GateDecision d = gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  EXPECT_EQ(d.reason, GateReason::kUnknown);
  // Unexamined too (even one cell), and cells outside the map window.
  map = levelMap();
  setRect(&map, kFront + 0.35, 0.0, kFront + 0.35, 0.0, SafetyLabel::kUnexamined);
  EXPECT_EQ(gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1).reason, GateReason::kUnknown);
  const SafetyMap small = levelMap(-1.0, -1.0, 0.9, 1.0);  // ends 0.2 m ahead
  d = gate.evaluate(small, kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  EXPECT_EQ(d.reason, GateReason::kUnknown);
  EXPECT_FALSE(d.cell.inside_map);
  // Beyond the stop zone it does not matter.
  map = levelMap();
  setRect(&map, 2.5, -2.0, 4.0, 2.0, SafetyLabel::kUnknown);
  EXPECT_EQ(gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1).state, GateState::kAllowed);
  // Unseen cells under the chair (the camera cannot see there) do not stop it.
  map = levelMap();
  setRect(&map, -0.4, -0.3, 0.7, 0.3, SafetyLabel::kUnknown);
  EXPECT_EQ(gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1).state, GateState::kAllowed);
}

TEST(SafetyGate, SmallHolesEnclosedBySafeGroundAreBridged) {
  SafetyGate gate;
  const double x = kFront + 0.35;
  for (const int cells : {1, 4, 5}) {
    SafetyMap map = levelMap();
    // A hole of `cells` cells in a row across the path.
    setRect(&map, x, -0.2, x, -0.2 + (cells - 1) * kRes, SafetyLabel::kUnknown);
    const GateDecision d = gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1);
    if (cells <= gate.config().max_hole_cells) {
      EXPECT_EQ(d.state, GateState::kAllowed) << cells << " cells: " << d.text;
    } else {
      EXPECT_EQ(d.state, GateState::kStopped) << cells << " cells: " << d.text;
      EXPECT_EQ(d.reason, GateReason::kUnknown);
    }
  }
  // A hole next to a drop-off edge, or to too steep ground, is not bridged.
  SafetyMap map = levelMap();
  setRect(&map, x, 0.0, x, 0.0, SafetyLabel::kUnknown);
  setRect(&map, x + kRes, 0.0, x + kRes, 0.0, SafetyLabel::kLevel, true, 0);
  GateDecision d = gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  EXPECT_EQ(d.reason, GateReason::kUnknown) << d.text;  // the hole, entered before the edge
  EXPECT_EQ(d.cell.u, cellOf(x));
  map = levelMap();
  const int steep = addSegment(&map, SafetyLabel::kInclined, 15.0);
  setRect(&map, x, 0.0, x, 0.0, SafetyLabel::kUnknown);
  setRect(&map, x + 3 * kRes, -0.1, x + 3 * kRes, 0.1, SafetyLabel::kInclined, false, steep);
  setRect(&map, x + kRes, -0.1, x + 2 * kRes, 0.1, SafetyLabel::kUnknown);  // joins it: 7 cells
  EXPECT_EQ(gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1).reason, GateReason::kUnknown);
  // Bridging off.
  SafetyGateConfig strict;
  strict.max_hole_cells = 0;
  SafetyGate strict_gate(strict);
  map = levelMap();
  setRect(&map, x, 0.0, x, 0.0, SafetyLabel::kUnknown);
  EXPECT_EQ(strict_gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1).reason, GateReason::kUnknown);
  EXPECT_EQ(gate.evaluate(map, kOrigin, 1.0, 0.0, 0.1).state, GateState::kAllowed);
}

TEST(SafetyGate, CellsSeenSafeAMomentAgoAreRemembered) {
  SafetyGate gate;  // safe_memory 2 s
  const double x = kFront + 0.35;
  SafetyMap seen = levelMap();
  // The same ground a map later: a patch too large to be a hole has turned Unknown.
  SafetyMap flicker = levelMap();
  setRect(&flicker, x, -0.2, x + 0.2, 0.2, SafetyLabel::kUnknown);
  EXPECT_EQ(gate.evaluate(flicker, kOrigin, 1.0, 0.0, 0.1).state, GateState::kStopped);
  gate.observe(seen, 10.0);
  gate.observe(flicker, 11.0);
  EXPECT_GT(gate.rememberedCells(), 0);
  GateDecision d = gate.evaluate(flicker, kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kAllowed) << d.text;
  // Not after safe_memory.
  gate.observe(flicker, 12.5);
  d = gate.evaluate(flicker, kOrigin, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  EXPECT_EQ(d.reason, GateReason::kUnknown);
  // A hazard in between erases the memory of its cells.
  SafetyMap hazard = levelMap();
  setRect(&hazard, x, -0.2, x + 0.2, 0.2, SafetyLabel::kNonGround);
  gate.observe(seen, 20.0);
  gate.observe(hazard, 20.5);
  gate.observe(flicker, 21.0);
  EXPECT_EQ(gate.evaluate(flicker, kOrigin, 1.0, 0.0, 0.1).state, GateState::kStopped);
  // Memory never turns a hazard safe.
  gate.observe(seen, 30.0);
  gate.observe(hazard, 30.5);
  EXPECT_EQ(gate.evaluate(hazard, kOrigin, 1.0, 0.0, 0.1).reason, GateReason::kNonGround);
  // Stamps going back (a bag restarted) clear it.
  gate.observe(seen, 40.0);
  gate.observe(flicker, 5.0);
  EXPECT_EQ(gate.evaluate(flicker, kOrigin, 1.0, 0.0, 0.1).state, GateState::kStopped);
  // The window scrolls with the robot: memory follows the cells, not the indices.
  SafetyMap shifted = levelMap(-3.0, -4.0, 5.0, 4.0);
  setRect(&shifted, x, -0.2, x + 0.2, 0.2, SafetyLabel::kUnknown);
  gate.observe(seen, 50.0);
  gate.observe(shifted, 50.5);
  EXPECT_EQ(gate.evaluate(shifted, kOrigin, 1.0, 0.0, 0.1).state, GateState::kAllowed);
  // Off.
  SafetyGateConfig c;
  c.safe_memory = 0.0;
  SafetyGate forgetful(c);
  forgetful.observe(seen, 10.0);
  forgetful.observe(flicker, 10.1);
  EXPECT_EQ(forgetful.evaluate(flicker, kOrigin, 1.0, 0.0, 0.1).state, GateState::kStopped);
}

TEST(SafetyGate, ReverseOnlyOverRememberedSafeCellsAndAtTheReverseLimit) {
  SafetyGate gate;
  SafetyMap map = levelMap();
  GateDecision d = gate.evaluate(map, kOrigin, -1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kSlowed) << d.text;
  EXPECT_EQ(d.reason, GateReason::kReverseLimit);
  EXPECT_NEAR(d.v, -gate.config().reverse_speed_limit, 1e-12);
  d = gate.evaluate(map, kOrigin, -0.2, 0.1, 0.1);
  EXPECT_EQ(d.state, GateState::kAllowed) << d.text;
  EXPECT_DOUBLE_EQ(d.v, -0.2);
  EXPECT_DOUBLE_EQ(d.omega, 0.1);
  // Behind the chair never seen: Unknown.
  setRect(&map, -4.0, -4.0, -0.55, 4.0, SafetyLabel::kUnknown);
  d = gate.evaluate(map, kOrigin, -0.2, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped) << d.text;
  EXPECT_EQ(d.reason, GateReason::kUnknown);
  // Reversing disabled.
  SafetyGateConfig c;
  c.reverse_speed_limit = 0.0;
  SafetyGate no_reverse(c);
  d = no_reverse.evaluate(levelMap(), kOrigin, -0.1, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kStopped);
  EXPECT_EQ(d.reason, GateReason::kReverseLimit);
}

TEST(SafetyGate, ZeroCommandIsZeroAtOnce) {
  SafetyGate gate;
  const GateDecision d = gate.evaluate(dropOffAhead(0.0), kOrigin, 0.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kAllowed);
  EXPECT_EQ(d.reason, GateReason::kZeroCommand);
  EXPECT_EQ(d.v, 0.0);
  EXPECT_EQ(d.omega, 0.0);
  EXPECT_EQ(d.cells_checked, 0);
}

TEST(SafetyGate, StaleMissingMapsAndBadInputStop) {
  SafetyGate gate;
  const SafetyMap map = levelMap();
  GateDecision d = gate.evaluate(map, kOrigin, 1.0, 0.0, 0.6);  // max_map_age 0.5 s
  EXPECT_EQ(d.state, GateState::kStopped);
  EXPECT_EQ(d.reason, GateReason::kStaleMap);
  EXPECT_NE(d.text.find("old"), std::string::npos) << d.text;
  EXPECT_EQ(gate.evaluate(map, kOrigin, 1.0, 0.0, -0.6).reason, GateReason::kStaleMap);
  EXPECT_EQ(gate.evaluate(map, kOrigin, 1.0, 0.0, std::nan("")).reason, GateReason::kStaleMap);
  // A stale map stops a zero command too (state stopped, output zero).
  d = gate.evaluate(map, kOrigin, 0.0, 0.0, 0.6);
  EXPECT_EQ(d.state, GateState::kStopped);
  EXPECT_EQ(d.v, 0.0);
  EXPECT_EQ(gate.evaluate(SafetyMap(), kOrigin, 1.0, 0.0, 0.1).reason, GateReason::kNoMap);
  EXPECT_EQ(gate.evaluate(map, kOrigin, std::nan(""), 0.0, 0.1).reason,
            GateReason::kInvalidCommand);
  EXPECT_EQ(gate.evaluate(map, kOrigin, 0.5, INFINITY, 0.1).reason, GateReason::kInvalidCommand);
  EXPECT_EQ(gate.evaluate(map, Pose2D{std::nan(""), 0.0, 0.0}, 0.5, 0.0, 0.1).reason,
            GateReason::kInvalidPose);
  d = gate.evaluate(map, kOrigin, 1.0, 0.0, 0.4);
  EXPECT_EQ(d.state, GateState::kAllowed);
}

TEST(SafetyGate, PoseAndHeadingInTheMapFrame) {
  // The same drop-off, seen from a chair elsewhere in the map facing -y.
  SafetyGate gate;
  SafetyMap map = levelMap(-6.0, -6.0, 6.0, 6.0);
  const Pose2D pose{1.0, 2.0, -M_PI / 2};
  const double y_edge = 2.0 - kFront - 1.0;  // near side of the edge cells
  setRect(&map, -1.0, y_edge - 0.5 * kRes, 3.0, y_edge - 0.5 * kRes, SafetyLabel::kLevel, true, 0);
  setRect(&map, -1.0, -6.0, 3.0, y_edge - 1.5 * kRes, SafetyLabel::kNonGround);
  const GateDecision d = gate.evaluate(map, pose, 1.0, 0.0, 0.1);
  EXPECT_EQ(d.state, GateState::kSlowed) << d.text;
  EXPECT_EQ(d.reason, GateReason::kDropOff);
  EXPECT_LE(stopDistance(gate.config(), d.v), 1.0 - gate.config().footprint_padding);
}

// Property test over random commands and maps: the gate never adds speed, never changes a sign,
// keeps the curvature, and the braking sweep of the gated command (unpadded footprint, fine
// steps) never enters a hazard cell that the footprint did not already cover.
TEST(SafetyGate, NeverAddsSpeedAndNeverEntersAHazard) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  SafetyGate gate;
  const SafetyGateConfig& c = gate.config();
  int allowed = 0, slowed = 0, stopped = 0, entered = 0;
  for (int trial = 0; trial < 400; ++trial) {
    SafetyMap map = levelMap(-3.0, -3.0, 3.0, 3.0);
    const int steep = addSegment(&map, SafetyLabel::kInclined, 15.0);
    const int gentle = addSegment(&map, SafetyLabel::kInclined, 5.0);
    const int blobs = 1 + static_cast<int>(uni(rng) * 6);
    for (int b = 0; b < blobs; ++b) {
      const double x = -2.5 + 5.0 * uni(rng), y = -2.5 + 5.0 * uni(rng);
      const double sx = 0.05 + 0.6 * uni(rng), sy = 0.05 + 0.6 * uni(rng);
      const int kind = static_cast<int>(uni(rng) * 5);
      if (kind == 0) setRect(&map, x, y, x + sx, y + sy, SafetyLabel::kNonGround);
      if (kind == 1) setRect(&map, x, y, x + sx, y + sy, SafetyLabel::kUnknown);
      if (kind == 2) setRect(&map, x, y, x + sx, y + sy, SafetyLabel::kLevel, true, 0);
      if (kind == 3) setRect(&map, x, y, x + sx, y + sy, SafetyLabel::kInclined, false, steep);
      if (kind == 4) setRect(&map, x, y, x + sx, y + sy, SafetyLabel::kInclined, false, gentle);
    }
    const double v = uni(rng) < 0.1 ? 0.0 : -0.6 + 2.1 * uni(rng);
    const double w = uni(rng) < 0.3 ? 0.0 : -1.5 + 3.0 * uni(rng);
    const Pose2D pose{-0.3 + 0.6 * uni(rng), -0.3 + 0.6 * uni(rng), -M_PI + 2 * M_PI * uni(rng)};
    const GateDecision d = gate.evaluate(map, pose, v, w, 0.1);
    ASSERT_LE(std::abs(d.v), std::abs(v) + 1e-12);
    ASSERT_LE(std::abs(d.omega), std::abs(w) + 1e-12);
    ASSERT_GE(d.v * v, 0.0);
    ASSERT_GE(d.omega * w, 0.0);
    if (v != 0.0 && d.v != 0.0) {
      ASSERT_NEAR(d.omega / d.v, w / v, 1e-9);
    }
    if (v == 0.0 && w == 0.0) {
      ASSERT_EQ(d.state, GateState::kAllowed);
    }
    if (v < 0.0) {
      ASSERT_LE(-d.v, c.reverse_speed_limit + 1e-12);
    }
    allowed += d.state == GateState::kAllowed;
    slowed += d.state == GateState::kSlowed;
    stopped += d.state == GateState::kStopped;
    if (d.v == 0.0 && d.omega == 0.0) continue;

    // Braking from the gated command: reaction + braking progress, sampled finely, unpadded.
    const double t_b =
        std::max(std::abs(d.v) / c.deceleration, std::abs(d.omega) / c.angular_deceleration);
    const double rest = c.reaction_time + 0.5 * t_b;  // progress in seconds at the gated speed
    auto poseAt = [&](double t) {
      Pose2D p = pose;
      const double dth = d.omega * t;
      if (std::abs(dth) < 1e-12) {
        p.x += d.v * t * std::cos(pose.yaw);
        p.y += d.v * t * std::sin(pose.yaw);
      } else {
        const double r = d.v / d.omega;
        p.x += r * (std::sin(pose.yaw + dth) - std::sin(pose.yaw));
        p.y -= r * (std::cos(pose.yaw + dth) - std::cos(pose.yaw));
      }
      p.yaw += dth;
      return p;
    };
    // The padding the gate used (footprint_padding plus half a sweep step).
    double r_max = 0.0;
    for (const Eigen::Vector2d& p : c.footprint)
      r_max = std::max(r_max, p.norm());
    const double ps = std::abs(v) + std::abs(w) * r_max;
    double dl = c.step_fraction * kRes / ps;
    if (w != 0.0) dl = std::min(dl, c.max_step_angle_deg * M_PI / 180.0 / std::abs(w));
    const double pad = c.footprint_padding + 0.5 * ps * dl;
    std::vector<Eigen::Vector2d> start, poly;
    gate.footprintAt(pose, &start);
    for (int i = 1; i <= 400; ++i) {
      gate.footprintAt(poseAt(rest * i / 400.0), &poly);
      Eigen::Vector2d lo = poly[0], hi = poly[0];
      for (const Eigen::Vector2d& p : poly) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
      for (int cv = cellOf(lo.y()) - 1; cv <= cellOf(hi.y()) + 1; ++cv) {
        for (int cu = cellOf(lo.x()) - 1; cu <= cellOf(hi.x()) + 1; ++cu) {
          const Eigen::Vector2d cc(cu * kRes, cv * kRes);
          if (!squareTouchesPolygon(poly, cc, 0.5 * kRes)) continue;
          auto unsafe = [&](int u, int v) {
            if (!map.inside(u, v)) return true;
            const int k = map.index(u, v);
            const SafetyLabel l = map.labels[k];
            return l == SafetyLabel::kNonGround || l == SafetyLabel::kUnknown ||
                   l == SafetyLabel::kUnexamined || map.drop_off[k] != 0 ||
                   (l == SafetyLabel::kInclined && map.segment[k] == steep);
          };
          bool hazard = unsafe(cu, cv);
          if (hazard && map.inside(cu, cv) &&
              map.labels[map.index(cu, cv)] == SafetyLabel::kUnknown) {
            // A hole of at most max_hole_cells Unknown cells (8-connected) enclosed by safe
            // ground is bridged.
            std::vector<std::pair<int, int>> hole = {{cu, cv}};
            bool open = false;
            for (std::size_t h = 0; h < hole.size() && !open; ++h) {
              for (int dv = -1; dv <= 1 && !open; ++dv) {
                for (int du = -1; du <= 1 && !open; ++du) {
                  const std::pair<int, int> n(hole[h].first + du, hole[h].second + dv);
                  if (std::find(hole.begin(), hole.end(), n) != hole.end()) continue;
                  if (!unsafe(n.first, n.second)) continue;
                  if (map.inside(n.first, n.second) &&
                      map.labels[map.index(n.first, n.second)] == SafetyLabel::kUnknown &&
                      static_cast<int>(hole.size()) < c.max_hole_cells) {
                    hole.push_back(n);
                  } else {
                    open = true;
                  }
                }
              }
            }
            hazard = open;
          }
          if (!hazard) continue;
          // Cells under the chair at the start may be driven along or away from, not into;
          // unseen ones whose centre it covers are the ground it stands on.
          const double d0 = signedDistanceToPolygon(start, cc);
          if (map.inside(cu, cv) && map.labels[map.index(cu, cv)] == SafetyLabel::kUnknown &&
              d0 <= 0.0) {
            continue;
          }
          if (squareTouchesPolygon(start, cc, 0.5 * kRes + pad) &&
              signedDistanceToPolygon(poly, cc) >= d0 - 1e-3) {
            continue;
          }
          ++entered;
          ADD_FAILURE() << "trial " << trial << ": command (" << v << ", " << w << ") gated to ("
                        << d.v << ", " << d.omega << ") enters cell (" << cu << ", " << cv
                        << ") at " << rest * i / 400.0 << " s of progress; " << d.text;
          break;
        }
        if (entered > 0) break;
      }
      if (entered > 0) break;
    }
    if (entered > 0) break;
  }
  // The random worlds exercise every outcome.
  EXPECT_GT(allowed, 20);
  EXPECT_GT(slowed, 20);
  EXPECT_GT(stopped, 20);
}

}  // namespace
