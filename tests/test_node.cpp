#include <gtest/gtest.h>

#include <fstream>

#include "config/yaml_config.hpp"
#include "liloc/status_t.hpp"
#include "node/node.hpp"
#include "node/process_config.hpp"
#include "transport/log_file.hpp"

namespace liloc::node {
namespace {

// Counts what it receives on "IN" and answers each on "OUT".
class EchoNode final : public Node {
 public:
  EchoNode(transport::Transport& bus, bool finishes_well) : bus_(bus), ok_(finishes_well) {
    bus_.subscribe<liloc::status_t>(
        "IN", [this](const liloc::status_t& m, const transport::ReceiveInfo&) {
          ++received;
          liloc::status_t out = m;
          bus_.publish("OUT", out);
        });
  }
  std::string name() const override { return "echo"; }
  void tick(int64_t now_us) override {
    ++ticks;
    last_tick_us = now_us;
  }
  bool finish() override {
    ++finished;
    return ok_;
  }
  int received = 0, ticks = 0, finished = 0;
  int64_t last_tick_us = 0;

 private:
  transport::Transport& bus_;
  bool ok_;
};

std::string write_log(int messages) {
  const std::string path = ::testing::TempDir() + "liloc_node_input.lcmlog";
  transport::LogWriter log(path);
  for (int i = 0; i < messages; ++i) {
    liloc::status_t m{};
    m.header.seq = i;
    log.write("IN", 1000 * i, m);
  }
  return path;
}

// A process runs its node on a log at full speed: every message handled, the node ticked,
// finished at the end of the log; a node that lost data makes the run report it.
TEST(RunNodes, HandlesALogTicksAndFinishes) {
  transport::TransportConfig config;
  config.url = "file://" + write_log(50) + "?speed=0";
  config.publish_url = "memq://";
  transport::Transport bus(config);
  EchoNode good(bus, true), lossy(bus, false);
  EXPECT_FALSE(run_nodes(bus, {&good, &lossy}));
  EXPECT_EQ(good.received, 50);
  EXPECT_EQ(lossy.received, 50);
  EXPECT_GE(good.ticks, 1);
  EXPECT_GT(good.last_tick_us, 1'600'000'000'000'000);  // wall-clock time
  EXPECT_EQ(good.finished, 1);
  EXPECT_EQ(lossy.finished, 1);
}

// Nodes compose in one process: over memq:// what one publishes reaches the next at the
// following drain, in order.
TEST(RunNodes, NodesComposeOverMemq) {
  transport::TransportConfig config;
  config.url = "memq://";
  transport::Transport bus(config);
  EchoNode echo(bus, true);
  std::vector<int64_t> out;
  bus.subscribe<liloc::status_t>("OUT",
                                 [&](const liloc::status_t& m, const transport::ReceiveInfo&) {
                                   out.push_back(m.header.seq);
                                 });
  for (int i = 0; i < 5; ++i) {
    liloc::status_t m{};
    bus.publish("IN", m);
  }
  bus.drain();
  EXPECT_EQ(echo.received, 5);
  EXPECT_EQ(out, (std::vector<int64_t>{0, 1, 2, 3, 4}));
}

struct SmallConfig {
  int answer = 42;
  template <class V>
  void visit_fields(V& v) {
    v("answer", answer);
  }
};

struct SmallNodeConfig {
  SmallConfig odometry;
  template <class V>
  void visit_fields(V& v) {
    v("odometry", odometry);
  }
};

// A process reads its sections and accepts the other system sections by name only; an
// unknown section is an error; --print-config shows what the process reads.
TEST(ProcessConfig, ReadsItsSectionsAndKnowsTheOthers) {
  const std::string path = ::testing::TempDir() + "liloc_node_process.yaml";
  std::ofstream(path) << "odometry:\n  answer: 7\nmap_server:\n  anything: [1, 2]\n";
  const auto config = load_config<ProcessConfig<SmallNodeConfig>>(path);
  EXPECT_EQ(config.node.odometry.answer, 7);
  const std::string dumped = dump_config(config);
  EXPECT_NE(dumped.find("answer: 7"), std::string::npos) << dumped;
  EXPECT_EQ(dumped.find("map_server"), std::string::npos) << dumped;
  std::ofstream(path) << "odometry:\n  answer: 7\nmap_srever: {}\n";
  EXPECT_THROW(load_config<ProcessConfig<SmallNodeConfig>>(path), ConfigError);
}

}  // namespace
}  // namespace liloc::node
