#include <gtest/gtest.h>

#include <fstream>

#include "config/yaml_config.hpp"
#include "system/system_config.hpp"

namespace liloc {
namespace {

// The configuration shipped in config/ must load, and say what the docs say it says.
TEST(SystemConfig, TheShippedConfigLoads) {
  const SystemConfig config =
      load_config<SystemConfig>(std::string(LILOC_SOURCE_DIR) + "/config/liloc.yaml");
  EXPECT_NE(config.transport.url.find("ttl=0"), std::string::npos);
  EXPECT_NE(config.transport.url.find("recv_buf_size"), std::string::npos);
  EXPECT_TRUE(config.odometry.use_imu);
  EXPECT_DOUBLE_EQ(config.odometry.keyframe_translation_m, 1.0);
  EXPECT_DOUBLE_EQ(config.odometry.keyframe_rotation_rad, 0.2);
  EXPECT_NO_THROW(config.odometry.validate());
}

// Loading `yaml` fails with a ConfigError whose message contains `expected`.
void expect_config_error(const std::string& yaml, const std::string& expected) {
  // One file per test: ctest runs tests side by side.
  const std::string path = ::testing::TempDir() + "liloc_system_" +
                           ::testing::UnitTest::GetInstance()->current_test_info()->name() +
                           ".yaml";
  std::ofstream(path) << yaml;
  try {
    load_config<SystemConfig>(path);
    FAIL() << "loaded:\n" << yaml;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

TEST(SystemConfig, AMisspelledSectionIsAnError) {
  expect_config_error("odometry:\n  use_imu: true\nodometyr:\n  use_imu: false\n",
                      "unknown key 'odometyr'");
}

// A bad value in the map server's section is an error naming the key, not a server that
// starts without reply threads.
TEST(SystemConfig, ABadMapServerValueNamesIt) {
  expect_config_error("map_server:\n  reply_threads: 0\n", "reply_threads must be 1 to 64, got 0");
}

// Values no config may hold are refused naming the key: negative sigmas, impossible
// cache sizes, sensor limits that are no limits.
TEST(SystemConfig, RefusesImpossibleValuesNamingThem) {
  expect_config_error("odometry:\n  motion_translation_sigma_mps: -1\n",
                      "motion_translation_sigma_mps must be positive");
  expect_config_error("odometry:\n  max_range_m: .nan\n", "must be a finite number");
  expect_config_error("map_server:\n  cache_mb: 1e20\n", "cache_mb must be in (0, 1e6]");
  expect_config_error("sensors:\n  confirm_jump_messages: 0\n", "confirm_jump_messages");
  expect_config_error("map_builder:\n  odometry_translation_sigma_m: -0.01\n",
                      "odometry sigmas must be positive");
  expect_config_error("map_server:\n  service:\n    allowed_robots: [\"a,b\"]\n",
                      "allowed robot 'a,b' is not a valid name");
  expect_config_error("channels:\n  imu: \"\"\n", "imu '' must be 1-40 letters");
}

// Each setting has one home: the descriptor and the submap rule (Eq. 2) are system
// sections, so the builder's loop closure and the map service cannot be given other ones
// that would be accepted and then ignored, or cut a built map and merged updates apart.
TEST(SystemConfig, TheDescriptorAndTheSubmapRuleHaveOneHomeEach) {
  expect_config_error("map_builder:\n  loops:\n    descriptor:\n      sectors: 30\n",
                      "unknown key 'map_builder.loops.descriptor'");
  expect_config_error("map_server:\n  service:\n    submaps:\n      max_keyframes: 5\n",
                      "unknown key 'map_server.service.submaps'");
  const std::string path = ::testing::TempDir() + "liloc_system_one_home.yaml";
  std::ofstream(path) << "submaps:\n  max_keyframes: 5\ndescriptor:\n  sectors: 30\n";
  const SystemConfig config = load_config<SystemConfig>(path);
  EXPECT_EQ(config.map_server_node().submaps.max_keyframes, 5);
  EXPECT_EQ(config.map_server_node().descriptor.sectors, 30);
}

// A process reads its own sections and knows the others by name: the shipped config loads
// in each, a misspelled section is still an error, and the sections every process knows
// are the system config's.
struct SectionNames {
  std::vector<std::string> names;
  template <class T>
  void operator()(const char* key, const T&) {
    names.push_back(key);
  }
};

TEST(SystemConfig, ProcessesReadTheirSectionsAndKnowTheOthers) {
  SystemConfig system;
  SectionNames visited;
  system.visit_fields(visited);
  const std::vector<std::string> known(node::kSystemSections.begin(), node::kSystemSections.end());
  EXPECT_EQ(visited.names, known);
  const std::string shipped = std::string(LILOC_SOURCE_DIR) + "/config/liloc.yaml";
  EXPECT_NO_THROW(load_config<node::ProcessConfig<OdometryNodeConfig>>(shipped));
  EXPECT_NO_THROW(load_config<node::ProcessConfig<MapServerNodeConfig>>(shipped));
  const std::string path = ::testing::TempDir() + "liloc_system_process.yaml";
  std::ofstream(path) << "map_server:\n  reply_threads: 2\nodometyr:\n  use_imu: false\n";
  EXPECT_THROW(load_config<node::ProcessConfig<OdometryNodeConfig>>(path), ConfigError);
}

}  // namespace
}  // namespace liloc
