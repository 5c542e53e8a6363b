#pragma once
// Opens a real dataset by format name, for every program that reads one (liloc_ingest,
// liloc_map build-from-poses).

#include <memory>
#include <string>

#include "dataset/folder_dataset_reader.hpp"
#include "dataset/kitti_odometry_reader.hpp"
#include "dataset/nclt_reader.hpp"
#include "dataset/sensor_dataset_reader.hpp"

namespace liloc::dataset {

// The reader options of every format (the "ingest" section of a config).
struct DatasetReadersConfig {
  KittiConfig kitti;
  NcltConfig nclt;
  FolderDatasetConfig folder;

  template <class V>
  void visit_fields(V& v) {
    v("kitti", kitti);
    v("nclt", nclt);
    v("folder", folder);
  }
};

// format: kitti (input = the odometry root, sequence "00" by default), nclt (input = the
// session folder, or its parent with sequence = the date) or folder. Throws
// std::invalid_argument for another format, DatasetError for unreadable input.
std::unique_ptr<SensorDatasetReader> open_dataset(const std::string& format,
                                                  const std::string& input,
                                                  const std::string& sequence,
                                                  const DatasetReadersConfig& config);

}  // namespace liloc::dataset
