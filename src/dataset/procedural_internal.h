// Internals of the procedural scene generator (dataset/procedural_scene.h), shared by its units:
//   procedural_geometry.cpp   numbers and their text (0.1 mm rounding), convex-polygon geometry,
//                             the robot's footprint and dense trajectory poses;
//   procedural_materials.cpp  floor materials and their scene-file text;
//   procedural_route.cpp      the wheelchair's trajectory (makeRoute) and the public collision
//                             check checkTrajectoryClear();
//   procedural_hazards.cpp    the hazard items (Builder: curbs, cuts, steps, ramps, drops, stairs,
//                             obstacles, walls);
//   procedural_scene.cpp      visibility, one attempt at a scene, the public API.
// Private to src/dataset (not installed). Every random draw goes through PortableRng in the order
// the units call it: moving code between these files must not reorder a draw, or scenes change
// (they are byte-identical per seed; see procedural_scene.h, "Determinism").
#pragma once

#include "stereo_safety_map/dataset/portable_random.h"
#include "stereo_safety_map/dataset/procedural_scene.h"
#include "stereo_safety_map/dataset/trajectory.h"

#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {
namespace procedural {

constexpr double kDeg = M_PI / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();
// Items keep this far from each other's footprints [m] (so that no two ground solids overlap and
// no obstacle stands on another item's ground).
constexpr double kItemGap = 0.3;
// Sunken fillers reach this far under the surrounding floor, so that no sliver between the cut
// and the filler is left without ground [m].
constexpr double kTuck = 0.05;

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Poly = std::vector<Vec2>;

double q4(double x);  // coordinates and heights: 0.1 mm
double q2(double x);
double q3(double x);
Vec2 q4(const Vec2& v);
// Shortest text of a value rounded to 4 decimals ("1.25", "0", "-0.0375").
std::string num(double x);
std::string v2(const Vec2& v);
std::string v3(const Vec3& v);
std::string polyText(const Poly& p);
std::string fmt(const char* f, double a);
Vec2 dir(double yaw);
Vec2 perp(const Vec2& v);
double cross(const Vec2& a, const Vec2& b);
double signedArea(const Poly& p);
// Keeps the part with n . x <= c.
Poly clip(const Poly& p, const Vec2& n, double c);
// Rounds to 0.1 mm and drops repeated and (nearly) collinear corners and slivers, so that the
// polygon is strictly convex as the loader wants it. Empty when nothing is left.
Poly cleanup(const Poly& in);
// P minus S (both convex): convex pieces of P outside S, one per edge of S (the part of P beyond
// that edge's line), so that they overlap each other instead of meeting along new lines: pieces
// at one height then leave no sliver without ground between them however their corners are
// rounded. They also reach `overlap` [m] into S (more than the 0.05 mm rounding of the corners),
// so that no sliver opens between them and what fills S. P alone when S does not meet it.
std::vector<Poly> subtract(const Poly& P, const Poly& S_in, double overlap);
bool insideConvex(const Vec2& p, const Poly& P);
double pointSegment(const Vec2& p, const Vec2& a, const Vec2& b);
bool segmentsCross(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d);
// Distance between a segment (a point when a == b) and a convex polygon; 0 when they meet.
double segmentPolygon(const Vec2& a, const Vec2& b, const Poly& P);
// Distance between two convex polygons; 0 when they overlap or touch.
double polyDistance(const Poly& A, const Poly& B);
Eigen::AlignedBox2d boxOf(const Poly& p);
// Rectangle `len` along `yaw` and `wid` across, centred on c.
Poly rect(const Vec2& c, double yaw, double len, double wid);
// Rectangle starting at the mid-point `a` of one end and extending `len` along yaw.
Poly rectFrom(const Vec2& a, double yaw, double len, double wid);
// Convex hull (Andrew's monotone chain), counter-clockwise.
Poly hull(std::vector<Vec2> pts);
Poly footprintAt(const FootprintConfig& fp, double x, double y, double yaw);
// Poses of a trajectory at least every `step_m` of travel and `step_deg` of turning, its end pose
// included.
std::vector<RobotPose> densePoses(const TrajectoryConfig& t, double step_m, double step_deg);

// ---- material text ----

struct Mat {
  std::string texture = "noise";
  double scale = 0.3, contrast = 0.1;
  Vec3 colour = Vec3(0.5, 0.5, 0.5);
  double line_width = -1.0, detail = -1.0, grain = -1.0, grain_size = -1.0, angle = 0.0;

