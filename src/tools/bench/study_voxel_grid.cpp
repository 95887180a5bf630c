// bench_pipeline's studies 3 and 4: reprojection against image_geometry (stereo_image_proc's point
// clouds) and the voxel grid update against OctoMap on the same points.
#include "bench.h"

#include "stereo_safety_map/core/voxel_grid.h"
#include "stereo_safety_map/ros/conversions.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <functional>

namespace bench {

void studyReprojection(Bench* b) {
  const Options& opt = b->opt;
  auto& head = b->head;
  auto& cam = b->cam;
  auto& pcfg = b->pcfg;
  auto& reg = b->reg;
  auto& comparisons = b->comparisons;
  auto& disparity_of = b->disparity_of;
  // ---- 3. reprojection: ours vs image_geometry (stereo_image_proc's point clouds) --------------
  {
    progress("reprojection");
    image_geometry::StereoCameraModel model;
    model.fromCameraInfo(ssm::toCameraInfo(ds::stereoCameraModel(head), false),
                         ssm::toCameraInfo(ds::stereoCameraModel(head), true));
    std::vector<Eigen::Vector3f> pts;
    cv::Mat xyz;
    Series& a = reg.get("reproject.ours", "reprojection 640x480",
                        "reprojectDisparity -> point list in [0.2, 8] m", "ours");
    Series& b = reg.get("reproject.image_geometry", "reprojection 640x480",
                        "image_geometry projectDisparityImageTo3d (organised)", "peer");
    for (const cv::Mat& d : disparity_of) {  // warm-up
      if (d.empty()) continue;
      ssm::reprojectDisparity(d, cam, pcfg.mapper.grid.min_range, pcfg.mapper.grid.max_range, 1,
                              &pts);
      model.projectDisparityImageTo3d(d, xyz, true);
      break;
    }
    for (int pass = 0; pass < opt.passes; ++pass) {
      for (const cv::Mat& d : disparity_of) {
        if (d.empty()) continue;
        a.add(measure([&] {
          ssm::reprojectDisparity(d, cam, pcfg.mapper.grid.min_range, pcfg.mapper.grid.max_range, 1,
                                  &pts);
        }));
        b.add(measure([&] { model.projectDisparityImageTo3d(d, xyz, true); }));
      }
    }
    comparisons.push_back({"reproject.ours", "reproject.image_geometry", "reprojection"});
  }
}

void studyVoxelGrid(Bench* b) {
  const Options& opt = b->opt;
  auto& frames = b->frames;
  auto& pcfg = b->pcfg;
  auto& reg = b->reg;
  auto& comparisons = b->comparisons;
  auto& extra = b->extra;
  auto& points_of = b->points_of;
  auto& dense_points_of = b->dense_points_of;
  // ---- 4. voxel grid update: ours vs OctoMap (same points, same origin, same range) ------------
  // Two inputs: the points the pipeline integrates (BM + filters: sparse on this poorly
  // textured dataset), and a dense frame (OpenCV SGBM without any filter, reprojected the same
  // way) as the upper bound of what one 640x480 stereo frame can hand the grid.
  {
    const ssm::VoxelGridConfig gcfg = pcfg.mapper.grid;
    {
      const std::uint64_t nb0 = alloc_count::new_bytes.load();
      ssm::VoxelGrid probe(gcfg);
      extra["voxel_grid_bytes"] = static_cast<double>(alloc_count::new_bytes.load() - nb0);
    }
    const std::size_t first = opt.warmup > 0 ? static_cast<std::size_t>(opt.warmup - 1) : 0;
    auto compare =
        [&](const std::string& prefix, const std::string& group, std::size_t count,
            const std::function<void(std::size_t, std::vector<Eigen::Vector3f>*)>& points_sensor) {
          ssm::VoxelGrid grid(gcfg);
          octomap::OcTree tree_plain(gcfg.voxel_size), tree_disc(gcfg.voxel_size);
          Series& s_ours = reg.get(prefix + ".ours", group,
                                   "VoxelGrid::integrate (l_v 0.1 m, max range 8 m)", "ours");
          Series& s_rec = reg.get(prefix + ".ours_recenter", group,
                                  "VoxelGrid::recenter (scrolling the window)", "ours");
          Series& s_oct =
              reg.get(prefix + ".octomap", group,
                      "octomap OcTree::insertPointCloud (0.1 m, max range 8 m)", "peer");
          Series& s_octd = reg.get(prefix + ".octomap_discretize", group,
                                   "octomap insertPointCloud, discretize = true", "peer");
          std::vector<Eigen::Vector3f> raw_pts, pts;
          octomap::Pointcloud cloud;
          std::vector<double> n_points, n_rays;
          const std::size_t last = std::min(frames.size(), first + count);
          for (std::size_t k = first; k < last; ++k) {
            const Frame& f = frames[k];
            points_sensor(k, &raw_pts);
            rangeFilter(raw_pts, gcfg.min_range, gcfg.max_range, &pts);
            cloud.clear();
            cloud.reserve(pts.size());
            for (const Eigen::Vector3f& p : pts) {
              const Eigen::Vector3f q = f.T_fixed_left * p;
              cloud.push_back(q.x(), q.y(), q.z());
            }
            const Eigen::Vector3f o = f.T_fixed_left.translation();
            const octomap::point3d origin(o.x(), o.y(), o.z());
            ssm::IntegrationStats st;
            const Sample r = measure([&] { grid.recenter(f.base); });
            const Sample a = measure([&] { st = grid.integrate(pts, f.T_fixed_left); });
            const Sample b =
                measure([&] { tree_plain.insertPointCloud(cloud, origin, gcfg.max_range); });
            const Sample c = measure(
                [&] { tree_disc.insertPointCloud(cloud, origin, gcfg.max_range, false, true); });
            if (k == first && opt.warmup > 0) continue;  // the first frame is the warm-up
            s_rec.add(r);
            s_ours.add(a);
            s_oct.add(b);
            s_octd.add(c);
            n_points.push_back(static_cast<double>(pts.size()));
            n_rays.push_back(static_cast<double>(st.points_used));
          }
          extra[prefix + "_points_median"] = statsOf(n_points).median;
          extra[prefix + "_rays_median"] = statsOf(n_rays).median;
          extra[prefix + "_octomap_bytes"] = static_cast<double>(tree_plain.memoryUsage());
          extra[prefix + "_octomap_discretize_bytes"] =
              static_cast<double>(tree_disc.memoryUsage());
          extra[prefix + "_octomap_nodes"] = static_cast<double>(tree_plain.size());
          comparisons.push_back({prefix + ".ours", prefix + ".octomap", group});
          comparisons.push_back({prefix + ".ours", prefix + ".octomap_discretize", group});
        };
    progress("voxel grid vs OctoMap, pipeline points: %d frames", opt.frames);
    compare("voxel", "voxel grid update, 640x480, pipeline points (BM + filters)", frames.size(),
            [&](std::size_t k, std::vector<Eigen::Vector3f>* out) { *out = points_of[k]; });
    const std::size_t dense_frames = opt.quick ? 2 : frames.size();
    progress("voxel grid vs OctoMap, dense SGBM points: %zu frames",
             std::min(dense_frames, frames.size() - first) - (opt.warmup > 0 ? 1 : 0));
    compare("voxel_dense", "voxel grid update, 640x480, dense points (SGBM, no filter)",
            dense_frames,
            [&](std::size_t k, std::vector<Eigen::Vector3f>* out) { *out = dense_points_of[k]; });
  }
}

}  // namespace bench
