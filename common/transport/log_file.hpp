#pragma once
// LCM log files (the format lcm-logger writes and lcm-logplayer plays): writing,
// reading with resynchronization past damage, and replaying into a Transport.

#include <chrono>
#include <cstdint>
#include <fstream>
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

// Bytes of a log that hold no readable event.
struct SkippedRegion {
  int64_t offset = 0;  // from the start of the file
  int64_t bytes = 0;
};

// What a LogReader had to skip so far. Nothing in a log is dropped without landing here.
struct LogDamage {
  static constexpr size_t kListedRegions = 16;

  int64_t corrupt_regions = 0;         // stretches between events that are not events
  int64_t bytes_skipped = 0;           // in those regions and in a truncated last event
  bool truncated_end = false;          // the last event is cut short (a recorder killed mid-write)
  int64_t truncated_offset = -1;       // where that last event starts
  std::vector<SkippedRegion> regions;  // the first kListedRegions corrupt regions

  bool any() const { return corrupt_regions > 0 || truncated_end; }
  // One line for messages: "2 corrupt regions, 310 bytes skipped, last event cut short at
  // byte offset 9000".
  std::string summary() const;
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

  // Pushes buffered events to the disk; throws std::runtime_error naming the path if that
  // fails (disk full), which write_raw() alone cannot notice for the last events.
  void flush();

  int64_t events_written() const { return events_written_; }

 private:
  std::string path_;
  std::unique_ptr<lcm::LogFile> log_;
  int64_t events_written_ = 0;
};

// Reads the LCM log format itself rather than through lcm::LogFile, which ends the log at
// the first corrupt event header and so silently drops everything after it. A header that
// is not plausible (no magic, channel length outside 1..256 or not printable, data length
// negative or over max_data_bytes, an event running past the end of the file) starts a
// corrupt region: the reader scans forward byte by byte to the next plausible header,
// records the region in damage() and warns with the file and byte offset. An incomplete
// last event is reported as a truncation.
class LogReader {
 public:
  static constexpr int64_t kDefaultMaxDataBytes = int64_t{64} << 20;

  // Throws std::runtime_error naming the path if it cannot be opened, and
  // std::invalid_argument unless 0 < max_data_bytes <= 2^31 - 1 (the format's limit).
  explicit LogReader(const std::string& path, int64_t max_data_bytes = kDefaultMaxDataBytes);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // Reads the next event; false at the end of the log. Throws std::runtime_error naming the
  // path if the file cannot be read.
  bool next(LogEventView& event);

  const LogDamage& damage() const { return damage_; }

 private:
  struct EventHeader {
    int64_t utime = 0;
    int32_t channel_bytes = 0;
    int32_t data_bytes = 0;
  };
  enum class HeaderCheck { kEvent, kRunsPastEnd, kNotAnEvent };

  HeaderCheck check_header(int64_t offset, EventHeader& header);
  // From an offset that starts no event, moves to the next plausible one (or the end),
  // recording what lies between as damage.
  void resynchronize();
  void record_corrupt_region(int64_t offset, int64_t bytes);
  void record_truncated_end(int64_t offset);
  // Pointer to `count` bytes of the file at `offset` (within the file), valid until the
  // next call.
  const uint8_t* bytes_at(int64_t offset, int64_t count);

  std::string path_;
  int64_t max_data_bytes_;
  std::ifstream file_;
  int64_t file_bytes_ = 0;
  int64_t position_ = 0;  // where the next event should start
  std::vector<uint8_t> window_;
  int64_t window_offset_ = 0;
  LogDamage damage_;
};

// When each event of a log played at `speed` is due on the wall clock: its log time since
// the first event's, divided by speed, after the first event was due (as LCM's log
// provider plays). Speed 0 plays everything at once.
class ReplayClock {
 public:
  // Throws std::invalid_argument unless speed is finite and >= 0.
  explicit ReplayClock(double speed);
  std::chrono::steady_clock::time_point due(int64_t log_utime);

 private:
  double speed_;
  bool started_ = false;
  int64_t first_utime_ = 0;
  std::chrono::steady_clock::time_point start_;
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

struct ReplayResult {
  int64_t published = 0;  // events handed to transport.publish_raw()
  LogDamage damage;       // what could not be read from the log
};

// Publishes every event of the log on `transport`, in log order, and drains the
// transport after each one so that in-process (memq://) subscribers handle every
// message before the next is published: a replay that is deterministic and never
// drops. Stops early when keep_going() returns false.
ReplayResult replay_log(
    const std::string& path, Transport& transport, const ReplayOptions& options,
    const std::function<bool()>& keep_going = [] { return true; });

}  // namespace liloc::transport
