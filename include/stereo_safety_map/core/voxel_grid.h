// 3D log-odds occupancy grid with a fixed-capacity point list per voxel (paper 000, Sec. IV)
// and the running moments of every point each voxel received (ours, VoxelMoments).
//
// ROS-free. The grid is robot-local and fixed-size: voxels are addressed by the global integer
// indices of Eq. (1) (u, v, w) = (round(x / l_v), round(y / l_v), round(z / l_v)) and stored in a
// ring buffer, so scrolling the window with the robot moves no memory: voxels that leave the
// window are cleared and reused for the ones that enter it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <utility>
#include <vector>

namespace stereo_safety_map {

/// Global voxel index of Eq. (1) (000, Sec. IV). w is the "indexed height".
struct VoxelIndex {
  int u = 0;
  int v = 0;
  int w = 0;
  bool operator==(const VoxelIndex& o) const { return u == o.u && v == o.v && w == o.w; }
  bool operator!=(const VoxelIndex& o) const { return !(*this == o); }
};

/// Parameters of the grid and of its sensor model. Defaults are paper 000's values.
struct VoxelGridConfig {
  double voxel_size = 0.1;     ///< l_v [m], 000 Sec. IV ("l_v = 0.1 m")
  double size_x = 10.0;        ///< extent along x [m], 000 Sec. VII-D (10 x 10 x 3 m map)
  double size_y = 10.0;        ///< extent along y [m]
  double size_z = 3.0;         ///< extent along z [m]
  double z_below_robot = 1.0;  ///< how far the window reaches below the robot's base [m]
                               ///< (drop-offs down to this depth stay inside the grid)
  int incr_high = 10;          ///< incr_H, added to the voxel the point falls in (000 Sec. IV)
  int incr_low = 4;            ///< incr_L, added to its fore and aft neighbours on the ray
  int decr = 1;                ///< subtracted from every voxel between fore neighbour and camera
                               ///< (000 Sec. IV / VII-A evaluate 1, 3 and 5)
  int occ_threshold = 100;     ///< occ_t: a voxel is occupied at LOP >= occ_t (000 Sec. IV)
  int lop_min = -100;          ///< LOP clamp so that the map can change its mind (not in the paper)
  int lop_max = 250;           ///< LOP clamp (not in the paper)
  int point_list_capacity = 8;  ///< points kept per voxel, closest to the camera first
  double max_range = 8.0;       ///< points farther than this from the camera are ignored [m]
  double min_range = 0.2;       ///< points closer than this are ignored [m]
  /// incr_L where the point's range error reaches (ours; 0 = 000 Sec. IV: the fore and aft
  /// neighbours always get incr_L). incr_L spreads a point's evidence along its ray because its
  /// range is uncertain; stereo's depth error grows with the square of the depth (001 Sec. 4.1:
  /// sigma_Z = Z^2 sigma_d / (f b)). A floor point whose ray enters its voxel through the top
  /// face gives incr_L to the voxel above the floor, and one such point per frame out-weighs the
  /// passing rays' decr: the voxel above the floor fills (with few points of its own, the
  /// floor's noise tail: a rule passing over top voxels with few points changed nothing) and the
  /// floor reads a voxel high (docs/evaluation.md, "The fore neighbour above the floor"). With this
  /// > 0 and the stereo geometry known (setStereoGeometry()), a neighbour gets incr_L only when the
  /// distance along the ray from the point to the face it shares with the endpoint's voxel is at
  /// most neighbour_sigmas x sigma_d r^2 / (f b) at the point's range r (r >= Z: at least the
  /// error along the ray, |P| Z sigma_d / (f b)); otherwise it gets nothing (the fore neighbour
  /// is not decremented either). Measured on the open-world dev split (same section): at 2 or 4
  /// nothing changes (FP 21.7 %: the voxels that matter are fed from 2-4 m, where 2 sigma is
  /// more than l_v); at 0.5 / 1 FP 18.2 / 19.6 % with FN 1.5 -> 1.8 / 2.0 % and more forgotten
  /// obstacle cells, a worse trade than halving incr_low. Off by default. [0, 100].
  double neighbour_sigmas = 0.0;
  /// sigma_d [px] of neighbour_sigmas: the disparity error's standard deviation (001 Sec. 4.1;
  /// the landmark filter's default). (0, 10].
  double disparity_sigma = 0.5;
  /// incr_L of the fore neighbour alone (ours; -1 = incr_low, as 000 Sec. IV gives both
  /// neighbours). The fore neighbour of a floor point whose ray enters its voxel through the
  /// top face is the voxel above the floor (neighbour_sigmas above); the aft neighbour of a
  /// point on a surface lies behind or under it. The measurement refutes that the fore neighbour
  /// alone makes the false positives: the aft neighbours' increments feed them too. Measured on the
  /// open-world dev split (docs/evaluation.md, "The fore neighbour alone"): 0 takes FP 21.7 -> 14.0
  /// % but FN 1.5 -> 3.7 % (steps down are seen through the fore neighbours too), 2 FP 18.3 %,
  /// FN 2.3 %: both worse than incr_low 2 for both neighbours. Off by default. [-1, 32767].
  int incr_low_fore = -1;

