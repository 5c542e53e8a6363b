#include "dataset/dataset_factory.hpp"

#include <stdexcept>

namespace liloc::dataset {

std::unique_ptr<SensorDatasetReader> open_dataset(const std::string& format,
                                                  const std::string& input,
                                                  const std::string& sequence,
                                                  const DatasetReadersConfig& config) {
  if (format == "kitti") {
    return std::make_unique<KittiOdometryReader>(input, sequence.empty() ? "00" : sequence,
                                                 config.kitti);
  }
  if (format == "nclt") {
    return std::make_unique<NcltReader>(sequence.empty() ? input : input + "/" + sequence,
                                        config.nclt);
  }
  if (format == "folder") {
    return std::make_unique<FolderDatasetReader>(input, config.folder);
  }
  throw std::invalid_argument("dataset format must be kitti, nclt or folder (got '" + format +
                              "')");
}

}  // namespace liloc::dataset
