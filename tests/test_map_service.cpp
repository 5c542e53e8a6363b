#include <gtest/gtest.h>

#include <limits>
#include <set>
#include <tuple>

#include "map/map_validation.hpp"
#include "map_service/map_service.hpp"
#include "map_test_data.hpp"

namespace liloc {
namespace {

using test::straight_drive;

// A map of 3 submaps along x, 20 keyframes each, clouds of 1000 points.
struct ServiceFixture {
  MapData map;
  std::map<int64_t, std::shared_ptr<const PointCloud>> clouds;
  int cloud_loads = 0;
  ServiceFixture() {
    map.keyframes = straight_drive(60, 1.0, "A");
    map.submaps = join_submaps(map.keyframes, SubmapConfig{}, 0);
    for (const MapKeyframe& kf : map.keyframes) {
      auto c = std::make_shared<PointCloud>();
      for (int i = 0; i < 1000; ++i) {
        c->push_back(Eigen::Vector3f(i * 0.01f, 0, 0), 1.0f);
      }
      clouds[kf.id] = c;
    }
  }
  KeyframeCloudSource source() {
    return [this](int64_t id) {
      ++cloud_loads;
      return clouds.at(id);
    };
  }
  // Full keyframe clouds unless a test asks for deduplication.
  static MapServiceConfig full_clouds() {
    MapServiceConfig config;
    config.reply_voxel_m = 0.0;
    config.allowed_robots = {"r1", "r2"};
    return config;
  }
  MapService service(MapServiceConfig config = full_clouds(),
                     const SubmapCloudStore* store = nullptr) {
    return MapService(map, source(), {}, config, SubmapConfig{}, PolarDescriptorConfig{}, store);
  }
};

// A SubmapCloudStore in memory, as the server's files are on disk.
class MemoryCloudStore final : public SubmapCloudStore {
 public:
  explicit MemoryCloudStore(double voxel_m) : voxel_m_(voxel_m) {}
  double voxel_m() const override { return voxel_m_; }
  bool contains(const Submap& submap, const std::vector<MapKeyframe>& keyframes) const override {
    return stored_.count(key(submap, keyframes)) > 0;
  }
  std::optional<SubmapClouds> load(const Submap& submap,
                                   const std::vector<MapKeyframe>& keyframes) const override {
    const auto it = stored_.find(key(submap, keyframes));
    return it == stored_.end() ? std::nullopt : std::optional<SubmapClouds>(it->second);
  }
  void save(const Submap& submap, const std::vector<MapKeyframe>& keyframes,
            const SubmapClouds& clouds) const override {
    stored_[key(submap, keyframes)] = clouds;
    ++saves;
  }
  mutable int saves = 0;