  /// Empty when valid, otherwise a message naming the first offending parameter and its range.
  std::string validate() const;
};

/// Counters of one integrate() call. points_in = points_non_finite + points_out_of_range +
/// points_duplicate + points_used; points_outside_grid counts the used points whose endpoint
/// lies outside the window.
struct IntegrationStats {
  std::size_t points_in = 0;            ///< points handed in
  std::size_t points_non_finite = 0;    ///< NaN / inf, skipped
  std::size_t points_out_of_range = 0;  ///< outside [min_range, max_range], skipped
  std::size_t points_outside_grid = 0;  ///< endpoint outside the window (ray still clears)
  std::size_t points_duplicate = 0;     ///< voxel already had its point this frame (000 Sec. IV)
  std::size_t points_used = 0;          ///< points whose ray was cast (incl. outside_grid)
  std::size_t voxels_decremented = 0;   ///< free-space updates applied
};

/// One point of a voxel's list and its distance to the camera when it was seen.
struct VoxelPoint {
  Eigen::Vector3f position;  ///< fixed frame [m]
  float range;               ///< distance to the camera at observation [m]
};

/// Running moments of every point a voxel received (ours): the sums of x, y, z and their weight,
/// one point per voxel per frame (000 Sec. IV), every one counted, not only the list's closest.
/// Older points fade: once the weight reaches VoxelGrid::kMomentWindow, each new point first
/// scales the sums by (N - 1) / N, an exponential mean over about the last N points, so a voxel
/// whose surface moved follows it.
struct VoxelMoments {
  float sx = 0.0f, sy = 0.0f, sz = 0.0f;
  float weight = 0.0f;
};

/// Read-only view of one voxel's point list, ordered by ascending range.
struct VoxelPointList {
  const VoxelPoint* data = nullptr;
  std::size_t size = 0;
  const VoxelPoint* begin() const { return data; }
  const VoxelPoint* end() const { return data + size; }
  bool empty() const { return size == 0; }
};

namespace detail {
/// std::allocator that default-initialises on resize() instead of value-initialising, so a
/// large buffer whose unused part is never read is not zeroed up front.
template <typename T>
struct DefaultInitAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <typename U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <typename U>
  void construct(U* p) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
}  // namespace detail

class VoxelGrid {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit VoxelGrid(const VoxelGridConfig& config = VoxelGridConfig());

  const VoxelGridConfig& config() const { return config_; }

  /// Number of voxels along each axis (size / l_v rounded).
  int sizeU() const { return nu_; }
  int sizeV() const { return nv_; }
  int sizeW() const { return nw_; }
  /// Smallest global index inside the window; the window is [min, min + size).
  VoxelIndex minIndex() const { return min_; }

