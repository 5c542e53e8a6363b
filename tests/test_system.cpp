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

TEST(SystemConfig, AMisspelledSectionIsAnError) {
  const std::string path = ::testing::TempDir() + "liloc_system_typo.yaml";
  {
    std::ofstream out(path);
    out << "odometry:\n  use_imu: true\nodometyr:\n  use_imu: false\n";
  }
  try {
    load_config<SystemConfig>(path);
    FAIL() << "a misspelled section loaded";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown key 'odometyr'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace liloc
