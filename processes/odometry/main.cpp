// liloc_odometry: LiDAR-inertial odometry for one robot (common/odometry_node/).
//   in:  <robot>.IMU, <robot>.LIDAR, <robot>.CORRECTION
//   out: <robot>.ODOM (every sweep), <robot>.KEYFRAME, <robot>.STATUS.odometry

#include "node/robot_process.hpp"
#include "odometry_node/odometry_node.hpp"

int main(int argc, char** argv) {
  using namespace liloc;
  return node::run_robot_process<OdometryNode, OdometryNodeConfig>(
      "odometry", "LiDAR-inertial odometry (the ILM front end) for one robot.", argc, argv);
}
