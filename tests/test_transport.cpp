#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <thread>

#include "bridge/lcm_conversions.hpp"
#include "bridge/message_samples.hpp"
#include "liloc/status_t.hpp"
#include "transport/log_file.hpp"
#include "transport/sequence_tracker.hpp"
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

std::vector<uint8_t> read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

// `count` status messages on "IN" with seq 0, 1, ..., 1 ms apart; all events have one size,
// returned so that a test can find the boundaries between them.
int64_t write_status_log(const std::string& path, int count) {
  {
    LogWriter writer(path);
    auto msg = bridge::make_sample<liloc::status_t>("r");
    for (int i = 0; i < count; ++i) {
      msg.header.seq = i;
      writer.write("IN", 1000000 + i * 1000, msg);
    }
  }
  return static_cast<int64_t>(read_file(path).size()) / count;
}

// What a recorder killed mid-write and restarted leaves: the start of an event header whose
// channel length is nonsense (lcm::LogFile ends the log there), then junk.
std::vector<uint8_t> torn_write() {
  std::vector<uint8_t> bytes = {0xED, 0xA1, 0xDA, 0x01};  // the event magic
  bytes.resize(bytes.size() + 16, 0);                     // event number, timestamp
  bytes.insert(bytes.end(), {0xFF, 0xFF, 0xFF, 0xFF});    // channel length -1
  bytes.resize(bytes.size() + 100, 0xAB);
  return bytes;
}

// Inserts `garbage` into the log at byte `offset`.
void insert_into(const std::string& path, int64_t offset, const std::vector<uint8_t>& garbage) {
  std::vector<uint8_t> bytes = read_file(path);
  bytes.insert(bytes.begin() + offset, garbage.begin(), garbage.end());
  write_file(path, bytes);
}

// The seq of every status message in the log, in order.
std::vector<int64_t> logged_sequence(LogReader& reader) {
  std::vector<int64_t> seqs;
  LogEventView event;
  while (reader.next(event)) {
    liloc::status_t msg;
    EXPECT_TRUE(decode(event, msg));
    seqs.push_back(msg.header.seq);
  }
  return seqs;
}

std::vector<int64_t> iota(int64_t count) {
  std::vector<int64_t> values(static_cast<size_t>(count));
  for (int64_t i = 0; i < count; ++i) {
    values[static_cast<size_t>(i)] = i;
  }
  return values;
}

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
  EXPECT_EQ(types_with_header, 14);  // the channel messages; nested parts have no header
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

// An IMU message from `robot` with the given seq, on "IMU".
void send_imu(Transport& bus, const std::string& robot, int64_t seq) {
  auto msg = bridge::make_sample<liloc::imu_t>(robot);
  msg.header.seq = seq;
  const auto bytes = encode(msg);
  bus.publish_raw("IMU", bytes.data(), bytes.size());
}

