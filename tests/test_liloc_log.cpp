#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <vector>

#include "bridge/message_samples.hpp"
#include "liloc_log/log_inspector.hpp"
#include "transport/log_file.hpp"

namespace liloc::tools {
namespace {

std::string temp_path(const std::string& name) { return ::testing::TempDir() + name; }

// `count` IMU messages of robot "r" with seq 0, 1, ...; returns the bytes of one event.
int64_t write_imu_log(const std::string& path, int count) {
  {
    transport::LogWriter writer(path);
    auto imu = bridge::make_sample<liloc::imu_t>("r");
    for (int i = 0; i < count; ++i) {
      imu.header.seq = i;
      writer.write("r.IMU", 1000000 + i * 10000, imu);
    }
  }
  return static_cast<int64_t>(std::ifstream(path, std::ios::binary | std::ios::ate).tellg()) /
         count;
}

// Inserts `bytes` of damage at `offset` of the file: a torn event header (the magic, then
// a channel length of -1, on which lcm::LogFile ends the log) and junk.
void insert_damage(const std::string& path, int64_t offset, size_t bytes) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> data{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  in.close();
  std::vector<char> damage = {'\xED', '\xA1', '\xDA', '\x01'};  // the event magic
  damage.resize(20, '\0');                                      // event number, timestamp
  damage.insert(damage.end(), 4, '\xFF');                       // channel length -1
  damage.resize(bytes, '\x55');
  data.insert(data.begin() + offset, damage.begin(), damage.end());
  std::ofstream(path, std::ios::binary)
      .write(data.data(), static_cast<std::streamsize>(data.size()));
}

// The exit status of liloc_log with these arguments (bounded: killed after 60 s).
int run_liloc_log(const std::string& arguments) {
  const std::string command = std::string("timeout 60 ") + LILOC_LOG + " " + arguments +
                              " --log-level off > /dev/null 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(LogInspector, NamesTypesAndCountsProblems) {
  const std::string path = temp_path("liloc_inspect.lcmlog");
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
  const LogSummary summary = summarize_log(path);
  ASSERT_EQ(summary.channels.size(), 3u);
  const ChannelSummary& imu = summary.channels.at("r.IMU");
  EXPECT_EQ(imu.type, "imu_t");
  EXPECT_EQ(imu.messages, 6);
  EXPECT_EQ(imu.sequence_gaps, 2);
  EXPECT_EQ(imu.out_of_order, 1);
  EXPECT_EQ(summary.channels.at("r.LIDAR").type, "lidar_scan_t");
  EXPECT_EQ(summary.channels.at("r.LIDAR").decode_errors, 1);
  EXPECT_EQ(summary.channels.at("JUNK").type, "unknown");
  EXPECT_FALSE(summary.damage.any());
  const std::string table = format_summary(summary);
  EXPECT_NE(table.find("r.IMU"), std::string::npos);
  EXPECT_NE(table.find("imu_t"), std::string::npos);
  EXPECT_EQ(table.find("damaged"), std::string::npos);
  std::remove(path.c_str());
}

// A sender that restarts or jumps counts as a restart, as the transport counts it, not as
// 2^62 missing messages.
TEST(LogInspector, CountsSequenceJumpsAsRestarts) {
  const std::string path = temp_path("liloc_inspect_jump.lcmlog");
  {
    transport::LogWriter writer(path);
    auto imu = bridge::make_sample<liloc::imu_t>("r");
    for (const int64_t seq : {int64_t{0}, int64_t{1}, int64_t{1} << 62, int64_t{2}, int64_t{4}}) {
      imu.header.seq = seq;
      writer.write("r.IMU", 1000000, imu);
    }
  }
  const ChannelSummary imu = summarize_log(path).channels.at("r.IMU");
  EXPECT_EQ(imu.sequence_resets, 2);  // up to 2^62, back to 2
  EXPECT_EQ(imu.sequence_gaps, 1);    // 3
  EXPECT_EQ(imu.out_of_order, 0);
  std::remove(path.c_str());
}

TEST(LogInspector, ReportsCorruptRegionsWithTheirByteOffsets) {
  const std::string path = temp_path("liloc_inspect_damaged.lcmlog");
  const int64_t event_bytes = write_imu_log(path, 30);
  insert_damage(path, 20 * event_bytes, 333);
  insert_damage(path, 7 * event_bytes, 100);
  const LogSummary summary = summarize_log(path);
  EXPECT_EQ(summary.channels.at("r.IMU").messages, 30);
  EXPECT_EQ(summary.channels.at("r.IMU").sequence_gaps, 0);
  EXPECT_EQ(summary.damage.corrupt_regions, 2);
  EXPECT_EQ(summary.damage.bytes_skipped, 433);
  const std::string table = format_summary(summary);
  const int64_t second_at = 20 * event_bytes + 100;
  EXPECT_NE(table.find("byte offset " + std::to_string(7 * event_bytes) + ": 100 bytes"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("byte offset " + std::to_string(second_at) + ": 333 bytes"),
            std::string::npos)
      << table;
  std::remove(path.c_str());
}

// The tool's exit status tells a script that data was lost: info and play on a damaged log,
// record from one.
TEST(LilocLog, ExitsNonZeroWhenDataWasLost) {
  const std::string clean = temp_path("liloc_tool_clean.lcmlog");
  const std::string damaged = temp_path("liloc_tool_damaged.lcmlog");
  const std::string recorded = temp_path("liloc_tool_recorded.lcmlog");
  write_imu_log(clean, 10);
  const int64_t event_bytes = write_imu_log(damaged, 10);
  insert_damage(damaged, 5 * event_bytes, 64);
  EXPECT_EQ(run_liloc_log("info " + clean), 0);
  EXPECT_EQ(run_liloc_log("info " + damaged), 1);
  EXPECT_EQ(run_liloc_log("play " + clean + " --speed 0 --lcm-url memq://"), 0);
  EXPECT_EQ(run_liloc_log("play " + damaged + " --speed 0 --lcm-url memq://"), 1);
  EXPECT_EQ(run_liloc_log("record " + recorded + " --lcm-url 'file://" + clean + "?speed=0'"), 0);
  EXPECT_EQ(run_liloc_log("record " + recorded + " --lcm-url 'file://" + damaged + "?speed=0'"), 1);
  std::remove(clean.c_str());
  std::remove(damaged.c_str());
  std::remove(recorded.c_str());
}

}  // namespace
}  // namespace liloc::tools
