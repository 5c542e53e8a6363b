#pragma once
// A map directory on disk (docs/map_format.md): the central session, versioned.
//
//   MapStore store("maps/campus");
//   MapData map = store.load();                       // the current version, checked
//   PointCloud cloud = store.load_cloud(map.keyframes[0].id);
//   ... add keyframes ...
//   store.save(map, new_clouds, new_descriptors);     // version + 1, atomically
//
// Versions are immutable directories; CURRENT names the current one and is replaced by
// rename(2), so a save that dies at any point leaves the previous version loadable with
// all its keyframes. Keyframe files are written once and shared by the versions that
// list them. One process saves at a time (save() and prune() hold an flock on LOCK);
// any number of threads or processes may load.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "map/map_types.hpp"
#include "pointcloud/point_cloud.hpp"
#include "storage/map_manifest.hpp"

namespace liloc::storage {

// The steps of save(), in order, each reported once it is complete (the per-file steps
// once per file). A crash after any of them leaves the previous version current; after
// kCommitted the new one is.
enum class SaveStep {
  kKeyframeFileWritten,     // a new keyframe file is in keyframes/, fsynced
  kKeyframeFilesSynced,     // keyframes/ fsynced: the new names are durable
  kVersionFileWritten,      // a file of versions/vN.tmp/ is written and fsynced
  kVersionDirectorySynced,  // versions/vN.tmp/ fsynced
  kVersionRenamed,          // vN.tmp renamed to vN, versions/ fsynced
  kCurrentTmpWritten,       // CURRENT.tmp written and fsynced
  kCommitted,               // CURRENT replaced by CURRENT.tmp, directory fsynced
};
const char* to_string(SaveStep step);

// What a save did and how long each of its steps took.
struct SaveReport {
  int64_t version = 0;  // the new version
  int keyframe_files_written = 0;
  double check_ms = 0.0;           // the rules of map/map_validation.hpp, the plan
  double keyframe_files_ms = 0.0;  // new keyframe files written and synced
  double version_ms = 0.0;         // the version directory written, synced, renamed
  double commit_ms = 0.0;          // CURRENT replaced
  double total_ms = 0.0;
};

struct PruneResult {
  int versions_removed = 0;  // committed versions, uncommitted leftovers and temporaries
  int keyframe_files_removed = 0;
  uint64_t bytes_removed = 0;
};

class MapStore {
 public:
  // No I/O until a method needs it.
  explicit MapStore(std::string directory);

  const std::string& directory() const { return directory_; }

  // True if the directory holds a committed version (has a CURRENT file).
  bool exists() const;

  // The current version. Checks the manifest's own checksum, the size and CRC-32 of every
  // metadata file, that every line parses and the files agree with each other, and that
  // every keyframe file exists with its recorded size. Throws MapError naming the file
  // and the reason. Reads only; never changes anything on disk.
  MapData load() const;

  // The manifest of the version this store last loaded or saved (the current one if it
  // has done neither yet). Reads the manifest only, not the files it lists.
  MapManifest manifest() const;

  // Reads every keyframe file of that version in full and checks its CRC-32 (and that
  // clouds decode). Slow: the whole map. Throws MapError listing the damaged files.
  void verify_clouds() const;

  // Writes data as a new version and makes it current: new keyframe files first, then the
  // version directory under a temporary name, renamed, then CURRENT (each step fsynced).
  // data.version must be the current version on disk (0 for an empty directory) and
  // data.map_id the map's id; on success data.version is the new version.
  // new_clouds / new_descriptors: the files of keyframes that are not yet on disk, by
  // keyframe id. Every keyframe of data needs both, on disk or given here.
  // Throws std::invalid_argument for data that cannot be saved (the rules of
  // map/map_validation.hpp, missing or already stored keyframe files) and MapError for
  // I/O failures or a version conflict.
  SaveReport save(MapData& data, const std::map<int64_t, PointCloud>& new_clouds,
                  const std::map<int64_t, std::vector<uint8_t>>& new_descriptors);

  // A keyframe file of the version this store last loaded or saved, checked against the
  // size and CRC-32 in its manifest. Throws MapError. Thread-safe.
  PointCloud load_cloud(int64_t keyframe_id) const;
  std::vector<uint8_t> load_descriptor(int64_t keyframe_id) const;

  // Keeps the current version and the newest committed versions before it, `keep` in
  // all (>= 1); removes older versions, leftovers of interrupted saves (temporaries and
  // versions newer than CURRENT) and keyframe files no kept version lists. Readers of a
  // removed version fail and must load the current one.
  PruneResult prune(int keep);

  // Called after each step of save(), e.g. for progress or to stop a test at a step.
  void set_save_step_observer(std::function<void(SaveStep)> observer);

 private:
  struct VersionIndex;
  struct NewKeyframeFile;
  struct SavePlan;

  // The steps of save(), in order.
  void check_saveable(const MapData& data, const std::map<int64_t, PointCloud>& new_clouds,
                      const std::map<int64_t, std::vector<uint8_t>>& new_descriptors) const;
  std::shared_ptr<const VersionIndex> current_version_for_save(const MapData& data) const;
  SavePlan plan_keyframe_files(
      const MapData& data, const VersionIndex* current,
      const std::map<int64_t, PointCloud>& new_clouds,
      const std::map<int64_t, std::vector<uint8_t>>& new_descriptors) const;
  int write_keyframe_files(SavePlan& plan, const VersionIndex* current) const;
  std::shared_ptr<VersionIndex> write_version(const MapData& data,
                                              std::vector<StoredFile> keyframe_files) const;
  void commit(const std::string& version_name) const;

  std::shared_ptr<const VersionIndex> index() const;
  std::shared_ptr<const VersionIndex> read_version_index(const std::string& version_name) const;
  std::string read_current_version_name() const;
  std::string read_keyframe_file(int64_t keyframe_id, const std::string& relative_path) const;
  // Versions newer than the current one were never committed (or were rolled back).
  bool is_listed_by_committed_version(const std::string& relative_path,
                                      int64_t current_version) const;
  void notify(SaveStep step) const;

  std::string directory_;
  mutable std::mutex index_mutex_;
  mutable std::shared_ptr<const VersionIndex> index_;  // last loaded or saved version
  std::function<void(SaveStep)> save_step_observer_;
};

}  // namespace liloc::storage
