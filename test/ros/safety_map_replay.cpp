// One frame path (ARCHITECTURE.md, "one core entry point per frame"): a bag replayed through the
// disparity and safety-map nodelets at rate 1 gives, map for map and cell for cell, the maps of
// the offline run of the same bag (StereoFrameProcessor::processImages, what evaluate_safety_map
// and the open-world evaluation run). The test node renders the bag (make_dataset --small), plays
// it with `rosbag play --clock`, records every safety_map_labels message, then maps the bag
// offline and compares.
#include "stereo_safety_map/core/map_costs.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/msgs.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/tools/dataset_reader.h"

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace ssm = stereo_safety_map;

namespace {

const std::string kSource = SSM_SOURCE_DIR;
const std::string kBin = SSM_BIN_DIR;

// Runs a command to its end; its exit code.
int run(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args)
    argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    execvp(argv[0], argv.data());
    _exit(127);
  }
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(SafetyMapReplay, EveryPublishedMapEqualsTheOfflineMapCellByCell) {
  ros::NodeHandle nh;
  char tmpl[] = "/tmp/ssm_replay_XXXXXX";
  ASSERT_NE(mkdtemp(tmpl), nullptr);
  const std::string dir = tmpl;
  const std::string scene = kSource + "/scenes/dataset3_two_ramps.yaml";
  ASSERT_EQ(
      run({kBin + "/make_dataset", "--scene", scene, "--out", dir, "--small", "--threads", "2"}),
      0);
  const std::string bag = dir + "/dataset3_two_ramps.bag";

  std::mutex mutex;
  std::map<double, ssm::SafetyMapMsg::ConstPtr> published;  // by stamp
  int duplicates = 0;
  ros::Subscriber sub = nh.subscribe<ssm::SafetyMapMsg>(
      "safety_map_labels", 1000, [&](const ssm::SafetyMapMsg::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!published.emplace(m->header.stamp.toSec(), m).second) ++duplicates;
      });
  // The published OccupancyGrids, as costmap_2d's static layer reads them (the README's costmap
  // section: trinary_costmap true, lethal_cost_threshold 100, unknown_cost_value -1,
  // track_unknown_space true): checked against the labels of their stamp after the run.
  std::map<double, nav_msgs::OccupancyGrid::ConstPtr> grids;  // by stamp, the last one
  ros::Subscriber grid_sub = nh.subscribe<nav_msgs::OccupancyGrid>(
      "safety_map", 1000, [&](const nav_msgs::OccupancyGrid::ConstPtr& g) {
        std::lock_guard<std::mutex> lock(mutex);
        grids[g->header.stamp.toSec()] = g;
      });
  ros::Subscriber timings_sub;
  ssm::StageTimingsMsg::ConstPtr last_timings;
  timings_sub = nh.subscribe<ssm::StageTimingsMsg>("stage_timings", 1000,
                                                   [&](const ssm::StageTimingsMsg::ConstPtr& m) {
                                                     std::lock_guard<std::mutex> lock(mutex);
                                                     last_timings = m;
                                                   });
  ros::AsyncSpinner spinner(2);
  spinner.start();
  // The nodelets subscribe while rosbag play waits (-d): every frame reaches them.
  ASSERT_EQ(run({"rosbag", "play", "--clock", "-q", "-d", "3", "-r", "1", bag}), 0);
  ros::WallDuration(2.0).sleep();  // the last frame through both nodelets
  spinner.stop();

  // Offline: the same bag, the same configuration files, the core's entry point per frame.
  ssm::StereoFrameProcessorConfig config;
  ASSERT_EQ(ssm::loadCoreParams(kSource + "/config/disparity.yaml", &config), "");
  ASSERT_EQ(ssm::loadCoreParams(kSource + "/config/safety_map.yaml", &config), "");
  ssm::StereoFrameProcessor processor(config);
  ssm::StereoBagReader reader;
  ASSERT_EQ(reader.open(bag), "");
  ssm::StereoBagFrame frame;
  int offline_maps = 0, compared = 0, equal = 0, stationary = 0;
  while (reader.next(&frame)) {
    ASSERT_EQ(frame.error, "") << "pair " << frame.index;
    ssm::StereoFrameResult result;
    std::string err;
    const bool ok = processor.processImages(
        frame.left, frame.right, frame.camera, frame.T_fixed_sensor.cast<float>(),
        frame.robot.cast<float>(), frame.stamp.toSec(), &result, &err);
    // A stationary frame is skipped (000 Sec. IV) but answered with the map at its stamp (which
    // may have aged): the nodelet republishes the processor's current map.
    if (!ok) {
      EXPECT_EQ(result.mapper.status, ssm::FrameStatus::kStationary) << err;
      if (result.mapper.status != ssm::FrameStatus::kStationary) continue;
      ++stationary;
    }
    ++offline_maps;
    ssm::SafetyMapMsg expected;
    std_msgs::Header header;
    header.stamp = frame.stamp;
    header.frame_id = "odom";
    ssm::toSafetyMapMsg(processor.mapper().safetyMap(), frame.robot.cast<float>(), header,
                        &expected);
    std::lock_guard<std::mutex> lock(mutex);
    const auto it = published.find(frame.stamp.toSec());
    if (it == published.end()) {
      ADD_FAILURE() << "no map published for frame " << frame.index << " (" << frame.stamp << ")";
      continue;
    }
    const ssm::SafetyMapMsg& got = *it->second;
    ++compared;
    const bool same =
        got.info.width == expected.info.width && got.info.height == expected.info.height &&
        got.info.origin.position.x == expected.info.origin.position.x &&
        got.info.origin.position.y == expected.info.origin.position.y &&
        got.labels == expected.labels && got.drop_off == expected.drop_off &&
        got.segment == expected.segment && got.robot_segment == expected.robot_segment;
    if (same) {
      ++equal;
      continue;
    }
    int differ = 0;
    for (std::size_t k = 0; k < got.labels.size() && k < expected.labels.size(); ++k)
      differ += got.labels[k] != expected.labels[k];
    ADD_FAILURE() << "frame " << frame.index << ": the nodelet's map differs from the offline map ("
                  << differ << " labels of " << expected.labels.size() << ")";
  }
  std::lock_guard<std::mutex> lock(mutex);
  // No drop-off edge or Non-ground cell reads as free to the static layer; every grid is stamped
  // with a frame's stamp (a frame that made a labels message).
  std::size_t hazard_cells = 0, drop_off_cells = 0, grids_checked = 0;
  for (const auto& [stamp, grid] : grids) {
    const auto it = published.find(stamp);
    if (it == published.end()) {
      ADD_FAILURE() << "a grid stamped " << stamp << " that no frame's labels have";
      continue;
    }
    const ssm::SafetyMapMsg& m = *it->second;
    ASSERT_EQ(grid->data.size(), m.labels.size());
    ++grids_checked;
    for (std::size_t k = 0; k < m.labels.size(); ++k) {
      const bool safe =
          m.labels[k] == ssm::SafetyMapMsg::LEVEL || m.labels[k] == ssm::SafetyMapMsg::INCLINED;
      const bool drop = safe && m.drop_off[k] != 0;
      if (m.labels[k] != ssm::SafetyMapMsg::NON_GROUND && !drop) continue;
      ++hazard_cells;
      drop_off_cells += drop;
      EXPECT_NE(ssm::staticLayerCost(grid->data[k], ssm::StaticLayerSettings()),
                ssm::kCostmapFreeSpace)
          << "stamp " << stamp << " cell " << k << ": label " << int(m.labels[k]) << " drop-off "
          << drop << " reads as free (value " << int(grid->data[k]) << ")";
    }
  }
  EXPECT_EQ(grids_checked, published.size());
  EXPECT_GT(hazard_cells, 1000u);
  std::printf(
      "safety_map_replay: %zu grids read as the static layer does: %zu hazardous cells "
      "(%zu drop-off edges), none free\n",
      grids_checked, hazard_cells, drop_off_cells);
  EXPECT_EQ(duplicates, 0);
  EXPECT_GT(offline_maps, 20);
  EXPECT_GT(stationary, 0) << "the bag has no stationary frame: the republish is not tested";
  EXPECT_EQ(compared, offline_maps);
  EXPECT_EQ(equal, offline_maps);
  EXPECT_EQ(static_cast<int>(published.size()), offline_maps)
      << "the nodelet published maps the offline run did not make";
  ASSERT_TRUE(last_timings);
  EXPECT_EQ(last_timings->frames_dropped, 0u);
  EXPECT_EQ(last_timings->frames_rejected, 0u);
  RecordProperty("maps_compared", compared);
  std::printf(
      "safety_map_replay: %d maps published by the nodelets, %d offline (%d stationary), %d "
      "equal\n",
      static_cast<int>(published.size()), offline_maps, stationary, equal);
  run({"rm", "-rf", dir});
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_map_replay_test");
  return RUN_ALL_TESTS();
}
