// liloc_optimizer: a robot's pose in the map frame, keyframe by keyframe, by the egocentric
// factor graph (common/optimizer_node/, docs/optimizer.md).
//   in:  <robot>.KEYFRAME, <robot>.ODOM, <robot>.INIT, <robot>.IMU (with IMU factors),
//        MAP.INFO, <robot>.DESCRIPTORS, <robot>.SUBMAP
//   out: <robot>.POSE, <robot>.STATUS.optimizer, <robot>.COARSE_POSE (when lost),
//        MAP.DESCRIPTOR_REQUEST, MAP.REQUEST

#include "node/robot_process.hpp"
#include "optimizer_node/optimizer_node.hpp"

int main(int argc, char** argv) {
  using namespace liloc;
  return node::run_robot_process<OptimizerNode, OptimizerNodeConfig>(
      "optimizer",
      "The joint optimizer of one robot: its pose in the map frame by the egocentric factor "
      "graph (paper Sections III, IV-C, IV-D).",
      argc, argv);
}
