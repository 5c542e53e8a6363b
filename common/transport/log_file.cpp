#include "transport/log_file.hpp"

#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <thread>

namespace liloc::transport {

LogWriter::LogWriter(const std::string& path)
    : path_(path), log_(std::make_unique<lcm::LogFile>(path, "w")) {
  if (!log_->good()) {
    throw std::runtime_error(path + ": cannot create LCM log file");
  }
}

LogWriter::~LogWriter() = default;

void LogWriter::write_raw(const std::string& channel, int64_t utime, const void* data,
                          size_t size) {
  lcm::LogEvent event;
  event.eventnum = events_written_;
  event.timestamp = utime;
  event.channel = channel;
  event.datalen = static_cast<int32_t>(size);
  event.data = const_cast<void*>(data);
  if (log_->writeEvent(&event) != 0) {
    throw std::runtime_error(path_ + ": write failed (disk full?)");
  }
  ++events_written_;
}

void LogWriter::record(Transport& transport, const std::string& channel_regex) {
  transport.subscribe_raw(channel_regex,
                          [this](const void* data, size_t size, const ReceiveInfo& info) {
                            write_raw(info.channel, info.recv_utime, data, size);
                          });
}

LogReader::LogReader(const std::string& path) : log_(std::make_unique<lcm::LogFile>(path, "r")) {
  if (!log_->good()) {
    throw std::runtime_error(path + ": cannot open LCM log file");
  }
}

LogReader::~LogReader() = default;

bool LogReader::next(LogEventView& event) {
  const lcm::LogEvent* e = log_->readNextEvent();
  if (e == nullptr) {
    return false;
  }
  event.utime = e->timestamp;
  event.channel = e->channel;
  event.data = e->data;
  event.size = static_cast<size_t>(e->datalen);
  return true;
}

int64_t replay_log(const std::string& path, Transport& transport, const ReplayOptions& options,
                   const std::function<bool()>& keep_going) {
  LogReader reader(path);
  LogEventView event;
  int64_t published = 0;
  int64_t first_log_utime = 0;
  const auto wall_start = std::chrono::steady_clock::now();
  while (keep_going() && reader.next(event)) {
    if (options.speed > 0.0) {
      if (published == 0) {
        first_log_utime = event.utime;
      }
      const auto due = wall_start + std::chrono::microseconds(static_cast<int64_t>(
                                        (event.utime - first_log_utime) / options.speed));
      std::this_thread::sleep_until(due);
    }
    transport.publish_raw(event.channel, event.data, event.size);
    ++published;
    transport.drain();
  }
  return published;
}

}  // namespace liloc::transport