  /// Eq. (1): global index of a point (rounding, so voxel u spans [(u - 0.5) l_v, (u + 0.5) l_v)).
  VoxelIndex indexOf(const Eigen::Vector3f& p) const;
  /// Centre of a voxel in the fixed frame: (u, v, w) * l_v.
  Eigen::Vector3f centerOf(const VoxelIndex& i) const;
  bool contains(const VoxelIndex& i) const;

  /// Moves the window by whole voxels so that the robot's base is at its xy centre and
  /// z_below_robot above its bottom. Voxels leaving the window are cleared (LOP 0, no points).
  /// Returns the number of voxels cleared. The first call places the window.
  std::size_t recenter(const Eigen::Vector3f& robot_base_position);

  /// Clears every voxel (LOP 0, empty point lists); keeps the window.
  void clear();

  /// Integrates one frame (000 Sec. IV). `points` are in the sensor frame, `T_fixed_sensor`
  /// maps them to the fixed frame; the camera origin is its translation. Only the first point
  /// that falls into a voxel in this frame is used. Non-finite points are skipped.
  /// Points from index `first_no_carve` on are occupancy evidence alone (ours): the voxel they
  /// fall in and its aft neighbour get their increments, but their rays decrement nothing and
  /// give no fore-neighbour increment. For readings whose depth is less certain than their
  /// presence (the coarse fill of DisparityPipelineConfig::coarse_fill_levels: its window
  /// fattens a far surface over a near edge, and those rays would carve the near surface's
  /// voxels free). They come last, so the other points keep their voxels (one per frame).
  IntegrationStats integrate(const std::vector<Eigen::Vector3f>& points,
                             const Eigen::Isometry3f& T_fixed_sensor,
                             std::size_t first_no_carve = kAllCarve);
  static constexpr std::size_t kAllCarve = static_cast<std::size_t>(-1);

  /// f b [px m] of the stereo camera whose points integrate() receives, for
  /// VoxelGridConfig::neighbour_sigmas; 0 or non-finite = unknown (incr_L as in 000 Sec. IV).
  void setStereoGeometry(double focal_times_baseline);
  /// The last setStereoGeometry()'s f b [px m]; 0 when unknown.
  double focalBaseline() const { return focal_baseline_; }

  /// Log-odds of a voxel; 0 outside the window.
  int logOdds(const VoxelIndex& i) const;
  /// LOP >= occ_t (000 Sec. IV); false outside the window.
  bool isOccupied(const VoxelIndex& i) const;
  /// The voxel's point list (empty outside the window).
  VoxelPointList points(const VoxelIndex& i) const;
  /// The running moments of every point the voxel received (zero weight outside the window or
  /// when it has none). The point list keeps the point_list_capacity points nearest to the
  /// camera: along each ray those are the ones in front of the surface, and a list holds as
  /// many points after 8 observations as after 800; the moments hold them all (ours, for
  /// HeightMapConfig::observation_means).
  VoxelMoments moments(const VoxelIndex& i) const;
  /// Points after which the moments fade (VoxelMoments).
  static constexpr float kMomentWindow = 64.0f;

