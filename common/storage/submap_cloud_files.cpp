#include "storage/submap_cloud_files.hpp"

#include <unistd.h>

#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>

#include "storage/file_io.hpp"
#include "storage/map_error.hpp"
#include "storage/map_layout.hpp"

namespace liloc::storage {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the file layout is little-endian");

constexpr char kMagic[8] = {'L', 'I', 'L', 'O', 'C', 'S', 'U', 'B'};
constexpr uint32_t kFormat = 1;
constexpr size_t kBytesPerPoint = 4 * sizeof(float);
constexpr const char* kSubdirectory = "derived/submap_clouds";
constexpr const char* kExtension = ".bin";

// FNV-1a, 64 bit: a stable hash of the bytes the clouds derive from.
class Fnv1a {
 public:
  template <class T>
  void add(const T& value) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(&value);
    for (size_t i = 0; i < sizeof(T); ++i) {
      hash_ = (hash_ ^ bytes[i]) * 0x100000001b3ULL;
    }
  }
  uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 0xcbf29ce484222325ULL;
};

uint64_t key_of(double voxel_m, const Submap& submap, const std::vector<MapKeyframe>& keyframes) {
  Fnv1a h;
  h.add(kFormat);
  h.add(voxel_m);
  h.add(submap.id);
  for (const MapKeyframe& kf : keyframes) {
    h.add(kf.id);
    const Eigen::Matrix<double, 3, 4> T = kf.T_map_body.matrix().topRows<3>();
    for (int i = 0; i < 12; ++i) {
      h.add(T(i % 3, i / 3));
    }
  }
  return h.value();
}

template <class T>
void append(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <class T>
T read_at(std::string_view bytes, size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  return value;
}

// Header: magic, format, key, keyframe count, then the points of each keyframe; the
// last four bytes are the CRC-32 of everything before them.
constexpr size_t kHeaderBytes =
    sizeof(kMagic) + sizeof(uint32_t) + sizeof(uint64_t) + sizeof(uint32_t);

std::string encode(uint64_t key, const SubmapClouds& clouds) {
  size_t points = 0;
  for (const auto& cloud : clouds) {
    points += cloud->size();
  }
  std::string out;
  out.reserve(kHeaderBytes + 4 * clouds.size() + points * kBytesPerPoint + 4);
  out.append(kMagic, sizeof(kMagic));
  append(out, kFormat);
  append(out, key);
  append(out, static_cast<uint32_t>(clouds.size()));
  for (const auto& cloud : clouds) {
    append(out, static_cast<uint32_t>(cloud->size()));
  }
  for (const auto& cloud : clouds) {
    for (size_t i = 0; i < cloud->size(); ++i) {
      const float point[4] = {cloud->points[i].x(), cloud->points[i].y(), cloud->points[i].z(),
                              cloud->intensities[i]};
      out.append(reinterpret_cast<const char*>(point), kBytesPerPoint);
    }
  }
  append(out, crc32_of(out));
  return out;
}

// Nothing unless `bytes` is an intact file for `key` with `keyframes` clouds.
std::optional<SubmapClouds> decode(std::string_view bytes, uint64_t key, size_t keyframes) {
  if (bytes.size() < kHeaderBytes + 4 ||
      crc32_of(bytes.substr(0, bytes.size() - 4)) != read_at<uint32_t>(bytes, bytes.size() - 4) ||
      std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0 ||
      read_at<uint32_t>(bytes, 8) != kFormat || read_at<uint64_t>(bytes, 12) != key ||
      read_at<uint32_t>(bytes, 20) != keyframes) {
    return std::nullopt;
  }
  size_t offset = kHeaderBytes + 4 * keyframes;
  if (bytes.size() < offset + 4) {
    return std::nullopt;
  }
  std::vector<uint32_t> counts(keyframes);
  size_t points = 0;
  for (size_t k = 0; k < keyframes; ++k) {
    counts[k] = read_at<uint32_t>(bytes, kHeaderBytes + 4 * k);
    points += counts[k];
  }
  if (bytes.size() != offset + points * kBytesPerPoint + 4) {
    return std::nullopt;
  }
  SubmapClouds clouds;
  clouds.reserve(keyframes);
  for (size_t k = 0; k < keyframes; ++k) {
    auto cloud = std::make_shared<PointCloud>();
    cloud->points.resize(counts[k]);
    cloud->intensities.resize(counts[k]);
    for (uint32_t i = 0; i < counts[k]; ++i, offset += kBytesPerPoint) {
      float point[4];
      std::memcpy(point, bytes.data() + offset, kBytesPerPoint);
      cloud->points[i] = Eigen::Vector3f(point[0], point[1], point[2]);
      cloud->intensities[i] = point[3];
    }
    clouds.push_back(std::move(cloud));
  }
  return clouds;
}

}  // namespace

