// Procedural scenes (dataset/procedural_scene.h): visibility of the hazards, one attempt at a
// scene from a seed, and the public API. The generator's other concerns live beside it (geometry,
// materials, route and collision check, hazard builders: procedural_internal.h lists them).
#include "stereo_safety_map/dataset/procedural_scene.h"

#include "procedural_internal.h"

#include "stereo_safety_map/dataset/portable_random.h"
#include "stereo_safety_map/dataset/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace stereo_safety_map {
namespace dataset {

using namespace procedural;  // NOLINT: the generator's internals (procedural_internal.h)

namespace {

// The robot never sees farther than this in the visibility test [m] (000 Sec. VII-B: objects
// beyond 4-5 m are seen poorly).
constexpr double kViewMin = 1.0;
constexpr double kViewMax = 6.0;

struct Look {
  bool indoor = false;
  std::string floor_kind;
};

// ---- visibility ----

// Per item: frames whose left camera sees one of its look points (in the image, kViewMin to
// kViewMax away, not hidden behind another item or scenery); and frames that see any item.
void visibility(const SceneFile& f, const std::vector<Plan>& plans, std::vector<int>* per_item,
                int* frames_any, int* frames) {
  const StereoHeadConfig& head = f.camera;
  const Eigen::Isometry3d T_base_opt = head.baseToLeftOptical();
  const double fx = head.fx(), cx = head.cx(), cy = head.cy();
  const double mx = 0.02 * head.width, my = 0.02 * head.height;
  const std::vector<RobotPose> poses = sampleTrajectory(f.trajectory);
  per_item->assign(plans.size(), 0);
  *frames_any = 0;
  *frames = static_cast<int>(poses.size());
  for (const RobotPose& pose : poses) {
    const Eigen::Isometry3d T =
        basePose(pose.x, pose.y, f.trajectory.base_z, pose.yaw) * T_base_opt;
    const Eigen::Matrix3d Rt = T.linear().transpose();
    const Vec3 o = T.translation();
    bool any = false;
    for (std::size_t i = 0; i < plans.size(); ++i) {
      bool seen = false;
      for (const Vec3& P : plans[i].look) {
        const Vec3 pc = Rt * (P - o);
        const double dist = (P - o).norm();
        if (pc.z() < 0.3 || dist < kViewMin || dist > kViewMax) continue;
        const double u = fx * pc.x() / pc.z() + cx, v = fx * pc.y() / pc.z() + cy;
        if (u < mx || u > head.width - 1 - mx || v < my || v > head.height - 1 - my) continue;
        Ray ray;
        ray.origin = o;
        ray.dir = P - o;
        Hit hit;
        if (f.scene.intersect(ray, 1e-6, 0.98, &hit)) {
          const std::string& g = f.scene.primitives[hit.primitive].group;
          if (g.compare(0, plans[i].item.group.size(), plans[i].item.group) != 0) continue;
        }
        seen = true;
        break;
      }
      if (seen) {
        ++(*per_item)[i];
        any = true;
      }
    }
    if (any) ++*frames_any;
  }
}

const std::vector<std::string> kIndoorFloors = {"polished", "matt", "carpet", "tiles", "concrete"};
const std::vector<std::string> kOutdoorFloors = {"concrete", "paving", "asphalt", "tiles"};

// One whole scene from the generator's current state; empty error on success.
std::string attempt(std::uint64_t seed, const ProceduralConfig& cfg, PortableRng& rng,
                    ProceduralScene* out) {
  ProceduralScene sc;
  sc.seed = seed;
  // Look: indoor or outdoor, floor kind, stereo head, light.
  sc.indoor = rng.chance(cfg.indoor_probability);
  const std::vector<std::string>& kinds = sc.indoor ? kIndoorFloors : kOutdoorFloors;
  sc.floor_kind = kinds[rng.integer(0, static_cast<int>(kinds.size()) - 1)];
  const double mount_z = q3(rng.uniform(cfg.mount_z_min, cfg.mount_z_max));
  const double pitch = q2(rng.uniform(cfg.pitch_min_deg, cfg.pitch_max_deg));

  const Route route = makeRoute(cfg, rng);
  if (route.frames.empty()) return "empty trajectory";
  // The area: the swept footprint plus a margin, at least area_min_size wide, on a 0.1 m grid.
  Eigen::AlignedBox2d box = route.box;
  box.min() -= Vec2::Constant(cfg.area_margin);
  box.max() += Vec2::Constant(cfg.area_margin);
  for (int i = 0; i < 2; ++i) {
    const double grow = 0.5 * std::max(0.0, cfg.area_min_size - box.sizes()[i]);
    box.min()[i] = std::floor((box.min()[i] - grow) * 10.0) / 10.0;
    box.max()[i] = std::ceil((box.max()[i] + grow) * 10.0) / 10.0;
  }
  const Poly area = {box.min(), Vec2(box.max().x(), box.min().y()), box.max(),
                     Vec2(box.min().x(), box.max().y())};

  // Hazard items: a kind drawn by weight, a few placements tried, another kind after that.
  std::vector<std::pair<std::string, double>> weights(cfg.kind_weights.begin(),
                                                      cfg.kind_weights.end());
  double total = 0.0;
  for (const auto& kw : weights)
    total += kw.second;
  auto drawKind = [&]() {
    double u = rng.uniform() * total;
    for (const auto& kw : weights) {
      if (u < kw.second) return kw.first;
      u -= kw.second;
    }
    return weights.back().first;
  };
  const int n_items = rng.integer(cfg.min_items, cfg.max_items);
  Builder builder(cfg, rng, route, area);
  std::vector<Plan> plans;
  int edges = 0;
  for (int i = 0; i < n_items; ++i) {
    std::string kind;
    for (int tries = 0; tries < 40; ++tries) {
      if (tries % 8 == 0) kind = drawKind();
      Plan p;
      if (!builder.build(kind, static_cast<int>(plans.size()) + 1, plans, &p)) continue;
      if (p.edge && edges >= 2) continue;
      edges += p.edge ? 1 : 0;
      plans.push_back(std::move(p));
      break;
    }
  }
  if (static_cast<int>(plans.size()) < cfg.min_items) return "could not place enough hazards";

  // Materials.
  const Mat floor = floorMaterial(sc.floor_kind, rng);
  Mat curb;
  curb.scale = 0.2;
  curb.contrast = q3(rng.uniform(0.06, 0.15));
  curb.colour = greyish(rng, 0.5, 0.7);
  const Mat lower =
      floorMaterial(sc.indoor ? kinds[rng.integer(0, static_cast<int>(kinds.size()) - 1)]
                              : (rng.chance(0.6) ? "asphalt" : "concrete"),
                    rng);
  const Mat raised =
      floorMaterial(sc.indoor ? sc.floor_kind : (rng.chance(0.5) ? "paving" : "concrete"), rng);
  Mat ramp = floorMaterial(rng.chance(0.5) ? sc.floor_kind : "concrete", rng);
  Mat yard = floorMaterial(rng.chance(0.5) ? "asphalt" : "concrete", rng);
  Mat pit = floorMaterial("concrete", rng);
  pit.colour = greyish(rng, 0.3, 0.5);
  Mat stair = floorMaterial(rng.chance(0.5) ? "concrete" : "tiles", rng);
  Mat wall;
  if (sc.indoor) {
    wall.texture = rng.chance(0.5) ? "plain" : "noise";
    wall.scale = q3(rng.uniform(0.3, 1.0));
    wall.contrast = q3(rng.uniform(0.02, 0.08));
    wall.colour = greyish(rng, 0.6, 0.9);
  } else {
    wall.texture = rng.chance(0.5) ? "bricks" : "noise";
    wall.scale = q3(rng.uniform(0.2, 0.4));
    wall.contrast = q3(rng.uniform(0.1, 0.25));
    wall.line_width = wall.texture == "bricks" ? 0.05 : -1.0;
    wall.colour =
        rng.chance(0.5) ? tinted(rng, Vec3(0.62, 0.45, 0.36), 0.1) : greyish(rng, 0.5, 0.8);
  }
  Mat metal;
  metal.texture = "plain";
  metal.colour = greyish(rng, 0.15, 0.45);
  Mat paint;
  static const Vec3 kPaints[] = {
      {0.75, 0.6, 0.1}, {0.6, 0.15, 0.12}, {0.2, 0.25, 0.3}, {0.85, 0.85, 0.82}};
  paint.contrast = 0.05;
  paint.scale = 0.1;
  paint.colour = tinted(rng, kPaints[rng.integer(0, 3)], 0.1);
  Mat wood;
  wood.texture = "stripes";
  wood.scale = q3(rng.uniform(0.04, 0.1));
  wood.contrast = q3(rng.uniform(0.1, 0.25));
  wood.colour = tinted(rng, Vec3(0.5, 0.36, 0.22), 0.2);
  Mat fabric;
  fabric.scale = 0.05;
  fabric.contrast = 0.15;
  fabric.colour = tinted(rng, Vec3(0.3, 0.3, 0.35), 0.4);
  Mat cardboard;
  cardboard.scale = 0.1;
  cardboard.contrast = 0.08;
  cardboard.colour = tinted(rng, Vec3(0.6, 0.45, 0.3), 0.1);
  Mat stone;
  stone.scale = 0.1;
  stone.contrast = 0.15;
  stone.colour = greyish(rng, 0.5, 0.75);

  // Light.
  Vec3 light;
  double ambient, diffuse;
  Vec3 horizon, zenith;
  if (sc.indoor) {
    light = Vec3(q3(rng.uniform(-0.3, 0.3)), q3(rng.uniform(-0.3, 0.3)), -1.0);
    ambient = q3(rng.uniform(0.45, 0.6));
    diffuse = q3(rng.uniform(0.3, 0.5));
    const double g = q3(rng.uniform(0.45, 0.65));
    horizon = Vec3(g, g, g);
    zenith = Vec3(q3(g + 0.05), q3(g + 0.05), q3(g + 0.05));
  } else {
    const double el = rng.uniform(25.0, 70.0) * kDeg, az = rng.uniform(0.0, 360.0) * kDeg;
    light =
        Vec3(q3(-std::cos(el) * std::cos(az)), q3(-std::cos(el) * std::sin(az)), q3(-std::sin(el)));
    ambient = q3(rng.uniform(0.35, 0.5));
    diffuse = q3(rng.uniform(0.55, 0.75));
    horizon = tinted(rng, Vec3(0.82, 0.86, 0.92), 0.05);
    zenith = tinted(rng, Vec3(0.5, 0.62, 0.85), 0.1);
  }

  // Base floor: the area minus the sunken items' cuts, in convex pieces.
  double depth = 0.0;
  for (const Plan& p : plans)
    depth = std::max(depth, p.depth);
  std::vector<Poly> pieces = {area};
  for (const Plan& p : plans) {
    for (const Poly& cut : p.cuts) {
      Poly c = cut;
      if (signedArea(c) < 0.0) std::reverse(c.begin(), c.end());
      std::vector<Poly> next;
      for (const Poly& piece : pieces)
        for (const Poly& q : subtract(piece, c, 5e-4))
          next.push_back(q);
      pieces.swap(next);
    }
  }

  std::ostringstream y;
  const std::uint64_t file_seed = seed % 999999937ull + 1;
  y << "# Procedural scene (include/stereo_safety_map/dataset/procedural_scene.h), seed " << seed
    << ".\n# Hazards:\n";
  for (const Plan& p : plans)
    y << "#   " << p.item.group << ": " << p.item.description << " (" << toString(p.item.cls)
      << ")\n";
  std::string desc =
      std::string(sc.indoor ? "indoor" : "outdoor") + ", " + sc.floor_kind + " floor; ";
  for (std::size_t i = 0; i < plans.size(); ++i)
    desc += (i ? ", " : "") + plans[i].item.kind;
  y << "name: procedural_" << seed << "\n";
  y << "description: \"procedural seed " << seed << ": " << desc << "\"\n";
  y << "look: " << (sc.indoor ? "indoor" : "outdoor") << "\n";
  y << "seed: " << file_seed << "\n";
  y << "lighting: {direction: " << v3(light) << ", ambient: " << num(ambient)
    << ", diffuse: " << num(diffuse) << "}\n";
  y << "sky: {horizon: " << v3(horizon) << ", zenith: " << v3(zenith) << "}\n";
  y << "camera: {mount: [0.25, 0.06, " << num(mount_z) << "], pitch_deg: " << num(pitch) << "}\n";
  y << "materials:\n";
  y << "  floor: " << floor.yaml() << "\n";
  y << "  curb: " << curb.yaml() << "\n";
  y << "  lower: " << lower.yaml() << "\n";
  y << "  raised: " << raised.yaml() << "\n";
  y << "  ramp: " << ramp.yaml() << "\n";
  y << "  yard: " << yard.yaml() << "\n";
  y << "  pit: " << pit.yaml() << "\n";
  y << "  stair: " << stair.yaml() << "\n";
  y << "  wall: " << wall.yaml() << "\n";
  y << "  metal: " << metal.yaml() << "\n";
  y << "  paint: " << paint.yaml() << "\n";
  y << "  wood: " << wood.yaml() << "\n";
  y << "  fabric: " << fabric.yaml() << "\n";
  y << "  cardboard: " << cardboard.yaml() << "\n";
  y << "  stone: " << stone.yaml() << "\n";
  y << "primitives:\n";
  y << "  # The start level (z = 0), cut around the sunken areas.\n";
  int k = 0;
  for (const Poly& piece : pieces) {
    const Poly c = cleanup(piece);
    if (c.empty()) continue;
    y << "  - {type: floor, name: floor_" << ++k << ", polygon: " << polyText(c)
      << ", z: 0, thickness: " << num(depth + 0.3) << ", material: floor, side_material: curb}\n";
  }
  for (const Plan& p : plans) {
    y << "  # " << p.item.group << ": " << p.item.description << "\n";
    for (const std::string& e : p.entries)
      y << "  - " << e << "\n";
  }
  // Scenery: room walls indoors, a facade or two outdoors, just outside the area and down to the
  // deepest level.
  const double wall_z = -(depth + 0.3);
  const double room_h = q2(sc.indoor ? rng.uniform(2.5, 3.2) : rng.uniform(4.0, 8.0));
  const double p_side = sc.indoor ? 0.75 : 0.25;
  const Vec2 lo = box.min(), hi = box.max();
  const Vec2 corners[4][2] = {{Vec2(lo.x(), lo.y() - 0.1), Vec2(hi.x(), lo.y() - 0.1)},
                              {Vec2(hi.x() + 0.1, lo.y()), Vec2(hi.x() + 0.1, hi.y())},
                              {Vec2(hi.x(), hi.y() + 0.1), Vec2(lo.x(), hi.y() + 0.1)},
                              {Vec2(lo.x() - 0.1, hi.y()), Vec2(lo.x() - 0.1, lo.y())}};
  bool scenery = false;
  for (int side = 0; side < 4; ++side) {
    if (!rng.chance(p_side)) continue;
    if (!scenery) y << "  # Scenery.\n";
    scenery = true;
    y << "  - {type: wall, name: " << (sc.indoor ? "room_wall_" : "facade_") << side + 1
      << ", from: " << v2(corners[side][0]) << ", to: " << v2(corners[side][1])
      << ", height: " << num(room_h - wall_z) << ", thickness: 0.2, z: " << num(wall_z)
      << ", material: wall}\n";
  }
  const TrajectoryConfig& t = route.traj;
  y << "trajectory:\n";
  y << "  rate_hz: " << num(t.rate_hz) << "\n  start: [0, 0, 0]\n  base_z: 0\n";
  y << "  speed: " << num(t.speed) << "\n  turn_rate_deg: " << num(t.turn_rate_deg) << "\n";
  y << "  steps:\n";
  for (const TrajectoryStep& s : t.steps) {
    switch (s.kind) {
      case TrajectoryStep::Kind::kPause:
        y << "    - {pause: " << num(s.value) << "}\n";
        break;
      case TrajectoryStep::Kind::kGo:
        y << "    - {go: " << v2(Vec2(s.x, s.y)) << ", speed: " << num(s.speed) << "}\n";
        break;
      case TrajectoryStep::Kind::kBack:
        y << "    - {back: " << v2(Vec2(s.x, s.y)) << ", speed: " << num(s.speed) << "}\n";
        break;
      case TrajectoryStep::Kind::kTurnBy:
        y << "    - {turn_by: " << num(s.value) << "}\n";
        break;
      case TrajectoryStep::Kind::kTurnTo:
        y << "    - {turn_to: " << num(s.value) << "}\n";
        break;
    }
  }
  sc.yaml = y.str();
  std::string e = loadSceneFromString(sc.yaml, "", &sc.file);
  if (!e.empty()) return "generated YAML does not load: " + e;
  e = checkTrajectoryClear(sc.file, cfg.footprint);
  if (!e.empty()) return "trajectory not clear: " + e;
  std::vector<int> seen;
  int frames_any = 0, frames = 0;
  visibility(sc.file, plans, &seen, &frames_any, &frames);
  sc.view_fraction = frames > 0 ? static_cast<double>(frames_any) / frames : 0.0;
  if (sc.view_fraction < cfg.min_view_fraction)
    return "hazards seen in only " + fmt("%.0f", 100.0 * sc.view_fraction) + " % of the frames";
  for (std::size_t i = 0; i < plans.size(); ++i) {
    if (seen[i] < cfg.min_item_frames)
      return plans[i].item.group + " seen in only " + std::to_string(seen[i]) + " frames";
    plans[i].item.frames_seen = seen[i];
    sc.hazards.push_back(plans[i].item);
  }
  *out = std::move(sc);
  return "";
}

}  // namespace

// ---- public ----

const char* toString(HazardClass c) {
  switch (c) {
    case HazardClass::kNone:
      return "none";
    case HazardClass::kDropOff:
      return "drop_off";
    case HazardClass::kStepUp:
      return "step_up";
    case HazardClass::kSteepRamp:
      return "steep_ramp";
    case HazardClass::kGentleRamp:
      return "gentle_ramp";
    case HazardClass::kObstacle:
      return "obstacle";
    case HazardClass::kOverhang:
      return "overhang";
  }
  return "none";
}

bool parseHazardClass(const std::string& s, HazardClass* c) {
  for (int i = 0; i < kHazardClassCount; ++i) {
    if (s == toString(static_cast<HazardClass>(i))) {
      *c = static_cast<HazardClass>(i);
      return true;
    }
  }
  return false;
}

std::string FootprintConfig::validate() const {
  if (!(width > 0.0 && width <= 3.0)) return "footprint.width must be in (0, 3] [m]";
  if (!(length > 0.0 && length <= 3.0)) return "footprint.length must be in (0, 3] [m]";
  if (!(base_to_rear >= 0.0 && base_to_rear <= length))
    return "footprint.base_to_rear must be in [0, length] [m]";
  if (!(robot_height > 0.0 && robot_height <= 5.0))
    return "footprint.robot_height must be in (0, 5] [m]";
  if (!(clearance >= 0.0 && clearance < robot_height))
    return "footprint.clearance must be in [0, robot_height) [m]";
  if (!(ground_tolerance > 0.0 && ground_tolerance < GroundTruthConfig().h_t))
    return "footprint.ground_tolerance must be in (0, h_T = 0.05) [m]";
  return "";
}

std::map<std::string, double> ProceduralConfig::defaultKindWeights() {
  return {
      // Weights of the draws; kinds that often do not fit (ramps with landings, curb cuts, light
      // wells) are drawn more often so that they still appear in a good share of the scenes.
      {"curb_down", 1.0},     {"curb_up", 0.6},      {"curb_cut_down", 0.8}, {"curb_cut_up", 0.7},
      {"step_up", 0.7},       {"step_down", 0.7},    {"ramp_up", 1.6},       {"ramp_down", 1.6},
      {"platform_edge", 0.5}, {"loading_dock", 0.3}, {"pit", 0.4},           {"light_well", 0.5},
      {"stairs_down", 0.4},   {"pole", 0.5},         {"bollard", 0.5},       {"table", 0.5},
      {"shelf", 0.4},         {"legs", 0.4},         {"kerb_stone", 0.3},    {"box", 0.3},
      {"bag", 0.3},           {"wall", 0.4},         {"doorway", 0.4}};
}

std::vector<std::string> hazardKinds() {
  std::vector<std::string> k;
  for (const auto& kv : ProceduralConfig::defaultKindWeights())
    k.push_back(kv.first);
  return k;
}

const std::vector<std::string>& floorKinds() {
  static const std::vector<std::string> kKinds = {"polished", "matt",   "carpet", "tiles",
                                                  "concrete", "paving", "asphalt"};
  return kKinds;
}

std::string ProceduralConfig::validate() const {
  auto range = [](double lo, double hi, double min, double max) {
    return std::isfinite(lo) && std::isfinite(hi) && lo >= min && lo <= hi && hi <= max;
  };
  if (!(duration_s >= 2.0 && duration_s <= 600.0))
    return "procedural.duration_s must be in [2, 600] [s]";
  if (!(rate_hz > 0.0 && rate_hz <= 100.0)) return "procedural.rate_hz must be in (0, 100] [Hz]";
  if (!(min_items >= 1 && min_items <= max_items && max_items <= 8))
    return "procedural.min_items, max_items: 1 <= min <= max <= 8";
  if (!range(speed_min, speed_max, 0.05, 2.0))
    return "procedural.speed_min, speed_max: 0.05 <= min <= max <= 2 [m/s]";
  if (!(reverse_speed_max >= speed_min && reverse_speed_max <= 2.0))
    return "procedural.reverse_speed_max must be in [speed_min, 2] [m/s]";
  if (!range(turn_rate_min_deg, turn_rate_max_deg, 5.0, 180.0))
    return "procedural.turn_rate_min_deg, turn_rate_max_deg: 5 <= min <= max <= 180 [deg/s]";
  if (!range(pass_clearance_min, pass_clearance_max, 0.05, 5.0))
    return "procedural.pass_clearance_min, pass_clearance_max: 0.05 <= min <= max <= 5 [m]";
  if (!(min_clearance > 0.0 && min_clearance <= pass_clearance_min))
    return "procedural.min_clearance must be in (0, pass_clearance_min] [m]";
  if (!range(mount_z_min, mount_z_max, 0.2, 3.0))
    return "procedural.mount_z_min, mount_z_max: 0.2 <= min <= max <= 3 [m]";
  if (!range(pitch_min_deg, pitch_max_deg, 0.0, 60.0))
    return "procedural.pitch_min_deg, pitch_max_deg: 0 <= min <= max <= 60 [deg]";
  if (!(indoor_probability >= 0.0 && indoor_probability <= 1.0))
    return "procedural.indoor_probability must be in [0, 1]";
  if (!range(step_min, step_max, 0.01, 0.5))
    return "procedural.step_min, step_max: 0.01 <= min <= max <= 0.5 [m]";
  if (!(step_near_h_t_weight >= 0.0 && step_near_h_t_weight <= 1.0))
    return "procedural.step_near_h_t_weight must be in [0, 1]";
  if (!(slope_near_theta_t_weight >= 0.0 && slope_near_theta_max_weight >= 0.0 &&
        slope_near_theta_t_weight + slope_near_theta_max_weight <= 1.0))
    return "procedural.slope_near_theta_t_weight, slope_near_theta_max_weight: >= 0, sum <= 1";
  if (!range(slope_min_deg, slope_max_deg, 0.5, 30.0))
    return "procedural.slope_min_deg, slope_max_deg: 0.5 <= min <= max <= 30 [deg]";
  double total = 0.0;
  const std::map<std::string, double> known = defaultKindWeights();
  for (const auto& kv : kind_weights) {
    if (!known.count(kv.first)) return "procedural.kind_weights: unknown kind '" + kv.first + "'";
    if (!(kv.second >= 0.0 && std::isfinite(kv.second)))
      return "procedural.kind_weights: weights must be finite and >= 0";
    total += kv.second;
  }
  if (!(total > 0.0)) return "procedural.kind_weights: some kind needs a weight > 0";
  if (!(min_view_fraction >= 0.0 && min_view_fraction <= 1.0))
    return "procedural.min_view_fraction must be in [0, 1]";
  if (min_item_frames < 0) return "procedural.min_item_frames must be >= 0";
  if (!(area_margin >= 2.0 && area_margin <= 50.0))
    return "procedural.area_margin must be in [2, 50] [m]";
  if (!(area_min_size >= 0.0 && area_min_size <= 100.0))
    return "procedural.area_min_size must be in [0, 100] [m]";
  if (max_attempts < 1 || max_attempts > 10000)
    return "procedural.max_attempts must be in [1, 10000]";
  const std::string e = footprint.validate();
  if (!e.empty()) return "procedural." + e;
  return "";
}

std::string generateProceduralScene(std::uint64_t seed, const ProceduralConfig& config,
                                    ProceduralScene* out) {
  const std::string e = config.validate();
  if (!e.empty()) return e;
  PortableRng rng(seed);
  std::string last;
  for (int a = 1; a <= config.max_attempts; ++a) {
    ProceduralScene sc;
    last = attempt(seed, config, rng, &sc);
    if (last.empty()) {
      sc.attempts = a;
      *out = std::move(sc);
      return "";
    }
  }
  return "seed " + std::to_string(seed) + ": no valid scene in " +
         std::to_string(config.max_attempts) + " attempts (last: " + last + ")";
}

std::vector<HazardClass> hazardClassMap(const ProceduralScene& scene, const GroundTruthMap& gt,
                                        const GroundTruthConfig& config) {
  const std::size_t n = static_cast<std::size_t>(std::max(0, gt.width)) * std::max(0, gt.height);
  std::vector<HazardClass> out(n, HazardClass::kNone);
  if (gt.ground.size() != n || gt.obstacle.size() != n || gt.ground_height.size() != n) return out;
  const Scene& s = scene.file.scene;
  std::map<std::string, HazardClass> part_class;
  for (const HazardItem& it : scene.hazards)
    for (const HazardPart& part : it.parts)
      part_class[part.entry] = part.cls;
  std::vector<HazardClass> prim_class(s.primitives.size(), HazardClass::kNone);
  for (std::size_t i = 0; i < s.primitives.size(); ++i) {
    const auto f = part_class.find(s.primitives[i].group);
    if (f != part_class.end()) prim_class[i] = f->second;
  }
  for (std::size_t k = 0; k < n; ++k)
    if (gt.ground[k] >= 0 && static_cast<std::size_t>(gt.ground[k]) < prim_class.size())
      out[k] = prim_class[gt.ground[k]];
  // Obstacle cells: the GT's test again (000 Sec. V-A), noting whether the solid reaches down to
  // ground + clearance (standing) or only hangs above the cell (overhang).
  const double res = gt.resolution;
  double start_z = 0.0;
  if (gt.inside(gt.start_u, gt.start_v)) {
    const int sk = gt.index(gt.start_u, gt.start_v);
    if (gt.ground[sk] >= 0) start_z = gt.ground_height[sk];
  }
  std::vector<std::uint8_t> standing(n, 0), over(n, 0);
  const int S = config.samples_per_cell;
  for (const Primitive& p : s.primitives) {
    if (p.ground || p.bounds.isEmpty()) continue;
    const int u0 =
        std::max(gt.min_u, static_cast<int>(std::floor((p.bounds.min().x() - 0.5 * res) / res)));
    const int u1 = std::min(gt.min_u + gt.width - 1,
                            static_cast<int>(std::ceil((p.bounds.max().x() + 0.5 * res) / res)));
    const int v0 =
        std::max(gt.min_v, static_cast<int>(std::floor((p.bounds.min().y() - 0.5 * res) / res)));
    const int v1 = std::min(gt.min_v + gt.height - 1,
                            static_cast<int>(std::ceil((p.bounds.max().y() + 0.5 * res) / res)));
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        const int k = gt.index(u, v);
        if (!gt.obstacle[k] || standing[k]) continue;
        const bool has_ground = gt.ground[k] >= 0;
        const double z_top = (has_ground ? gt.ground_height[k] : start_z) + config.robot_height;
        const double len = has_ground ? config.robot_height - config.clearance : 1e6;
        Ray ray;
        ray.dir = Vec3(0.0, 0.0, -1.0);
        for (int i = 0; i < S * S && !standing[k]; ++i) {
          const double ox = ((i % S + 0.5) / S - 0.5) * res, oy = ((i / S + 0.5) / S - 0.5) * res;
          ray.origin = Vec3(u * res + ox, v * res + oy, z_top);
          double tin, tout;
          int face;
          if (!p.interval(ray, &tin, &tout, &face) || tin > len || tout < 0.0) continue;
          if (!has_ground || tout >= len) {  // no ground: anything in the column stands there
            standing[k] = 1;
          } else {
            over[k] = 1;
          }
        }
      }
    }
  }
  for (std::size_t k = 0; k < n; ++k)
    if (gt.obstacle[k])
      out[k] = standing[k] ? HazardClass::kObstacle
                           : (over[k] ? HazardClass::kOverhang : HazardClass::kObstacle);
  return out;
}

std::string proceduralSummary(const ProceduralScene& sc) {
  std::ostringstream s;
  const std::size_t frames = sampleTrajectory(sc.file.trajectory).size();
  s << "seed " << sc.seed << ": " << (sc.indoor ? "indoor" : "outdoor") << ", " << sc.floor_kind
    << " floor, camera " << num(sc.file.camera.mount_z) << " m / " << num(sc.file.camera.pitch_deg)
    << " deg, " << frames << " frames, hazards seen in " << fmt("%.0f", 100.0 * sc.view_fraction)
    << " %; ";
  for (std::size_t i = 0; i < sc.hazards.size(); ++i) {
    const HazardItem& h = sc.hazards[i];
    s << (i ? ", " : "") << h.kind << " " << num(h.size) << " (" << toString(h.cls) << ")";
  }
  return s.str();
}

}  // namespace dataset
}  // namespace stereo_safety_map
