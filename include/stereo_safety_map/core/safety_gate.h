// Velocity safety gate on the local safety map of paper 000, ROS-free.
//
// A power wheelchair is driven by its user's joystick far more than by a planner. Paper 000's map
// (Sec. I: "the robot must ... critically, detect catastrophic hazards like drop-offs") is there
// so that the chair does not roll off a curb, into a stairwell or onto a ramp that tips it. The
// gate sits between the joystick (or teleop, or move_base) and the base: for each commanded
// twist (v, omega) it predicts where the chair's footprint goes while it reacts and brakes, and
// stops or slows the command so that the footprint never enters
//  - a Non-ground cell (obstacle, overhang, too steep, unreachable: 000 Alg. 2),
//  - a potential drop-off edge (000 Sec. VI: "should be treated as requiring further
//    observation"),
//  - an Inclined cell steeper than max_incline_deg (or whose slope is not known), or the foot of
//    a too steep segment that the map cannot tell from the floor yet (ramp_foot_height),
//  - an Unknown or Unexamined cell, or a cell outside the map window: the map cannot vouch for it
//    (except small holes enclosed by safe ground, see max_hole_cells, and cells seen safe in the
//    last seconds, see safe_memory).
//
// The zone the gate must know (the stop zone) is the footprint, grown by footprint_padding, swept
// along the commanded arc (constant curvature: v and omega braked together) over the distance the
// chair needs to stop at the configured deceleration, plus its reaction time and a margin:
//   progress lambda [s at the commanded speed]: the pose after lambda is exp(lambda (v, omega)),
//   stopping progress at speed scale k:  k t_r + k^2 T_b / 2 + lambda_m,
//   T_b = max(|v| / a, |omega| / alpha)  (braking time at full command),
//   lambda_m = min(margin / |v|, margin_angle / |omega|)  (a margin of travel or of turn).
// Its cells are found conservatively: the footprint is placed every half cell of travel of its
// farthest point (and every max_step_angle_deg of turn) and every cell the padded polygon touches
// is taken, with the padding grown by half a step so that the sampled sweep covers the continuous
// one. Every cell the footprint enters must be known safe; this covers rotation in place (the
// swept footprint over the braking turn plus margin_angle) and reversing (the camera does not see
// behind: only cells the map remembers as Level / Inclined), alike.
//
// Slowing: the largest speed scale k <= 1 whose stopping progress still ends before the first
// hazard along the path; omega is scaled with v, so the path keeps its curvature. Below
// min_speed and min_angular_speed it stops. The gate never adds speed, never changes a sign, and
// a zero command is zero at once.
//
// Cells the padded footprint already covers where the chair stands are not entered by the
// motion: an unseen cell (Unknown) whose centre lies under the footprint is ground the chair
// stands on (the camera cannot see there) and is ignored; any other hazard among them stops the
// chair only when the motion brings the footprint closer to it (signed distance of the cell
// centre to the footprint decreasing), so a chair whose padding touches a drop-off edge or an
// obstacle may back or turn away from it, never towards it. A chair closer to hazards than its
// padding on several sides may find every motion refused: it stops, it is not pushed.
//
// What it does not do: it knows only what the map knows (static scenes, 000's model), it trusts
// tf for the pose, and it cannot see ground the camera has not seen: a chair at rest in front of
// ground its camera cannot see (below the lower image edge), or after max_cell_age, does not
// move forward until it has seen it.
#pragma once

