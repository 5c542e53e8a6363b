// liloc_map: looks at, checks, exports and draws a map directory (docs/map_format.md).
//
//   liloc_map build LOG OUT_DIR [--ground-truth gt.tum]  a map from a recorded drive
//   liloc_map build-from-poses DATASET OUT_DIR [--format kitti|folder] [--poses x.tum]
//   liloc_map build-from-pcd MAP.pcd OUT_DIR [--cell-m 20] [--radius-m 30]
//   liloc_map inspect DIR                          version, counts, points, bounds, disk use
//   liloc_map validate DIR                         every check, every keyframe file's CRC
//   liloc_map export DIR OUT.pcd [--voxel-m 0.2]   all clouds in the map frame, one PCD
//   liloc_map render DIR OUT.png [--px-per-m 2]    top-down image
//   liloc_map prune DIR [--keep 2]                 removes old versions and unlisted files
//   liloc_map localize DIR SCAN [--coarse x,y,yaw]  one scan in the map (exit 0: localized)
//
// A subcommand is one function taking its own argv (argv[0] = the subcommand) and one row
// of kSubcommands.

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "liloc_map/map_build.hpp"
#include "liloc_map/map_localize.hpp"
#include "liloc_map/map_render.hpp"
#include "pointcloud/voxel_grid.hpp"
#include "pointcloud/voxel_index_table.hpp"
#include "storage/file_io.hpp"
#include "storage/map_layout.hpp"
#include "storage/map_store.hpp"
#include "storage/pcd_codec.hpp"
#include "storage/submap_cloud_files.hpp"

