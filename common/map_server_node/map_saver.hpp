#pragma once
// Saves the growth of the central session as new map versions, on a thread of its own, so
// that serving never waits for the disk. Each merged update arrives as a MapDelta; a save
// writes the map on disk plus every delta not yet on disk. A save that fails for the disk
// (I/O, a full disk) keeps its deltas for the next one; a delta the map's rules refuse
// (the map service checks the same rules before merging, so this is a safety net) is
// dropped and reported, and never blocks the deltas after it.

#include <cstdint>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "app/worker_pool.hpp"
#include "map/map_types.hpp"
#include "storage/map_store.hpp"

namespace liloc {

class MapSaver {
 public:
  struct Result {
    int64_t version = 0;                // the new version on disk; 0: nothing was saved
    std::vector<int64_t> keyframe_ids;  // the keyframes this save put on disk
    std::string error;                  // why a save failed or deltas were dropped
    int64_t dropped_keyframes = 0;      // refused by the map's rules: never saved
    storage::SaveReport report;
  };

  // `on_disk`: the map as the store holds it now (its version is the store's current one).
  MapSaver(storage::MapStore& store, MapData on_disk, int keep_versions);
  MapSaver(const MapSaver&) = delete;
  MapSaver& operator=(const MapSaver&) = delete;

  // Queues a save of the map with this delta (and those before it). Thread-safe.
  void submit(MapDelta delta);
  // Queues another attempt for what a failed save kept; nothing if all is on disk.
  void retry();
  // Saves done or failed since the last call. Thread-safe.
  std::vector<Result> take_results();
  // Keyframes submitted and not on disk (queued, or kept by a failed save).
  int64_t unsaved_keyframes() const;
  // Waits for every queued save and returns unsaved_keyframes(): 0 if nothing was lost.
  int64_t finish();

 private:
  struct Job {
    std::optional<MapDelta> delta;
    std::shared_ptr<std::promise<void>> done;  // set once the job ran
  };
  void run(Job& job);
  void save_pending(Result& result);
  // Drops the pending deltas that the map's rules refuse; false if none was refused.
  bool drop_refused(Result& result);
  void add_result(Result result);

  storage::MapStore& store_;
  MapData on_disk_;                // the worker's alone
  std::vector<MapDelta> pending_;  // the worker's alone: merged, not yet on disk
  int keep_versions_;
  mutable std::mutex mutex_;  // guards results_ and unsaved_keyframes_
  std::vector<Result> results_;
  int64_t unsaved_keyframes_ = 0;
  // Last: destroyed first, finishing the queued saves.
  WorkerPool<Job> worker_{[this](Job& job) { run(job); }, WorkerPool<Job>::OnStop::kFinishQueued};
};

}  // namespace liloc
