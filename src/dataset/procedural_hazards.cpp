// Procedural scenes (procedural_internal.h): the hazard items a wheelchair meets (Builder).
// Thresholds are the labeller's (000 Alg. 2: h_T = 5 cm, theta_T = 3 deg, theta_max = 10 deg).
#include "procedural_internal.h"

#include <algorithm>

namespace stereo_safety_map {
namespace dataset {
namespace procedural {

Builder::Anchor Builder::ahead(double rmin, double rmax, double max_bearing_deg) {
  int f;
  if (!route_.stop_frames.empty() && rng_.chance(0.5)) {
    f = route_.stop_frames[rng_.integer(0, static_cast<int>(route_.stop_frames.size()) - 1)];
  } else {
    f = rng_.integer(0, static_cast<int>(route_.frames.size()) - 1);
  }
  const RobotPose& pose = route_.frames[f];
  Anchor a;
  a.yaw = pose.yaw + rng_.uniform(-max_bearing_deg, max_bearing_deg) * kDeg;
  a.p = Vec2(pose.x, pose.y) + dir(pose.yaw) * 0.25 + dir(a.yaw) * rng_.uniform(rmin, rmax);
  return a;
}

bool Builder::beside(double lateral, Anchor* a) {
  std::vector<const Leg*> legs;
  for (const Leg& l : route_.legs)
    if (!l.reverse && (l.b - l.a).norm() > 0.5) legs.push_back(&l);
  if (legs.empty()) return false;
  const Leg& l = *legs[rng_.integer(0, static_cast<int>(legs.size()) - 1)];
  // Far enough along the drive that the camera (0.25 m ahead of base_link) has it within 25 deg
  // of its axis while approaching; at most 1 m past the drive's end.
  const double off = 0.5 * cfg_.footprint.width + lateral;
  const double len = (l.b - l.a).norm();
  const double s_min = off / std::tan(25.0 * kDeg) - 0.25;
  if (s_min > len + 1.0) return false;
  a->yaw = l.yaw;
  a->side = rng_.sign();
  a->p = l.a + dir(l.yaw) * rng_.uniform(std::max(0.0, s_min), len + 1.0) +
         perp(dir(l.yaw)) * (a->side * off);
  a->beside = true;
  return true;
}

Builder::Edge Builder::edge(double gap, double p_ahead) {
  Edge e;
  if (route_.legs.empty() || rng_.chance(p_ahead)) {  // ahead of the robot at some frame
    const Anchor a = ahead(2.0, 3.0, 35.0);
    e.n = dir(a.yaw);
  } else {  // along a drive, on its left or right
    const Leg& l = route_.legs[rng_.integer(0, static_cast<int>(route_.legs.size()) - 1)];
    e.n = perp(dir(l.yaw)) * rng_.sign();
  }
  // Beyond the whole swept footprint by `gap`.
  double best = -kInf;
  Vec2 arg = Vec2::Zero();
  for (const Poly& fp : route_.swept) {
    for (const Vec2& v : fp) {
      if (e.n.dot(v) > best) {
        best = e.n.dot(v);
        arg = v;
      }
    }
  }
  e.c = best + gap;
  e.foot = arg + e.n * (e.c - e.n.dot(arg));
  return e;
}

double Builder::stepHeight() {
  // Curbs and steps on both sides of h_T = 5 cm (000 Alg. 2 step 17).
  if (rng_.chance(cfg_.step_near_h_t_weight)) return q4(rng_.uniform(0.03, 0.07));
  return q4(rng_.uniform(cfg_.step_min, cfg_.step_max));
}

double Builder::slope() {
  // Many ramps within 2 deg of theta_T = 3 deg and theta_max = 10 deg (000 Alg. 2 steps 2, 28).
  const double u = rng_.uniform();
  if (u < cfg_.slope_near_theta_t_weight) return rng_.uniform(1.0, 5.0);
  if (u < cfg_.slope_near_theta_t_weight + cfg_.slope_near_theta_max_weight)
    return rng_.uniform(8.0, 12.0);
  return rng_.uniform(cfg_.slope_min_deg, cfg_.slope_max_deg);
}

HazardClass slopeClass(double slope_deg) {
  return slope_deg > GroundTruthConfig().theta_max_deg ? HazardClass::kSteepRamp
                                                       : HazardClass::kGentleRamp;
}

void Builder::edgeLook(const Edge& e, double z, Plan* p) const {
  // Points along the edge inside the area, every 0.5 m, a little above the surface.
  const Vec2 t = perp(e.n);
  for (double s = -15.0; s <= 15.0; s += 0.5) {
    const Vec2 q = e.foot + t * s;
    if (insideConvex(q, area_)) p->look.emplace_back(q.x(), q.y(), z + 0.02);
  }
}

void Builder::rectLook(const Poly& r, double z, Plan* p) const {
  Vec2 c = Vec2::Zero();
  for (const Vec2& v : r)
    c += v;
  c /= static_cast<double>(r.size());
  p->look.emplace_back(c.x(), c.y(), z + 0.02);
  for (std::size_t i = 0; i < r.size(); ++i) {
    const Vec2 a = r[i], b = r[(i + 1) % r.size()];
    for (const Vec2& q : {a, Vec2(0.5 * (a + b))})
      p->look.emplace_back(q.x(), q.y(), z + 0.02);
  }
}

// curb_down / curb_up: a straight edge across the area, the far side `h` lower or higher.
bool Builder::curb(const std::string& kind, Plan* p) {
  const bool down = kind == "curb_down";
  const double h = stepHeight();
  const Edge e = edge(passClearance());
  const Poly far = region(e, 0.0);
  if (far.empty()) return false;
  p->edge = true;
  p->keepout.push_back(far);
  HazardItem& it = p->item;
  it.group_kind = "curb";
  it.size = h;
  it.position = e.foot;
  if (down) {
    const Poly street = region(e, -kTuck);
    p->cuts.push_back(far);
    p->entries.push_back("{type: floor, name: " + name(*p, "street") + ", polygon: " +
                         polyText(street) + ", z: " + num(-h) + ", material: lower}");
    it.cls = HazardClass::kDropOff;
    it.parts.push_back({name(*p, "street"), HazardClass::kDropOff});
    it.description = "curb " + num(h * 100) + " cm down to a street";
    p->depth = h;
    edgeLook(e, 0.0, p);
  } else {
    p->entries.push_back("{type: platform, name: " + name(*p, "upper") + ", polygon: " +
                         polyText(far) + ", z: " + num(h) + ", thickness: " + num(h + 0.05) +
                         ", material: raised, side_material: curb}");
    it.cls = HazardClass::kStepUp;
    it.parts.push_back({name(*p, "upper"), HazardClass::kStepUp});
    it.description = "curb " + num(h * 100) + " cm up to a sidewalk";
    edgeLook(e, h, p);
  }
  return true;
}

// A curb with a ramp cut into it perpendicular to the edge and a sloped triangular flare on each
// side (a kerb ramp). down: the robot is on the sidewalk, the cut leads down to the street; up:
// the robot is on the street level, the cut leads up to the sidewalk.
bool Builder::curbCut(bool down, Plan* p) {
  double h = q4(rng_.uniform(0.08, cfg_.step_max));
  double s = slope();
  double L = h / std::tan(s * kDeg);
  if (L > 3.0) {
    L = 3.0;
    h = q4(std::max(0.03, L * std::tan(s * kDeg)));
  }
  L = q4(std::max(0.4, L));
  s = std::atan(h / L) / kDeg;
  const double W = q4(rng_.uniform(0.9, 1.5));
  const double F = q4(std::min(1.5, std::max(0.25, h / std::tan(rng_.uniform(5.0, 15.0) * kDeg))));
  const double flare = std::atan(h * std::sqrt(1.0 / (F * F) + 1.0 / (L * L))) / kDeg;
  // Mostly ahead: the cut is what the camera should see, not only the curb beside the path.
  const Edge e = edge(passClearance() + (down ? L : 0.0), 0.85);
  const Vec2 t = perp(e.n);
  const Vec2 o = e.foot + t * rng_.uniform(-1.0, 1.0);
  // Local (s along the edge, d across it, positive towards the far side) to world.
  auto P = [&](double sl, double d) { return q4(Vec2(o + t * sl + e.n * d)); };
  auto P3 = [&](double sl, double d, double z) {
    const Vec2 q = P(sl, d);
    return Vec3(q.x(), q.y(), z);
  };
  const double hw = 0.5 * W;
  const Poly far = region(e, 0.0);
  if (far.empty()) return false;
  HazardItem& it = p->item;
  it.group_kind = "curb";
  it.size = s;
  it.cls = slopeClass(s);
  it.position = P(0.0, 0.0);
  p->edge = true;
  std::vector<Vec3> ramp, fl, fr;
  Poly trap;
  if (down) {
    ramp = {P3(-hw, -L, 0), P3(hw, -L, 0), P3(hw, 0, -h), P3(-hw, 0, -h)};
    fl = {P3(-hw, -L, 0), P3(-hw, 0, -h), P3(-hw - F, 0, 0)};
    fr = {P3(hw, -L, 0), P3(hw + F, 0, 0), P3(hw, 0, -h)};
    trap = {P(-hw, -L), P(hw, -L), P(hw + F, 0), P(-hw - F, 0)};
    const Poly street = region(e, -kTuck);
    p->cuts = {far, trap};
    p->keepout = {far, trap};
    p->entries.push_back("{type: floor, name: " + name(*p, "street") + ", polygon: " +
                         polyText(street) + ", z: " + num(-h) + ", material: lower}");
    it.parts.push_back({name(*p, "street"), HazardClass::kDropOff});
    p->depth = h;
    edgeLook(e, 0.0, p);
  } else {
    ramp = {P3(-hw, 0, 0), P3(hw, 0, 0), P3(hw, L, h), P3(-hw, L, h)};
    fl = {P3(-hw, L, h), P3(-hw, 0, 0), P3(-hw - F, 0, h)};
    fr = {P3(hw, L, h), P3(hw + F, 0, h), P3(hw, 0, 0)};
    trap = {P(-hw - F, 0), P(hw + F, 0), P(hw, L), P(-hw, L)};
    p->keepout = {far};
    int k = 0;
    for (const Poly& piece : subtract(far, trap, 5e-4)) {
      const Poly c = cleanup(piece);
      if (c.empty()) continue;
      const std::string nm = name(*p, "upper" + std::to_string(++k));
      p->entries.push_back("{type: platform, name: " + nm + ", polygon: " + polyText(c) +
                           ", z: " + num(h) + ", thickness: " + num(h + 0.05) +
                           ", material: raised, side_material: curb}");
      it.parts.push_back({nm, HazardClass::kStepUp});
    }
    edgeLook(e, h, p);
  }
  auto slab = [&](const std::string& part, const std::vector<Vec3>& top) {
    std::string s = "{type: slab, name: " + name(*p, part) + ", top: [";
    for (std::size_t i = 0; i < top.size(); ++i)
      s += (i ? ", " : "") + v3(top[i]);
    return s + "], material: ramp, side_material: curb}";
  };
  p->entries.push_back(slab("ramp", ramp));
  p->entries.push_back(slab("flare_l", fl));
  p->entries.push_back(slab("flare_r", fr));
  it.parts.push_back({name(*p, "ramp"), slopeClass(s)});
  it.parts.push_back({name(*p, "flare_l"), slopeClass(flare)});
  it.parts.push_back({name(*p, "flare_r"), slopeClass(flare)});
  for (const auto& v : ramp)
    p->look.emplace_back(v.x(), v.y(), v.z() + 0.02);
  it.description = std::string("curb cut ") + (down ? "down " : "up ") + num(h * 100) +
                   " cm: ramp " + fmt("%.1f", s) + " deg " + num(W) + " m wide, flares " +
                   fmt("%.1f", flare) + " deg";
  return true;
}

// step_up / step_down: a rectangular platform or sunken area h higher or lower.
bool Builder::step(bool up, Plan* p) {
  const double h = stepHeight();
  const double len = q4(rng_.uniform(1.0, 3.0)), wid = q4(rng_.uniform(1.0, 3.0));
  Anchor a;
  if (rng_.chance(0.4)) {
    if (!beside(passClearance() + 0.5 * wid, &a)) return false;
  } else {
    a = ahead(2.0, 4.5, 25.0);
    a.p += dir(a.yaw) * (0.5 * len);
  }
  const double yaw = q2((a.yaw / kDeg) + rng_.uniform(-20.0, 20.0)) * kDeg;
  const Poly r = cleanup(rect(q4(a.p), yaw, len, wid));
  if (r.empty()) return false;
  HazardItem& it = p->item;
  it.group_kind = "step";
  it.size = h;
  it.position = q4(a.p);
  p->keepout.push_back(r);
  if (up) {
    p->entries.push_back("{type: platform, name: " + name(*p, "top") + ", polygon: " + polyText(r) +
                         ", z: " + num(h) + ", thickness: " + num(h + 0.05) +
                         ", material: raised, side_material: curb}");
    it.cls = HazardClass::kStepUp;
    it.parts.push_back({name(*p, "top"), HazardClass::kStepUp});
    it.description =
        "step " + num(h * 100) + " cm up onto a " + num(len) + " x " + num(wid) + " m platform";
    rectLook(r, h, p);
  } else {
    p->cuts.push_back(r);
    p->entries.push_back("{type: floor, name: " + name(*p, "floor") + ", polygon: " +
                         polyText(cleanup(rect(q4(a.p), yaw, len + 2 * kTuck, wid + 2 * kTuck))) +
                         ", z: " + num(-h) + ", material: lower}");
    it.cls = HazardClass::kDropOff;
    it.parts.push_back({name(*p, "floor"), HazardClass::kDropOff});
    it.description = "step " + num(h * 100) + " cm down into a " + num(len) + " x " + num(wid) +
                     " m sunken area";
    p->depth = h;
    rectLook(r, 0.0, p);
  }
  return true;
}

// ramp_up: a ramp from the floor up to a landing; ramp_down: from the floor down to a lower area.
bool Builder::ramp(bool up, Plan* p) {
  const double s0 = slope();
  double L = rng_.uniform(1.0, 2.5);
  double h = L * std::tan(s0 * kDeg);
  if (h > 0.5) L = 0.5 / std::tan(s0 * kDeg);
  L = q4(L);
  h = q4(L * std::tan(s0 * kDeg));
  const double s = std::atan(h / L) / kDeg;
  const double W = q4(rng_.uniform(1.0, 2.0));
  const double land = q4(rng_.uniform(0.8, 1.5)), land_w = q4(W + rng_.uniform(0.0, 0.6));
  Anchor a;
  double yaw;
  if (rng_.chance(0.5)) {  // beside a drive, running along it
    if (!beside(passClearance() + 0.5 * std::max(W, land_w), &a)) return false;
    yaw = a.yaw;
  } else {  // ahead, the low (or top) end towards the robot
    a = ahead(1.5, 3.0, 25.0);
    yaw = a.yaw + rng_.uniform(-25.0, 25.0) * kDeg;
  }
  yaw = q2(yaw / kDeg) * kDeg;
  const Vec2 from = q4(a.p), u = dir(yaw);
  const Vec2 to = q4(from + u * L);
  const Poly ramp_r = cleanup(rectFrom(from, yaw, L, W));
  if (ramp_r.empty()) return false;
  HazardItem& it = p->item;
  it.group_kind = "ramp";
  it.size = s;
  it.cls = slopeClass(s);
  it.position = from;
  const std::string slope_txt = fmt("%.1f", s);
  if (up) {
    // The landing overlaps the ramp's top end by 1 cm (no gap, a step of < 3 mm).
    const Poly land_r = cleanup(rectFrom(q4(to - u * 0.01), yaw, land + 0.01, land_w));
    if (land_r.empty()) return false;
    p->keepout = {ramp_r, land_r};
    p->entries.push_back("{type: ramp, name: " + name(*p, "ramp") + ", from: " + v2(from) +
                         ", to: " + v2(to) + ", width: " + num(W) + ", z_from: 0, z_to: " + num(h) +
                         ", material: ramp, side_material: curb}");
    p->entries.push_back("{type: platform, name: " + name(*p, "landing") + ", polygon: " +
                         polyText(land_r) + ", z: " + num(h) + ", thickness: " + num(h + 0.05) +
                         ", material: raised, side_material: curb}");
    it.parts.push_back({name(*p, "ramp"), slopeClass(s)});
    it.parts.push_back({name(*p, "landing"), HazardClass::kStepUp});
    it.description = "ramp " + slope_txt + " deg up " + num(h) + " m to a landing";
    rectLook(ramp_r, 0.5 * h, p);
  } else {
    // The ramp starts 5 mm under the floor's rim and is 1 cm wider than its cut (no slivers).
    const Vec2 from_t = q4(from - u * 0.005);
    const double z_from = q4(0.005 * std::tan(s * kDeg));
    const Poly low_r = cleanup(rectFrom(to, yaw, land, land_w));
    const Poly low_fill =
        cleanup(rectFrom(q4(to - u * kTuck), yaw, land + 2 * kTuck, land_w + 2 * kTuck));
    if (low_r.empty() || low_fill.empty()) return false;
    p->cuts = {ramp_r, low_r};
    p->keepout = {ramp_r, low_r};
    p->entries.push_back("{type: ramp, name: " + name(*p, "ramp") + ", from: " + v2(from_t) +
                         ", to: " + v2(to) + ", width: " + num(W + 0.01) +
                         ", z_from: " + num(z_from) + ", z_to: " + num(-h) +
                         ", material: ramp, side_material: curb}");
    p->entries.push_back("{type: floor, name: " + name(*p, "lower") + ", polygon: " +
                         polyText(low_fill) + ", z: " + num(-h) + ", material: lower}");
    it.parts.push_back({name(*p, "ramp"), slopeClass(s)});
    it.parts.push_back({name(*p, "lower"), HazardClass::kDropOff});
    it.description = "ramp " + slope_txt + " deg down " + num(h) + " m to a lower area";
    p->depth = h;
    rectLook(ramp_r, -0.5 * h, p);
  }
  return true;
}

// platform_edge (0.3-1 m) and loading_dock (1-1.4 m): a deep drop along a straight edge.
bool Builder::deepEdge(const std::string& kind, Plan* p) {
  const bool dock = kind == "loading_dock";
  const double h = q4(dock ? rng_.uniform(1.0, 1.4) : rng_.uniform(0.3, 1.0));
  const Edge e = edge(passClearance());
  const Poly far = region(e, 0.0), low = region(e, -kTuck);
  if (far.empty() || low.empty()) return false;
  p->edge = true;
  p->cuts.push_back(far);
  p->keepout.push_back(far);
  p->entries.push_back("{type: floor, name: " + name(*p, "lower") + ", polygon: " + polyText(low) +
                       ", z: " + num(-h) + ", material: yard}");
  HazardItem& it = p->item;
  it.group_kind = "drop";
  it.cls = HazardClass::kDropOff;
  it.size = h;
  it.position = e.foot;
  it.parts.push_back({name(*p, "lower"), HazardClass::kDropOff});
  it.description = std::string(dock ? "loading dock edge " : "platform edge ") + num(h) + " m high";
  p->depth = h;
  edgeLook(e, 0.0, p);
  return true;
}

// pit (0.2-1 m deep) and light_well (1-2.5 m deep, a wall on its far side, sometimes a railing
// on its near side): a rectangular hole in the floor.
bool Builder::pit(const std::string& kind, Plan* p) {
  const bool well = kind == "light_well";
  const double h = q4(well ? rng_.uniform(1.0, 2.5) : rng_.uniform(0.2, 1.0));
  const double len = q4(well ? rng_.uniform(0.8, 1.5) : rng_.uniform(0.6, 2.0));
  const double wid = q4(well ? rng_.uniform(1.5, 3.0) : rng_.uniform(0.6, 2.0));
  Anchor a;
  if (rng_.chance(0.4)) {
    if (!beside(passClearance() + 0.5 * len, &a)) return false;
  } else {
    a = ahead(2.0, 4.5, 25.0);
    a.p += dir(a.yaw) * (0.5 * len);
  }
  // The rectangle's `len` axis points away from the robot (wall on the far long side).
  // Beside a drive: the long side along it, the wall on the side away from it.
  double yaw = a.beside ? a.yaw + a.side * M_PI / 2.0 : a.yaw;
  yaw = q2(yaw / kDeg + rng_.uniform(-10.0, 10.0)) * kDeg;
  const Vec2 c = q4(a.p), u = dir(yaw), w = perp(u);
  const Poly hole = cleanup(rect(c, yaw, len, wid));
  const Poly fill = cleanup(rect(c, yaw, len + 2 * kTuck, wid + 2 * kTuck));
  if (hole.empty() || fill.empty()) return false;
  HazardItem& it = p->item;
  it.group_kind = "drop";
  it.cls = HazardClass::kDropOff;
  it.size = h;
  it.position = c;
  p->cuts.push_back(hole);
  p->keepout.push_back(hole);
  p->entries.push_back("{type: floor, name: " + name(*p, "floor") + ", polygon: " + polyText(fill) +
                       ", z: " + num(-h) + ", material: pit}");
  it.parts.push_back({name(*p, "floor"), HazardClass::kDropOff});
  p->depth = h;
  rectLook(hole, 0.0, p);
  it.description =
      (well ? "light well " : "pit ") + num(len) + " x " + num(wid) + " m, " + num(h) + " m deep";
  if (well) {
    // The building's wall on the far long side, from the well's floor up.
    const double th = 0.2, wh = q4(rng_.uniform(2.5, 4.0));
    const Vec2 wa = q4(c + u * (0.5 * len + 0.5 * th) - w * (0.5 * wid + 0.3));
    const Vec2 wb = q4(c + u * (0.5 * len + 0.5 * th) + w * (0.5 * wid + 0.3));
    p->entries.push_back("{type: wall, name: " + name(*p, "wall") + ", from: " + v2(wa) +
                         ", to: " + v2(wb) + ", height: " + num(wh + h) +
                         ", thickness: " + num(th) + ", z: " + num(-h) + ", material: wall}");
    p->keepout.push_back(cleanup(rect(q4(0.5 * (wa + wb)), yaw, th, wid + 0.6)));
    if (rng_.chance(0.5)) {
      const Vec2 ra = q4(c - u * (0.5 * len + 0.06) - w * (0.5 * wid));
      const Vec2 rb = q4(c - u * (0.5 * len + 0.06) + w * (0.5 * wid));
      p->entries.push_back("{type: railing, name: " + name(*p, "railing") + ", from: " + v2(ra) +
                           ", to: " + v2(rb) +
                           ", height: 1.0, post_spacing: 1.0, material: metal}");
      p->keepout.push_back(cleanup(rect(q4(0.5 * (ra + rb)), yaw, 0.08, wid + 0.08)));
      it.description += ", railing";
    }
  }
  return true;
}

// stairs_down: 3-6 steps of 15-18 cm down a stairwell, a landing at the foot.
bool Builder::stairs(Plan* p) {
  const int count = rng_.integer(3, 6);
  const double rise = q4(rng_.uniform(0.15, 0.18)), run = q4(rng_.uniform(0.27, 0.32));
  const double W = q4(rng_.uniform(1.0, 1.8)), landing = q4(rng_.uniform(1.0, 1.5));
  const double len = count * run + landing;
  Anchor a = ahead(2.0, 4.0, 25.0);
  const double yaw = q2(a.yaw / kDeg + rng_.uniform(-30.0, 30.0)) * kDeg;
  const Vec2 rim = q4(a.p), u = dir(yaw);
  const Poly well = cleanup(rectFrom(rim, yaw, len - 0.01, W));
  if (well.empty()) return false;
  const double depth = q4(count * rise);
  // Steps from 5 mm under the rim, 1 cm wider than the opening (no slivers).
  const Vec2 from = q4(rim - u * 0.005);
  p->cuts.push_back(well);
  p->keepout.push_back(well);
  p->entries.push_back("{type: stairs, name: " + name(*p, "") + ", from: " + v2(from) +
                       ", direction_deg: " + num(yaw / kDeg) + ", width: " + num(W + 0.01) +
                       ", count: " + std::to_string(count) + ", rise: " + num(-rise) +
                       ", run: " + num(run) + ", landing: " + num(landing) +
                       ", material: stair, side_material: curb}");
  HazardItem& it = p->item;
  it.group_kind = "drop";
  it.cls = HazardClass::kDropOff;
  it.size = depth;
  it.position = rim;
  it.parts.push_back({name(*p, ""), HazardClass::kDropOff});
  it.description = "stairs down: " + std::to_string(count) + " steps of " + num(rise * 100) +
                   " cm, " + num(W) + " m wide";
  p->depth = depth;
  rectLook(well, 0.0, p);
  return true;
}

// Obstacles on the start level: poles, bollards, tables, shelves, thin legs, low obstacles.
bool Builder::obstacle(const std::string& kind, Plan* p) {
  HazardItem& it = p->item;
  // Footprint half-extent across a drive, for passes at a chosen lateral clearance.
  double half = 0.0, half_len = 0.0;
  double pole_r = 0.0, height = 0.0, sq = 0.0;
  bool square = false;
  double tl = 0.0, tw = 0.0, top_th = 0.0, leg_r = 0.0, inset = 0.0;
  double wall_len = 0.0, wall_h = 0.0, shelf_d = 0.0, shelf_th = 0.0, shelf_len = 0.0;
  int legs = 0;
  double leg_sp = 0.0;
  Vec3 low_size = Vec3::Zero();
  if (kind == "pole") {
    pole_r = q4(0.5 * rng_.uniform(0.05, 0.15));
    height = q4(rng_.uniform(0.8, 1.5));
    half = half_len = pole_r;
    it.group_kind = "pole";
    it.cls = HazardClass::kObstacle;
    it.size = 2 * pole_r;
  } else if (kind == "bollard") {
    square = rng_.chance(0.4);
    height = q4(rng_.uniform(0.3, 1.2));
    if (square) {
      sq = q4(rng_.uniform(0.08, 0.3));
      half = half_len = 0.5 * sq * std::sqrt(2.0);
      it.size = sq;
    } else {
      pole_r = q4(0.5 * rng_.uniform(0.1, 0.3));
      half = half_len = pole_r;
      it.size = 2 * pole_r;
    }
    it.group_kind = "pole";
    it.cls = HazardClass::kObstacle;
  } else if (kind == "table") {
    tl = q4(rng_.uniform(0.6, 1.6));
    tw = q4(rng_.uniform(0.5, 1.0));
    height = q4(rng_.uniform(0.5, 1.2));
    top_th = q4(rng_.uniform(0.02, 0.05));
    leg_r = q4(0.5 * rng_.uniform(0.02, 0.05));
    inset = q4(rng_.uniform(0.02, 0.1));
    half = 0.5 * tw;
    half_len = 0.5 * tl;
    it.group_kind = "overhang";
    it.cls = HazardClass::kOverhang;
    it.size = height;
  } else if (kind == "shelf") {
    wall_len = q4(rng_.uniform(1.5, 3.0));
    wall_h = q4(rng_.uniform(1.8, 2.5));
    shelf_d = q4(rng_.uniform(0.25, 0.5));
    shelf_th = q4(rng_.uniform(0.02, 0.04));
    shelf_len = q4(wall_len - rng_.uniform(0.0, 0.6));
    height = q4(rng_.uniform(0.5, 1.2));
    half = 0.5 * (shelf_d + 0.12);
    half_len = 0.5 * wall_len;
    it.group_kind = "overhang";
    it.cls = HazardClass::kOverhang;
    it.size = height;
  } else if (kind == "legs") {
    const double u = rng_.uniform();
    legs = u < 0.2 ? 1 : (u < 0.5 ? 2 : 4);
    leg_r = q4(0.5 * rng_.uniform(0.02, 0.05));
    height = q4(rng_.uniform(0.4, 1.0));
    leg_sp = q4(legs == 2 ? rng_.uniform(0.4, 1.0) : rng_.uniform(0.35, 0.6));
    half = legs == 4 ? 0.5 * leg_sp + leg_r : leg_r;
    half_len = legs == 1 ? leg_r : 0.5 * leg_sp + leg_r;
    it.group_kind = "legs";
    it.cls = HazardClass::kObstacle;
    it.size = 2 * leg_r;
  } else {  // kerb_stone, box, bag: 5-15 cm high
    const double h = q4(rng_.uniform(0.05, 0.15));
    if (kind == "kerb_stone") {
      low_size = Vec3(q4(rng_.uniform(0.4, 1.0)), q4(rng_.uniform(0.1, 0.2)), h);
    } else if (kind == "box") {
      low_size = Vec3(q4(rng_.uniform(0.2, 0.6)), q4(rng_.uniform(0.2, 0.6)), h);
    } else {
      low_size = Vec3(q4(rng_.uniform(0.3, 0.6)), q4(rng_.uniform(0.25, 0.45)), h);
    }
    half = 0.5 * low_size.y();
    half_len = 0.5 * low_size.x();
    height = h;
    it.group_kind = "low";
    it.cls = HazardClass::kObstacle;
    it.size = h;
  }
  // Placement: beside a drive at a chosen lateral clearance (the item's long axis along it), or
  // ahead of the robot at some frame.
  Anchor a;
  double yaw;
  if (rng_.chance(0.6) && beside(passClearance() + half, &a)) {
    yaw = a.yaw;
  } else {
    a = ahead(1.5, 4.5, 25.0);
    yaw = a.yaw + M_PI / 2.0 + rng_.uniform(-30.0, 30.0) * kDeg;  // across the view
  }
  yaw = q2(yaw / kDeg) * kDeg;
  const Vec2 c = q4(a.p), u = dir(yaw), w = perp(u);
  const std::string yaw_txt = num(yaw / kDeg);
  it.position = c;
  if (kind == "pole" || (kind == "bollard" && !square)) {
    p->entries.push_back("{type: pole, name: " + name(*p, "") + ", at: " + v2(c) +
                         ", radius: " + num(pole_r) + ", height: " + num(height) +
                         ", material: " + (kind == "pole" ? "metal" : "paint") + "}");
    Poly circle;
    for (int k = 0; k < 12; ++k)
      circle.push_back(c + dir(k * M_PI / 6.0) * (pole_r / std::cos(M_PI / 12.0)));
    p->keepout.push_back(circle);
    it.description = kind + " " + num(2 * pole_r * 100) + " cm wide, " + num(height) + " m high";
  } else if (kind == "bollard") {
    p->entries.push_back(
        "{type: box, name: " + name(*p, "") + ", base: " + v3(Vec3(c.x(), c.y(), 0)) +
        ", size: " + v3(Vec3(sq, sq, height)) + ", yaw_deg: " + yaw_txt + ", material: paint}");
    p->keepout.push_back(rect(c, yaw, sq, sq));
    it.description = "square bollard " + num(sq * 100) + " cm wide, " + num(height) + " m high";
  } else if (kind == "table") {
    p->entries.push_back("{type: table, name: " + name(*p, "") + ", center: " + v2(c) +
                         ", size: " + v2(Vec2(tl, tw)) + ", height: " + num(height) +
                         ", top_thickness: " + num(top_th) + ", leg_radius: " + num(leg_r) +
                         ", leg_inset: " + num(inset) + ", yaw_deg: " + yaw_txt +
                         ", material: wood}");
    p->keepout.push_back(rect(c, yaw, tl, tw));
    it.description = "table " + num(tl) + " x " + num(tw) + " m, top at " + num(height) +
                     " m, legs " + num(2 * leg_r * 100) + " cm";
  } else if (kind == "shelf") {
    // The wall on the far side of the footprint from the robot, the board on its near face.
    // Footprint across: the board (shelf_d) on the robot's side, the wall (0.12 m) behind it.
    Vec2 away = a.beside ? Vec2(w * a.side) : Vec2(w.dot(dir(a.yaw)) >= 0.0 ? w : Vec2(-w));
    const Vec2 wc = q4(c + away * (0.5 * shelf_d));
    const Vec2 bc = q4(c - away * 0.06);
    const Vec2 wa = q4(wc - u * (0.5 * wall_len)), wb = q4(wc + u * (0.5 * wall_len));
    p->entries.push_back("{type: wall, name: " + name(*p, "wall") + ", from: " + v2(wa) +
                         ", to: " + v2(wb) + ", height: " + num(wall_h) +
                         ", thickness: 0.12, material: wall}");
    p->entries.push_back("{type: box, name: " + name(*p, "board") +
                         ", center: " + v3(Vec3(bc.x(), bc.y(), height - 0.5 * shelf_th)) +
                         ", size: " + v3(Vec3(shelf_len, shelf_d, shelf_th)) +
                         ", yaw_deg: " + yaw_txt + ", material: wood}");
    p->keepout.push_back(rect(c, yaw, wall_len, shelf_d + 0.12));
    it.description = "shelf " + num(shelf_d) + " m deep at " + num(height) + " m on a wall";
  } else if (kind == "legs") {
    std::vector<Vec2> at;
    if (legs == 1) at = {c};
    if (legs == 2) at = {c - u * (0.5 * leg_sp), c + u * (0.5 * leg_sp)};
    if (legs == 4)
      for (int k = 0; k < 4; ++k)
        at.push_back(c + u * ((k & 1 ? 0.5 : -0.5) * leg_sp) + w * ((k & 2 ? 0.5 : -0.5) * leg_sp));
    for (std::size_t k = 0; k < at.size(); ++k)
      p->entries.push_back("{type: pole, name: " + name(*p, "leg" + std::to_string(k + 1)) +
                           ", at: " + v2(q4(at[k])) + ", radius: " + num(leg_r) +
                           ", height: " + num(height) + ", material: metal}");
    p->keepout.push_back(rect(c, yaw, 2 * half_len, 2 * half));
    it.description = std::to_string(legs) + " thin leg" + (legs > 1 ? "s " : " ") +
                     num(2 * leg_r * 100) + " cm, " + num(height) + " m high";
  } else {
    if (kind == "bag") {
      const Vec2 top(q4(low_size.x() * 0.6), q4(low_size.y() * 0.6));
      p->entries.push_back("{type: mound, name: " + name(*p, "") + ", center: " + v2(c) +
                           ", base_size: " + v2(low_size.head<2>()) + ", top_size: " + v2(top) +
                           ", height: " + num(low_size.z()) + ", yaw_deg: " + yaw_txt +
                           ", material: fabric}");
    } else {
      p->entries.push_back("{type: box, name: " + name(*p, "") +
                           ", base: " + v3(Vec3(c.x(), c.y(), 0)) + ", size: " + v3(low_size) +
                           ", yaw_deg: " + yaw_txt +
                           ", material: " + (kind == "box" ? "cardboard" : "stone") + "}");
    }
    p->keepout.push_back(rect(c, yaw, low_size.x(), low_size.y()));
    it.description = kind + " " + num(low_size.z() * 100) + " cm high";
  }
  for (const Poly& k : p->keepout)
    for (const Vec2& v : k)
      p->look.emplace_back(v.x(), v.y(), std::min(0.5 * height, 0.5));
  p->look.emplace_back(c.x(), c.y(), height);
  return true;
}

// wall (2-5 m, 1-2.5 m high) or doorway (a wall with a 0.8-1.2 m gap), across the view ahead or
// along a drive.
bool Builder::wall(bool doorway, Plan* p) {
  const double len = q4(doorway ? rng_.uniform(3.0, 6.0) : rng_.uniform(2.0, 5.0));
  const double h = q4(doorway ? rng_.uniform(2.0, 2.5) : rng_.uniform(1.0, 2.5));
  const double th = q4(rng_.uniform(0.1, 0.2));
  const double gap = q4(rng_.uniform(0.8, 1.2));
  Anchor a;
  double yaw;
  if (!doorway && rng_.chance(0.4) && beside(passClearance() + 0.5 * th, &a)) {
    yaw = a.yaw;
  } else {
    a = ahead(2.0, 4.5, 20.0);
    yaw = a.yaw + M_PI / 2.0 + rng_.uniform(-20.0, 20.0) * kDeg;
  }
  yaw = q2(yaw / kDeg) * kDeg;
  const Vec2 c = q4(a.p), u = dir(yaw);
  HazardItem& it = p->item;
  it.group_kind = "wall";
  it.cls = HazardClass::kObstacle;
  it.position = c;
  if (!doorway) {
    const Vec2 wa = q4(c - u * (0.5 * len)), wb = q4(c + u * (0.5 * len));
    p->entries.push_back("{type: wall, name: " + name(*p, "") + ", from: " + v2(wa) +
                         ", to: " + v2(wb) + ", height: " + num(h) + ", thickness: " + num(th) +
                         ", material: wall}");
    p->keepout.push_back(rect(c, yaw, len, th));
    it.size = h;
    it.description = "wall " + num(len) + " m long, " + num(h) + " m high";
    for (double s = -0.5; s <= 0.5; s += 0.125)
      p->look.emplace_back(c.x() + u.x() * s * len, c.y() + u.y() * s * len, 0.5);
    return true;
  }
  // The gap near the middle, so that it is in view.
  const double off = rng_.uniform(-0.5, 0.5);
  const Vec2 g = q4(c + u * off);
  const Vec2 a0 = q4(c - u * (0.5 * len)), a1 = q4(g - u * (0.5 * gap));
  const Vec2 b0 = q4(g + u * (0.5 * gap)), b1 = q4(c + u * (0.5 * len));
  const double door_h = 2.0;
  for (const auto& seg : {std::make_pair(a0, a1), std::make_pair(b0, b1)}) {
    const bool first = seg.first == a0;
    p->entries.push_back("{type: wall, name: " + name(*p, first ? "left" : "right") +
                         ", from: " + v2(seg.first) + ", to: " + v2(seg.second) +
                         ", height: " + num(h) + ", thickness: " + num(th) + ", material: wall}");
    const double L = (seg.second - seg.first).norm();
    p->keepout.push_back(rect(0.5 * (seg.first + seg.second), yaw, L, th));
    for (double s = 0.0; s <= 1.0; s += 0.25) {
      const Vec2 q = seg.first + (seg.second - seg.first) * s;
      p->look.emplace_back(q.x(), q.y(), 0.5);
    }
  }
  if (h > door_h + 0.05) {  // the lintel above the gap: above robot height, driven under
    p->entries.push_back("{type: box, name: " + name(*p, "lintel") +
                         ", center: " + v3(Vec3(g.x(), g.y(), 0.5 * (door_h + h))) +
                         ", size: " + v3(Vec3(gap + 0.02, th, h - door_h)) +
                         ", yaw_deg: " + num(yaw / kDeg) + ", material: wall}");
  }
  p->look.emplace_back(g.x(), g.y(), 0.02);  // the floor in the gap
  it.size = gap;
  it.description = "doorway " + num(gap) + " m wide in a " + num(len) + " m wall";
  return true;
}

bool Builder::build(const std::string& kind, int index, const std::vector<Plan>& placed,
                    Plan* out) {
  Plan p;
  p.item.kind = kind;
  p.item.group = "h" + std::to_string(index) + "_" + kind;
  bool ok = false;
  if (kind == "curb_down" || kind == "curb_up")
    ok = curb(kind, &p);
  else if (kind == "curb_cut_down" || kind == "curb_cut_up")
    ok = curbCut(kind == "curb_cut_down", &p);
  else if (kind == "step_up" || kind == "step_down")
    ok = step(kind == "step_up", &p);
  else if (kind == "ramp_up" || kind == "ramp_down")
    ok = ramp(kind == "ramp_up", &p);
  else if (kind == "platform_edge" || kind == "loading_dock")
    ok = deepEdge(kind, &p);
  else if (kind == "pit" || kind == "light_well")
    ok = pit(kind, &p);
  else if (kind == "stairs_down")
    ok = stairs(&p);
  else if (kind == "wall" || kind == "doorway")
    ok = wall(kind == "doorway", &p);
  else
    ok = obstacle(kind, &p);
  if (!ok || p.keepout.empty()) return false;
  for (Poly& k : p.keepout) {
    if (signedArea(k) < 0.0) std::reverse(k.begin(), k.end());
    if (k.size() < 3) return false;
  }
  // Inside the area (edges reach its border by construction), clear of the trajectory and of the
  // other items.
  if (!p.edge) {
    const Eigen::AlignedBox2d b = boxOf(area_);
    const Poly inner = {b.min() + Vec2(0.3, 0.3), Vec2(b.max().x() - 0.3, b.min().y() + 0.3),
                        b.max() - Vec2(0.3, 0.3), Vec2(b.min().x() + 0.3, b.max().y() - 0.3)};
    for (const Poly& k : p.keepout)
      for (const Vec2& v : k)
        if (!insideConvex(v, inner)) return false;
  }
  double clearance = kInf;
  for (const Poly& k : p.keepout)
    clearance = std::min(clearance, routeDistance(route_, k));
  if (clearance < cfg_.min_clearance) return false;
  for (const Plan& q : placed)
    for (const Poly& k : p.keepout)
      for (const Poly& l : q.keepout)
        if (polyDistance(k, l) < kItemGap) return false;
  p.item.clearance = clearance;
  *out = std::move(p);
  return true;
}

}  // namespace procedural
}  // namespace dataset
}  // namespace stereo_safety_map
