#include "storage/file_io.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "storage/map_error.hpp"

namespace liloc::storage {
namespace {

[[noreturn]] void fail_errno(const std::string& path, const std::string& action) {
  const int error = errno;
  throw MapError::in_file(path, action + ": " + std::strerror(error));
}

// Closes a descriptor on every path out of a function; close errors after a successful
// fsync cannot lose data, so they are not reported from here.
class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) {
      ::close(fd_);
    }
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

}  // namespace

uint32_t crc32_of(std::string_view bytes) {
  uLong crc = ::crc32(0L, Z_NULL, 0);
  // zlib takes lengths as uInt; feed large buffers in pieces.
  constexpr size_t kChunk = size_t{1} << 30;
  for (size_t offset = 0; offset < bytes.size(); offset += kChunk) {
    const size_t n = std::min(kChunk, bytes.size() - offset);
    crc = ::crc32(crc, reinterpret_cast<const Bytef*>(bytes.data() + offset), static_cast<uInt>(n));
  }
  return static_cast<uint32_t>(crc);
}

std::string format_crc32(uint32_t crc) {
  char text[9];
  std::snprintf(text, sizeof(text), "%08x", crc);
  return text;
}

std::optional<uint32_t> parse_crc32(std::string_view text) {
  if (text.size() != 8) {
    return std::nullopt;
  }
  uint32_t crc = 0;
  for (const char c : text) {
    uint32_t digit = 0;
    if (c >= '0' && c <= '9') {
      digit = static_cast<uint32_t>(c - '0');
    } else if (c >= 'a' && c <= 'f') {
      digit = static_cast<uint32_t>(c - 'a' + 10);
    } else {
      return std::nullopt;
    }
    crc = (crc << 4) | digit;
  }
  return crc;
}

std::optional<uint64_t> file_size_bytes(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) {
      return std::nullopt;
    }
    fail_errno(path, "cannot stat");
  }
  if (!S_ISREG(info.st_mode)) {
    throw MapError::in_file(path, "not a regular file");
  }
  return static_cast<uint64_t>(info.st_size);
}

std::string read_file(const std::string& path) {
  const FileDescriptor fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (fd.get() < 0) {
    if (errno == ENOENT || errno == ENOTDIR) {
      throw MapError::in_file(path, "missing");
    }
    fail_errno(path, "cannot open");
  }
  struct stat info {};
  if (::fstat(fd.get(), &info) != 0) {
    fail_errno(path, "cannot stat");
  }
  if (!S_ISREG(info.st_mode)) {
    throw MapError::in_file(path, "not a regular file");
  }
  std::string bytes(static_cast<size_t>(info.st_size), '\0');
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::read(fd.get(), bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) {
        continue;
      }
      fail_errno(path, "cannot read");
    }
    if (n == 0) {
      break;  // shrank while being read
    }
    done += static_cast<size_t>(n);
  }
  bytes.resize(done);
  return bytes;
}

void write_file_synced(const std::string& path, std::string_view bytes) {
  const FileDescriptor fd(::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (fd.get() < 0) {
    fail_errno(path, "cannot create");
  }
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd.get(), bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) {
        continue;
      }
      fail_errno(path, "cannot write");
    }
    done += static_cast<size_t>(n);
  }
  if (::fsync(fd.get()) != 0) {
    fail_errno(path, "fsync failed");
  }
}

void write_file_creating_directories(const std::string& path, std::string_view bytes) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) {
    create_directory_synced(parent.string());
  }
  write_file_synced(path, bytes);
}

void rename_file(const std::string& from, const std::string& to) {
  if (::rename(from.c_str(), to.c_str()) != 0) {
    fail_errno(from, "cannot rename to " + to);
  }
}

void fsync_directory(const std::string& path) {
  const FileDescriptor fd(::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (fd.get() < 0) {
    fail_errno(path, "cannot open directory");
  }
  if (::fsync(fd.get()) != 0) {
    fail_errno(path, "fsync of directory failed");
  }
}

void create_directory_synced(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code error;
  if (!parent.empty() && !std::filesystem::exists(parent, error)) {
    create_directory_synced(parent.string());
  }
  if (::mkdir(path.c_str(), 0755) != 0) {
    if (errno != EEXIST) {
      fail_errno(path, "cannot create directory");
    }
    return;
  }
  fsync_directory(parent.empty() ? "." : parent.string());
}

std::vector<std::string> list_directory(const std::string& path) {
  std::error_code error;
  std::vector<std::string> names;
  for (std::filesystem::directory_iterator it(path, error), end; it != end; it.increment(error)) {
    names.push_back(it->path().filename().string());
  }
  if (error) {
    throw MapError::in_file(path, "cannot list directory: " + error.message());
  }
  std::sort(names.begin(), names.end());
  return names;
}

uint64_t remove_tree(const std::string& path) {
  namespace fs = std::filesystem;
  // The byte count is for reports only: entries that vanish while counting are skipped.
  std::error_code ignored;
  uint64_t bytes = 0;
  const fs::file_status status = fs::symlink_status(path, ignored);
  if (fs::is_directory(status)) {
    // On an error the iterator becomes the end iterator.
    for (fs::recursive_directory_iterator it(path, ignored), end; it != end;
         it.increment(ignored)) {
      std::error_code size_error;
      const uintmax_t size = it->is_regular_file(size_error) ? it->file_size(size_error) : 0;
      bytes += size_error ? 0 : size;
    }
  } else if (fs::is_regular_file(status)) {
    const uintmax_t size = fs::file_size(path, ignored);
    bytes = ignored ? 0 : size;
  }
  std::error_code error;
  fs::remove_all(path, error);
  if (error) {
    throw MapError::in_file(path, "cannot remove: " + error.message());
  }
  return bytes;
}

FileLock::FileLock(const std::string& path)
    : fd_(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644)) {
  if (fd_ < 0) {
    fail_errno(path, "cannot open lock file");
  }
  while (::flock(fd_, LOCK_EX) != 0) {
    if (errno != EINTR) {
      const int error = errno;
      ::close(fd_);
      errno = error;
      fail_errno(path, "cannot lock");
    }
  }
}

FileLock::~FileLock() { ::close(fd_); }

}  // namespace liloc::storage
