#pragma once
// POSIX file primitives for crash-safe saves: whole-file reads, writes that reach the
// disk (fsync) before they return, directory fsync (so that a created or renamed entry
// survives a power loss), CRC-32 and an exclusive lock file. Every failure is a MapError
// naming the path and the system's reason.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace liloc::storage {

// CRC-32 (IEEE 802.3, as zlib and `crc32` compute it).
uint32_t crc32_of(std::string_view bytes);
// Eight lower-case hex digits, and back (nullopt if `text` is not exactly that).
std::string format_crc32(uint32_t crc);
std::optional<uint32_t> parse_crc32(std::string_view text);

// Size of a regular file, or nullopt if there is nothing at `path`.
std::optional<uint64_t> file_size_bytes(const std::string& path);

// The whole file. Throws MapError "missing" if it does not exist.
std::string read_file(const std::string& path);

// Creates or replaces `path` with `bytes` and fsyncs it. Not atomic by itself: callers
// write to a temporary name and rename (see rename_file).
void write_file_synced(const std::string& path, std::string_view bytes);

// write_file_synced, after creating the directory `path` names (if it names one) with
// create_directory_synced: a result file written wherever a command line points.
void write_file_creating_directories(const std::string& path, std::string_view bytes);

// rename(2); the caller fsyncs the parent directory to make it durable.
void rename_file(const std::string& from, const std::string& to);

// fsync of a directory: makes the creation, rename or removal of its entries durable.
void fsync_directory(const std::string& path);

// mkdir (and missing parents), each fsynced in its parent so that it survives a crash.
void create_directory_synced(const std::string& path);

// Names of the entries of a directory (not "." and ".."), sorted.
std::vector<std::string> list_directory(const std::string& path);

// Removes a file or a directory tree (nothing if `path` does not exist); returns the
// bytes of the regular files removed.
uint64_t remove_tree(const std::string& path);

// An exclusive flock(2) on `path` (created if missing), held until destruction. Blocks
// while another process holds it; released by the kernel if the holder dies.
class FileLock {
 public:
  explicit FileLock(const std::string& path);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace liloc::storage