TEST(Transport, SequenceGapsCountAsDropsPerSender) {
  Transport bus(memq());
  bus.subscribe<liloc::imu_t>("IMU", [](const liloc::imu_t&, const ReceiveInfo&) {});
  auto send = [&](const std::string& robot, int64_t seq) { send_imu(bus, robot, seq); };
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

// A jump, a negative number or a restart far back re-anchors the sender: no absurd drop
// counts, no overflow, no reorders reported for ever after.
TEST(Transport, SequenceJumpsAndNegativeNumbersAreSenderRestarts) {
  Transport bus(memq());
  bus.subscribe<liloc::imu_t>("IMU", [](const liloc::imu_t&, const ReceiveInfo&) {});
  constexpr int64_t kHuge = int64_t{1} << 62;
  constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
  constexpr int64_t kMin = std::numeric_limits<int64_t>::min();
  for (const int64_t seq : {int64_t{5}, kHuge, kHuge + 1, int64_t{-7}, int64_t{3}, int64_t{4}}) {
    send_imu(bus, "a", seq);  // resets at 2^62 and -7
  }
  for (const int64_t seq : {int64_t{0}, kMax, kMin, int64_t{1}}) {
    send_imu(bus, "b", seq);  // resets at the extremes
  }
  for (const int64_t seq : {int64_t{500000}, int64_t{3}, int64_t{4}, int64_t{6}}) {
    send_imu(bus, "c", seq);  // restarted far back, then loses 5
  }
  bus.drain();
  const ChannelStats s = bus.stats().at("IMU");
  EXPECT_EQ(s.received, 14);
  EXPECT_EQ(s.sequence_resets, 5);
  EXPECT_EQ(s.dropped, 1);
  EXPECT_EQ(s.out_of_order, 0);
}

// 10 000 senders on one subscription: it remembers max_senders of them, forgetting the
// least recently heard; a sender heard all along keeps its sequence.
TEST(Transport, PerSenderStateIsBoundedLeastRecentlyHeardFirst) {
  TransportConfig config = memq();
  ASSERT_EQ(config.max_senders, 256);
  Transport bus(config);
  bus.subscribe<liloc::imu_t>("IMU", [](const liloc::imu_t&, const ReceiveInfo&) {});
  constexpr int kSenders = 10000;
  int64_t steady_seq = 0;
  for (int i = 0; i < kSenders; ++i) {
    send_imu(bus, "s" + std::to_string(i), 10);
    if (i % 100 == 0) {
      send_imu(bus, "steady", steady_seq++);
    }
    bus.drain();
  }
  send_imu(bus, "steady", steady_seq + 1);  // one lost: still remembered
  send_imu(bus, "s0", 15);                  // forgotten long ago: anchors again, no loss
  bus.drain();
  const ChannelStats s = bus.stats().at("IMU");
  EXPECT_EQ(s.dropped, 1);
  EXPECT_EQ(s.out_of_order, 0);
  EXPECT_EQ(s.senders_forgotten, (kSenders + 1 - 256) + 1);

  SequenceTracker tracker(config.max_sequence_gap, config.max_senders);
  for (int i = 0; i < kSenders; ++i) {
    tracker.track("s" + std::to_string(i), 0);
  }
  EXPECT_EQ(tracker.senders(), 256u);
  EXPECT_EQ(tracker.counts().senders_forgotten, kSenders - 256);
}

TEST(TransportConfig, RefusesOutOfRangeSequenceBoundsNamingTheField) {
  const auto refusal = [](const TransportConfig& config) {
    try {
      config.validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  TransportConfig config;
  EXPECT_EQ(refusal(config), "accepted");
  config.max_sequence_gap = 0;
  EXPECT_NE(refusal(config).find("max_sequence_gap"), std::string::npos);
  config = {};
  config.max_senders = 0;
  EXPECT_NE(refusal(config).find("max_senders"), std::string::npos);
  config.max_senders = 2000000000;
  EXPECT_NE(refusal(config).find("max_senders"), std::string::npos);
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
  const ReplayResult replayed = replay_log(path, bus, {0.0});
  EXPECT_EQ(replayed.published, 100);
  EXPECT_FALSE(replayed.damage.any());
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
  EXPECT_EQ(replay_log(path, bus, {1.0}).published, 5);
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
  EXPECT_EQ(replay_log(path, bus, {0.0}, [&] { return budget-- > 0; }).published, 3);
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

// Garbage in the middle of a log costs only the garbage: every event after it is read, and
// the region is reported with its byte offset.
TEST(LogReader, SkipsGarbageInTheMiddleAndReportsItsOffset) {
  const std::string path = temp_path("liloc_garbage.lcmlog");
  const int64_t event_bytes = write_status_log(path, 20);
  const int64_t garbage_at = 10 * event_bytes;
  insert_into(path, garbage_at, torn_write());
  LogReader reader(path);
  EXPECT_EQ(logged_sequence(reader), iota(20));
  const LogDamage& damage = reader.damage();
  EXPECT_EQ(damage.corrupt_regions, 1);
  EXPECT_EQ(damage.bytes_skipped, static_cast<int64_t>(torn_write().size()));
  ASSERT_EQ(damage.regions.size(), 1u);
  EXPECT_EQ(damage.regions[0].offset, garbage_at);
  EXPECT_EQ(damage.regions[0].bytes, static_cast<int64_t>(torn_write().size()));
  EXPECT_FALSE(damage.truncated_end);
  std::remove(path.c_str());
}

// A data length pointing past the end of the file (a flipped bit in a header) costs that
// one event, not the rest of the log.
TEST(LogReader, ACorruptEventHeaderCostsOnlyThatEvent) {
  const std::string path = temp_path("liloc_bad_header.lcmlog");
  const int64_t event_bytes = write_status_log(path, 20);
  std::vector<uint8_t> bytes = read_file(path);
  bytes[static_cast<size_t>(5 * event_bytes + 24)] = 0x01;  // data length + 16 MiB
  write_file(path, bytes);
  LogReader reader(path);
  std::vector<int64_t> expected = iota(20);
  expected.erase(expected.begin() + 5);
  EXPECT_EQ(logged_sequence(reader), expected);
  ASSERT_EQ(reader.damage().regions.size(), 1u);
  EXPECT_EQ(reader.damage().regions[0].offset, 5 * event_bytes);
  EXPECT_EQ(reader.damage().regions[0].bytes, event_bytes);
  EXPECT_FALSE(reader.damage().truncated_end);
  std::remove(path.c_str());
}

TEST(LogReader, ReportsATruncatedLastEvent) {
  const std::string path = temp_path("liloc_truncated.lcmlog");
  const int64_t event_bytes = write_status_log(path, 10);
  std::vector<uint8_t> bytes = read_file(path);
  bytes.resize(bytes.size() - 7);  // the recorder was killed mid-write
  write_file(path, bytes);
  LogReader reader(path);
  EXPECT_EQ(logged_sequence(reader), iota(9));
  const LogDamage& damage = reader.damage();
  EXPECT_TRUE(damage.truncated_end);
  EXPECT_EQ(damage.truncated_offset, 9 * event_bytes);
  EXPECT_EQ(damage.bytes_skipped, event_bytes - 7);
  EXPECT_EQ(damage.corrupt_regions, 0);
  std::remove(path.c_str());
}

// What LogWriter writes (through lcm::LogFile, so lcm-logplayer plays it) reads back through
// LogReader exactly as LCM's own reader sees it: channels, times and bytes, including
// empty and multi-megabyte events.
TEST(LogReader, ReadsWhatLogWriterWroteAsLcmDoes) {
  const std::string path = temp_path("liloc_compat.lcmlog");
  {
    LogWriter writer(path);
    auto scan = bridge::make_sample<liloc::lidar_scan_t>("r");
    std::vector<uint8_t> big(5 << 20);
    for (size_t i = 0; i < big.size(); ++i) {
      big[i] = static_cast<uint8_t>(i * 31);
    }
    writer.write("r.LIDAR", 1000000, scan);
    writer.write_raw("EMPTY", 1000001, nullptr, 0);
    writer.write_raw("BIG", 1000002, big.data(), big.size());
    writer.write_raw(std::string(63, 'c'), -5, big.data(), 100);
    writer.write("r.LIDAR", 1000003, scan);
  }
  lcm::LogFile lcm_reader(path, "r");
  LogReader reader(path);
  LogEventView event;
  int events = 0;
  for (const lcm::LogEvent* expected = lcm_reader.readNextEvent(); expected != nullptr;
       expected = lcm_reader.readNextEvent()) {
    ASSERT_TRUE(reader.next(event));
    EXPECT_EQ(event.channel, expected->channel);
    EXPECT_EQ(event.utime, expected->timestamp);
    ASSERT_EQ(event.size, static_cast<size_t>(expected->datalen));
    EXPECT_EQ(std::memcmp(event.data, expected->data, event.size), 0);
    ++events;
  }
  EXPECT_EQ(events, 5);
  EXPECT_FALSE(reader.next(event));
  EXPECT_FALSE(reader.damage().any());
  std::remove(path.c_str());
}

TEST(LogFile, ReplayLogDeliversEverythingAfterGarbageAndReturnsTheDamage) {
  const std::string path = temp_path("liloc_replay_garbage.lcmlog");
  const int64_t event_bytes = write_status_log(path, 20);
  insert_into(path, 3 * event_bytes, torn_write());
  insert_into(path, 0, torn_write());
  Transport bus(memq());
  std::vector<int64_t> seqs;
  bus.subscribe<liloc::status_t>(
      "IN", [&](const liloc::status_t& m, const ReceiveInfo&) { seqs.push_back(m.header.seq); });
  const ReplayResult replayed = replay_log(path, bus, {0.0});
  EXPECT_EQ(replayed.published, 20);
  EXPECT_EQ(seqs, iota(20));
  EXPECT_EQ(replayed.damage.corrupt_regions, 2);
  ASSERT_EQ(replayed.damage.regions.size(), 2u);
  EXPECT_EQ(replayed.damage.regions[0].offset, 0);
  EXPECT_EQ(replayed.damage.regions[1].offset,
            static_cast<int64_t>(torn_write().size()) + 3 * event_bytes);
  std::remove(path.c_str());
}

// A process reading a log as its bus (file://) gets every message after garbage, and can
// report the damage.
TEST(LogFile, TransportOnALogDeliversEverythingAfterGarbageAndReportsIt) {
  const std::string path = temp_path("liloc_bus_garbage.lcmlog");
  const int64_t event_bytes = write_status_log(path, 20);
  insert_into(path, 10 * event_bytes, torn_write());
  TransportConfig config;
  config.url = "file://" + path + "?speed=0";
  config.publish_url = "memq://";
  Transport bus(config);
  std::vector<int64_t> seqs;
  bus.subscribe<liloc::status_t>(
      "IN", [&](const liloc::status_t& m, const ReceiveInfo&) { seqs.push_back(m.header.seq); });
  int rounds = 0;
  while (bus.handle(100) >= 0 && ++rounds < 1000) {
  }
  EXPECT_EQ(seqs, iota(20));
  EXPECT_EQ(bus.stats().at("IN").dropped, 0);
  ASSERT_NE(bus.log_damage(), nullptr);
  ASSERT_EQ(bus.log_damage()->regions.size(), 1u);
  EXPECT_EQ(bus.log_damage()->regions[0].offset, 10 * event_bytes);
  EXPECT_EQ(Transport(memq()).log_damage(), nullptr);
  std::remove(path.c_str());
}

// speed=S plays the logged spacing divided by S; an option LCM does not know is refused
// rather than ignored (a misspelt speed=0 would replay in real time).
TEST(LogFile, TransportOnALogKeepsTheUrlsSpeedAndRefusesUnknownOptions) {
  const std::string path = temp_path("liloc_bus_speed.lcmlog");
  {
    LogWriter writer(path);
    auto msg = bridge::make_sample<liloc::status_t>("r");
    for (int i = 0; i < 5; ++i) {
      writer.write("IN", 1000000 + i * 250000, msg);  // 1 s of log
    }
  }
  TransportConfig config;
  config.url = "file://" + path + "?speed=4";
  config.publish_url = "memq://";
  Transport bus(config);
  int received = 0;
  bus.subscribe<liloc::status_t>("IN",
                                 [&](const liloc::status_t&, const ReceiveInfo&) { ++received; });
  const auto start = std::chrono::steady_clock::now();
  int rounds = 0;
  while (bus.handle(20) >= 0 && ++rounds < 1000) {
  }
  const auto elapsed = std::chrono::steady_clock::now() - start;
  EXPECT_EQ(received, 5);
  EXPECT_GE(elapsed, std::chrono::milliseconds(245));
  EXPECT_LT(elapsed, std::chrono::milliseconds(900));  // real time would take 1 s
  config.url = "file://" + path + "?sped=0";
  EXPECT_THROW(Transport{config}, std::invalid_argument);
  std::remove(path.c_str());
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
