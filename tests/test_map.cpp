#include <gtest/gtest.h>

#include <random>
#include <set>
#include <tuple>

#include "map/central_session_builder.hpp"
#include "map/kd_tree.hpp"
#include "map/map_service.hpp"
#include "map/pose_graph_optimizer.hpp"
#include "map/submap_database.hpp"
#include "math/so3.hpp"

namespace liloc {
namespace {

TEST(KdTree, NearestAndWithinMatchBruteForce) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-50, 50);
  std::vector<KdTree::Item> items;
  for (int i = 0; i < 500; ++i) {
    items.push_back({i, Eigen::Vector3d(u(rng), u(rng), 0.1 * u(rng))});
  }
  const KdTree tree(items);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3d q(u(rng), u(rng), 0);
    std::vector<std::pair<double, int64_t>> brute;
    for (const auto& it : items) {
      brute.emplace_back((it.position - q).norm(), it.id);
    }
    std::sort(brute.begin(), brute.end());
    const auto hits = tree.nearest(q, 5);
    ASSERT_EQ(hits.size(), 5u);
    for (int k = 0; k < 5; ++k) {
      EXPECT_EQ(hits[k].id, brute[k].second);
    }
    const auto near = tree.within(q, 10.0);
    const size_t expected = static_cast<size_t>(
        std::count_if(brute.begin(), brute.end(), [](const auto& b) { return b.first <= 10.0; }));
    EXPECT_EQ(near.size(), expected);
  }
  EXPECT_TRUE(KdTree().nearest(Eigen::Vector3d::Zero(), 3).empty());
}

std::vector<MapKeyframe> straight_drive(int n, double spacing_m, const std::string& session) {
  std::vector<MapKeyframe> kfs;
  for (int i = 0; i < n; ++i) {
    MapKeyframe kf;
    kf.id = i;
    kf.session = session;
    kf.T_map_body.translation() = Eigen::Vector3d(spacing_m * i, 0, 0);
    kfs.push_back(kf);
  }
  return kfs;
}

// Eq. 2: a submap closes after N_s keyframes or h_p metres from the previous submap's end.
TEST(SubmapJoining, ClosesAtTwentyKeyframesOrTwentyMetres) {
  SubmapConfig config;
  std::vector<MapKeyframe> slow = straight_drive(50, 0.5, "A");  // 20 keyframes = 10 m
  const std::vector<Submap> by_count = join_submaps(slow, config, 7);
  ASSERT_EQ(by_count.size(), 3u);
  EXPECT_EQ(by_count[0].id, 7);
  EXPECT_EQ(by_count[0].keyframe_ids.size(), 20u);
  EXPECT_EQ(by_count[2].keyframe_ids.size(), 10u);
  EXPECT_EQ(slow[25].submap_id, 8);
  EXPECT_EQ(by_count[1].source_session, "A");

  std::vector<MapKeyframe> fast = straight_drive(30, 5.0, "B");  // 20 m every 4 keyframes
  const std::vector<Submap> by_distance = join_submaps(fast, config, 0);
  EXPECT_EQ(by_distance[0].keyframe_ids.size(), 5u);  // keyframes 0..4: 20 m from keyframe 0
  EXPECT_EQ(by_distance[1].keyframe_ids.size(), 4u);  // 5..8: 20 m from keyframe 4
  // Centroid of the positions; bounds around them with the margin.
  EXPECT_NEAR(by_distance[0].centroid.x(), 10.0, 1e-9);
  EXPECT_NEAR(by_distance[0].bounds.min_x, -config.bounds_margin_m, 1e-9);
  EXPECT_NEAR(by_distance[0].bounds.max_x, 20.0 + config.bounds_margin_m, 1e-9);
}

