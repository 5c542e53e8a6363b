#pragma once
// LCM log files (the format lcm-logger writes and lcm-logplayer plays): writing,
// reading, and replaying into a Transport.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "transport/transport.hpp"

namespace lcm {
class LogFile;
}

namespace liloc::transport {

// One event of a log; the data pointer is valid until the reader's next call.
struct LogEventView {
  int64_t utime = 0;  // event timestamp, microseconds since the Unix epoch
  std::string channel;
  const void* data = nullptr;
  size_t size = 0;
};

class LogWriter {
 public:
  // Creates (truncates) the file; throws std::runtime_error naming the path on failure.
  explicit LogWriter(const std::string& path);
  ~LogWriter();
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;

  void write_raw(const std::string& channel, int64_t utime, const void* data, size_t size);

  // Encodes msg as is (its header.seq is the caller's) and writes it at utime.
  template <class Msg>
  void write(const std::string& channel, int64_t utime, const Msg& msg) {
    std::vector<uint8_t> buffer(static_cast<size_t>(msg.getEncodedSize()));
    msg.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
    write_raw(channel, utime, buffer.data(), buffer.size());
  }

  // Writes every message that `transport` receives on channels matching the regex,
  // stamped with its receive time: a recorder like lcm-logger.
  void record(Transport& transport, const std::string& channel_regex = ".*");

  int64_t events_written() const { return events_written_; }

 private:
  std::string path_;
  std::unique_ptr<lcm::LogFile> log_;
  int64_t events_written_ = 0;
};

class LogReader {
 public:
  // Throws std::runtime_error naming the path if it cannot be opened.
  explicit LogReader(const std::string& path);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // Reads the next event; false at the end of the log (or at a truncated last event).
  bool next(LogEventView& event);

 private:
  std::unique_ptr<lcm::LogFile> log_;
};

// Decodes a logged message; false if its type or bytes do not match Msg.
template <class Msg>
bool decode(const LogEventView& event, Msg& msg) {
  try {
    return msg.decode(event.data, 0, static_cast<int>(event.size)) >= 0;
  } catch (const std::exception&) {
    return false;
  }
}

struct ReplayOptions {
  // 0 plays as fast as possible; 1 keeps the logged timing; 2 twice as fast ...
  double speed = 0.0;
};

// Publishes every event of the log on `transport`, in log order, and drains the
// transport after each one so that in-process (memq://) subscribers handle every
// message before the next is published: a replay that is deterministic and never
// drops. Stops early when keep_going() returns false. Returns the events published.
int64_t replay_log(
    const std::string& path, Transport& transport, const ReplayOptions& options,
    const std::function<bool()>& keep_going = [] { return true; });

}  // namespace liloc::transport
