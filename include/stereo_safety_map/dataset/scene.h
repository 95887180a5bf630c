// Synthetic benchmark scenes: the geometry and surface appearance of urban wheelchair scenes
// (level floors, ramps, curbs, steps, boxes, walls, poles, railings, tables; 000 Table I and
// Sec. VII-A) built from two convex solids, the convex polyhedron and the finite cylinder, so that
// the stereo renderer, the laser simulator and the analytic ground truth all intersect the very
// same shapes. ROS-free.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

/// Procedural texture of a material, evaluated on the surface in world coordinates so that the
/// left and the right image see the same pattern at the same 3D point.
enum class TextureKind : std::uint8_t {
  kPlain = 0,  ///< uniform albedo: textureless, stereo fails here (000 Sec. VII-A)
  kNoise,      ///< fractal value noise (concrete, plaster, carpet); `scale` = largest feature [m]
  kSpeckle,    ///< fine noise with dark and bright spots (asphalt, gravel, terrazzo)
  kTiles,      ///< square tiles of side `scale` with grout lines and per-tile shade (repeating)
  kBricks,     ///< running-bond bricks `scale` long and scale/3 high with mortar lines
  kStripes,    ///< periodic stripes of period `scale` along the texture u axis (repeating)
  kChecker,    ///< checkerboard of side `scale`
};

/// Name used in scene files ("plain", "noise", ...); parseTextureKind is its inverse.
const char* toString(TextureKind k);
bool parseTextureKind(const std::string& s, TextureKind* k);

/// Surface appearance. Albedo = colour * (1 + contrast * t) where t in [-1, 1] is the texture.
/// Default grain of textured materials (see Material::grain): a few percent of albedo
/// modulation, about what a broom-finished concrete slab or fine asphalt shows.
constexpr double kDefaultGrain = 0.05;

struct Material {
  TextureKind texture = TextureKind::kNoise;
  double scale = 0.2;     ///< feature size / period [m], > 0
  double contrast = 0.3;  ///< relative albedo modulation, in [0, 1]
  Eigen::Vector3f colour = Eigen::Vector3f(0.5f, 0.5f, 0.5f);  ///< linear RGB albedo in [0, 1]
  double line_width = 0.06;  ///< grout / mortar / joint width as a fraction of scale, in [0, 0.5)
  double detail = 0.3;       ///< fine noise inside tiles and bricks, fraction of contrast, [0, 1]
  /// Surface grain: fine albedo noise (aggregate, pores, fibres) at the centimetre scale, as
  /// real concrete, asphalt, terrazzo or carpet show, independent of the pattern above. Relative
  /// albedo modulation in [0, 1]; negative = the default for the texture kind (0 for `plain`,
  /// kDefaultGrain otherwise). Band-limited to the pixel footprint like the pattern, so it fades
  /// with distance as on a real camera.
  double grain = -1.0;
  double grain_size = 0.012;  ///< finest grain wavelength [m], > 0; octaves at 1, 2 and 4 x
  double angle_deg = 0.0;     ///< rotation of the texture axes on the surface [deg]
  std::uint32_t seed = 0;     ///< decorrelates materials that share parameters

  std::string validate() const;
  /// The grain amplitude in effect (resolves the negative default).
  double effectiveGrain() const {
    if (grain >= 0.0) return grain;
    return texture == TextureKind::kPlain ? 0.0 : kDefaultGrain;
  }
};

/// A half-space n . x <= d with unit normal n pointing out of the solid.
struct HalfSpace {
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  double d = 0.0;
};

/// Oriented bounding box, used for the ground-truth obstacle list.
struct OrientedBox {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_size = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< columns are the box axes in world
};

/// A ray p(t) = origin + t * dir. dir need not be unit: t is measured in units of |dir|.
struct Ray {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d dir = Eigen::Vector3d::UnitX();
};

/// Nearest intersection of a ray with a scene.
struct Hit {
  double t = std::numeric_limits<double>::infinity();
  int primitive = -1;  ///< index into Scene::primitives, -1 = no hit
  int face = -1;       ///< convex: index of the half-space entered; cylinder: -1 side, -2 cap
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, world, pointing out of the solid
};

/// One convex solid of a scene.
struct Primitive {
  enum class Shape : std::uint8_t { kConvex = 0, kCylinder = 1 };

  Shape shape = Shape::kConvex;
  std::string name;   ///< unique within the scene
  std::string group;  ///< the scene-file entry it came from (a table gives 5 primitives)
  std::string type;   ///< the scene-file type ("floor", "ramp", "table", ...)
  /// A ground surface: its top face is a surface the robot may drive on (floors, ramps, steps,
  /// platforms). Everything else is an obstacle where it is below robot height (000 Sec. VI).
  bool ground = false;
  int material = 0;  ///< index into Scene::materials
  int side_material =
      -1;  ///< for faces whose normal is less than ~45 deg from horizontal; -1 = same