 private:
  // The submap and where its first keyframe is: enough to tell the fixtures' versions apart.
  static std::pair<int64_t, double> key(const Submap& submap,
                                        const std::vector<MapKeyframe>& keyframes) {
    return {submap.id, keyframes.front().T_map_body.translation().x()};
  }
  double voxel_m_;
  mutable std::map<std::pair<int64_t, double>, SubmapClouds> stored_;
};

TEST(MapService, AnswersByPositionAndById) {
  ServiceFixture f;
  MapService s = f.service();
  SubmapQuery q;
  q.robot_id = "r1";
  q.request_id = 5;
  q.position = Eigen::Vector3d(45, 1, 0);
  const auto parts = s.answer(q);
  ASSERT_EQ(parts.size(), 1u);
  ASSERT_TRUE(parts[0].submap);
  EXPECT_EQ(parts[0].submap->id, 2);
  EXPECT_EQ(parts[0].robot_id, "r1");
  EXPECT_EQ(parts[0].request_id, 5);
  EXPECT_EQ(parts[0].keyframes.size(), 20u);
  EXPECT_EQ(parts[0].clouds->keyframes(), 20u);
  q.by_id = true;
  q.submap_ids = {0, 1, 77};
  q.include_clouds = false;
  const auto by_id = s.answer(q);
  ASSERT_EQ(by_id.size(), 2u);
  EXPECT_EQ(by_id[1].submap->id, 1);
  EXPECT_EQ(by_id[1].reply_index, 1);
  EXPECT_EQ(by_id[1].reply_count, 2);
  EXPECT_FALSE(by_id[0].clouds);
  q.submap_ids = {77};
  const auto none = s.answer(q);
  ASSERT_EQ(none.size(), 1u);
  EXPECT_FALSE(none[0].submap);
  EXPECT_EQ(none[0].reply_count, 1);
  EXPECT_EQ(s.counters().empty_replies, 1);
}

TEST(MapService, ChunksBigSubmapsIntoWholeKeyframes) {
  ServiceFixture f;
  MapServiceConfig config = ServiceFixture::full_clouds();
  config.max_chunk_points = 4500;  // 4 keyframes of 1000 points per chunk
  MapService s = f.service(config);
  SubmapQuery q;
  q.position = Eigen::Vector3d(5, 0, 0);
  const auto parts = s.answer(q);
  ASSERT_EQ(parts.size(), 5u);
  size_t keyframes = 0;
  for (size_t i = 0; i < parts.size(); ++i) {
    EXPECT_EQ(parts[i].chunk_index, static_cast<int>(i));
    EXPECT_EQ(parts[i].num_chunks, 5);
    EXPECT_EQ(parts[i].reply_count, 5);
    EXPECT_LE(parts[i].keyframes.size(), 4u);
    EXPECT_EQ(parts[i].keyframes.size(), parts[i].clouds->keyframes());
    keyframes += parts[i].keyframes.size();
  }
  EXPECT_EQ(keyframes, 20u);
}

MapUpdatePart update_part(const std::string& robot, int64_t update_id, int chunk, int chunks,
                          int keyframes, double x0) {
  MapUpdatePart p;
  p.robot_id = robot;
  p.session_id = robot + "-B";
  p.update_id = update_id;
  p.chunk_index = chunk;
  p.num_chunks = chunks;
  for (int i = 0; i < keyframes; ++i) {
    UpdateKeyframe kf;
    kf.sender_keyframe_id = i;
    kf.utime_us = 1000 * i;
    kf.T_map_body.translation() = Eigen::Vector3d(x0 + i, 50, 0);
    kf.cloud_body.push_back(Eigen::Vector3f::Zero(), 0.0f);
    p.keyframes.push_back(kf);
  }
  return p;
}

// Overlapping keyframes: a reply sends each 0.3 m map voxel once, every point in its own
// keyframe's frame, and a repeated request is served from the deduplicated cache.
TEST(MapService, SendsEachMapVoxelOnceAndCachesIt) {
  ServiceFixture f;
  MapServiceConfig config;
  config.reply_voxel_m = 0.3;
  MapService s = f.service(config);
  SubmapQuery q;
  q.by_id = true;
  q.submap_ids = {0};
  const auto parts = s.answer(q);
  std::set<std::tuple<int, int, int>> voxels;
  size_t points = 0;
  for (const SubmapReplyPart& part : parts) {
    ASSERT_EQ(part.keyframes.size(), part.clouds->keyframes());
    for (size_t k = 0; k < part.keyframes.size(); ++k) {
      for (const Eigen::Vector3f& p : part.clouds->keyframe_cloud(k).points) {
        const Eigen::Vector3f q_map = (part.keyframes[k].T_map_body.cast<float>() * p);
        const Eigen::Vector3i v = (q_map / 0.3f).array().floor().cast<int>();
        EXPECT_TRUE(voxels.insert({v.x(), v.y(), v.z()}).second) << "a voxel sent twice";
        ++points;
      }
    }
  }
  // n keyframes one metre apart along x, each with points 0 .. 9.99 m ahead of it: the
  // voxels from x = 0 to n - 1 + 9.99 m, against n * 1000 points in the keyframe clouds.
  size_t n = 0;
  for (const SubmapReplyPart& part : parts) {
    n += part.keyframes.size();
  }
  ASSERT_GE(n, 10u);
  EXPECT_EQ(points, static_cast<size_t>(std::floor((n - 1 + 9.99) / 0.3)) + 1);
  EXPECT_LT(points * 100, n * 1000);
  const int loads = f.cloud_loads;
  s.answer(q);
  EXPECT_EQ(f.cloud_loads, loads);
}

// The reply cache drops the least recently used submap, not the oldest one.
TEST(MapService, ReplyCacheKeepsTheRecentlyUsedSubmaps) {
  ServiceFixture f;
  MapServiceConfig config;
  config.reply_cache_submaps = 2;
  MapService s = f.service(config);
  const auto fetch = [&](int64_t submap) {
    SubmapQuery q;
    q.by_id = true;
    q.submap_ids = {submap};
    s.answer(q);
  };
  fetch(0);
  fetch(1);
  fetch(0);  // used again: now the most recent
  EXPECT_EQ(f.cloud_loads, 40);
  fetch(2);  // evicts 1
  EXPECT_EQ(f.cloud_loads, 60);
  fetch(0);
  EXPECT_EQ(f.cloud_loads, 60);
  fetch(1);
  EXPECT_EQ(f.cloud_loads, 80);
}

// Deduplicated clouds are computed once per submap and kept in the store: a second
// service (the server restarted) answers from the store without loading keyframe clouds;
// fill_submap_cloud_store computes what the store lacks, and stops when asked.
TEST(MapService, KeepsDeduplicatedCloudsInTheStoreAcrossServices) {
  ServiceFixture f;
  MapServiceConfig config;
  config.reply_voxel_m = 0.3;
  MemoryCloudStore store(0.3);
  SubmapQuery q;
  q.by_id = true;
  q.submap_ids = {1};
  std::vector<SubmapReplyPart> first;
  {
    MapService s = f.service(config, &store);
    first = s.answer(q);
  }
  EXPECT_EQ(store.saves, 1);
  const int loads = f.cloud_loads;
  EXPECT_EQ(loads, 20);
  MapService again = f.service(config, &store);
  const auto second = again.answer(q);
  EXPECT_EQ(f.cloud_loads, loads);
  ASSERT_EQ(first.size(), second.size());
  for (size_t i = 0; i < first.size(); ++i) {
    ASSERT_TRUE(first[i].clouds && second[i].clouds);
    EXPECT_EQ(first[i].clouds->offsets, second[i].clouds->offsets);
    EXPECT_EQ(first[i].clouds->cloud.x, second[i].clouds->cloud.x);
    EXPECT_EQ(first[i].clouds->cloud.intensity, second[i].clouds->cloud.intensity);
  }
  EXPECT_EQ(again.store_errors(), 0);

  EXPECT_EQ(fill_submap_cloud_store(f.map, f.source(), store, [&] { return store.saves >= 2; }), 1);
  EXPECT_EQ(fill_submap_cloud_store(f.map, f.source(), store), 1);
  EXPECT_EQ(fill_submap_cloud_store(f.map, f.source(), store), 0);
  EXPECT_EQ(store.saves, 3);
  EXPECT_EQ(fill_submap_cloud_store(f.map, f.source(), MemoryCloudStore(0.0)), 0);
  MemoryCloudStore other_voxel(0.5);
  EXPECT_THROW(f.service(config, &other_voxel), std::invalid_argument);
}

TEST(MapService, MergesACompleteUpdateIntoNewSubmaps) {
  ServiceFixture f;
  MapService s = f.service();
  auto first = s.receive(update_part("r2", 1, 1, 2, 15, 15), 0);
  EXPECT_EQ(first.status, UpdateOutcome::Status::kPending);
  auto done = s.receive(update_part("r2", 1, 0, 2, 15, 0), 1000);
  ASSERT_EQ(done.status, UpdateOutcome::Status::kMerged);
  EXPECT_EQ(done.new_keyframes.size(), 30u);
  EXPECT_EQ(done.new_keyframes.front().id, 60);
  EXPECT_EQ(done.new_keyframes.front().session, "r2-B");
  // Chunk order, not arrival order: the first keyframe is chunk 0's.
  EXPECT_DOUBLE_EQ(done.new_keyframes.front().T_map_body.translation().x(), 0.0);
  EXPECT_EQ(done.new_submaps.size(), 2u);
  EXPECT_EQ(done.new_submaps.front().id, 3);
  EXPECT_EQ(s.map().keyframes.size(), 90u);
  // The next request near the new area gets the new submap, with its clouds.
  SubmapQuery q;
  q.position = Eigen::Vector3d(5, 50, 0);
  const auto parts = s.answer(q);
  ASSERT_TRUE(parts[0].submap);
  EXPECT_EQ(parts[0].submap->id, 3);
  EXPECT_EQ(parts[0].clouds->keyframes(), 20u);
  const MapDelta unsaved = s.take_unsaved();
  EXPECT_EQ(unsaved.keyframes.size(), 30u);
  EXPECT_EQ(unsaved.clouds.size(), 30u);
  EXPECT_EQ(unsaved.submaps.size(), 2u);
  EXPECT_EQ(unsaved.edges.size(), 29u);
  EXPECT_TRUE(s.take_unsaved().keyframes.empty());
  // Once saved, replies name the version on disk (the clouds come from storage then).
  s.saved(8, {60, 61});
  EXPECT_EQ(s.map().version, 8);
  q.include_clouds = false;
  EXPECT_EQ(s.answer(q)[0].map_version, 8);
  // A repeat of the merged update changes nothing.
  s.receive(update_part("r2", 1, 0, 2, 15, 0), 2000);
  EXPECT_EQ(s.map().keyframes.size(), 90u);
}

TEST(MapService, RejectsBadUpdatesAndExpiresIncompleteOnes) {
  ServiceFixture f;
  MapServiceConfig config = ServiceFixture::full_clouds();
  config.max_update_points = 10;
  MapService s = f.service(config);
  MapUpdatePart nan = update_part("r1", 2, 0, 1, 3, 0);
  nan.keyframes[1].T_map_body.translation().x() = std::nan("");
  const UpdateOutcome non_finite = s.receive(nan, 0);
  EXPECT_EQ(non_finite.status, UpdateOutcome::Status::kRejected);
  EXPECT_NE(non_finite.reason.find("non-finite"), std::string::npos);
  EXPECT_EQ(s.receive(update_part("r1", 3, 0, 1, 20, 0), 0).status,
            UpdateOutcome::Status::kRejected);  // 20 points > 10
  EXPECT_EQ(s.receive(update_part("r1", 4, 3, 2, 1, 0), 0).status,
            UpdateOutcome::Status::kRejected);  // chunk 3 of 2
  EXPECT_EQ(s.counters().updates_rejected, 3);
  // A part the process could not convert rejects its whole update: the other part that
  // arrived before it is dropped.
  EXPECT_EQ(s.receive(update_part("r2", 6, 0, 2, 1, 0), 0).status, UpdateOutcome::Status::kPending);
  EXPECT_EQ(s.reject("r2", "r2-B", 6, "pose has a non-finite value").status,
            UpdateOutcome::Status::kRejected);
  EXPECT_EQ(s.counters().updates_rejected, 4);
  EXPECT_EQ(s.pending_updates(), 0u);
  EXPECT_EQ(s.receive(update_part("r2", 5, 0, 2, 1, 0), 0).status, UpdateOutcome::Status::kPending);
  s.expire(static_cast<int64_t>(31e6));
  EXPECT_EQ(s.counters().updates_expired, 1);
  EXPECT_EQ(s.map().keyframes.size(), 60u);
}

// What the service merges, a save accepts: an update whose session or robot names cannot
// go into the map's files, or whose values are not finite or far beyond any map, is
// rejected when it arrives (with the reason the save would give), not merged.
TEST(MapService, RefusesUpdatesTheMapCouldNotSave) {
  ServiceFixture f;
  MapService s = f.service();
  const auto merge = [&](MapUpdatePart part) { return s.receive(std::move(part), 0); };
  MapUpdatePart comma = update_part("r1", 1, 0, 1, 3, 0);
  comma.session_id = "B,evil";
  UpdateOutcome outcome = merge(comma);
  EXPECT_EQ(outcome.status, UpdateOutcome::Status::kRejected);
  EXPECT_NE(outcome.reason.find("session"), std::string::npos) << outcome.reason;
  MapUpdatePart control = update_part("r1", 2, 0, 1, 3, 0);
  control.session_id = std::string("B\x01");
  EXPECT_EQ(merge(control).status, UpdateOutcome::Status::kRejected);
  MapUpdatePart fitness = update_part("r1", 3, 0, 1, 3, 0);
  fitness.keyframes[2].fitness_m = std::numeric_limits<double>::infinity();
  EXPECT_EQ(merge(fitness).status, UpdateOutcome::Status::kRejected);
  MapUpdatePart far = update_part("r1", 4, 0, 1, 3, 0);
  far.keyframes[0].T_map_body.translation().y() = 1e308;
  EXPECT_EQ(merge(far).status, UpdateOutcome::Status::kRejected);
  EXPECT_EQ(s.counters().updates_rejected, 4);
  EXPECT_EQ(s.map().keyframes.size(), 60u);
  EXPECT_TRUE(s.take_unsaved().keyframes.empty());
  // A valid update after them merges, and what it leaves to save is valid.
  EXPECT_EQ(merge(update_part("r1", 5, 0, 1, 3, 0)).status, UpdateOutcome::Status::kMerged);
  EXPECT_FALSE(find_map_problem(s.map()));
}

// Only robots the config names grow the map: anyone else is refused and counted (an empty
// list refuses everyone).
TEST(MapService, OnlyNamedRobotsUpdateTheMap) {
  ServiceFixture f;
  MapService s = f.service();
  const UpdateOutcome intruder = s.receive(update_part("intruder", 1, 0, 1, 3, 0), 0);
  EXPECT_EQ(intruder.status, UpdateOutcome::Status::kRejected);
  EXPECT_NE(intruder.reason.find("allowed_robots"), std::string::npos) << intruder.reason;
  EXPECT_EQ(s.counters().updates_refused_robot, 1);
  MapServiceConfig none = ServiceFixture::full_clouds();
  none.allowed_robots.clear();
  MapService closed = f.service(none);
  EXPECT_EQ(closed.receive(update_part("r1", 1, 0, 1, 3, 0), 0).status,
            UpdateOutcome::Status::kRejected);
  EXPECT_EQ(closed.map().keyframes.size(), 60u);
}

// An update is known by (robot, session, update id) and only merged ones are remembered:
// a rejected spoof with a real update's ids does not make the real one be ignored, a
// robot restarting its ids in a new session is not taken for a repeat, and a repeat of a
// merged update is counted, not merged twice.
TEST(MapService, ARejectedUpdateNeverShadowsARealOne) {
  ServiceFixture f;
  MapService s = f.service();
  MapUpdatePart spoof = update_part("r1", 7, 0, 1, 3, 0);
  spoof.keyframes[0].fitness_m = std::nan("");
  EXPECT_EQ(s.receive(spoof, 0).status, UpdateOutcome::Status::kRejected);
  EXPECT_EQ(s.receive(update_part("r1", 7, 0, 1, 3, 0), 0).status, UpdateOutcome::Status::kMerged);
  EXPECT_EQ(s.receive(update_part("r1", 7, 0, 1, 3, 0), 0).status, UpdateOutcome::Status::kPending);
  EXPECT_EQ(s.counters().updates_repeated, 1);
  MapUpdatePart next_session = update_part("r1", 7, 0, 1, 3, 0);
  next_session.session_id = "r1-C";
  EXPECT_EQ(s.receive(next_session, 0).status, UpdateOutcome::Status::kMerged);
  EXPECT_EQ(s.map().keyframes.size(), 66u);
}

// Updates waiting for chunks are bounded in count and points: beyond, new ones are
// refused (counted) until those complete or expire.
TEST(MapService, PendingUpdatesAreBounded) {
  ServiceFixture f;
  MapServiceConfig config = ServiceFixture::full_clouds();
  config.max_pending_updates = 3;
  config.max_pending_points = 1000;
  MapService s = f.service(config);
  for (int64_t id = 0; id < 100; ++id) {
    s.receive(update_part("r1", id, 0, 2, 1, 0), 0);  // chunk 0 of 2, never completed
  }
  EXPECT_EQ(s.pending_updates(), 3u);
  EXPECT_EQ(s.counters().updates_refused_busy, 97);
  EXPECT_EQ(s.receive(update_part("r2", 1, 0, 2, 2000, 0), 0).status,
            UpdateOutcome::Status::kRejected);
  s.expire(static_cast<int64_t>(31e6));
  EXPECT_EQ(s.pending_updates(), 0u);
  EXPECT_EQ(s.receive(update_part("r2", 2, 0, 2, 1, 0), 0).status, UpdateOutcome::Status::kPending);
}

// Merged updates are remembered so that repeats are ignored, but not without bound.
TEST(MapService, ForgetsTheOldestMergedUpdatesBeyondItsBound) {
  ServiceFixture f;
  MapServiceConfig config = ServiceFixture::full_clouds();
  config.max_finished_updates = 10;
  MapService s = f.service(config);
  for (int64_t id = 0; id < 30; ++id) {
    ASSERT_EQ(s.receive(update_part("r1", id, 0, 1, 1, 0), 0).status,
              UpdateOutcome::Status::kMerged);
  }
  EXPECT_EQ(s.finished_updates(), 10u);
  s.receive(update_part("r1", 29, 0, 1, 1, 0), 0);  // still remembered: ignored
  EXPECT_EQ(s.counters().updates_repeated, 1);
  EXPECT_EQ(s.counters().updates_merged, 30);
}

}  // namespace
}  // namespace liloc