  std::string yaml() const {
    std::string s = "{texture: " + texture;
    if (texture != "plain") s += ", scale: " + num(scale) + ", contrast: " + num(contrast);
    s += ", colour: " + v3(colour);
    if (line_width >= 0.0) s += ", line_width: " + num(line_width);
    if (detail >= 0.0) s += ", detail: " + num(detail);
    if (grain >= 0.0) s += ", grain: " + num(grain);
    if (grain_size > 0.0) s += ", grain_size: " + num(grain_size);
    if (angle != 0.0) s += ", angle_deg: " + num(angle);
    return s + "}";
  }
};

Vec3 greyish(PortableRng& rng, double lo, double hi);
Vec3 tinted(PortableRng& rng, const Vec3& base, double jitter);
// A floor of the given kind (ranges documented at floorKinds() in the header).
Mat floorMaterial(const std::string& kind, PortableRng& rng);

// ---- the trajectory ----

struct Leg {
  Vec2 a, b;
  double yaw = 0.0;
  bool reverse = false;
};

struct Route {
  TrajectoryConfig traj;
  std::vector<RobotPose> frames;
  std::vector<Poly> swept;  // footprints every 5 cm / 3 deg
  std::vector<Eigen::AlignedBox2d> swept_box;
  Eigen::AlignedBox2d box;
  std::vector<Leg> legs;
  std::vector<int> stop_frames;  // the last frame of each drive
};

// The trajectory: optional pause, then drives (some at an angle), pauses, turns in place,
// look-arounds and short reverses until config.duration_s, padded with a final pause.
Route makeRoute(const ProceduralConfig& cfg, PortableRng& rng);
// Smallest distance between the swept footprint and a polygon.
double routeDistance(const Route& r, const Poly& p);

// ---- hazard items ----

struct Plan {
  HazardItem item;
  std::vector<std::string> entries;  // scene-file primitives (flow maps)
  std::vector<Poly> cuts;            // removed from the base floor
  std::vector<Poly> keepout;         // everything not start-level ground
  std::vector<Vec3> look;            // points whose visibility makes the item seen
  bool edge = false;                 // a straight edge across the whole area
  double depth = 0.0;                // deepest level below the start level [m]
};

class Builder {
 public:
  Builder(const ProceduralConfig& cfg, PortableRng& rng, const Route& route, const Poly& area)
      : cfg_(cfg), rng_(rng), route_(route), area_(area) {}

  // Tries to place one item of `kind` with index `index`; false when this draw does not fit.
  bool build(const std::string& kind, int index, const std::vector<Plan>& placed, Plan* out);

 private:
  struct Anchor {
    Vec2 p;
    double yaw = 0.0;  // direction from the robot towards the item, or of the leg passed
    bool beside = false;
    double side = 1.0;  // beside: +1 left of the leg, -1 right
  };
  struct Edge {
    Vec2 n;  // unit normal towards the far side
    double c = 0.0;
    Vec2 foot;  // the point of the edge nearest the trajectory
  };

  Anchor ahead(double rmin, double rmax, double max_bearing_deg);
  bool beside(double lateral, Anchor* a);
  Edge edge(double gap, double p_ahead = 0.6);
  double stepHeight();
  double slope();
  double passClearance() { return rng_.uniform(cfg_.pass_clearance_min, cfg_.pass_clearance_max); }
  Poly region(const Edge& e, double offset) const {
    return cleanup(clip(area_, -e.n, -(e.c + offset)));
  }
  void edgeLook(const Edge& e, double z, Plan* p) const;
  void rectLook(const Poly& r, double z, Plan* p) const;
  std::string name(const Plan& p, const std::string& part) const {
    return part.empty() ? p.item.group : p.item.group + "_" + part;
  }

  bool curb(const std::string& kind, Plan* p);
  bool curbCut(bool down, Plan* p);
  bool step(bool up, Plan* p);
  bool ramp(bool up, Plan* p);
  bool deepEdge(const std::string& kind, Plan* p);
  bool pit(const std::string& kind, Plan* p);
  bool stairs(Plan* p);
  bool obstacle(const std::string& kind, Plan* p);
  bool wall(bool doorway, Plan* p);

  const ProceduralConfig& cfg_;
  PortableRng& rng_;
  const Route& route_;
  Poly area_;
};

// Ramp class of a slope: steeper than theta_max (000 Alg. 2 step 2) or not.
HazardClass slopeClass(double slope_deg);

}  // namespace procedural
}  // namespace dataset
}  // namespace stereo_safety_map