namespace {
using namespace liloc;
namespace fs = std::filesystem;

constexpr const char* kProgram = "liloc_map";

// Calls visit(keyframe, cloud_body) for each keyframe of the map, in id order, one cloud
// in memory at a time.
template <class Visit>
void for_each_cloud(const storage::MapStore& store, const MapData& map, const Visit& visit) {
  for (const MapKeyframe& kf : map.keyframes) {
    visit(kf, store.load_cloud(kf.id));
  }
}

std::string format_bytes(uint64_t bytes) {
  char text[32];
  if (bytes < 1024 * 1024) {
    std::snprintf(text, sizeof(text), "%.1f KiB", static_cast<double>(bytes) / 1024.0);
  } else if (bytes < uint64_t{1024} * 1024 * 1024) {
    std::snprintf(text, sizeof(text), "%.1f MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
  } else {
    std::snprintf(text, sizeof(text), "%.2f GiB",
                  static_cast<double>(bytes) / (1024.0 * 1024.0 * 1024.0));
  }
  return text;
}

uint64_t directory_bytes(const std::string& path) {
  uint64_t bytes = 0;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(path)) {
    if (entry.is_regular_file()) {
      bytes += entry.file_size();
    }
  }
  return bytes;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int inspect(int argc, const char* const* argv) {
  std::vector<std::string> args;
  CommandLine cli("liloc_map inspect",
                  "Version, counts, points, bounds and disk use of a map directory. Reads every "
                  "keyframe cloud (checksum-verified).");
  cli.add_positional("DIR", &args, "the map directory", 1);
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    storage::MapStore store(args[0]);
    const MapData map = store.load();
    const storage::MapManifest manifest = store.manifest();

    std::map<std::string, int64_t> keyframes_by_session;
    for (const MapKeyframe& kf : map.keyframes) {
      ++keyframes_by_session[kf.session];
    }
    int64_t points = 0;
    Eigen::AlignedBox3f point_bounds;
    for_each_cloud(store, map, [&](const MapKeyframe& kf, const PointCloud& cloud) {
      const Eigen::Affine3f T_map_body = Eigen::Affine3f(kf.T_map_body.cast<float>());
      for (const Eigen::Vector3f& p : cloud.points) {
        point_bounds.extend(T_map_body * p);
      }
      points += static_cast<int64_t>(cloud.size());
    });
    Eigen::AlignedBox3d keyframe_bounds;
    double path_m = 0.0;
    for (size_t i = 0; i < map.keyframes.size(); ++i) {
      keyframe_bounds.extend(map.keyframes[i].T_map_body.translation());
      if (i > 0 && map.keyframes[i].session == map.keyframes[i - 1].session) {
        path_m += (map.keyframes[i].T_map_body.translation() -
                   map.keyframes[i - 1].T_map_body.translation())
                      .norm();
      }
    }
    uint64_t version_bytes = 0;
    for (const storage::StoredFile& file : manifest.version_files) {
      version_bytes += file.size_bytes;
    }
    uint64_t keyframe_file_bytes = 0;
    for (const storage::StoredFile& file : manifest.keyframe_files) {
      keyframe_file_bytes += file.size_bytes;
    }
    int versions = 0;
    for (const fs::directory_entry& entry : fs::directory_iterator(args[0] + "/versions")) {
      versions += storage::parse_version_dir_name(entry.path().filename().string()) ? 1 : 0;
    }

    std::printf("map directory   %s\n", args[0].c_str());
    std::printf("map_id          %s\n", map.map_id.c_str());
    std::printf("version         %lld (created %s, frame '%s', format %d)\n",
                static_cast<long long>(map.version), manifest.created_utc.c_str(),
                manifest.frame.c_str(), manifest.format_version);
    std::printf("keyframes       %zu\n", map.keyframes.size());
    for (const auto& [session, count] : keyframes_by_session) {
      std::printf("  session %-8s%lld\n", session.empty() ? "(none)" : session.c_str(),
                  static_cast<long long>(count));
    }
    std::printf("submaps         %zu\n", map.submaps.size());
    std::printf("edges           %lld odometry, %lld loop\n",
                static_cast<long long>(manifest.counts.odometry_edges),
                static_cast<long long>(manifest.counts.loop_edges));
    std::printf("points          %lld (%.0f per keyframe)\n", static_cast<long long>(points),
                map.keyframes.empty()
                    ? 0.0
                    : static_cast<double>(points) / static_cast<double>(map.keyframes.size()));
    if (!point_bounds.isEmpty()) {
      std::printf("point bounds    x %.1f .. %.1f  y %.1f .. %.1f  z %.1f .. %.1f m\n",
                  point_bounds.min().x(), point_bounds.max().x(), point_bounds.min().y(),
                  point_bounds.max().y(), point_bounds.min().z(), point_bounds.max().z());
    }
    if (!keyframe_bounds.isEmpty()) {
      std::printf("keyframe bounds x %.1f .. %.1f  y %.1f .. %.1f  z %.1f .. %.1f m, path %.1f m\n",
                  keyframe_bounds.min().x(), keyframe_bounds.max().x(), keyframe_bounds.min().y(),
                  keyframe_bounds.max().y(), keyframe_bounds.min().z(), keyframe_bounds.max().z(),
                  path_m);
    }
    std::printf("this version    %s metadata + %s keyframe files (%zu files)\n",
                format_bytes(version_bytes).c_str(), format_bytes(keyframe_file_bytes).c_str(),
                manifest.keyframe_files.size());
    std::printf("directory       %s in all, %d versions\n",
                format_bytes(directory_bytes(args[0])).c_str(), versions);
    return 0;
  });
}

int validate(int argc, const char* const* argv) {
  std::vector<std::string> args;
  CommandLine cli("liloc_map validate",
                  "Checks a map directory: every metadata file (size, CRC-32, syntax, "
                  "consistency) and every keyframe file in full. Exit status 0 if intact.");
  cli.add_positional("DIR", &args, "the map directory", 1);
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    const auto start = std::chrono::steady_clock::now();
    storage::MapStore store(args[0]);
    const MapData map = store.load();
    store.verify_clouds();
    uint64_t bytes = 0;
    const storage::MapManifest manifest = store.manifest();
    for (const storage::StoredFile& file : manifest.keyframe_files) {
      bytes += file.size_bytes;
    }
    std::printf("OK: %s version %lld, %zu keyframes, %zu keyframe files (%s) verified in %.1f s\n",
                map.map_id.c_str(), static_cast<long long>(map.version), map.keyframes.size(),
                manifest.keyframe_files.size(), format_bytes(bytes).c_str(), seconds_since(start));
    return 0;
  });
}

