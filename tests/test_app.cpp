#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "app/child_process.hpp"
#include "app/command_line.hpp"
#include "app/process_memory.hpp"
#include "app/program.hpp"
#include "app/worker_pool.hpp"

namespace liloc {
namespace {

struct Parsed {
  std::string config = "config/liloc.yaml";
  double speed = 1.0;
  int robots = 1;
  bool verbose = false;
  std::vector<std::string> files;
};

bool parse(std::vector<const char*> argv, Parsed& p, size_t required_files = 0) {
  CommandLine cli("prog", "test program");
  cli.add_option("config", &p.config, "config file");
  cli.add_option("speed", &p.speed, "speed");
  cli.add_option("robots", &p.robots, "robots");
  cli.add_flag("verbose", &p.verbose, "more output");
  cli.add_positional("FILES", &p.files, "inputs", required_files);
  argv.insert(argv.begin(), "prog");
  return cli.parse(static_cast<int>(argv.size()), argv.data());
}

TEST(CommandLine, ParsesOptionsFlagsAndPositionals) {
  Parsed p;
  ASSERT_TRUE(parse(
      {"--config", "x.yaml", "--speed=2.5", "--robots", "8", "--verbose", "a.log", "b.log"}, p));
  EXPECT_EQ(p.config, "x.yaml");
  EXPECT_EQ(p.speed, 2.5);
  EXPECT_EQ(p.robots, 8);
  EXPECT_TRUE(p.verbose);
  EXPECT_EQ(p.files, (std::vector<std::string>{"a.log", "b.log"}));
}

TEST(CommandLine, KeepsDefaultsWhenAbsent) {
  Parsed p;
  ASSERT_TRUE(parse({}, p));
  EXPECT_EQ(p.config, "config/liloc.yaml");
  EXPECT_EQ(p.robots, 1);
}

TEST(CommandLine, ErrorsNameTheOption) {
  Parsed p;
  EXPECT_THROW(
      {
        try {
          parse({"--colour", "red"}, p);
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("--colour"), std::string::npos);
          throw;
        }
      },
      std::invalid_argument);
  EXPECT_THROW(parse({"--speed", "fast"}, p), std::invalid_argument);
  EXPECT_THROW(parse({"--robots", "3x"}, p), std::invalid_argument);
  EXPECT_THROW(parse({"--config"}, p), std::invalid_argument);
  EXPECT_THROW(parse({}, p, 1), std::invalid_argument);
  EXPECT_THROW(parse({"a.log", "b.log"}, p, 1), std::invalid_argument);  // one too many
}

TEST(CommandLine, HelpStopsParsingAndListsOptions) {
  Parsed p;
  CommandLine cli("prog", "test program");
  cli.add_option("config", &p.config, "config file");
  EXPECT_NE(cli.usage().find("--config VALUE"), std::string::npos);
  EXPECT_NE(cli.usage().find("default: config/liloc.yaml"), std::string::npos);
  EXPECT_FALSE(parse({"--help"}, p));
}

TEST(Program, RejectsUnknownLogLevel) {
  EXPECT_THROW(setup_logging("chatty", "test"), std::invalid_argument);
  EXPECT_NO_THROW(setup_logging("off", "test"));
  EXPECT_NO_THROW(setup_logging("warn", "test"));
}

TEST(Program, ExitCodesReportOutcome) {
  const char* ok_argv[] = {"prog", "--log-level", "error"};
  CommandLine ok("prog", "");
  EXPECT_EQ(run_program(ok, "prog", 3, ok_argv, [] { return 0; }), 0);

  const char* bad_level[] = {"prog", "--log-level", "loud"};
  CommandLine bad("prog", "");
  EXPECT_EQ(run_program(bad, "prog", 3, bad_level, [] { return 0; }), 2);

  CommandLine throwing("prog", "");
  EXPECT_EQ(run_program(throwing, "prog", 3, ok_argv,
                        []() -> int { throw std::runtime_error("map directory is corrupt"); }),
            1);
}

TEST(SplitList, ItemsInOrderWithoutEmptyOnes) {
  EXPECT_EQ(split_list("vlp16,hdl32"), (std::vector<std::string>{"vlp16", "hdl32"}));
  EXPECT_EQ(split_list("A,,B,"), (std::vector<std::string>{"A", "B"}));
  EXPECT_TRUE(split_list("").empty());
  EXPECT_EQ(split_list("1:10", ':'), (std::vector<std::string>{"1", "10"}));
}

// One thread: jobs run in order on another thread; a throwing job does not stop the
// worker; on destruction the queued jobs are finished or dropped as asked.
TEST(WorkerPool, RunsJobsInOrderAndFinishesOrDropsTheQueue) {
  std::vector<int> done;
  std::mutex done_mutex;
  std::thread::id worker_thread;
  {
    WorkerPool<int> worker(
        [&](int& job) {
          if (job < 0) {
            throw std::runtime_error("bad job");
          }
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
          std::lock_guard<std::mutex> lock(done_mutex);
          worker_thread = std::this_thread::get_id();
          done.push_back(job);
        },
        WorkerPool<int>::OnStop::kFinishQueued);
    for (int i = 0; i < 20; ++i) {
      worker.submit(i == 5 ? -1 : i);
    }
  }
  std::vector<int> expected;
  for (int i = 0; i < 20; ++i) {
    if (i != 5) {
      expected.push_back(i);
    }
  }
  EXPECT_EQ(done, expected);
  EXPECT_NE(worker_thread, std::this_thread::get_id());

  std::atomic<int> ran{0};
  {
    WorkerPool<int> worker(
        [&](int&) {
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
          ++ran;
        },
        WorkerPool<int>::OnStop::kDropQueued);
    for (int i = 0; i < 50; ++i) {
      worker.submit(i);
    }
  }
  EXPECT_LT(ran.load(), 50);
}

// Two threads run two jobs side by side: each job waits (up to 10 s) until both have
// started, which only happens if they run at once.
TEST(WorkerPool, RunsJobsSideBySideWithSeveralThreads) {
  std::mutex mutex;
  std::condition_variable both_started;
  int started = 0;
  std::atomic<int> met{0};
  {
    WorkerPool<int> pool(
        [&](int&) {
          std::unique_lock<std::mutex> lock(mutex);
          ++started;
          both_started.notify_all();
          if (both_started.wait_for(lock, std::chrono::seconds(10), [&] { return started >= 2; })) {
            ++met;
          }
        },
        WorkerPool<int>::OnStop::kFinishQueued, 2);
    pool.submit(1);
    pool.submit(2);
  }
  EXPECT_EQ(met.load(), 2);
  EXPECT_THROW(WorkerPool<int>([](int&) {}, WorkerPool<int>::OnStop::kDropQueued, 0),
               std::invalid_argument);
}

TEST(ProcessMemory, GrowsWithAllocationsAndIsZeroForNoProcess) {
  const ProcessMemory before = read_process_memory();
  EXPECT_GT(before.rss_mb, 0.0);
  EXPECT_GE(before.peak_mb, before.rss_mb);
  std::vector<char> block(64 * 1024 * 1024, 1);  // touched: resident
  const ProcessMemory after = read_process_memory();
  EXPECT_GT(after.rss_mb, before.rss_mb + 50.0) << static_cast<int>(block[12345]);
  const ProcessMemory gone = read_process_memory("999999999");
  EXPECT_EQ(gone.rss_mb, 0.0);
  EXPECT_EQ(gone.peak_mb, 0.0);
}

}  // namespace
// A child's exit status comes back; a signal stops one that runs on; one that outlives its
// deadline is killed.
TEST(ChildProcess, ReportsExitStatusAndStopsOrKills) {
  EXPECT_EQ(ChildProcess("/bin/sh", {"-c", "exit 3"}).wait(10.0), 3);
  EXPECT_EQ(ChildProcess("/bin/sleep", {"30"}).stop(SIGINT, 10.0), 128 + SIGINT);
  ChildProcess deaf([] {
    std::signal(SIGINT, SIG_IGN);
    std::this_thread::sleep_for(std::chrono::seconds(30));
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // it ignores SIGINT by now
  EXPECT_EQ(deaf.stop(SIGINT, 0.3), -1);
  EXPECT_EQ(ChildProcess([] { throw std::runtime_error("no"); }).wait(10.0), 1);
  EXPECT_EQ(ChildProcess("/nonexistent/program", {}).wait(10.0), 127);
}

}  // namespace liloc
