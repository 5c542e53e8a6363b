#include "storage/submap_cloud_files.hpp"

#include <unistd.h>

#include <algorithm>
#include <cinttypes>
#include <cmath>
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
constexpr uint32_t kFormat = 2;  // 2: quantized (CompactCloud); 1 had floats
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

// Poses are hashed rounded (rotation to 1e-9, translation to 0.1 um): a map saved and
// loaded again has the same poses only to the last digit (they are written as text and
// pass through a rotation matrix), and its submaps must keep their files.
uint64_t key_of(double voxel_m, const Submap& submap, const std::vector<MapKeyframe>& keyframes) {
  Fnv1a h;
  h.add(kFormat);
  h.add(voxel_m);
  h.add(submap.id);
  for (const MapKeyframe& kf : keyframes) {
    h.add(kf.id);
    const Eigen::Matrix<double, 3, 4> T = kf.T_map_body.matrix().topRows<3>();
    for (int i = 0; i < 12; ++i) {
      const double step = i < 9 ? 1e-9 : 1e-7;  // column-major: the last three are t
      h.add(static_cast<int64_t>(std::llround(T(i % 3, i / 3) / step)));
    }
  }
  return h.value();
}

template <class T>
void append(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <class T>
void append_array(std::string& out, const std::vector<T>& values) {
  out.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

template <class T>
T read_at(std::string_view bytes, size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  return value;
}

// Reads n values at `offset` and moves it past them.
template <class T>
std::vector<T> read_array(std::string_view bytes, size_t& offset, size_t n) {
  std::vector<T> values(n);
  std::memcpy(values.data(), bytes.data() + offset, n * sizeof(T));
  offset += n * sizeof(T);
  return values;
}

// Header: magic, format, key, keyframe count, resolution, intensity scale; then the
// keyframes' offsets (count + 1), the x, y, z and intensity arrays (the CompactCloud as
// it is in memory, so that loading is a copy); the last four bytes are the CRC-32 of
// everything before them.
constexpr size_t kHeaderBytes =
    sizeof(kMagic) + sizeof(uint32_t) + sizeof(uint64_t) + sizeof(uint32_t) + 2 * sizeof(float);
constexpr size_t kBytesPerPoint = 3 * sizeof(int16_t) + sizeof(uint8_t);

std::string encode(uint64_t key, const SubmapClouds& clouds) {
  const size_t points = clouds.cloud.size();
  std::string out;
  out.reserve(kHeaderBytes + 4 * clouds.offsets.size() + points * kBytesPerPoint + 4);
  out.append(kMagic, sizeof(kMagic));
  append(out, kFormat);
  append(out, key);
  append(out, static_cast<uint32_t>(clouds.keyframes()));
  append(out, clouds.cloud.resolution_m);
  append(out, clouds.cloud.intensity_scale);
  append_array(out, clouds.offsets);
  append_array(out, clouds.cloud.x);
  append_array(out, clouds.cloud.y);
  append_array(out, clouds.cloud.z);
  append_array(out, clouds.cloud.intensity);
  append(out, crc32_of(out));
  return out;
}

// Nothing unless `bytes` is an intact file for `key` with `keyframes` clouds.
std::optional<SubmapClouds> decode(std::string_view bytes, uint64_t key, size_t keyframes) {
  if (bytes.size() < kHeaderBytes + 4 * (keyframes + 1) + 4 ||
      crc32_of(bytes.substr(0, bytes.size() - 4)) != read_at<uint32_t>(bytes, bytes.size() - 4) ||
      std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0 ||
      read_at<uint32_t>(bytes, 8) != kFormat || read_at<uint64_t>(bytes, 12) != key ||
      read_at<uint32_t>(bytes, 20) != keyframes) {
    return std::nullopt;
  }
  SubmapClouds clouds;
  clouds.cloud.resolution_m = read_at<float>(bytes, 24);
  clouds.cloud.intensity_scale = read_at<float>(bytes, 28);
  size_t offset = kHeaderBytes;
  clouds.offsets = read_array<uint32_t>(bytes, offset, keyframes + 1);
  const size_t points = clouds.offsets.back();
  if (clouds.offsets.front() != 0 ||
      !std::is_sorted(clouds.offsets.begin(), clouds.offsets.end()) ||
      bytes.size() != offset + points * kBytesPerPoint + 4) {
    return std::nullopt;
  }
  clouds.cloud.x = read_array<int16_t>(bytes, offset, points);
  clouds.cloud.y = read_array<int16_t>(bytes, offset, points);
  clouds.cloud.z = read_array<int16_t>(bytes, offset, points);
  clouds.cloud.intensity = read_array<uint8_t>(bytes, offset, points);
  try {
    check_compact_cloud(clouds.cloud);
  } catch (const std::invalid_argument&) {
    return std::nullopt;
  }
  return clouds;
}

// Relative to the map directory.
std::string relative_path_of(int64_t submap_id, uint64_t key) {
  char name[64];
  std::snprintf(name, sizeof(name), "%06" PRId64 "-%016" PRIx64 "%s", submap_id, key, kExtension);
  return std::string(kSubdirectory) + "/" + name;
}

}  // namespace

SubmapCloudFiles::SubmapCloudFiles(std::string map_directory, double voxel_m)
    : directory_(map_directory + "/" + kSubdirectory),
      map_directory_(std::move(map_directory)),
      voxel_m_(voxel_m) {}

std::string SubmapCloudFiles::relative_path(const Submap& submap,
                                            const std::vector<MapKeyframe>& keyframes) const {
  return relative_path_of(submap.id, key_of(voxel_m_, submap, keyframes));
}

bool SubmapCloudFiles::contains(const Submap& submap,
                                const std::vector<MapKeyframe>& keyframes) const {
  return file_size_bytes(map_directory_ + "/" + relative_path(submap, keyframes)).has_value();
}

std::optional<SubmapClouds> SubmapCloudFiles::load(
    const Submap& submap, const std::vector<MapKeyframe>& keyframes) const {
  const uint64_t key = key_of(voxel_m_, submap, keyframes);
  const std::string path = map_directory_ + "/" + relative_path_of(submap.id, key);
  if (!file_size_bytes(path)) {
    return std::nullopt;
  }
  std::optional<SubmapClouds> clouds;
  try {
    clouds = decode(read_file(path), key, keyframes.size());
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
  if (clouds.keyframes() != keyframes.size()) {
    throw std::invalid_argument("submap " + std::to_string(submap.id) + ": " +
                                std::to_string(clouds.keyframes()) + " clouds for " +
                                std::to_string(keyframes.size()) + " keyframes");
  }
  create_directory_synced(directory_);
  const uint64_t key = key_of(voxel_m_, submap, keyframes);
  const std::string path = map_directory_ + "/" + relative_path_of(submap.id, key);
  // Unique per writer: two threads may compute the same submap at once.
  const std::string temporary =
      path + "." + std::to_string(::getpid()) + "-" + std::to_string(temporaries_++) + kTempSuffix;
  write_file_synced(temporary, encode(key, clouds));
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
