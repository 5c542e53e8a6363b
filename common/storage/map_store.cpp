#include "storage/map_store.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include "map/map_validation.hpp"
#include "math/stopwatch.hpp"
#include "storage/file_io.hpp"
#include "storage/map_error.hpp"
#include "storage/map_layout.hpp"
#include "storage/map_text_files.hpp"
#include "storage/pcd_codec.hpp"

namespace liloc::storage {

namespace fs = std::filesystem;

struct MapStore::VersionIndex {
  std::string name;       // "v000012"
  std::string directory;  // full path of versions/v000012
  MapManifest manifest;
  std::unordered_map<std::string, StoredFile> keyframe_files;  // by path in the map directory

  const StoredFile* find_keyframe_file(const std::string& relative_path) const {
    const auto it = keyframe_files.find(relative_path);
    return it == keyframe_files.end() ? nullptr : &it->second;
  }
};

namespace {

constexpr size_t kMaxErrorsListed = 20;

std::string join(const std::string& directory, const std::string& name) {
  return directory + "/" + name;
}

void check_size(const std::string& path, uint64_t actual_bytes, const StoredFile& record) {
  if (actual_bytes < record.size_bytes) {
    throw MapError::in_file(path, "truncated: " + std::to_string(actual_bytes) +
                                      " bytes, the manifest records " +
                                      std::to_string(record.size_bytes));
  }
  if (actual_bytes > record.size_bytes) {
    throw MapError::in_file(path, std::to_string(actual_bytes) + " bytes, the manifest records " +
                                      std::to_string(record.size_bytes));
  }
}

std::string read_checked(const std::string& path, const StoredFile& record) {
  std::string bytes = read_file(path);
  check_size(path, bytes.size(), record);
  const uint32_t crc = crc32_of(bytes);
  if (crc != record.crc32) {
    throw MapError::in_file(path, "checksum mismatch (manifest crc32 " +
                                      format_crc32(record.crc32) + ", file " + format_crc32(crc) +
                                      ")");
  }
  return bytes;
}

StoredFile record_of(const std::string& relative_path, std::string_view bytes) {
  return {relative_path, bytes.size(), crc32_of(bytes)};
}

std::string utc_now_iso8601() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

MapCounts count_of(const MapData& data) {
  MapCounts counts;
  counts.keyframes = static_cast<int64_t>(data.keyframes.size());
  counts.submaps = static_cast<int64_t>(data.submaps.size());
  for (const PoseGraphEdge& edge : data.edges) {
    ++(edge.kind == PoseGraphEdge::Kind::kLoop ? counts.loop_edges : counts.odometry_edges);
  }
  std::set<std::string> sessions;
  for (const MapKeyframe& kf : data.keyframes) {
    sessions.insert(kf.session);
  }
  counts.sessions = static_cast<int64_t>(sessions.size());
  return counts;
}

bool operator==(const MapCounts& a, const MapCounts& b) {
  return a.keyframes == b.keyframes && a.submaps == b.submaps &&
         a.odometry_edges == b.odometry_edges && a.loop_edges == b.loop_edges &&
         a.sessions == b.sessions;
}

std::string describe(const MapCounts& c) {
  return std::to_string(c.keyframes) + " keyframes, " + std::to_string(c.submaps) + " submaps, " +
         std::to_string(c.odometry_edges) + " odometry edges, " + std::to_string(c.loop_edges) +
         " loop edges, " + std::to_string(c.sessions) + " sessions";
}

// The file of a map version that holds a part of the map.
const char* file_of(MapPart part) {
  switch (part) {
    case MapPart::kKeyframes:
      return kKeyframesCsvFile;
    case MapPart::kPoses:
      return kPosesTumFile;
    case MapPart::kSubmaps:
      return kSubmapsCsvFile;
    case MapPart::kPoseGraph:
      return kPoseGraphFile;
  }
  return kKeyframesCsvFile;
}

}  // namespace

const char* to_string(SaveStep step) {
  switch (step) {
    case SaveStep::kKeyframeFileWritten:
      return "keyframe file written";
    case SaveStep::kKeyframeFilesSynced:
      return "keyframe files synced";
    case SaveStep::kVersionFileWritten:
      return "version file written";
    case SaveStep::kVersionDirectorySynced:
      return "version directory synced";
    case SaveStep::kVersionRenamed:
      return "version renamed";
    case SaveStep::kCurrentTmpWritten:
      return "CURRENT.tmp written";
    case SaveStep::kCommitted:
      return "committed";
  }
  return "unknown";
}

MapStore::MapStore(std::string directory) : directory_(std::move(directory)) {}

bool MapStore::exists() const {
  std::error_code error;
  return fs::is_regular_file(join(directory_, kCurrentFile), error);
}

std::string MapStore::read_current_version_name() const {
  std::error_code error;
  if (!fs::is_directory(directory_, error)) {
    throw MapError::in_file(directory_, fs::exists(directory_, error)
                                            ? "is a file, not a map directory"
                                            : "missing (no such map directory)");
  }
  const std::string path = join(directory_, kCurrentFile);
  if (!file_size_bytes(path)) {
    throw MapError::in_file(path, "missing (not a map directory, or no version was ever saved)");
  }
  const std::string text = read_file(path);
  std::string_view name = text;
  if (!name.empty() && name.back() == '\n') {
    name.remove_suffix(1);
  }
  if (!parse_version_dir_name(name)) {
    throw MapError::in_file(path, "malformed: expected a version name like v000012, found '" +
                                      printable_excerpt(text) + "'");
  }
  return std::string(name);
}

std::shared_ptr<const MapStore::VersionIndex> MapStore::read_version_index(
    const std::string& version_name) const {
  auto index = std::make_shared<VersionIndex>();
  index->name = version_name;
  index->directory = join(join(directory_, kVersionsDir), version_name);
  std::error_code error;
  if (!fs::is_directory(index->directory, error)) {
    throw MapError::in_file(index->directory, "missing");
  }
  const std::string manifest_path = join(index->directory, kManifestFile);
  index->manifest = parse_manifest(read_file(manifest_path), manifest_path);
  if (version_dir_name(index->manifest.version) != version_name) {
    throw MapError::in_file(manifest_path, "version " + std::to_string(index->manifest.version) +
                                               " in a directory named " + version_name);
  }
  for (const StoredFile& file : index->manifest.keyframe_files) {
    if (!index->keyframe_files.emplace(file.path, file).second) {
      throw MapError::in_file(manifest_path, "lists " + file.path + " twice");
    }
  }
  return index;
}

std::shared_ptr<const MapStore::VersionIndex> MapStore::index() const {
  const std::lock_guard<std::mutex> lock(index_mutex_);
  if (!index_) {
    index_ = read_version_index(read_current_version_name());
  }
  return index_;
}

MapManifest MapStore::manifest() const { return index()->manifest; }

MapData MapStore::load() const {
  const std::shared_ptr<const VersionIndex> index = read_version_index(read_current_version_name());
  const MapManifest& manifest = index->manifest;
  const std::string manifest_path = join(index->directory, kManifestFile);

  std::unordered_map<std::string, std::string> contents;  // file name -> verified bytes
  for (const StoredFile& file : manifest.version_files) {
    contents[file.path] = read_checked(join(index->directory, file.path), file);
  }
  const auto version_file = [&](const char* name) -> const std::string& {
    const auto it = contents.find(name);
    if (it == contents.end()) {
      throw MapError::in_file(manifest_path, std::string("lists no ") + name);
    }
    return it->second;
  };
  const auto path_of = [&](const char* name) { return join(index->directory, name); };

  MapData data;
  data.map_id = manifest.map_id;
  data.version = manifest.version;
  data.keyframes = parse_keyframes_csv(version_file(kKeyframesCsvFile), path_of(kKeyframesCsvFile));
  parse_poses_tum(version_file(kPosesTumFile), path_of(kPosesTumFile), data.keyframes);
  data.submaps = parse_submaps_csv(version_file(kSubmapsCsvFile), path_of(kSubmapsCsvFile));
  data.edges =
      parse_pose_graph_g2o(version_file(kPoseGraphFile), path_of(kPoseGraphFile), data.keyframes);
  if (contents.size() != 4) {
    throw MapError::in_file(manifest_path, "lists " + std::to_string(contents.size()) +
                                               " version files; this format has 4");
  }
  if (const std::optional<MapProblem> problem = find_map_problem(data)) {
    throw MapError::in_file(path_of(file_of(problem->part)), problem->what);
  }
  const MapCounts counts = count_of(data);
  if (!(counts == manifest.counts)) {
    throw MapError::in_file(manifest_path, "counts (" + describe(manifest.counts) +
                                               ") differ from the files (" + describe(counts) +
                                               ")");
  }

  // Keyframe files: present with their recorded sizes (CRCs: verify_clouds, load_cloud).
  if (index->keyframe_files.size() != 2 * data.keyframes.size()) {
    throw MapError::in_file(manifest_path,
                            "lists " + std::to_string(index->keyframe_files.size()) +
                                " keyframe files; the " + std::to_string(data.keyframes.size()) +
                                " keyframes have " + std::to_string(2 * data.keyframes.size()));
  }
  for (const MapKeyframe& kf : data.keyframes) {
    for (const std::string& relative_path :
         {keyframe_cloud_path(kf.id), keyframe_descriptor_path(kf.id)}) {
      const StoredFile* record = index->find_keyframe_file(relative_path);
      if (record == nullptr) {
        throw MapError::in_file(
            manifest_path, "lists no " + relative_path + " for keyframe " + std::to_string(kf.id));
      }
      const std::string path = join(directory_, relative_path);
      const std::optional<uint64_t> size = file_size_bytes(path);
      if (!size) {
        throw MapError::in_file(path, "missing (keyframe " + std::to_string(kf.id) + ")");
      }
      check_size(path, *size, *record);
    }
  }

  const std::lock_guard<std::mutex> lock(index_mutex_);
  index_ = index;
  return data;
}

std::string MapStore::read_keyframe_file(int64_t keyframe_id,
                                         const std::string& relative_path) const {
  const std::shared_ptr<const VersionIndex> version = index();
  const StoredFile* record = version->find_keyframe_file(relative_path);
  if (record == nullptr) {
    throw MapError::in_file(directory_, "keyframe " + std::to_string(keyframe_id) +
                                            " is not in map version " + version->name);
  }
  return read_checked(join(directory_, relative_path), *record);
}

PointCloud MapStore::load_cloud(int64_t keyframe_id) const {
  const std::string relative_path = keyframe_cloud_path(keyframe_id);
  return decode_pcd(read_keyframe_file(keyframe_id, relative_path),
                    join(directory_, relative_path));
}

std::vector<uint8_t> MapStore::load_descriptor(int64_t keyframe_id) const {
  const std::string bytes = read_keyframe_file(keyframe_id, keyframe_descriptor_path(keyframe_id));
  return std::vector<uint8_t>(bytes.begin(), bytes.end());
}

void MapStore::verify_clouds() const {
  const std::shared_ptr<const VersionIndex> version = index();
  std::vector<std::string> errors;
  for (const StoredFile& file : version->manifest.keyframe_files) {
    const std::string path = join(directory_, file.path);
    try {
      const std::string bytes = read_checked(path, file);
      if (file.path.size() > 4 && file.path.compare(file.path.size() - 4, 4, ".pcd") == 0) {
        decode_pcd(bytes, path);
      }
    } catch (const MapError& e) {
      errors.push_back(e.what());
    }
  }
  if (errors.empty()) {
    return;
  }
  std::string message = std::to_string(errors.size()) + " of " +
                        std::to_string(version->manifest.keyframe_files.size()) +
                        " keyframe files of " + join(directory_, version->name) + " are damaged:";
  for (size_t k = 0; k < std::min(errors.size(), kMaxErrorsListed); ++k) {
    message += "\n  " + errors[k];
  }
  if (errors.size() > kMaxErrorsListed) {
    message += "\n  ... and " + std::to_string(errors.size() - kMaxErrorsListed) + " more";
  }
  throw MapError(message);
}

bool MapStore::is_listed_by_committed_version(const std::string& relative_path,
                                              int64_t current_version) const {
  for (const std::string& name : list_directory(join(directory_, kVersionsDir))) {
    const std::optional<int64_t> version = parse_version_dir_name(name);
    if (version && *version <= current_version &&
        read_version_index(name)->find_keyframe_file(relative_path) != nullptr) {
      return true;
    }
  }
  return false;
}

void MapStore::notify(SaveStep step) const {
  if (save_step_observer_) {
    save_step_observer_(step);
  }
}

void MapStore::set_save_step_observer(std::function<void(SaveStep)> observer) {
  save_step_observer_ = std::move(observer);
}

// A keyframe file a save writes: the entry in the new manifest and what goes into it.
struct MapStore::NewKeyframeFile {
  size_t record = 0;  // index in SavePlan::keyframe_files
  const PointCloud* cloud = nullptr;
  const std::vector<uint8_t>* descriptor = nullptr;  // if not a cloud
  std::string bytes() const {
    return cloud != nullptr ? encode_pcd(*cloud)
                            : std::string(descriptor->begin(), descriptor->end());
  }
};

struct MapStore::SavePlan {
  std::vector<StoredFile> keyframe_files;  // of the new version, in keyframe order
  std::vector<NewKeyframeFile> new_files;
};

SaveReport MapStore::save(MapData& data, const std::map<int64_t, PointCloud>& new_clouds,
                          const std::map<int64_t, std::vector<uint8_t>>& new_descriptors) {
  const Stopwatch watch;
  SaveReport report;
  check_saveable(data, new_clouds, new_descriptors);
  create_directory_synced(directory_);
  create_directory_synced(join(directory_, kVersionsDir));
  create_directory_synced(join(directory_, kKeyframesDir));
  const FileLock lock(join(directory_, kLockFile));
  const std::shared_ptr<const VersionIndex> current = current_version_for_save(data);
  SavePlan plan = plan_keyframe_files(data, current.get(), new_clouds, new_descriptors);
  report.check_ms = watch.ms();

  Stopwatch step;
  report.keyframe_files_written = write_keyframe_files(plan, current.get());
  report.keyframe_files_ms = step.ms();
  step = Stopwatch();
  std::shared_ptr<VersionIndex> written = write_version(data, std::move(plan.keyframe_files));
  report.version_ms = step.ms();
  step = Stopwatch();
  commit(written->name);
  report.commit_ms = step.ms();

  data.version = written->manifest.version;
  {
    const std::lock_guard<std::mutex> index_lock(index_mutex_);
    index_ = std::move(written);
  }
  notify(SaveStep::kCommitted);
  report.version = data.version;
  report.total_ms = watch.ms();
  return report;
}

void MapStore::check_saveable(
    const MapData& data, const std::map<int64_t, PointCloud>& new_clouds,
    const std::map<int64_t, std::vector<uint8_t>>& new_descriptors) const {
  const auto invalid = [&](const std::string& what) {
    throw std::invalid_argument("cannot save map '" + data.map_id + "' to " + directory_ + ": " +
                                what);
  };
  if (!is_valid_map_id(data.map_id)) {
    invalid("map_id must be letters, digits, '.', '_' or '-', starting with a letter or digit");
  }
  if (data.version < 0) {
    invalid("negative version");
  }
  if (const std::optional<MapProblem> problem = find_map_problem(data)) {
    invalid(problem->what);
  }
  std::unordered_set<int64_t> keyframe_ids;
  for (const MapKeyframe& kf : data.keyframes) {
    keyframe_ids.insert(kf.id);
  }
  for (const auto& [id, cloud] : new_clouds) {
    if (keyframe_ids.count(id) == 0) {
      invalid("new_clouds has keyframe " + std::to_string(id) + ", which the map does not have");
    }
    if (cloud.points.size() != cloud.intensities.size()) {
      invalid("the cloud of keyframe " + std::to_string(id) +
              " has a different number of points and intensities");
    }
  }
  for (const auto& entry : new_descriptors) {
    if (keyframe_ids.count(entry.first) == 0) {
      invalid("new_descriptors has keyframe " + std::to_string(entry.first) +
              ", which the map does not have");
    }
  }
}

std::shared_ptr<const MapStore::VersionIndex> MapStore::current_version_for_save(
    const MapData& data) const {
  // The version on disk, read now (under the lock), not the one this store cached.
  if (!exists()) {
    return nullptr;
  }
  std::shared_ptr<const VersionIndex> current = read_version_index(read_current_version_name());
  if (current->manifest.map_id != data.map_id) {
    throw MapError::in_file(
        directory_, "holds map '" + current->manifest.map_id + "', not '" + data.map_id + "'");
  }
  if (current->manifest.version != data.version) {
    throw MapError::in_file(directory_,
                            "is at version " + std::to_string(current->manifest.version) +
                                ", the map to save is version " + std::to_string(data.version) +
                                " (load the current version, change it, save)");
  }
  return current;
}

MapStore::SavePlan MapStore::plan_keyframe_files(
    const MapData& data, const VersionIndex* current,
    const std::map<int64_t, PointCloud>& new_clouds,
    const std::map<int64_t, std::vector<uint8_t>>& new_descriptors) const {
  // Each keyframe file is either listed by the current version or new; all of them are
  // checked before anything is written.
  SavePlan plan;
  plan.keyframe_files.reserve(2 * data.keyframes.size());
  const auto plan_file = [&](int64_t id, const std::string& relative_path, const char* what,
                             const NewKeyframeFile& file) {
    const StoredFile* stored = current ? current->find_keyframe_file(relative_path) : nullptr;
    const bool given = file.cloud != nullptr || file.descriptor != nullptr;
    const std::string prefix = "cannot save map '" + data.map_id + "' to " + directory_ + ": ";
    if (stored != nullptr && given) {
      throw std::invalid_argument(prefix + "keyframe " + std::to_string(id) + " already has its " +
                                  what + " in version " + current->name +
                                  "; keyframe files are written once (new data needs a new id)");
    }
    if (stored == nullptr && !given) {
      throw std::invalid_argument(prefix + "keyframe " + std::to_string(id) + " has no " + what +
                                  " on disk and none was given");
    }
    if (stored != nullptr) {
      plan.keyframe_files.push_back(*stored);
    } else {
      NewKeyframeFile added = file;
      added.record = plan.keyframe_files.size();
      plan.new_files.push_back(added);
      plan.keyframe_files.push_back({relative_path, 0, 0});  // size and CRC once encoded
    }
  };
  for (const MapKeyframe& kf : data.keyframes) {
    const auto cloud = new_clouds.find(kf.id);
    const auto descriptor = new_descriptors.find(kf.id);
    plan_file(kf.id, keyframe_cloud_path(kf.id), "cloud",
              {0, cloud == new_clouds.end() ? nullptr : &cloud->second, nullptr});
    plan_file(kf.id, keyframe_descriptor_path(kf.id), "descriptor",
              {0, nullptr, descriptor == new_descriptors.end() ? nullptr : &descriptor->second});
  }
  return plan;
}

int MapStore::write_keyframe_files(SavePlan& plan, const VersionIndex* current) const {
  // Each under a temporary name, fsynced and renamed, so that a file with a final name is
  // always complete.
  int written = 0;
  for (const NewKeyframeFile& file : plan.new_files) {
    StoredFile& record = plan.keyframe_files[file.record];
    const std::string bytes = file.bytes();
    record.size_bytes = bytes.size();
    record.crc32 = crc32_of(bytes);
    const std::string path = join(directory_, record.path);
    if (const std::optional<uint64_t> size = file_size_bytes(path)) {
      // Left by an interrupted save (then no committed version lists it), or a reused
      // keyframe id.
      if (*size == record.size_bytes && crc32_of(read_file(path)) == record.crc32) {
        continue;
      }
      if (current && is_listed_by_committed_version(record.path, current->manifest.version)) {
        throw MapError::in_file(path,
                                "is listed by a committed version and holds other data than "
                                "given now (keyframe ids must not be reused)");
      }
    }
    const std::string temporary = path + kTempSuffix;
    write_file_synced(temporary, bytes);
    rename_file(temporary, path);
    ++written;
    notify(SaveStep::kKeyframeFileWritten);
  }
  if (!plan.new_files.empty()) {
    fsync_directory(join(directory_, kKeyframesDir));
    notify(SaveStep::kKeyframeFilesSynced);
  }
  return written;
}

std::shared_ptr<MapStore::VersionIndex> MapStore::write_version(
    const MapData& data, std::vector<StoredFile> keyframe_files) const {
  // Complete under a temporary name, then renamed. A directory with the final name may
  // exist if a save died after renaming it but before replacing CURRENT: it is not
  // current (CURRENT names data.version), so it is replaced.
  const std::string versions_dir = join(directory_, kVersionsDir);
  auto index = std::make_shared<VersionIndex>();
  index->name = version_dir_name(data.version + 1);
  index->directory = join(versions_dir, index->name);
  const std::string temporary_dir = index->directory + kTempSuffix;
  remove_tree(temporary_dir);
  remove_tree(index->directory);
  create_directory_synced(temporary_dir);

  MapManifest& manifest = index->manifest;
  manifest.map_id = data.map_id;
  manifest.version = data.version + 1;
  manifest.created_utc = utc_now_iso8601();
  manifest.counts = count_of(data);
  manifest.keyframe_files = std::move(keyframe_files);
  const std::pair<const char*, std::string> version_files[] = {
      {kKeyframesCsvFile, encode_keyframes_csv(data.keyframes)},
      {kPosesTumFile, encode_poses_tum(data.keyframes)},
      {kSubmapsCsvFile, encode_submaps_csv(data.submaps)},
      {kPoseGraphFile, encode_pose_graph_g2o(data.keyframes, data.edges)},
  };
  for (const auto& [name, bytes] : version_files) {
    write_file_synced(join(temporary_dir, name), bytes);
    manifest.version_files.push_back(record_of(name, bytes));
    notify(SaveStep::kVersionFileWritten);
  }
  write_file_synced(join(temporary_dir, kManifestFile), encode_manifest(manifest));
  notify(SaveStep::kVersionFileWritten);
  fsync_directory(temporary_dir);
  notify(SaveStep::kVersionDirectorySynced);
  rename_file(temporary_dir, index->directory);
  fsync_directory(versions_dir);
  notify(SaveStep::kVersionRenamed);
  for (const StoredFile& file : manifest.keyframe_files) {
    index->keyframe_files.emplace(file.path, file);
  }
  return index;
}

void MapStore::commit(const std::string& version_name) const {
  // CURRENT is replaced by rename, which is atomic.
  const std::string current_path = join(directory_, kCurrentFile);
  const std::string current_temporary = current_path + kTempSuffix;
  write_file_synced(current_temporary, version_name + "\n");
  notify(SaveStep::kCurrentTmpWritten);
  rename_file(current_temporary, current_path);
  fsync_directory(directory_);
}

PruneResult MapStore::prune(int keep) {
  if (keep < 1) {
    throw std::invalid_argument("prune: keep must be at least 1 (the current version)");
  }
  read_current_version_name();  // a map directory? (before LOCK is created in it)
  const FileLock lock(join(directory_, kLockFile));
  // Read under the lock: a save may have committed since.
  const std::string current = read_current_version_name();
  const int64_t current_version = *parse_version_dir_name(current);

  const std::string versions_dir = join(directory_, kVersionsDir);
  std::vector<int64_t> committed;
  std::vector<std::string> temporaries;         // in versions/
  std::vector<std::string> versions_to_remove;  // in versions/
  for (const std::string& name : list_directory(versions_dir)) {
    const std::optional<int64_t> version = parse_version_dir_name(name);
    if (version && *version <= current_version) {
      committed.push_back(*version);
    } else if (version) {
      versions_to_remove.push_back(name);  // newer than CURRENT: never committed
    } else if (name.size() > 4 && name.compare(name.size() - 4, 4, kTempSuffix) == 0) {
      temporaries.push_back(name);
    }
  }
  std::sort(committed.rbegin(), committed.rend());
  if (committed.empty() || committed.front() != current_version) {
    throw MapError::in_file(join(versions_dir, current), "missing (named by CURRENT)");
  }
  std::unordered_set<std::string> listed;  // keyframe files the kept versions need
  std::unordered_set<std::string> kept_names;
  for (size_t k = 0; k < committed.size(); ++k) {
    const std::string name = version_dir_name(committed[k]);
    if (k < static_cast<size_t>(keep)) {
      // Throws before anything is removed if a kept version cannot be read.
      const std::shared_ptr<const VersionIndex> version = read_version_index(name);
      for (const StoredFile& file : version->manifest.keyframe_files) {
        listed.insert(file.path);
      }
      kept_names.insert(name);
    } else {
      versions_to_remove.push_back(name);
    }
  }

  PruneResult result;
  // Version directories first, keyframe files after: a crash in between leaves only
  // unlisted files, which the next prune removes. A version is renamed to a temporary name
  // before it is removed, so that no half-removed directory ever carries a version's name.
  for (const std::string& name : temporaries) {
    result.bytes_removed += remove_tree(join(versions_dir, name));
    ++result.versions_removed;
  }
  for (const std::string& name : versions_to_remove) {
    const std::string doomed = join(versions_dir, name) + kTempSuffix;
    rename_file(join(versions_dir, name), doomed);
    result.bytes_removed += remove_tree(doomed);
    ++result.versions_removed;
  }
  fsync_directory(versions_dir);
  const std::string keyframes_dir = join(directory_, kKeyframesDir);
  for (const std::string& name : list_directory(keyframes_dir)) {
    const std::string extension = fs::path(name).extension().string();
    const bool keyframe_file = extension == ".pcd" || extension == ".desc";
    if (extension == kTempSuffix ||
        (keyframe_file && listed.count(std::string(kKeyframesDir) + "/" + name) == 0)) {
      result.bytes_removed += remove_tree(join(keyframes_dir, name));
      ++result.keyframe_files_removed;
    }
  }
  fsync_directory(keyframes_dir);

  const std::lock_guard<std::mutex> index_lock(index_mutex_);
  if (index_ && kept_names.count(index_->name) == 0) {
    index_.reset();
  }
  return result;
}

}  // namespace liloc::storage