#include "stereo_safety_map/core/safety_map.h"

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace stereo_safety_map {

struct SafetyGateConfig {
  /// Footprint polygon in the footprint frame (x forward, y left, REP 103) [m], 3 to 64
  /// vertices, simple (any orientation, need not be convex). Default: a mid-wheel-drive power
  /// wheelchair 0.7 m wide and 1.2 m long whose footrests reach 0.75 m ahead of the drive axle.
  std::vector<Eigen::Vector2d> footprint = {
      {0.75, 0.35}, {-0.45, 0.35}, {-0.45, -0.35}, {0.75, -0.35}};
  /// Grown on every side of the footprint [m], [0, 1]: localisation and map errors.
  double footprint_padding = 0.05;
  /// Linear braking deceleration the base achieves [m/s^2], (0, 20].
  double deceleration = 1.0;
  /// Angular braking deceleration [rad/s^2], (0, 50].
  double angular_deceleration = 2.0;
  /// Time from the command to the base braking [s], [0, 5]: the command period, the base's
  /// controller and the user's joystick filter.
  double reaction_time = 0.3;
  /// Further travel past the predicted stop that must still be safe [m], [0, 5].
  double margin = 0.2;
  /// Further turn past the predicted stop that must still be safe [deg], [0, 180]; for arcs the
  /// margin ends at whichever of `margin` and this comes first.
  double margin_angle_deg = 10.0;
  /// Holes in the map: an Unknown region of at most this many cells (4-connected) whose every
  /// neighbour is a safe cell the gate accepts (not a drop-off edge, not too steep) is taken as
  /// the ground around it, [0, 100]; 0 = every Unknown cell stops. Stereo finds no match on some
  /// patches of ground (weak texture, the uniqueness test), and 000's map leaves such columns
  /// Unknown; 4 cells (0.04 m^2) stay below 000's n_small = 6 (Alg. 2 step 3), the size below
  /// which the map itself calls a segment noise. A real hole shows lower ground or marks its rim
  /// as potential drop-off edges (000 Sec. VI), and a rim of drop-off edges is never bridged.
  int max_hole_cells = 4;
  /// Memory of safe cells [s], [0, 60]; 0 = off. A cell that a map observed with observe() at
  /// most this long before the latest one called safe (Level / Inclined, not a drop-off edge,
  /// not too steep) and that the latest map calls Unknown is taken as that safe ground: 000's
  /// segmentation turns single cells and small patches of seen ground Unknown from one map to
  /// the next (a column whose voxel above the floor collects stereo noise splits off as a
  /// segment too small to judge, Alg. 2 step 3), and the chair must not stop on every such
  /// flicker. A hazard in a later map erases the memory of its cell; memory never makes a
  /// hazard, Unexamined or a cell outside the map safe.
  double safe_memory = 2.0;
  /// The foot of a too steep ramp [m], [0, 1]; 0 = off. 000's map finds a slope only where the
  /// ground has risen (or fallen) a voxel layer away from the floor: below that the ramp's cells
  /// join the floor's Level segment. The cells of sloped ground the chair may not enter (a
  /// Non-ground segment whose plane is steeper than theta_T = 3 deg, an Inclined one steeper than
  /// max_incline_deg) are therefore extended along the slope, both ways, by ramp_foot_height /
  /// tan(max(slope, max_incline_deg)): with 0.1 m (l_v), 0.40 m for a 14 deg plane, at most
  /// 0.57 m (10 deg; Alg. 1's height bands cut a steep ramp into segments whose planes come out
  /// flatter than it).
  double ramp_foot_height = 0.1;
  /// Inclined cells steeper than this stop the chair [deg], (0, 90). Default theta_max of 000
  /// Alg. 2 step 2 (the map calls steeper ground Non-ground); lower it for a comfort limit.
  double max_incline_deg = 10.0;
  /// Largest reversing speed [m/s], [0, 10]; 0 = no reversing.
  double reverse_speed_limit = 0.3;
  /// Slow down before a hazard (true) or only stop (false).
  bool slow_down = true;
  /// A command slowed below both of these stops instead [m/s], [0, 10] and [rad/s], [0, 10].
  double min_speed = 0.05;
  double min_angular_speed = 0.1;
  /// A map older than this stops the chair [s], (0, 3600].
  double max_map_age = 0.5;
  /// Sweep step: the farthest footprint point moves at most this fraction of a cell per step,
  /// (0, 1].
  double step_fraction = 0.5;
  /// Sweep step: the footprint turns at most this much per step [deg], (0, 45].
  double max_step_angle_deg = 3.0;

  /// Empty when valid, otherwise a message naming the parameter and its range.
  std::string validate() const;
};

enum class GateState : std::uint8_t {
  kAllowed = 0,  ///< the command passes unchanged
  kSlowed = 1,   ///< scaled down (v and omega together), not zero
  kStopped = 2,  ///< zero
};
const char* toString(GateState s);

/// Why the gate decided as it did. Values are stable: they travel in GateState messages.
enum class GateReason : std::uint8_t {
  kClear = 0,            ///< the stop zone is known safe
  kZeroCommand = 1,      ///< zero command: forwarded at once
  kNonGround = 2,        ///< a Non-ground cell in the stop zone
  kDropOff = 3,          ///< a potential drop-off edge in the stop zone
  kTooSteep = 4,         ///< an Inclined cell steeper than max_incline_deg
  kUnknown = 5,          ///< Unknown / Unexamined / outside the map, or Inclined without a slope
  kReverseLimit = 6,     ///< reversing faster than reverse_speed_limit (or reversing disabled)
  kNoMap = 7,            ///< no map (yet)
  kStaleMap = 8,         ///< map older than max_map_age (or stamped in the future)
  kWrongFrame = 9,       ///< map in another frame than the gate's (ROS layer)
  kNoTf = 10,            ///< no current pose of the footprint (ROS layer)
  kInvalidCommand = 11,  ///< non-finite command
  kInvalidPose = 12,     ///< non-finite pose
  kCommandTimeout = 13,  ///< no command for cmd_timeout (ROS layer's watchdog)
  kInvalidMap = 14,      ///< a map the gate cannot read (ROS layer)
};
const char* toString(GateReason r);

/// Planar pose of the footprint frame in the map's frame.
struct Pose2D {
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;  ///< [rad]
};

/// The cell that decided: the first hazard along the path.
struct GateCell {
  bool valid = false;  ///< false when no cell decided
  int u = 0;           ///< map cell (centred at (u l_v, v l_v), 000 Eq. (1))
  int v = 0;
  double x = 0.0;  ///< its centre in the map's frame [m]
  double y = 0.0;
  bool inside_map = false;  ///< false: outside the map window (taken as Unknown)
  SafetyLabel label = SafetyLabel::kUnknown;
  bool drop_off = false;
  double slope_deg = std::numeric_limits<double>::quiet_NaN();  ///< of its plane, if any
};

struct GateDecision {
  GateState state = GateState::kStopped;
  GateReason reason = GateReason::kNoMap;
  std::string text;  ///< one line for people: what and where

  double commanded_v = 0.0;      ///< [m/s]
  double commanded_omega = 0.0;  ///< [rad/s]
  double v = 0.0;                ///< gated [m/s]
  double omega = 0.0;            ///< gated [rad/s]
  double scale = 0.0;            ///< gated / commanded (0 for a zero command)

  GateCell cell;
  bool hazard = false;  ///< a hazard lies in the commanded stop zone
  /// Path length of the footprint origin to the last safe sampled pose before the first hazard,
  /// or the stop zone's length when there is none [m]; free_angle likewise [rad].
  double free_distance = 0.0;
  double free_angle = 0.0;
  /// Length and turn of the commanded stop zone (braking from the command plus the margin).
  double stop_distance = 0.0;
  double stop_angle = 0.0;

  // Geometry for display, in the map's frame.
  std::vector<Eigen::Vector2d> footprint;       ///< at the current pose (unpadded)
  std::vector<Eigen::Vector2d> stop_footprint;  ///< where the gated command would come to rest
  std::vector<Eigen::Vector2d> stop_zone;       ///< convex hull of the swept footprints (outline)
  std::vector<Eigen::Vector2d> zone_cells;      ///< centres of the cells the sweep checked
  int cells_checked = 0;
  int steps = 0;  ///< footprint placements of the sweep
};

class SafetyGate {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit SafetyGate(const SafetyGateConfig& config = SafetyGateConfig());

  const SafetyGateConfig& config() const { return config_; }

  /// Gates the command (v [m/s], omega [rad/s]) of a chair whose footprint frame is at `pose`
  /// in `map`'s frame, the map being `map_age` seconds old. `out`'s buffers are reused.
  void evaluate(const SafetyMap& map, const Pose2D& pose, double v, double omega, double map_age,
                GateDecision* out);
  GateDecision evaluate(const SafetyMap& map, const Pose2D& pose, double v, double omega,
                        double map_age) {
    GateDecision d;
    evaluate(map, pose, v, omega, map_age, &d);
    return d;
  }

  /// Remembers the safe cells of a map taken at `stamp` [s] (see safe_memory). Call it once per
  /// map, before evaluate() on that map. Stamps going back, a non-finite stamp or a map of
  /// another resolution clear the memory first.
  void observe(const SafetyMap& map, double stamp);
  /// Forgets every remembered cell (e.g. when the map's frame changes).
  void clearMemory();
  /// Cells currently remembered safe within safe_memory of the latest observed map.
  int rememberedCells() const;

  /// A stop for a reason found outside the core (no map, wrong frame, no tf, command timeout):
  /// zero output, `text` as given; the geometry is cleared (fill `footprint` with footprintAt()
  /// when a pose is known).
  static void stop(GateReason reason, const std::string& text, double v, double omega,
                   GateDecision* out);

  /// The footprint at `pose` (map frame), unpadded.
  void footprintAt(const Pose2D& pose, std::vector<Eigen::Vector2d>* out) const;

 private:
  struct LocalCell {
    int first_step = -1;          ///< first sweep step that touched it, -1 none
    bool initial_hazard = false;  ///< a hazard touched by the padded footprint at the start
    double d0 = 0.0;  ///< then: signed distance of its centre to the footprint at the start
  };
  enum class Hazard : std::uint8_t { kNone = 0, kUnknown, kTooSteep, kDropOff, kNonGround };

  /// classifyCell(), then Unknown cells remembered safe or in a small enclosed hole are safe.
  Hazard classify(const SafetyMap& map, int u, int v, GateCell* cell);
  /// The label alone (no memory, no holes).
  Hazard classifyCell(const SafetyMap& map, int u, int v, GateCell* cell) const;
  /// Whether Unknown cell (u, v) lies in a hole of at most max_hole_cells enclosed by safe cells.
  bool smallEnclosedHole(const SafetyMap& map, int u, int v);
  Pose2D poseAt(const Pose2D& start, double v, double omega, double lambda) const;
  void place(const Pose2D& pose, std::vector<Eigen::Vector2d>* poly) const;

  SafetyGateConfig config_;
  double r_max_ = 0.0;            ///< farthest footprint vertex from the origin [m]
  std::vector<LocalCell> cells_;  ///< the sweep's window, reused
  std::vector<Eigen::Vector2d> poly_, poly0_, hull_pts_;
  std::vector<std::pair<int, int>> hole_;  ///< hole search scratch
  /// Marks the feet of too steep segments on the sweep's window (ramp_foot_height).
  void markRampFeet(const SafetyMap& map, int u0, int v0, int w, int h);
  std::vector<float> foot_slope_;  ///< per window cell: slope of the steep ramp whose foot it is
  int win_u0_ = 0, win_v0_ = 0, win_w_ = 0, win_h_ = 0;

  /// Remembered safe cells on the window of the latest observed map (see safe_memory).
  struct MemoryCell {
    double stamp = -1.0;  ///< when last seen safe, < 0 never
    SafetyLabel label = SafetyLabel::kUnknown;
    float slope_deg = 0.0f;
  };
  bool remembered(int u, int v, GateCell* cell) const;
  std::vector<MemoryCell> memory_, memory_scratch_;
  int mem_min_u_ = 0, mem_min_v_ = 0, mem_width_ = 0, mem_height_ = 0;
  double mem_resolution_ = 0.0;
  double mem_stamp_ = -1.0;  ///< stamp of the latest observed map, < 0 none
};

/// Signed distance of `p` to the polygon's boundary: negative inside.
double signedDistanceToPolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p);
/// Whether the axis-aligned square of centre `c` and half side `h` meets the polygon.
bool squareTouchesPolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& c,
                          double h);

}  // namespace stereo_safety_map