int export_cloud(int argc, const char* const* argv) {
  std::vector<std::string> args;
  double voxel_m = 0.2;
  CommandLine cli("liloc_map export",
                  "Writes every keyframe cloud, in the map frame, as one binary PCD (x y z "
                  "intensity), voxel-downsampled to the centroid of each voxel.");
  cli.add_positional("DIR OUT.pcd", &args, "the map directory and the PCD to write", 2);
  cli.add_option("voxel-m", &voxel_m, "voxel edge, metres; 0 keeps every point");
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    if (!(voxel_m >= 0.0)) {
      throw std::invalid_argument("--voxel-m must be >= 0");
    }
    storage::MapStore store(args[0]);
    const MapData map = store.load();
    // Voxels are accumulated cloud by cloud: the map's clouds are never all in memory.
    struct Accumulator {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double intensity_sum = 0.0;
      int64_t count = 0;
    };
    VoxelIndexTable voxels;
    std::vector<Accumulator> accumulators;
    PointCloud merged;
    int64_t points_in = 0;
    for_each_cloud(store, map, [&](const MapKeyframe& kf, const PointCloud& cloud) {
      const Eigen::Affine3f T_map_body = Eigen::Affine3f(kf.T_map_body.cast<float>());
      points_in += static_cast<int64_t>(cloud.size());
      for (size_t i = 0; i < cloud.size(); ++i) {
        const Eigen::Vector3f p = T_map_body * cloud.points[i];
        if (voxel_m == 0.0) {
          merged.push_back(p, cloud.intensities[i]);
          continue;
        }
        const auto [index, inserted] =
            voxels.insert(voxel_key(voxel_index(p, static_cast<float>(voxel_m))));
        if (inserted) {
          accumulators.emplace_back();
        }
        Accumulator& a = accumulators[index];
        a.sum += p.cast<double>();
        a.intensity_sum += cloud.intensities[i];
        ++a.count;
      }
    });
    for (const Accumulator& a : accumulators) {
      const double inverse = 1.0 / static_cast<double>(a.count);
      merged.push_back((a.sum * inverse).cast<float>(),
                       static_cast<float>(a.intensity_sum * inverse));
    }
    const std::string bytes = storage::encode_pcd(merged);
    storage::write_file_synced(args[1], bytes);
    spdlog::info("wrote {} points ({} before downsampling, voxel {} m) to {} ({})", merged.size(),
                 points_in, voxel_m, args[1], format_bytes(bytes.size()));
    return 0;
  });
}

int render(int argc, const char* const* argv) {
  std::vector<std::string> args;
  tools::MapRenderConfig config;
  bool grey = false;
  CommandLine cli("liloc_map render",
                  "Draws a map top-down: points coloured by height, keyframe paths by session, "
                  "submap bounds with ids, scale bar.");
  cli.add_positional("DIR OUT.png", &args, "the map directory and the image to write", 2);
  cli.add_option("px-per-m", &config.px_per_m, "image resolution, pixels per metre");
  cli.add_flag("grey", &grey, "grey points instead of height colours");
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    config.height_colours = !grey;
    storage::MapStore store(args[0]);
    const MapData map = store.load();
    tools::MapRenderer renderer(config);
    for_each_cloud(store, map, [&](const MapKeyframe& kf, const PointCloud& cloud) {
      renderer.add_cloud(cloud, kf.T_map_body);
    });
    const std::string title = map.map_id + " v" + std::to_string(map.version) + ": " +
                              std::to_string(map.keyframes.size()) + " keyframes, " +
                              std::to_string(map.submaps.size()) + " submaps";
    const cv::Mat image = renderer.render(map, title);
    if (!cv::imwrite(args[1], image)) {
      throw std::runtime_error("cannot write " + args[1]);
    }
    spdlog::info("wrote {} ({} x {} px)", args[1], image.cols, image.rows);
    return 0;
  });
}

