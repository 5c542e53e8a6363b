#include <gtest/gtest.h>

#include <cstdio>

#include "bridge/message_samples.hpp"
#include "liloc_log/log_inspector.hpp"
#include "transport/log_file.hpp"

namespace liloc::tools {
namespace {

TEST(LogInspector, NamesTypesAndCountsProblems) {
  const std::string path = ::testing::TempDir() + "liloc_inspect.lcmlog";
  {
    transport::LogWriter writer(path);
    auto imu = bridge::make_sample<liloc::imu_t>("r");
    for (const int64_t seq : {0, 1, 2, 5, 6, 6}) {  // 3, 4 missing; 6 repeated
      imu.header.seq = seq;
      writer.write("r.IMU", 1000000 + seq * 10000, imu);
    }
    auto scan = bridge::make_sample<liloc::lidar_scan_t>("r");
    std::vector<uint8_t> bytes(static_cast<size_t>(scan.getEncodedSize()));
    scan.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    writer.write("r.LIDAR", 1000000, scan);
    writer.write_raw("r.LIDAR", 1100000, bytes.data(), bytes.size() / 2);  // truncated
    const char junk[] = "not an lcm message";
    writer.write_raw("JUNK", 1000000, junk, sizeof(junk));
  }
  const auto summary = summarize_log(path);
  ASSERT_EQ(summary.size(), 3u);
  const ChannelSummary& imu = summary.at("r.IMU");
  EXPECT_EQ(imu.type, "imu_t");
  EXPECT_EQ(imu.messages, 6);
  EXPECT_EQ(imu.sequence_gaps, 2);
  EXPECT_EQ(imu.out_of_order, 1);
  EXPECT_EQ(summary.at("r.LIDAR").type, "lidar_scan_t");
  EXPECT_EQ(summary.at("r.LIDAR").decode_errors, 1);
  EXPECT_EQ(summary.at("JUNK").type, "unknown");
  const std::string table = format_summary(summary);
  EXPECT_NE(table.find("r.IMU"), std::string::npos);
  EXPECT_NE(table.find("imu_t"), std::string::npos);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace liloc::tools
