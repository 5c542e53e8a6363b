#include <gtest/gtest.h>

#include "bridge/init_conversions.hpp"
#include "initializer_node/initializer_node.hpp"
#include "liloc/init_result_t.hpp"
#include "liloc/status_t.hpp"
#include "street_map.hpp"

namespace liloc {
namespace {

// The street's map server and an initializer over memq://, with its answers and status.
struct Rig : test::StreetRig {
  std::unique_ptr<InitializerNode> initializer;
  std::vector<InitAnswer> answers;
  std::vector<liloc::status_t> status;

  explicit Rig(const std::string& name) : StreetRig("liloc_initializer_node_" + name) {
    InitializerNodeConfig config;
    config.initializer.request_period_s = 0.2;
    initializer = std::make_unique<InitializerNode>(*bus, "robot0", config);
    nodes.push_back(initializer.get());
    bus->subscribe<liloc::init_result_t>(
        "robot0.INIT", [this](const liloc::init_result_t& m, const transport::ReceiveInfo&) {
          answers.push_back(bridge::from_msg(m));
        });
    bus->subscribe<liloc::status_t>(
        "robot0.STATUS.initializer",
        [this](const liloc::status_t& m, const transport::ReceiveInfo&) { status.push_back(m); });
  }
};

// The initializer and the map server composed over memq://, the server started after the
// initializer: the initializer says it waits, asks again, gets the map's keyframe index and
// the submaps it needs, and localizes a keyframe globally (no coarse pose) to within 5 cm.
TEST(InitializerNode, LocalizesGloballyWithAMapServerThatStartsLater) {
  Rig rig("global");
  const Eigen::Vector3d truth(40.4, 0.3, 1.8);
  // The odometry's frame: its own yaw and origin.
  const Eigen::Isometry3d T_odom_body =
      se3::make(Eigen::AngleAxisd(0.9, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                Eigen::Vector3d(3, 4, 0));
  rig.send_keyframe(1, T_odom_body, test::seen_from(rig.world, truth));
  ASSERT_TRUE(rig.run_until([&] { return !rig.status.empty(); }));
  EXPECT_NE(rig.status.back().message.find("waiting for the map's keyframe index"),
            std::string::npos)
      << rig.status.back().message;
  EXPECT_TRUE(rig.answers.empty());
  rig.start_server();
  ASSERT_TRUE(rig.run_until([&] { return !rig.answers.empty(); }))
      << (rig.status.empty() ? "" : rig.status.back().message);
  const InitAnswer& a = rig.answers.back();
  ASSERT_TRUE(a.localized) << a.message;
  EXPECT_EQ(a.method, "global");
  EXPECT_EQ(a.keyframe_id, 1);
  // The body's yaw in the map is 0: the keyframe was taken looking along x.
  const Eigen::Isometry3d expected = se3::make(Eigen::Matrix3d::Identity(), truth);
  EXPECT_LT((a.T_map_body.translation() - truth).norm(), 0.05) << a.T_map_body.translation();
  EXPECT_LT(se3::rotation_angle(expected.inverse() * a.T_map_body), 0.01);
  EXPECT_GE(rig.initializer->map().counters().index_requests,
            2);  // asked again for the late server
}

// A coarse pose asks for coarse-to-fine; asking again (the optimizer lost track) runs it
// again on the next keyframe.
TEST(InitializerNode, ReinitializesWhenAsked) {
  Rig rig("coarse");
  rig.start_server();
  CoarsePose coarse;
  coarse.x_m = 63.0;
  coarse.y_m = 2.0;
  coarse.yaw_rad = 0.3;
  liloc::pose_t ask = bridge::to_msg(coarse, 0, "robot0");
  rig.bus->publish("robot0.COARSE_POSE", ask);
  rig.send_keyframe(7, Eigen::Isometry3d::Identity(),
                    test::seen_from(rig.world, {60.2, -0.4, 1.8}));
  ASSERT_TRUE(rig.run_until([&] { return !rig.answers.empty(); }));
  ASSERT_TRUE(rig.answers.back().localized) << rig.answers.back().message;
  EXPECT_EQ(rig.answers.back().method, "coarse_to_fine");
  EXPECT_LT((rig.answers.back().T_map_body.translation() - Eigen::Vector3d(60.2, -0.4, 1.8)).norm(),
            0.05);
  // Once localized it waits; asked again, it localizes the next keyframe.
  rig.send_keyframe(8, Eigen::Isometry3d::Identity(),
                    test::seen_from(rig.world, {61.2, -0.4, 1.8}));
  rig.run_until([] { return false; }, 1.0);
  EXPECT_EQ(rig.answers.size(), 1u);
  coarse.x_m = 80.0;
  liloc::pose_t again = bridge::to_msg(coarse, 0, "robot0");
  rig.bus->publish("robot0.COARSE_POSE", again);
  rig.send_keyframe(9, Eigen::Isometry3d::Identity(), test::seen_from(rig.world, {78.0, 0.5, 1.8}));
  ASSERT_TRUE(rig.run_until([&] {
    return rig.answers.size() >= 2 && rig.answers.back().localized;
  })) << rig.answers.back().message;
  EXPECT_EQ(rig.answers.back().keyframe_id, 9);
}

}  // namespace
}  // namespace liloc
