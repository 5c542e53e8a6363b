#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "map/kd_tree.hpp"
#include "map/map_validation.hpp"
#include "map/submap_database.hpp"
#include "map_test_data.hpp"

namespace liloc {
namespace {

using test::straight_drive;

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

// One set of rules for every map: storage loads and saves by them, the map service merges
// by them.
TEST(MapValidation, NamesIdsValuesAndReferences) {
  EXPECT_TRUE(is_valid_name("robot-7 B"));
  for (const std::string& bad :
       std::vector<std::string>{"", "a,b", "say \"hi\"", std::string("tab\there"),
                                std::string(65, 'x'), std::string("nul\0", 4)}) {
    EXPECT_FALSE(is_valid_name(bad)) << printable_excerpt(bad);
  }
  EXPECT_TRUE(is_valid_map_id("campus.v2_b-1"));
  EXPECT_FALSE(is_valid_map_id("-campus"));
  EXPECT_FALSE(is_valid_map_id("a b"));

  MapData map;
  map.keyframes = straight_drive(30, 1.0, "A");
  map.submaps = join_submaps(map.keyframes, SubmapConfig{}, 0);
  EXPECT_FALSE(find_map_problem(map));
  const auto problem_of = [&](auto change) {
    MapData bad = map;
    change(bad);
    return find_map_problem(bad);
  };
  auto p = problem_of([](MapData& m) { m.keyframes[3].session = "x,y"; });
  ASSERT_TRUE(p);
  EXPECT_EQ(p->part, MapPart::kKeyframes);
  EXPECT_NE(p->what.find("keyframe 3"), std::string::npos) << p->what;
  p = problem_of([](MapData& m) { m.keyframes[4].fitness_m = std::nan(""); });
  ASSERT_TRUE(p);
  EXPECT_NE(p->what.find("fitness"), std::string::npos) << p->what;
  p = problem_of([](MapData& m) { m.keyframes[5].T_map_body.translation().x() = 1e308; });
  ASSERT_TRUE(p);
  EXPECT_EQ(p->part, MapPart::kPoses);
  p = problem_of([](MapData& m) { std::swap(m.keyframes[1].id, m.keyframes[2].id); });
  ASSERT_TRUE(p);
  EXPECT_NE(p->what.find("increasing"), std::string::npos) << p->what;
  p = problem_of([](MapData& m) { m.submaps[0].keyframe_ids.push_back(99); });
  ASSERT_TRUE(p);
  EXPECT_EQ(p->part, MapPart::kSubmaps);
  p = problem_of([](MapData& m) { m.edges.push_back({0, 99}); });
  ASSERT_TRUE(p);
  EXPECT_EQ(p->part, MapPart::kPoseGraph);
}

}  // namespace
}  // namespace liloc
