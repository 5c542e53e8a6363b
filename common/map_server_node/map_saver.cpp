#include "map_server_node/map_saver.hpp"

#include <map>
#include <stdexcept>

#include "map/map_validation.hpp"

namespace liloc {

MapSaver::MapSaver(storage::MapStore& store, MapData on_disk, int keep_versions)
    : store_(store), on_disk_(std::move(on_disk)), keep_versions_(keep_versions) {}

void MapSaver::submit(MapDelta delta) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    unsaved_keyframes_ += static_cast<int64_t>(delta.keyframes.size());
  }
  worker_.submit({std::move(delta), nullptr});
}

void MapSaver::retry() {
  if (unsaved_keyframes() > 0) {
    worker_.submit({std::nullopt, nullptr});
  }
}

std::vector<MapSaver::Result> MapSaver::take_results() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Result> out;
  out.swap(results_);
  return out;
}

int64_t MapSaver::unsaved_keyframes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return unsaved_keyframes_;
}

int64_t MapSaver::finish() {
  auto done = std::make_shared<std::promise<void>>();
  std::future<void> finished = done->get_future();
  worker_.submit({std::nullopt, done});
  finished.wait();
  return unsaved_keyframes();
}

void MapSaver::run(Job& job) {
  if (job.delta) {
    pending_.push_back(std::move(*job.delta));
  }
  if (!pending_.empty()) {
    Result result;
    save_pending(result);
    add_result(std::move(result));
  }
  if (job.done) {
    job.done->set_value();
  }
}

void MapSaver::save_pending(Result& result) {
  for (int attempt = 0; attempt < 2 && !pending_.empty(); ++attempt) {
    MapData next = on_disk_;
    std::map<int64_t, PointCloud> clouds;
    std::map<int64_t, std::vector<uint8_t>> descriptors;
    for (const MapDelta& delta : pending_) {
      delta.append_to(next);
      for (const auto& [id, cloud] : delta.clouds) {
        clouds.emplace(id, *cloud);
      }
      descriptors.insert(delta.descriptors.begin(), delta.descriptors.end());
    }
    try {
      result.report = store_.save(next, clouds, descriptors);
    } catch (const std::invalid_argument& e) {
      // Refused data: drop what the map's rules refuse and save the rest; anything else
      // the store refuses (a keyframe id it already holds) would be refused forever.
      result.error = e.what();
      if (attempt == 0 && drop_refused(result)) {
        continue;
      }
      for (const MapDelta& delta : pending_) {
        result.dropped_keyframes += static_cast<int64_t>(delta.keyframes.size());
      }
      pending_.clear();
      return;
    } catch (const std::exception& e) {
      result.error = e.what();  // the disk: kept for the next save
      return;
    }
    on_disk_ = std::move(next);
    result.version = on_disk_.version;
    for (const auto& entry : clouds) {
      result.keyframe_ids.push_back(entry.first);
    }
    pending_.clear();
    try {
      store_.prune(keep_versions_);
    } catch (const std::exception& e) {
      result.error = std::string("saved, but pruning old versions failed: ") + e.what();
    }
    return;
  }
}

bool MapSaver::drop_refused(Result& result) {
  MapData accepted = on_disk_;
  std::vector<MapDelta> kept;
  for (MapDelta& delta : pending_) {
    MapData candidate = accepted;
    delta.append_to(candidate);
    if (const std::optional<MapProblem> problem = find_map_problem(candidate)) {
      result.error +=
          "; dropped " + std::to_string(delta.keyframes.size()) + " keyframes: " + problem->what;
      result.dropped_keyframes += static_cast<int64_t>(delta.keyframes.size());
    } else {
      accepted = std::move(candidate);
      kept.push_back(std::move(delta));
    }
  }
  const bool dropped = kept.size() < pending_.size();
  pending_ = std::move(kept);
  return dropped;
}

void MapSaver::add_result(Result result) {
  std::lock_guard<std::mutex> lock(mutex_);
  unsaved_keyframes_ -= static_cast<int64_t>(result.keyframe_ids.size()) + result.dropped_keyframes;
  results_.push_back(std::move(result));
}

}  // namespace liloc