int prune(int argc, const char* const* argv) {
  std::vector<std::string> args;
  int keep = 2;
  std::string config_path;  // see kConfigOptionHelp
  CommandLine cli("liloc_map prune",
                  "Keeps the current version and the newest ones before it; removes older "
                  "versions, leftovers of interrupted saves, keyframe files no kept version "
                  "lists and submap reply clouds the current version does not use.");
  cli.add_positional("DIR", &args, "the map directory", 1);
  cli.add_option("keep", &keep, "versions to keep, the current one included");
  cli.add_option("config", &config_path, kConfigOptionHelp);
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    const SystemConfig config = load_program_config<SystemConfig>(config_path);
    storage::MapStore store(args[0]);
    const storage::PruneResult result = store.prune(keep);
    const int reply_clouds =
        storage::SubmapCloudFiles(args[0], config.map_server.service.reply_voxel_m)
            .prune(store.load());
    spdlog::info(
        "removed {} version directories, {} keyframe files ({}) and {} submap reply "
        "cloud files",
        result.versions_removed, result.keyframe_files_removed, format_bytes(result.bytes_removed),
        reply_clouds);
    return 0;
  });
}

int print_config(int argc, const char* const* argv) {
  std::string config_path;  // see kConfigOptionHelp
  CommandLine cli("liloc_map --print-config",
                  "Prints the config the subcommands run with, as YAML: the built-in defaults "
                  "(the paper's values), ./config/liloc.yaml if there is one, or --config.");
  cli.add_option("config", &config_path, kConfigOptionHelp);
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    std::printf("%s\n", dump_config(load_program_config<SystemConfig>(config_path)).c_str());
    return 0;
  });
}

struct Subcommand {
  const char* name;
  const char* summary;
  int (*run)(int argc, const char* const* argv);
};

const Subcommand kSubcommands[] = {
    {"build", "a map from a recorded drive (odometry, loops, submaps)", build_map},
    {"build-from-poses", "a map from scans with known poses (KITTI, PCD folder)",
     build_map_from_poses},
    {"build-from-pcd", "a map from one global point cloud (grid pseudo-keyframes)",
     build_map_from_pcd},
    {"inspect", "version, counts, points, bounds, disk use", inspect},
    {"validate", "check everything, exit 0 if intact", validate},
    {"export", "all clouds in the map frame as one PCD", export_cloud},
    {"render", "top-down PNG of points, paths and submaps", render},
    {"prune", "remove old versions and unlisted keyframe files", prune},
    {"localize", "one scan (PCD or KITTI .bin) in the map, with or without a coarse pose",
     localize_scan},
    {"--print-config", "the effective config as YAML (defaults, ./config/liloc.yaml, --config)",
     print_config},
};

void print_usage(std::ostream& out) {
  out << "usage: liloc_map <command> ...   (liloc_map <command> --help)\n";
  for (const Subcommand& command : kSubcommands) {
    char line[128];
    std::snprintf(line, sizeof(line), "  %-17s %s\n", command.name, command.summary);
    out << line;
  }
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    print_usage(std::cerr);
    return 2;
  }
  const std::string name = argv[1];
  if (name == "--help" || name == "help") {
    print_usage(std::cout);
    return 0;
  }
  for (const Subcommand& command : kSubcommands) {
    if (name == command.name) {
      return command.run(argc - 1, argv + 1);
    }
  }
  std::cerr << "liloc_map: unknown command '" << name << "'\n";
  print_usage(std::cerr);
  return 2;
}
