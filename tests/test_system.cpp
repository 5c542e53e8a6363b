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

}  // namespace
}  // namespace liloc