  /// How many of the frames' points fell into the voxel, every one of them, not only the first
  /// of each frame that 000 Sec. IV integrates (ours, for HeightMapConfig::tail_share): a
  /// discounted sum over the frames, each frame's count fading by (1 - 1 / kHitMassWindow) per
  /// integrated frame since. 000's one update per voxel per frame makes a voxel that a surface's
  /// noise tail reaches with one stray point a frame as occupied as the surface's own voxel,
  /// which receives hundreds; the counts tell the two apart. 0 outside the window.
  float hitMass(const VoxelIndex& i) const;
  /// Mean height [m] of the points behind hitMass() (every point of the frames, faded alike);
  /// NaN when the voxel has none. Unlike the point list (the closest-first few) and moments()
  /// (one point per frame), each point weighs the same, so a voxel that a noise tail reaches
  /// with a few points a frame weighs little beside its neighbour with hundreds.
  float hitMeanZ(const VoxelIndex& i) const;
  /// Mean height [m] of every point (hitMass()-weighted, hitMeanZ()) of the voxels w_from ..
  /// w_to of column (u, v), NaN when they hold none: a surface's stereo noise spreads over
  /// the voxel it lies in and its neighbours, so the mean over the three around a column's top is
  /// the surface's height, not that of the part of its noise one voxel happens to hold.
  float massMeanZ(int u, int v, int w_from, int w_to) const;
  /// Faded hitMass() summed over the voxels w_from .. w_to of column (u, v); 0 when none.
  float columnMass(int u, int v, int w_from, int w_to) const;
  /// Integrated frames over which hitMass() fades (e-folding), so that a voxel whose surface
  /// moved follows it.
  static constexpr float kHitMassWindow = 64.0f;
  /// Keep hitMass() (default true); SafetyMapper turns it off when no switch reads it (tail_share,
  /// mass_heights, plane_mass_heights), so that 000's default path does none of its per-point
  /// work. While off, integrated frames add nothing to it.
  void setHitMassTracking(bool on) { track_hit_mass_ = on; }
  bool hitMassTracking() const { return track_hit_mass_; }

  /// Highest and lowest occupied voxel (LOP >= occ_t) of the column (u, v) among the indexed
  /// heights [w_lo, w_hi] (global indices, clipped to the window). Returns false and leaves the
  /// outputs unchanged when there is none or the column is outside the window. The same answer
  /// as isOccupied() on every voxel of the column, in one pass over the column's contiguous
  /// storage: the height map's inner loop (000 Sec. V-A).
  bool occupiedExtent(int u, int v, int w_lo, int w_hi, int* w_top, int* w_bottom) const;
  /// Whether the column (u, v), among the indexed heights [w_lo, w_hi] (global, clipped to the
  /// window), holds a voxel that was not seen, below one that was. Seen is occupied (LOP >=
  /// occ_t) or seen free: passing rays' decrements (000 Sec. IV) took its LOP to -free_lop or
  /// below. A voxel between (at the prior 0, a few grazing rays, a few hits) was not seen: a
  /// layer hidden between seen space, such as the edge-on top of a table whose front edge
  /// stereo did not match while rays passed under and over it (SafetyMapperConfig::
  /// unseen_overhang_min_height). False outside the window. free_lop >= 1.
  bool hiddenBelowObserved(int u, int v, int w_lo, int w_hi, int free_lop) const;
  /// Whether a voxel of column (u, v) among the indexed heights [w_lo, w_hi] (global, clipped
  /// to the window) was seen free: passing rays' decrements took its LOP to -free_lop or below
  /// (SafetyMapperConfig::unseen_floor_band). False outside the window. free_lop >= 1.
  bool seenFreeWithin(int u, int v, int w_lo, int w_hi, int free_lop) const;

  /// Sets a voxel's log-odds directly (clamped). For tests and for fusing external cues.
  void setLogOdds(const VoxelIndex& i, int lop);

  /// Number of integrate() calls so far.
  std::uint32_t frameCount() const { return frame_; }

 private:
  // The contiguous storage of column (u, v) and the ring rows [*lo, *hi] of the global heights
  // [w_lo, w_hi] clipped to the window (in ring order through slot_w_); false when the column is
  // outside the window or the clipped range is empty.
  bool columnSpan(int u, int v, int w_lo, int w_hi, const std::int16_t** column, std::int64_t* lo,
                  std::int64_t* hi) const;
  // Global indices are clamped to +-kIndexLimit so that any coordinate (even 1e30) converts to
  // int without overflow; a clamped index is always far outside the window.
  static constexpr int kIndexLimit = 1 << 30;
  // Endpoints outside the window are de-duplicated in a small hash set (000 Sec. IV: one point
  // per voxel per frame holds for every voxel, not only for those the window stores).
  static constexpr int kOutsideSetBits = 16;
  static constexpr int kOutsideSetProbes = 16;
  struct OutsideEntry {
    std::uint64_t key = 0;
    std::uint32_t stamp = 0;
  };

