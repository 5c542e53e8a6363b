#include "transport/log_file.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <stdexcept>
#include <thread>

#include "app/rate_limit.hpp"

namespace liloc::transport {
namespace {

// The event header: magic, event number, timestamp, channel length, data length; all
// big-endian.
constexpr std::array<uint8_t, 4> kMagic = {0xED, 0xA1, 0xDA, 0x01};
constexpr int64_t kHeaderBytes = 4 + 8 + 8 + 4 + 4;
constexpr int64_t kTimestampAt = 12;
constexpr int64_t kChannelBytesAt = 20;
constexpr int64_t kDataBytesAt = 24;
constexpr int32_t kMaxChannelBytes = 256;
// Read ahead in chunks of this size, so that scanning a corrupt region byte by byte does not
// cost a read per byte.
constexpr int64_t kReadChunkBytes = int64_t{1} << 20;
constexpr int64_t kCorruptRegionLogPeriod = 100;

template <class T>
T read_big_endian(const uint8_t* bytes) {
  uint64_t value = 0;
  for (size_t i = 0; i < sizeof(T); ++i) {
    value = (value << 8) | bytes[i];
  }
  return static_cast<T>(value);
}

bool printable(uint8_t c) { return c >= 0x20 && c < 0x7f; }

}  // namespace

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

void LogWriter::flush() {
  if (std::fflush(log_->getFilePtr()) != 0) {
    throw std::runtime_error(path_ + ": write failed (disk full?)");
  }
}

LogReader::LogReader(const std::string& path, int64_t max_data_bytes)
    : path_(path), max_data_bytes_(max_data_bytes), file_(path, std::ios::binary) {
  if (max_data_bytes <= 0 || max_data_bytes > std::numeric_limits<int32_t>::max()) {
    throw std::invalid_argument("LogReader: max_data_bytes must be in [1, 2^31 - 1]");
  }
  if (!file_) {
    throw std::runtime_error(path + ": cannot open LCM log file");
  }
  file_.seekg(0, std::ios::end);
  file_bytes_ = static_cast<int64_t>(file_.tellg());
  if (!file_ || file_bytes_ < 0) {
    throw std::runtime_error(path + ": cannot read LCM log file");
  }
}

LogReader::~LogReader() = default;

bool LogReader::next(LogEventView& event) {
  while (position_ < file_bytes_) {
    EventHeader header;
    if (check_header(position_, header) != HeaderCheck::kEvent) {
      resynchronize();
      continue;
    }
    const int64_t event_bytes = kHeaderBytes + header.channel_bytes + header.data_bytes;
    const uint8_t* bytes = bytes_at(position_, event_bytes);
    event.utime = header.utime;
    event.channel.assign(reinterpret_cast<const char*>(bytes + kHeaderBytes),
                         static_cast<size_t>(header.channel_bytes));
    event.data = bytes + kHeaderBytes + header.channel_bytes;
    event.size = static_cast<size_t>(header.data_bytes);
    position_ += event_bytes;
    return true;
  }
  return false;
}

LogReader::HeaderCheck LogReader::check_header(int64_t offset, EventHeader& header) {
  const int64_t available = file_bytes_ - offset;
  const int64_t magic_bytes = std::min<int64_t>(available, kMagic.size());
  const uint8_t* bytes = bytes_at(offset, magic_bytes);
  if (!std::equal(bytes, bytes + magic_bytes, kMagic.begin())) {
    return HeaderCheck::kNotAnEvent;
  }
  if (available < kHeaderBytes) {
    return HeaderCheck::kRunsPastEnd;
  }
  bytes = bytes_at(offset, kHeaderBytes);
  header.utime = read_big_endian<int64_t>(bytes + kTimestampAt);
  header.channel_bytes = read_big_endian<int32_t>(bytes + kChannelBytesAt);
  header.data_bytes = read_big_endian<int32_t>(bytes + kDataBytesAt);
  if (header.channel_bytes < 1 || header.channel_bytes > kMaxChannelBytes ||
      header.data_bytes < 0 || header.data_bytes > max_data_bytes_) {
    return HeaderCheck::kNotAnEvent;
  }
  // Of a channel cut off by the end of the file, the bytes present must still be printable.
  const int64_t channel_present = std::min<int64_t>(header.channel_bytes, available - kHeaderBytes);
  bytes = bytes_at(offset, kHeaderBytes + channel_present);
  if (!std::all_of(bytes + kHeaderBytes, bytes + kHeaderBytes + channel_present, printable)) {
    return HeaderCheck::kNotAnEvent;
  }
  return kHeaderBytes + header.channel_bytes + header.data_bytes <= available
             ? HeaderCheck::kEvent
             : HeaderCheck::kRunsPastEnd;
}

void LogReader::resynchronize() {
  const int64_t start = position_;
  // The first candidate that only lacks its end: a truncated last event, unless a complete
  // event follows it.
  int64_t cut_event = -1;
  EventHeader header;
  for (int64_t offset = start; offset < file_bytes_; ++offset) {
    const HeaderCheck check = check_header(offset, header);
    if (check == HeaderCheck::kEvent) {
      record_corrupt_region(start, offset - start);
      position_ = offset;
      return;
    }
    if (check == HeaderCheck::kRunsPastEnd && cut_event < 0) {
      cut_event = offset;
    }
  }
  const int64_t corrupt_end = cut_event < 0 ? file_bytes_ : cut_event;
  if (corrupt_end > start) {
    record_corrupt_region(start, corrupt_end - start);
  }
  if (cut_event >= 0) {
    record_truncated_end(cut_event);
  }
  position_ = file_bytes_;
}

void LogReader::record_corrupt_region(int64_t offset, int64_t bytes) {
  ++damage_.corrupt_regions;
  damage_.bytes_skipped += bytes;
  if (damage_.regions.size() < LogDamage::kListedRegions) {
    damage_.regions.push_back({offset, bytes});
  }
  if (should_log(damage_.corrupt_regions, kCorruptRegionLogPeriod)) {
    spdlog::warn("{}: skipped {} corrupt bytes at byte offset {} (corrupt region #{})", path_,
                 bytes, offset, damage_.corrupt_regions);
  }
}

void LogReader::record_truncated_end(int64_t offset) {
  damage_.truncated_end = true;
  damage_.truncated_offset = offset;
  damage_.bytes_skipped += file_bytes_ - offset;
  spdlog::warn("{}: the last event, at byte offset {}, is cut short after {} bytes; ignored", path_,
               offset, file_bytes_ - offset);
}

const uint8_t* LogReader::bytes_at(int64_t offset, int64_t count) {
  const int64_t window_end = window_offset_ + static_cast<int64_t>(window_.size());
  if (offset >= window_offset_ && offset + count <= window_end) {
    return window_.data() + (offset - window_offset_);
  }
  // Keeps what the window already holds of the range (the start of a large event).
  int64_t kept = 0;
  if (offset >= window_offset_ && offset < window_end) {
    kept = window_end - offset;
    std::memmove(window_.data(), window_.data() + (offset - window_offset_),
                 static_cast<size_t>(kept));
  }
  const int64_t size = std::min(std::max(count, kReadChunkBytes), file_bytes_ - offset);
  window_.resize(static_cast<size_t>(size));
  window_offset_ = offset;
  file_.clear();
  file_.seekg(offset + kept);
  file_.read(reinterpret_cast<char*>(window_.data() + kept), size - kept);
  if (file_.gcount() != size - kept) {
    window_.clear();
    throw std::runtime_error(path_ + ": read failed at byte offset " +
                             std::to_string(offset + kept));
  }
  return window_.data();
}

ReplayClock::ReplayClock(double speed) : speed_(speed) {
  if (!std::isfinite(speed) || speed < 0.0) {
    throw std::invalid_argument("replay speed must be a finite number >= 0 (0: at once)");
  }
}

std::chrono::steady_clock::time_point ReplayClock::due(int64_t log_utime) {
  if (!started_) {
    started_ = true;
    first_utime_ = log_utime;
    start_ = std::chrono::steady_clock::now();
  }
  if (speed_ == 0.0) {
    return start_;
  }
  // Beyond any real log (30 years); keeps a corrupt timestamp from overflowing the clock.
  constexpr double kLongestDelayUs = 1e15;
  const double delay_us =
      std::clamp((static_cast<double>(log_utime) - static_cast<double>(first_utime_)) / speed_, 0.0,
                 kLongestDelayUs);
  return start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                      std::chrono::duration<double, std::micro>(delay_us));
}

ReplayResult replay_log(const std::string& path, Transport& transport, const ReplayOptions& options,
                        const std::function<bool()>& keep_going) {
  LogReader reader(path);
  ReplayClock clock(options.speed);
  LogEventView event;
  ReplayResult result;
  while (keep_going() && reader.next(event)) {
    std::this_thread::sleep_until(clock.due(event.utime));
    if (transport.publish_raw(event.channel, event.data, event.size)) {
      ++result.published;
    }
    transport.drain();
  }
  result.damage = reader.damage();
  return result;
}

std::string LogDamage::summary() const {
  std::string out = std::to_string(corrupt_regions) + " corrupt regions, " +
                    std::to_string(bytes_skipped) + " bytes skipped";
  if (truncated_end) {
    out += ", last event cut short at byte offset " + std::to_string(truncated_offset);
  }
  return out;
}

}  // namespace liloc::transport