SubmapCloudFiles::SubmapCloudFiles(std::string map_directory, double voxel_m)
    : directory_(map_directory + "/" + kSubdirectory),
      map_directory_(std::move(map_directory)),
      voxel_m_(voxel_m) {}

std::string SubmapCloudFiles::relative_path(const Submap& submap,
                                            const std::vector<MapKeyframe>& keyframes) const {
  char name[64];
  std::snprintf(name, sizeof(name), "%06" PRId64 "-%016" PRIx64 "%s", submap.id,
                key_of(voxel_m_, submap, keyframes), kExtension);
  return std::string(kSubdirectory) + "/" + name;
}

bool SubmapCloudFiles::contains(const Submap& submap,
                                const std::vector<MapKeyframe>& keyframes) const {
  return file_size_bytes(map_directory_ + "/" + relative_path(submap, keyframes)).has_value();
}

std::optional<SubmapClouds> SubmapCloudFiles::load(
    const Submap& submap, const std::vector<MapKeyframe>& keyframes) const {
  const std::string path = map_directory_ + "/" + relative_path(submap, keyframes);
  if (!file_size_bytes(path)) {
    return std::nullopt;
  }
  std::optional<SubmapClouds> clouds;
  try {
    clouds = decode(read_file(path), key_of(voxel_m_, submap, keyframes), keyframes.size());
  } catch (const MapError&) {
    // Removed by a prune meanwhile, or unreadable: recomputed like a damaged file.
  }
  if (!clouds) {
    ++damaged_;
  }
  return clouds;
}

void SubmapCloudFiles::save(const Submap& submap, const std::vector<MapKeyframe>& keyframes,
                            const SubmapClouds& clouds) const {
  if (clouds.size() != keyframes.size()) {
    throw std::invalid_argument("submap " + std::to_string(submap.id) + ": " +
                                std::to_string(clouds.size()) + " clouds for " +
                                std::to_string(keyframes.size()) + " keyframes");
  }
  create_directory_synced(directory_);
  const std::string path = map_directory_ + "/" + relative_path(submap, keyframes);
  // Unique per writer: two threads may compute the same submap at once.
  const std::string temporary =
      path + "." + std::to_string(::getpid()) + "-" + std::to_string(temporaries_++) + kTempSuffix;
  write_file_synced(temporary, encode(key_of(voxel_m_, submap, keyframes), clouds));
  rename_file(temporary, path);
}

int SubmapCloudFiles::prune(const MapData& map) const {
  std::error_code error;
  if (!std::filesystem::is_directory(directory_, error)) {
    return 0;
  }
  const std::vector<std::vector<MapKeyframe>> keyframes_of = keyframes_of_submaps(map);
  std::set<std::string> current;
  for (size_t s = 0; s < map.submaps.size(); ++s) {
    current.insert(relative_path(map.submaps[s], keyframes_of[s]));
  }
  int removed = 0;
  for (const std::string& name : list_directory(directory_)) {
    if (current.count(std::string(kSubdirectory) + "/" + name) == 0) {
      remove_tree(directory_ + "/" + name);
      ++removed;
    }
  }
  return removed;
}

}  // namespace liloc::storage