  // kConvex
  std::vector<HalfSpace> planes;          ///< the solid is the intersection of these
  std::vector<Eigen::Vector3d> vertices;  ///< corners (computed from the planes)
  int top_face = -1;                      ///< plane with the most upward normal (ground surface)

  // kCylinder: axis from p0 to p0 + axis * length, radius
  Eigen::Vector3d p0 = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< unit
  double length = 0.0;
  double radius = 0.0;

  Eigen::AlignedBox3d bounds;  ///< world axis-aligned bounding box
  OrientedBox obb;             ///< tight oriented box (ground-truth obstacles)

  /// Entry and exit parameters of the ray through the solid (it is convex, so one interval).
  /// Returns false when the ray's line misses it. `entry_face` receives the face of t_in
  /// (see Hit::face); t_in may be negative when the origin is inside.
  bool interval(const Ray& ray, double* t_in, double* t_out, int* entry_face) const;

  /// Outward unit normal of a face (Hit::face) at point p.
  Eigen::Vector3d normalAt(int face, const Eigen::Vector3d& p) const;

  /// Height of the top face above (x, y) when (x, y) lies inside the top face's footprint
  /// (convex only; tolerance `eps` [m] on the footprint's border).
  bool topHeightAt(double x, double y, double* z, double eps = 1e-9) const;

  /// The top face's polygon (counter-clockwise seen from above) in world coordinates.
  std::vector<Eigen::Vector3d> topPolygon() const;

  /// Moves the solid by `offset`.
  void translate(const Eigen::Vector3d& offset);
};

/// Directional light plus ambient term of the Lambertian shading.
struct Lighting {
  Eigen::Vector3d direction = Eigen::Vector3d(0.3, 0.2, -1.0);  ///< direction light travels
  double ambient = 0.4;  ///< radiance factor of surfaces facing away from the light
  double diffuse = 0.6;  ///< added times cos(incidence)
  std::string validate() const;
};

/// The world: solids, their materials, lighting and the colour of rays that hit nothing.
struct Scene {
  std::string name = "scene";
  std::string description;
  bool outdoor = false;
  Lighting lighting;
  Eigen::Vector3f sky_horizon = Eigen::Vector3f(0.80f, 0.83f, 0.88f);  ///< background at horizon
  Eigen::Vector3f sky_zenith = Eigen::Vector3f(0.55f, 0.65f, 0.85f);   ///< background straight up
  std::vector<Material> materials;
  std::vector<std::string> material_names;  ///< parallel to materials
  std::vector<Primitive> primitives;

  /// Adds a material (or returns the index of the one with this name).
  int addMaterial(const std::string& name, const Material& m);
  int findMaterial(const std::string& name) const;
  /// Appends a primitive, giving it a unique name when empty; returns its index.
  int add(Primitive p);

  /// Nearest hit with t in (t_min, t_max), brute force over all primitives (laser, tests).
  bool intersect(const Ray& ray, double t_min, double t_max, Hit* hit) const;

  /// Bounding box of all primitives (empty box when none).
  Eigen::AlignedBox3d bounds() const;

  /// Empty when usable; otherwise the first problem (bad material index, degenerate solid, ...).
  std::string validate() const;
};

// ---- builders: each returns solids with name/group/type/ground/material left for the caller ----

/// Box of the given full size centred at `center`, rotated by R (columns = box axes).
Primitive makeBox(const Eigen::Vector3d& center, const Eigen::Vector3d& size,
                  const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity());

/// Rotation yaw about z, then pitch about the new y, then roll about the new x (all radians).
Eigen::Matrix3d rotationYpr(double yaw, double pitch = 0.0, double roll = 0.0);

/// Convex solid from half-spaces; vertices, bounds and obb are computed. Returns a primitive
/// with no vertices when the half-spaces do not bound a solid.
Primitive makeConvex(const std::vector<HalfSpace>& planes);

/// Ramp: rectangle of width `width` from edge midpoint `from` (height z_from) to `to` (height
/// z_to), a solid down to min(z_from, z_to) - thickness.
Primitive makeRamp(const Eigen::Vector2d& from, const Eigen::Vector2d& to, double width,
                   double z_from, double z_to, double thickness);

/// Truncated pyramid (mound): base rectangle at z_base, top rectangle `height` higher, both
/// centred on `center` and rotated by yaw (radians).
Primitive makeFrustum(const Eigen::Vector2d& center, double z_base,
                      const Eigen::Vector2d& base_size, const Eigen::Vector2d& top_size,
                      double height, double yaw);

/// Convex slab: its top face is the planar convex polygon `top` (corners in either order seen
/// from above, planar within 1 mm, not vertical), vertical sides, the bottom `thickness` below its
/// lowest corner. Curb-cut flares (triangles), floors cut around a sunken area at an angle.
/// Returns a primitive with no vertices when the polygon is not planar, not convex or degenerate.
Primitive makeSlab(const std::vector<Eigen::Vector3d>& top, double thickness);

/// Finite cylinder between the centres of its two caps.
Primitive makeCylinder(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, double radius);

}  // namespace dataset
}  // namespace stereo_safety_map
