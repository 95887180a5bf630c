// rviz draws the safety map: rviz/safety_map.rviz under Xvfb on the synthetic scene, a
// screenshot (ImageMagick `import -window root`), and a check that the middle of the 3D view is
// not the background colour. The screenshot is kept as a test artifact.
#include "test_util.h"

#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <opencv2/imgcodecs.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <thread>

namespace fs = std::filesystem;

namespace {

// Starts argv with DISPLAY set; returns the child's pid.
pid_t spawn(const std::vector<std::string>& args, const std::string& display) {
  const pid_t pid = fork();
  if (pid == 0) {
    setenv("DISPLAY", display.c_str(), 1);
    // Xvfb, rviz and import are not ours: under scripts/test --sanitize they would inherit the
    // sanitizer runtime that rostest's processes get preloaded for our nodelets.
    unsetenv("LD_PRELOAD");
    setpgid(0, 0);
    std::vector<char*> argv;
    for (const auto& a : args)
      argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

void stop(pid_t pid) {
  if (pid <= 0) return;
  kill(-pid, SIGTERM);
  for (int i = 0; i < 50; ++i) {
    if (waitpid(pid, nullptr, WNOHANG) == pid) return;
    test_util::sleepFor(0.1);
  }
  kill(-pid, SIGKILL);
  waitpid(pid, nullptr, 0);
}

// The test results folder of this package: build/test_results/stereo_safety_map next to the
// devel space this binary runs from (devel/lib/stereo_safety_map/<test>), else ROS_HOME's.
fs::path resultsDir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path ws = exe.parent_path().parent_path().parent_path().parent_path();
    if (fs::exists(ws / "build")) return ws / "build" / "test_results" / "stereo_safety_map";
  }
  if (const char* d = std::getenv("ROS_TEST_RESULTS_DIR")) return fs::path(d) / "stereo_safety_map";
  const char* home = std::getenv("HOME");
  return fs::path(home ? home : "/tmp") / ".ros" / "test_results" / "stereo_safety_map";
}

// In the middle of the 3D view: the fraction of pixels that differ from the background
// (48, 48, 48), the number of pixels of the Map display (mostly Unknown cells, which rviz's "map"
// scheme draws grey-green, ~ (100, 120, 117) at alpha 0.8) and of green Level planes.
void analyse(const cv::Mat& img, double* drawn_fraction, int* map_pixels, int* green) {
  // Window at (10, 10), 1260 x 1000, left dock ~ 330 px, toolbar ~ 80 px (rviz/safety_map.rviz).
  const cv::Rect roi(620, 380, 420, 300);
  const cv::Rect inside = roi & cv::Rect(0, 0, img.cols, img.rows);
  int drawn = 0;
  *map_pixels = 0;
  *green = 0;
  for (int y = inside.y; y < inside.y + inside.height; ++y) {
    for (int x = inside.x; x < inside.x + inside.width; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
      if (std::abs(p[0] - 48) > 8 || std::abs(p[1] - 48) > 8 || std::abs(p[2] - 48) > 8) ++drawn;
      // OpenCV pixels are BGR.
      if (std::abs(p[2] - 100) < 25 && std::abs(p[1] - 120) < 25 && std::abs(p[0] - 117) < 25) {
        ++*map_pixels;
      }
      if (p[1] > 150 && p[2] < 120 && p[0] < 120) ++*green;
    }
  }
  *drawn_fraction = inside.area() > 0 ? static_cast<double>(drawn) / inside.area() : 0.0;
}

TEST(Rviz, DrawsTheSafetyMap) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string rviz_config;
  ASSERT_TRUE(pnh.getParam("rviz_config", rviz_config));
  for (const char* tool : {"Xvfb", "rviz", "import"}) {
    ASSERT_EQ(std::system((std::string("command -v ") + tool + " > /dev/null").c_str()), 0)
        << tool << " is not installed";
  }

  tf2_ros::StaticTransformBroadcaster tf;
  test_util::publishSceneTf(tf);
  test_util::ScenePublisher pub(nh, "");
  test_util::Latest<nav_msgs::OccupancyGrid> grid(nh, "/safety_map");
  ASSERT_TRUE(pub.waitForSubscribers(20.0));
  std::atomic<bool> running{true};
  std::thread feeder([&] {
    while (running && ros::ok()) {
      pub.publishDisparity(ros::Time::now());
      test_util::sleepFor(0.15);
    }
  });
  ASSERT_TRUE(test_util::waitFor(
      [&] { return grid.get() && test_util::costAt(*grid.get(), 1.3, 0.0) == 0; }, 30.0))
      << "no map with the Level floor";

  // A free X display.
  int n = 90;
  for (; n < 200; ++n) {
    if (!fs::exists("/tmp/.X11-unix/X" + std::to_string(n)) &&
        !fs::exists("/tmp/.X" + std::to_string(n) + "-lock")) {
      break;
    }
  }
  const std::string display = ":" + std::to_string(n);
  const pid_t xvfb =
      spawn({"Xvfb", display, "-screen", "0", "1280x1024x24", "-nolisten", "tcp"}, display);
  ASSERT_TRUE(
      test_util::waitFor([&] { return fs::exists("/tmp/.X11-unix/X" + std::to_string(n)); }, 10.0))
      << "Xvfb did not start on " << display;
  const pid_t rviz = spawn({"rviz", "-d", rviz_config, "__name:=rviz_screenshot"}, display);

  const fs::path dir = resultsDir();
  fs::create_directories(dir);
  const fs::path png = dir / "safety_map_rviz.png";
  double drawn = 0.0;
  int map_pixels = 0, green = 0;
  bool ok = false;
  // rviz needs a few seconds to start and render under software OpenGL: retry.
  for (int attempt = 0; attempt < 15 && !ok; ++attempt) {
    test_util::sleepFor(attempt == 0 ? 10.0 : 3.0);
    const std::string cmd =
        "import -display " + display + " -window root " + png.string() + " 2> /dev/null";
    if (std::system(cmd.c_str()) != 0) continue;
    const cv::Mat img = cv::imread(png.string(), cv::IMREAD_COLOR);
    if (img.empty()) continue;
    analyse(img, &drawn, &map_pixels, &green);
    ok = drawn > 0.6 && map_pixels > 5000 && green > 500;
  }
  running = false;
  feeder.join();
  stop(rviz);
  stop(xvfb);
  ASSERT_TRUE(fs::exists(png)) << "no screenshot";
  std::cout << "screenshot: " << png << " (drawn " << drawn << ", map pixels " << map_pixels
            << ", green plane pixels " << green << ")" << std::endl;
  EXPECT_GT(drawn, 0.6) << "the middle of the 3D view is mostly background; see " << png;
  EXPECT_GT(map_pixels, 5000) << "the safety map (Map display) is not drawn; see " << png;
  EXPECT_GT(green, 500) << "no green Level plane drawn; see " << png;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_map_rviz_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