TEST(Overlap, IsTheFractionOfTheSquareInsideTheBounds) {
  const BoundsXY bounds{0, 100, 0, 100};
  EXPECT_DOUBLE_EQ(overlap_ratio(Eigen::Vector3d(50, 50, 0), 10, bounds), 1.0);
  EXPECT_DOUBLE_EQ(overlap_ratio(Eigen::Vector3d(100, 50, 0), 10, bounds), 0.5);
  EXPECT_DOUBLE_EQ(overlap_ratio(Eigen::Vector3d(100, 100, 0), 10, bounds), 0.25);
  EXPECT_DOUBLE_EQ(overlap_ratio(Eigen::Vector3d(200, 50, 0), 10, bounds), 0.0);
}

// A square drive with odometry drift in heading; one loop edge back to the start pulls the
// graph onto the truth.
TEST(PoseGraph, ALoopClosureRemovesOdometryDrift) {
  std::vector<MapKeyframe> truth, drifted;
  std::vector<PoseGraphEdge> edges;
  const int per_side = 10;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 4 * per_side; ++i) {
    MapKeyframe kf;
    kf.id = i;
    kf.T_map_body = T;
    truth.push_back(kf);
    const bool corner = (i + 1) % per_side == 0;
    T = T * se3::make(so3::exp(Eigen::Vector3d(0, 0, corner ? M_PI / 2 : 0)),
                      Eigen::Vector3d(corner ? 0 : 2, 0, 0));
  }
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  for (size_t i = 0; i < truth.size(); ++i) {
    if (i > 0) {
      const Eigen::Isometry3d step = truth[i - 1].T_map_body.inverse() * truth[i].T_map_body;
      PoseGraphEdge e;
      e.from = static_cast<int64_t>(i - 1);
      e.to = static_cast<int64_t>(i);
      e.T_from_to =
          step * se3::make(so3::exp(Eigen::Vector3d(0, 0, 0.01)), Eigen::Vector3d::Zero());
      e.information = Matrix6d::Identity() * 100.0;
      edges.push_back(e);
      D = D * e.T_from_to;
    }
    MapKeyframe kf = truth[i];
    kf.T_map_body = D;
    drifted.push_back(kf);
  }
  PoseGraphEdge loop;
  loop.from = 0;
  loop.to = static_cast<int64_t>(truth.size() - 1);
  loop.T_from_to = truth.front().T_map_body.inverse() * truth.back().T_map_body;
  loop.information = Matrix6d::Identity() * 1e4;
  loop.kind = PoseGraphEdge::Kind::kLoop;
  edges.push_back(loop);
  const double before =
      (drifted.back().T_map_body.translation() - truth.back().T_map_body.translation()).norm();
  const PoseGraphResult r = optimize_pose_graph(drifted, edges, PoseGraphConfig{});
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.final_cost, r.initial_cost);
  double worst = 0.0;
  for (size_t i = 0; i < truth.size(); ++i) {
    worst = std::max(
        worst, (drifted[i].T_map_body.translation() - truth[i].T_map_body.translation()).norm());
  }
  EXPECT_GT(before, 1.0);
  EXPECT_LT(worst, 0.5 * before);
  EXPECT_TRUE(drifted.front().T_map_body.isApprox(Eigen::Isometry3d::Identity()));
  PoseGraphEdge bad;
  bad.from = 0;
  bad.to = 999;
  EXPECT_THROW(optimize_pose_graph(drifted, {bad}, PoseGraphConfig{}), std::invalid_argument);
}

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
    return config;
  }
  MapService service(MapServiceConfig config = full_clouds(),
                     const SubmapCloudStore* store = nullptr) {
    return MapService(map, source(), config, store);
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

// A straight 59 m drive with a keyframe per metre, loops off: the keyframes keep their
// odometry poses, consecutive ones are linked with odometry edges, Eq. 2 closes a submap
// every 20 keyframes, and the clouds come out by keyframe id.
TEST(CentralSessionBuilder, KeyframesEdgesSubmapsAndClouds) {
  CentralSessionConfig config;
  config.close_loops = false;
  CentralSessionBuilder builder(config);
  for (int i = 0; i < 60; ++i) {
    Keyframe kf;
    kf.utime_us = 1000000 * i;
    kf.T_odom_body.translation() = Eigen::Vector3d(i, 0.0, 0.0);
    kf.cloud_body.points.assign(static_cast<size_t>(i + 1), Eigen::Vector3f::UnitZ());
    kf.cloud_body.intensities.assign(static_cast<size_t>(i + 1), 1.0f);
    builder.add(kf);
  }
  std::map<int64_t, PointCloud> clouds;
  CentralSessionReport report;
  const MapData map = builder.build(&clouds, &report);
  ASSERT_EQ(map.keyframes.size(), 60u);
  EXPECT_EQ(report.keyframes, 60u);
  EXPECT_EQ(report.loop_closures, 0u);
  ASSERT_EQ(map.edges.size(), 59u);
  for (const PoseGraphEdge& e : map.edges) {
    EXPECT_EQ(e.kind, PoseGraphEdge::Kind::kOdometry);
    EXPECT_EQ(e.to, e.from + 1);
    EXPECT_NEAR(e.T_from_to.translation().x(), 1.0, 1e-12);
  }
  for (const MapKeyframe& kf : map.keyframes) {
    EXPECT_EQ(kf.session, "A");
    EXPECT_NEAR(kf.T_map_body.translation().x(), static_cast<double>(kf.id), 1e-12);
    ASSERT_EQ(clouds.count(kf.id), 1u);
    EXPECT_EQ(clouds.at(kf.id).size(), static_cast<size_t>(kf.id + 1));
    EXPECT_GE(kf.submap_id, 0);
  }
  EXPECT_EQ(report.submaps, map.submaps.size());
  EXPECT_EQ(map.submaps.size(), 3u);
}

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
  EXPECT_EQ(s.take_new_clouds().size(), 30u);
  EXPECT_TRUE(s.take_new_clouds().empty());
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
  MapServiceConfig config;
  config.allowed_robots = {"r1", "r2"};
  config.max_update_points = 10;
  MapService s = f.service(config);
  EXPECT_EQ(s.receive(update_part("intruder", 1, 0, 1, 3, 0), 0).status,
            UpdateOutcome::Status::kRejected);
  MapUpdatePart nan = update_part("r1", 2, 0, 1, 3, 0);
  nan.keyframes[1].T_map_body.translation().x() = std::nan("");
  const UpdateOutcome non_finite = s.receive(nan, 0);
  EXPECT_EQ(non_finite.status, UpdateOutcome::Status::kRejected);
  EXPECT_NE(non_finite.reason.find("non-finite"), std::string::npos);
  EXPECT_EQ(s.receive(update_part("r1", 3, 0, 1, 20, 0), 0).status,
            UpdateOutcome::Status::kRejected);  // 20 points > 10
  EXPECT_EQ(s.receive(update_part("r1", 4, 3, 2, 1, 0), 0).status,
            UpdateOutcome::Status::kRejected);  // chunk 3 of 2
  EXPECT_EQ(s.counters().updates_rejected, 4);
  // A part the process could not convert rejects its whole update: the other part that
  // arrived before it is dropped, and later ones are ignored.
  EXPECT_EQ(s.receive(update_part("r2", 6, 0, 2, 1, 0), 0).status, UpdateOutcome::Status::kPending);
  EXPECT_EQ(s.reject("r2", 6, "pose has a non-finite value").status,
            UpdateOutcome::Status::kRejected);
  EXPECT_EQ(s.counters().updates_rejected, 5);
  EXPECT_EQ(s.receive(update_part("r2", 6, 1, 2, 1, 0), 0).status, UpdateOutcome::Status::kPending);
  EXPECT_EQ(s.receive(update_part("r2", 5, 0, 2, 1, 0), 0).status, UpdateOutcome::Status::kPending);
  s.expire(static_cast<int64_t>(31e6));
  EXPECT_EQ(s.counters().updates_expired, 1);
  EXPECT_EQ(s.map().keyframes.size(), 60u);
}

}  // namespace
}  // namespace liloc
