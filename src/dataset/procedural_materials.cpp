// Procedural scenes (procedural_internal.h): floor materials.
#include "procedural_internal.h"

#include <algorithm>

namespace stereo_safety_map {
namespace dataset {
namespace procedural {

Vec3 greyish(PortableRng& rng, double lo, double hi) {
  const double g = rng.uniform(lo, hi);
  const Vec3 c(g * (1.0 + rng.uniform(-0.05, 0.08)), g, g * (1.0 + rng.uniform(-0.1, 0.03)));
  return Vec3(q3(std::min(1.0, c.x())), q3(c.y()), q3(std::min(1.0, c.z())));
}
Vec3 tinted(PortableRng& rng, const Vec3& base, double jitter) {
  Vec3 c;
  for (int i = 0; i < 3; ++i)
    c[i] = q3(std::min(1.0, std::max(0.02, base[i] * (1.0 + rng.uniform(-jitter, jitter)))));
  return c;
}

// A floor of the given kind (ranges documented at floorKinds() in the header).
Mat floorMaterial(const std::string& kind, PortableRng& rng) {
  Mat m;
  m.angle = q2(rng.uniform(0.0, 90.0));
  if (kind == "polished") {
    if (rng.chance(0.5)) {
      m.texture = "plain";
    } else {
      m.texture = "noise";
      m.scale = q3(rng.uniform(0.5, 2.0));
      m.contrast = q3(rng.uniform(0.0, 0.03));
    }
    m.grain = q3(rng.uniform(0.0, 0.005));
    m.colour = greyish(rng, 0.45, 0.8);
  } else if (kind == "matt") {
    m.scale = q3(rng.uniform(0.3, 1.0));
    m.contrast = q3(rng.uniform(0.03, 0.08));
    m.grain = q3(rng.uniform(0.005, 0.02));
    m.colour = greyish(rng, 0.35, 0.75);
  } else if (kind == "carpet") {
    static const Vec3 kCarpets[] = {{0.30, 0.33, 0.42},
                                    {0.45, 0.25, 0.22},
                                    {0.32, 0.38, 0.30},
                                    {0.55, 0.50, 0.42},
                                    {0.35, 0.35, 0.36}};
    m.scale = q3(rng.uniform(0.05, 0.2));
    m.contrast = q3(rng.uniform(0.08, 0.2));
    m.grain = q3(rng.uniform(0.06, 0.12));
    m.grain_size = q3(rng.uniform(0.004, 0.008));
    m.colour = tinted(rng, kCarpets[rng.integer(0, 4)], 0.15);
  } else if (kind == "tiles") {
    m.texture = "tiles";
    m.scale = q3(rng.uniform(0.2, 0.6));
    m.contrast = q3(rng.uniform(0.04, 0.15));
    m.line_width = q3(rng.uniform(0.015, 0.05));
    m.detail = q3(rng.uniform(0.1, 0.5));
    m.grain = q3(rng.uniform(0.0, 0.03));
    m.colour = greyish(rng, 0.5, 0.85);
  } else if (kind == "concrete") {
    m.scale = q3(rng.uniform(0.3, 1.5));
    m.contrast = q3(rng.uniform(0.06, 0.15));
    m.grain = q3(rng.uniform(0.02, 0.06));
    m.colour = greyish(rng, 0.45, 0.7);
  } else if (kind == "paving") {
    m.texture = rng.chance(0.5) ? "bricks" : "tiles";
    m.scale = q3(rng.uniform(0.1, 0.3));
    m.contrast = q3(rng.uniform(0.1, 0.3));
    m.line_width = q3(rng.uniform(0.04, 0.1));
    m.detail = q3(rng.uniform(0.2, 0.6));
    m.grain = q3(rng.uniform(0.03, 0.08));
    m.colour =
        rng.chance(0.5) ? greyish(rng, 0.4, 0.65) : tinted(rng, Vec3(0.55, 0.38, 0.30), 0.15);
  } else {  // asphalt
    m.texture = "speckle";
    m.scale = q3(rng.uniform(0.1, 0.4));
    m.contrast = q3(rng.uniform(0.2, 0.4));
    m.grain = q3(rng.uniform(0.05, 0.1));
    m.colour = greyish(rng, 0.22, 0.36);
  }
  return m;
}

}  // namespace procedural
}  // namespace dataset
}  // namespace stereo_safety_map
