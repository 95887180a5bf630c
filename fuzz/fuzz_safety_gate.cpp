// libFuzzer target: the velocity safety gate (include/stereo_safety_map/core/safety_gate.h) on
// arbitrary maps, poses, commands and map ages, with observe() in between (memory of safe cells).
//
// Inputs: maps of 0..60 x 0..60 cells at odd resolutions and offsets, any labels (also outside
// 0..4 cast in), drop-off arrays of the right or wrong size, segment indices in and out of range,
// planes with NaN / inf / huge coefficients and slopes; poses, commands and ages that are NaN,
// inf, huge or ordinary; valid configurations drawn at random.
//
// Contracts checked (safety_gate.h): nothing throws or crashes; the gate never adds speed, never
// changes a sign, keeps the curvature when it scales; a zero command gives zero; a non-finite
// command gives a stop; an allowed command passes unchanged; a stopped one is zero.
#include "fuzz_common.h"

#include "stereo_safety_map/core/safety_gate.h"

#include <cmath>
#include <cstdint>

using namespace stereo_safety_map;
using ssm_fuzz::specialDouble;

namespace {

SafetyMap randomMap(FuzzedDataProvider& fdp) {
  SafetyMap m;
  m.width = fdp.ConsumeIntegralInRange<int>(0, 60);
  m.height = fdp.ConsumeIntegralInRange<int>(0, 60);
  m.min_u = fdp.ConsumeIntegralInRange<int>(-80, 20);
  m.min_v = fdp.ConsumeIntegralInRange<int>(-80, 20);
  m.resolution = fdp.ConsumeBool() ? 0.1 : specialDouble(fdp, 0.01, 1.0);
  const std::size_t n = static_cast<std::size_t>(m.width) * m.height;
  const bool wrong_size = fdp.ConsumeIntegralInRange<int>(0, 15) == 0;
  m.labels.resize(wrong_size ? n / 2 : n);
  for (auto& l : m.labels)
    l = static_cast<SafetyLabel>(fdp.ConsumeIntegralInRange<int>(0, 4));
  m.drop_off.resize(fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? 0 : n);
  for (auto& d : m.drop_off)
    d = fdp.ConsumeIntegralInRange<int>(0, 9) == 0;
  const int nseg = fdp.ConsumeIntegralInRange<int>(0, 6);
  for (int k = 0; k < nseg; ++k) {
    SegmentInfo s;
    s.id = k;
    s.label = static_cast<SafetyLabel>(fdp.ConsumeIntegralInRange<int>(0, 4));
    s.plane.valid = fdp.ConsumeBool();
    s.plane.a = specialDouble(fdp, -1.0, 1.0);
    s.plane.b = specialDouble(fdp, -1.0, 1.0);
    s.plane.slope_deg = specialDouble(fdp, 0.0, 40.0);
    m.segments.push_back(s);
  }
  m.segment.resize(fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? 0 : n);
  for (std::size_t i = 0; i < m.segment.size(); ++i) {
    m.segment[i] = fdp.ConsumeIntegralInRange<int>(-2, nseg + 1);
    if (m.segment[i] >= 0 && m.segment[i] < nseg && fdp.ConsumeBool()) {
      m.segments[m.segment[i]].cells.push_back(static_cast<int>(i));
    }
  }
  if (nseg > 0 && fdp.ConsumeIntegralInRange<int>(0, 7) == 0) {
    m.segments[0].cells.push_back(fdp.ConsumeIntegral<int>());  // an index out of the map
  }
  return m;
}

SafetyGateConfig randomConfig(FuzzedDataProvider& fdp) {
  SafetyGateConfig c;
  if (fdp.ConsumeBool()) return c;
  c.footprint_padding = fdp.ConsumeFloatingPointInRange<double>(0.0, 0.3);
  c.deceleration = fdp.ConsumeFloatingPointInRange<double>(0.05, 5.0);
  c.angular_deceleration = fdp.ConsumeFloatingPointInRange<double>(0.05, 10.0);
  c.reaction_time = fdp.ConsumeFloatingPointInRange<double>(0.0, 1.0);
  c.margin = fdp.ConsumeFloatingPointInRange<double>(0.0, 1.0);
  c.margin_angle_deg = fdp.ConsumeFloatingPointInRange<double>(0.0, 45.0);
  c.max_hole_cells = fdp.ConsumeIntegralInRange<int>(0, 12);
  c.safe_memory = fdp.ConsumeFloatingPointInRange<double>(0.0, 5.0);
  c.ramp_foot_height = fdp.ConsumeFloatingPointInRange<double>(0.0, 0.3);
  c.max_incline_deg = fdp.ConsumeFloatingPointInRange<double>(1.0, 30.0);
  c.reverse_speed_limit = fdp.ConsumeFloatingPointInRange<double>(0.0, 1.0);
  c.slow_down = fdp.ConsumeBool();
  c.step_fraction = fdp.ConsumeFloatingPointInRange<double>(0.2, 1.0);
  c.max_step_angle_deg = fdp.ConsumeFloatingPointInRange<double>(1.0, 20.0);
  if (fdp.ConsumeBool()) {  // a concave polygon
    c.footprint = {{0.8, 0.4}, {-0.4, 0.4}, {-0.4, -0.4}, {0.8, -0.4}, {0.6, 0.0}};
  }
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider fdp(data, size);
  const SafetyGateConfig config = randomConfig(fdp);
  FUZZ_CHECK(config.validate().empty());
  SafetyGate gate(config);
  GateDecision d;
  const int rounds = fdp.ConsumeIntegralInRange<int>(1, 4);
  for (int r = 0; r < rounds; ++r) {
    const SafetyMap map = randomMap(fdp);
    gate.observe(map, specialDouble(fdp, 0.0, 100.0));
    const Pose2D pose{specialDouble(fdp, -3.0, 3.0), specialDouble(fdp, -3.0, 3.0),
                      specialDouble(fdp, -4.0, 4.0)};
    const double v = specialDouble(fdp, -2.0, 2.0);
    const double w = fdp.ConsumeBool() ? 0.0 : specialDouble(fdp, -2.0, 2.0);
    gate.evaluate(map, pose, v, w, specialDouble(fdp, -1.0, 1.0), &d);
    if (!std::isfinite(v) || !std::isfinite(w)) {
      FUZZ_CHECK(d.state == GateState::kStopped && d.v == 0.0 && d.omega == 0.0);
      continue;
    }
    FUZZ_CHECK(std::abs(d.v) <= std::abs(v));
    FUZZ_CHECK(std::abs(d.omega) <= std::abs(w));
    FUZZ_CHECK(d.v * v >= 0.0 && d.omega * w >= 0.0);
    if (v == 0.0 && w == 0.0) FUZZ_CHECK(d.v == 0.0 && d.omega == 0.0);
    if (d.state == GateState::kStopped) FUZZ_CHECK(d.v == 0.0 && d.omega == 0.0);
    if (d.state == GateState::kAllowed) FUZZ_CHECK(d.v == v && d.omega == w);
    if (d.state == GateState::kSlowed) {
      // Slowing keeps the path: one scale in (0, 1) for both parts of the command.
      FUZZ_CHECK(d.scale > 0.0 && d.scale < 1.0);
      FUZZ_CHECK(d.v == d.scale * v && d.omega == d.scale * w);
      // The curvature itself, where no quotient or product under- or overflows (a denormal speed
      // rounds to zero when scaled: CI crash of 2026-11-27, v = denorm_min).
      const double c_in = w / v;
      const double c_out = d.omega / d.v;
      if (std::isnormal(d.v) && std::isnormal(d.omega) && std::isnormal(c_in) &&
          std::isnormal(c_out)) {
        FUZZ_CHECK(std::abs(c_out - c_in) <= 1e-9 * std::abs(c_in));
      }
    }
  }
  return 0;
}