  std::size_t linear(const VoxelIndex& i) const;  // ring-buffer address, i must be contained
  void clearVoxel(std::size_t k);
  VoxelIndex windowMinFor(const Eigen::Vector3f& robot_base_position) const;
  void rebuildSlotTables();
  std::uint32_t nextStamp();
  bool firstOutsideHit(std::int64_t ru, std::int64_t rv, std::int64_t rw);
  // A point of integrate() that passed the one-point-per-voxel test.
  struct Endpoint {
    double s[3];         // x / l_v + 1/2 per axis (Eq. (1) before the floor)
    std::int64_t r[3];   // global index minus minIndex()
    Eigen::Vector3f pf;  // fixed frame
    float range;
    std::size_t k;  // ring-buffer address when inside
    bool inside;
  };
  void useEndpoint(const double a[3], const Endpoint& ep, bool carve, IntegrationStats& stats);
  void castRay(const double a[3], const double b[3], const int e[3], bool fore_increment,
               IntegrationStats& stats);
  void addIncrement(std::size_t k, int amount);
  void insertPoint(std::size_t k, const Eigen::Vector3f& p, float range);

  VoxelGridConfig config_;
  int nu_ = 0, nv_ = 0, nw_ = 0;
  int z_below_voxels_ = 0;
  double inv_voxel_size_ = 0.0;
  // neighbour_sigmas x sigma_d / (f b) [1/m]: k sigma_Z = this x range^2; 0 = incr_L always.
  double neighbour_reach_ = 0.0;
  double focal_baseline_ = 0.0;  // setStereoGeometry()
  VoxelIndex min_;
  std::uint32_t frame_ = 0;
  std::uint32_t stamp_now_ = 0;            // stamp of the current frame, 0 = never
  std::vector<std::int16_t> lop_;          // log-odds per voxel
  std::vector<std::uint32_t> stamp_;       // stamp of the frame in which the voxel got its point
  std::vector<std::uint8_t> point_count_;  // points in each voxel's list
  std::vector<VoxelMoments> moments_;      // every point's moments, per voxel
  bool track_hit_mass_ = true;             // setHitMassTracking()
  std::vector<float> hit_mass_;            // hitMass() as of the frame in mass_frame_
  std::vector<std::uint32_t> mass_frame_;  // frame_ of the voxel's last hit_mass_ update
  std::vector<float> hit_frac_;            // hitMass()-weighted sum of the points' height
                                           // within their voxel, in voxels from its bottom
  std::vector<std::uint16_t> frame_hits_;  // this frame's points per voxel (saturating)
  std::vector<float> frame_frac_;          // this frame's sum of those heights
  std::vector<std::uint32_t> hit_voxels_;  // voxels with points this frame (each once)
  // capacity points per voxel, contiguous; default-initialised (slots past a list's count are
  // never read), so pages are only touched when points arrive
  std::vector<VoxelPoint, detail::DefaultInitAllocator<VoxelPoint>> point_storage_;
  std::vector<std::int32_t> pending_;   // this frame's increments, applied after decrements
  std::vector<std::uint32_t> touched_;  // voxels with a non-zero pending_ (each at most once)
  std::size_t num_touched_ = 0;
  // Window-relative index -> ring-buffer offset per axis; their sum is the linear address.
  std::vector<std::uint32_t> slot_u_, slot_v_, slot_w_;
  std::vector<OutsideEntry> outside_seen_;
};

}  // namespace stereo_safety_map
