// A static transform on /tf_static, with the arguments of tf2_ros' static_transform_publisher:
//
//   static_tf_publisher x y z yaw pitch roll frame_id child_frame_id
//
// (metres, radians; the rotation is yaw about z, then pitch about y, then roll about x). Debian 12
// packages tf2_ros' library but not its static_transform_publisher executable, so robot.launch's
// camera_tf:=true starts this one (roslaunch-check found the missing node).
#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  ros::init(argc, argv, "static_tf_publisher", ros::init_options::AnonymousName);
  std::vector<std::string> args;
  ros::removeROSArgs(argc, argv, args);
  if (args.size() != 9) {
    std::fprintf(stderr,
                 "usage: static_tf_publisher x y z yaw pitch roll frame_id child_frame_id\n");
    return 2;
  }
  double v[6];
  for (int i = 0; i < 6; ++i) {
    char* end = nullptr;
    v[i] = std::strtod(args[1 + i].c_str(), &end);
    if (end == args[1 + i].c_str() || *end != '\0' || !std::isfinite(v[i])) {
      std::fprintf(stderr, "static_tf_publisher: '%s' is not a number\n", args[1 + i].c_str());
      return 2;
    }
  }
  if (args[7].empty() || args[8].empty() || args[7] == args[8]) {
    std::fprintf(stderr, "static_tf_publisher: frame_id and child_frame_id must differ\n");
    return 2;
  }
  const Eigen::Quaterniond q(Eigen::AngleAxisd(v[3], Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(v[4], Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(v[5], Eigen::Vector3d::UnitX()));
  ros::NodeHandle nh;  // starts the node: ros::Time::now() needs it
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time::now();
  t.header.frame_id = args[7];
  t.child_frame_id = args[8];
  tf2::toMsg(Eigen::Vector3d(v[0], v[1], v[2]), t.transform.translation);
  t.transform.rotation = tf2::toMsg(q);
  tf2_ros::StaticTransformBroadcaster broadcaster;
  broadcaster.sendTransform(t);
  ros::spin();
  return 0;
}
