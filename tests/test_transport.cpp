#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>

#include "bridge/lcm_conversions.hpp"
#include "bridge/message_samples.hpp"
#include "liloc/status_t.hpp"
#include "transport/log_file.hpp"
#include "transport/transport.hpp"

namespace liloc::transport {
namespace {

TransportConfig memq() {
  TransportConfig c;
  c.url = "memq://";
  return c;
}

template <class Msg>
std::vector<uint8_t> encode(const Msg& msg) {
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

std::string temp_path(const std::string& name) { return ::testing::TempDir() + name; }

// Publishes the sample of Msg over memq:// and checks that the decoded copy re-encodes to
// the same bytes (LCM types have no operator==; equal encodings mean equal fields).
template <class Msg>
void expect_round_trip() {
  Transport bus(memq());
  Msg sent = bridge::make_sample<Msg>("robot7");
  std::vector<Msg> received;
  bus.subscribe<Msg>("ROUND_TRIP",
                     [&](const Msg& m, const ReceiveInfo&) { received.push_back(m); });
  ASSERT_TRUE(bus.publish("ROUND_TRIP", sent));
  ASSERT_TRUE(bus.publish("ROUND_TRIP", sent));
  EXPECT_EQ(bus.drain(), 2);
  ASSERT_EQ(received.size(), 2u);
  EXPECT_EQ(encode(received[1]), encode(sent));
  EXPECT_EQ(received[0].header.seq + 1, received[1].header.seq);
  EXPECT_EQ(received[1].header.robot_id, "robot7");
  const ChannelStats s = bus.stats().at("ROUND_TRIP");
  EXPECT_EQ(s.received, 2);
  EXPECT_EQ(s.decode_errors + s.dropped + s.out_of_order, 0);
}

TEST(Transport, EveryMessageTypeRoundTripsOverMemq) {
  int types_with_header = 0;
#define LILOC_ROUND_TRIP(type)                                                             \
  if constexpr (bridge::HasHeader<liloc::type>::value) {                                   \
    SCOPED_TRACE(#type);                                                                   \
    expect_round_trip<liloc::type>();                                                      \
    ++types_with_header;                                                                   \
  } else {                                                                                 \
    const auto sample = bridge::make_sample<liloc::type>("r");                             \
    liloc::type back;                                                                      \
    const auto bytes = encode(sample);                                                     \
    ASSERT_EQ(back.decode(bytes.data(), 0, bytes.size()), static_cast<int>(bytes.size())); \
    EXPECT_EQ(encode(back), bytes) << #type;                                               \
  }
  LILOC_FOR_EACH_LCM_TYPE(LILOC_ROUND_TRIP)
#undef LILOC_ROUND_TRIP
  EXPECT_EQ(types_with_header, 12);  // the channel messages; nested parts have no header
}

TEST(Transport, WrongFingerprintIsCountedAndSkipped) {
  Transport bus(memq());
  int handled = 0;
  bus.subscribe<liloc::lidar_scan_t>(
      "X.LIDAR", [&](const liloc::lidar_scan_t&, const ReceiveInfo&) { ++handled; });
  auto imu = bridge::make_sample<liloc::imu_t>("r");
  bus.publish("X.LIDAR", imu);  // an IMU message on the LiDAR channel
  auto scan = bridge::make_sample<liloc::lidar_scan_t>("r");
  bus.publish("X.LIDAR", scan);
  bus.drain();
  EXPECT_EQ(handled, 1);
  EXPECT_EQ(bus.stats().at("X.LIDAR").decode_errors, 1);
  EXPECT_EQ(bus.stats().at("X.LIDAR").received, 1);
}

TEST(Transport, TruncatedMessagesAreCountedAndSkipped) {
  Transport bus(memq());
  int handled = 0;
  bus.subscribe<liloc::lidar_scan_t>(
      "X.LIDAR", [&](const liloc::lidar_scan_t&, const ReceiveInfo&) { ++handled; });
  const auto bytes = encode(bridge::make_sample<liloc::lidar_scan_t>("r"));
  for (const size_t keep :
       {size_t{0}, size_t{4}, size_t{8}, size_t{20}, bytes.size() / 2, bytes.size() - 1}) {
    bus.publish_raw("X.LIDAR", bytes.data(), keep);
  }
  bus.publish_raw("X.LIDAR", bytes.data(), bytes.size());
  bus.drain();
  EXPECT_EQ(handled, 1);
  EXPECT_EQ(bus.stats().at("X.LIDAR").decode_errors, 6);
}

// A count field of 2^31 - 1 with the right fingerprint: rejected before allocating.
TEST(Transport, CorruptArrayLengthIsRejectedWithoutAllocating) {
  liloc::point_cloud_t cloud;
  cloud.num_points = 0;
  liloc::keyframe_t kf = bridge::make_sample<liloc::keyframe_t>("r");
  kf.cloud = cloud;
  std::vector<uint8_t> bytes = encode(kf);
  // The cloud is the last field: its count is the final 4 bytes of an empty cloud.
  const size_t count_at = bytes.size() - 4;
  const uint8_t huge[4] = {0x7f, 0xff, 0xff, 0xff};
  std::memcpy(bytes.data() + count_at, huge, 4);

  Transport bus(memq());
  int handled = 0;
  bus.subscribe<liloc::keyframe_t>(
      "K", [&](const liloc::keyframe_t&, const ReceiveInfo&) { ++handled; });
  bus.publish_raw("K", bytes.data(), bytes.size());
  bus.drain();
  EXPECT_EQ(handled, 0);
  EXPECT_EQ(bus.stats().at("K").decode_errors, 1);
}

TEST(Transport, OversizedMessagesAreNotPublished) {
  TransportConfig config = memq();
  config.max_message_bytes = 2048;
  Transport bus(config);
  std::vector<uint8_t> big(4096, 0);
  EXPECT_FALSE(bus.publish_raw("BIG", big.data(), big.size()));
  EXPECT_EQ(bus.publish_errors(), 1);
  EXPECT_TRUE(bus.publish_raw("BIG", big.data(), 2048));
}

TEST(Transport, SequenceGapsCountAsDropsPerSender) {
  Transport bus(memq());
  bus.subscribe<liloc::imu_t>("IMU", [](const liloc::imu_t&, const ReceiveInfo&) {});
  auto send = [&](const std::string& robot, int64_t seq) {
    auto msg = bridge::make_sample<liloc::imu_t>(robot);
    msg.header.seq = seq;
    const auto bytes = encode(msg);
    bus.publish_raw("IMU", bytes.data(), bytes.size());
  };
  send("a", 0);
  send("b", 0);
  send("a", 1);
  send("a", 4);  // 2 and 3 lost
  send("b", 1);
  send("a", 4);  // duplicate
  send("a", 3);  // late
  bus.drain();
  const ChannelStats s = bus.stats().at("IMU");
  EXPECT_EQ(s.received, 7);
  EXPECT_EQ(s.dropped, 2);
  EXPECT_EQ(s.out_of_order, 2);
}

TEST(Transport, HandlerExceptionsAreCountedAndDoNotStopDispatch) {
  Transport bus(memq());
  int calls = 0;
  bus.subscribe<liloc::status_t>("S", [&](const liloc::status_t&, const ReceiveInfo&) {
    if (++calls == 1) {
      throw std::runtime_error("bad scan");
    }
  });
  auto msg = bridge::make_sample<liloc::status_t>("r");
  bus.publish("S", msg);
  bus.publish("S", msg);
  bus.drain();
  EXPECT_EQ(calls, 2);
  EXPECT_EQ(bus.stats().at("S").handler_errors, 1);
  EXPECT_EQ(bus.stats().at("S").received, 1);
}

// Several threads publishing on one channel (the map server's reply workers): every
// message leaves with the next sequence number, so a receiver counts no false reorders or
// drops.
TEST(Transport, ConcurrentPublishersSendInSequenceOrder) {
  TransportConfig config = memq();
  config.queue_capacity = 100000;
  Transport bus(config);
  int64_t received = 0;
  bus.subscribe<liloc::status_t>("BUSY",
                                 [&](const liloc::status_t&, const ReceiveInfo&) { ++received; });
  const auto publisher = [&bus] {
    for (int i = 0; i < 20000; ++i) {
      liloc::status_t m{};
      m.header.robot_id = "server";
      bus.publish("BUSY", m);
    }
  };
  std::thread a(publisher), b(publisher);
  a.join();
  b.join();
  bus.drain();
  EXPECT_EQ(received, 40000);
  const ChannelStats s = bus.stats().at("BUSY");
  EXPECT_EQ(s.out_of_order, 0);
  EXPECT_EQ(s.dropped, 0);
}

TEST(Transport, ChannelNamesAreExactNotRegex) {
  Transport bus(memq());
  int handled = 0;
  bus.subscribe<liloc::status_t>("robot1.STATUS",
                                 [&](const liloc::status_t&, const ReceiveInfo&) { ++handled; });
  auto msg = bridge::make_sample<liloc::status_t>("r");
  bus.publish("robot1XSTATUS", msg);
  bus.publish("robot1.STATUS", msg);
  bus.drain();
  EXPECT_EQ(handled, 1);
}

TEST(LogFile, WriteThenReplayDeliversEveryMessageInOrder) {
  const std::string path = temp_path("liloc_replay_test.lcmlog");
  {
    LogWriter writer(path);
    for (int i = 0; i < 50; ++i) {
      auto scan = bridge::make_sample<liloc::lidar_scan_t>("r");
      scan.header.seq = i;
      scan.header.utime += i * 100000;
      writer.write("r.LIDAR", scan.header.utime, scan);
      auto imu = bridge::make_sample<liloc::imu_t>("r");
      imu.header.seq = i;
      writer.write("r.IMU", scan.header.utime + 50000, imu);
    }
    EXPECT_EQ(writer.events_written(), 100);
  }
  Transport bus(memq());
  std::vector<std::string> order;
  std::vector<int64_t> scan_utimes;
  bus.subscribe<liloc::lidar_scan_t>("r.LIDAR",
                                     [&](const liloc::lidar_scan_t& m, const ReceiveInfo&) {
                                       order.push_back("L");
                                       scan_utimes.push_back(m.header.utime);
                                     });
  bus.subscribe<liloc::imu_t>(
      "r.IMU", [&](const liloc::imu_t&, const ReceiveInfo&) { order.push_back("I"); });
  EXPECT_EQ(replay_log(path, bus, {0.0}), 100);
  ASSERT_EQ(order.size(), 100u);
  for (size_t i = 0; i < order.size(); ++i) {
    EXPECT_EQ(order[i], i % 2 == 0 ? "L" : "I");
  }
  for (size_t i = 1; i < scan_utimes.size(); ++i) {
    EXPECT_EQ(scan_utimes[i] - scan_utimes[i - 1], 100000);
  }
  EXPECT_EQ(bus.stats().at("r.LIDAR").dropped, 0);
  std::remove(path.c_str());
}

TEST(LogFile, RealTimeReplayKeepsTheLoggedSpacing) {
  const std::string path = temp_path("liloc_realtime_test.lcmlog");
  {
    LogWriter writer(path);
    auto msg = bridge::make_sample<liloc::status_t>("r");
    for (int i = 0; i < 5; ++i) {
      writer.write("S", 1000000 + i * 50000, msg);  // 0.2 s of log
    }
  }
  Transport bus(memq());
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(replay_log(path, bus, {1.0}), 5);
  // A lower bound only: real time never plays faster than logged.
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(195));
  std::remove(path.c_str());
}

TEST(LogFile, ReplayStopsWhenAsked) {
  const std::string path = temp_path("liloc_stop_test.lcmlog");
  {
    LogWriter writer(path);
    auto msg = bridge::make_sample<liloc::status_t>("r");
    for (int i = 0; i < 10; ++i) {
      writer.write("S", 1000000 + i, msg);
    }
  }
  Transport bus(memq());
  int budget = 3;
  EXPECT_EQ(replay_log(path, bus, {0.0}, [&] { return budget-- > 0; }), 3);
  std::remove(path.c_str());
}

TEST(LogFile, UnreadablePathsAreNamed) {
  try {
    LogReader reader("/nonexistent/dir/x.lcmlog");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/x.lcmlog"), std::string::npos);
  }
  EXPECT_THROW(LogWriter("/nonexistent/dir/y.lcmlog"), std::runtime_error);
}

TEST(LogFile, RecorderCapturesWhatTheBusCarries) {
  const std::string path = temp_path("liloc_record_test.lcmlog");
  {
    Transport bus(memq());
    LogWriter writer(path);
    writer.record(bus, "r\\..*");
    auto msg = bridge::make_sample<liloc::odometry_t>("r");
    bus.publish("r.ODOM", msg);
    bus.publish("other.ODOM", msg);
    bus.publish("r.ODOM", msg);
    bus.drain();
    EXPECT_EQ(writer.events_written(), 2);
  }
  LogReader reader(path);
  LogEventView event;
  int n = 0;
  while (reader.next(event)) {
    liloc::odometry_t m;
    ASSERT_TRUE(decode(event, m));
    EXPECT_EQ(event.channel, "r.ODOM");
    EXPECT_EQ(m.header.seq, n);  // numbered per channel: other.ODOM has its own count
    ++n;
  }
  EXPECT_EQ(n, 2);
  std::remove(path.c_str());
}

// A process can read a log as its bus and write its output to another log.
TEST(LogFile, ReadsOneLogAndPublishesIntoAnother) {
  const std::string in = temp_path("liloc_in.lcmlog");
  const std::string out = temp_path("liloc_out.lcmlog");
  {
    LogWriter writer(in);
    auto msg = bridge::make_sample<liloc::status_t>("r");
    for (int i = 0; i < 20; ++i) {
      msg.header.seq = i;
      writer.write("IN", 1000000 + i * 1000, msg);
    }
  }
  {
    TransportConfig config;
    config.url = "file://" + in + "?speed=0";
    config.publish_url = "file://" + out + "?mode=w";
    Transport bus(config);
    bus.subscribe<liloc::status_t>("IN", [&](const liloc::status_t& m, const ReceiveInfo&) {
      liloc::status_t copy = m;
      bus.publish("OUT", copy);
    });
    int rounds = 0;
    while (bus.handle(100) >= 0 && ++rounds < 1000) {
    }
    EXPECT_EQ(bus.stats().at("IN").received, 20);
  }
  LogReader reader(out);
  LogEventView event;
  int n = 0;
  while (reader.next(event)) {
    EXPECT_EQ(event.channel, "OUT");
    ++n;
  }
  EXPECT_EQ(n, 20);
  std::remove(in.c_str());
  std::remove(out.c_str());
}

// Loopback multicast with a sized receive buffer: a 1 MB scan arrives whole. Bounded:
// gives up after 5 s.
TEST(Udpm, LargeMessagesArriveOverLoopback) {
  TransportConfig config;  // the default udpm URL with ttl=0 and recv_buf_size
  config.url = "udpm://239.255.76.67:7671?ttl=0&recv_buf_size=4194304";
  Transport rx(config);
  Transport tx(config);
  int received = 0;
  size_t points = 0;
  rx.subscribe<liloc::lidar_scan_t>("T.LIDAR",
                                    [&](const liloc::lidar_scan_t& m, const ReceiveInfo&) {
                                      ++received;
                                      points = static_cast<size_t>(m.num_points);
                                    });
  LidarScan scan;
  scan.points.resize(50000);
  for (size_t i = 0; i < scan.points.size(); ++i) {
    scan.points[i].position_m = Eigen::Vector3f(1.0f * i, 0, 0);
  }
  auto msg = bridge::to_msg(scan, "T", "lidar", "hdl32");
  ASSERT_GT(msg.getEncodedSize(), 1000000);
  const int kSent = 10;
  for (int i = 0; i < kSent; ++i) {
    ASSERT_TRUE(tx.publish("T.LIDAR", msg));
    rx.handle(50);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (received < kSent && std::chrono::steady_clock::now() < deadline) {
    rx.handle(50);
  }
  EXPECT_EQ(received, kSent);
  EXPECT_EQ(points, 50000u);
  EXPECT_EQ(rx.stats().at("T.LIDAR").dropped, 0);
}

// A receiver with a smaller bound counts a larger message as oversized, undecoded.
TEST(Udpm, ReceiverCountsOversizedMessages) {
  TransportConfig tx_config;
  tx_config.url = "udpm://239.255.76.67:7672?ttl=0&recv_buf_size=4194304";
  TransportConfig rx_config = tx_config;
  rx_config.max_message_bytes = 4096;
  Transport rx(rx_config);
  Transport tx(tx_config);
  int handled = 0;
  rx.subscribe<liloc::status_t>("T.CLOUD",
                                [&](const liloc::status_t&, const ReceiveInfo&) { ++handled; });
  std::vector<uint8_t> big(10000, 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (rx.stats().at("T.CLOUD").oversized == 0 && std::chrono::steady_clock::now() < deadline) {
    tx.publish_raw("T.CLOUD", big.data(), big.size());
    rx.handle(50);
  }
  EXPECT_GE(rx.stats().at("T.CLOUD").oversized, 1);
  EXPECT_EQ(handled, 0);
}

}  // namespace
}  // namespace liloc::transport
