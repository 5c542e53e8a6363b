// liloc_initializer: a robot's first pose in the map frame, and again when asked
// (common/initializer_node/, docs/initialization.md).
//   in:  <robot>.KEYFRAME, <robot>.COARSE_POSE, MAP.INFO, <robot>.DESCRIPTORS, <robot>.SUBMAP
//   out: <robot>.INIT, <robot>.STATUS.initializer, MAP.DESCRIPTOR_REQUEST, MAP.REQUEST

#include "initializer_node/initializer_node.hpp"
#include "node/robot_process.hpp"

int main(int argc, char** argv) {
  using namespace liloc;
  return node::run_robot_process<InitializerNode, InitializerNodeConfig>(
      "initializer",
      "Pose initialization of one robot in the map frame: coarse-to-fine from a coarse pose "
      "(paper Section IV-B), or global without one.",
      argc, argv);
}
