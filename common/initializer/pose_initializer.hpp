#pragma once
// Pose initialization: a robot's first pose in the map frame (paper Section IV-B: the polar
// descriptor of Eq. 3, the best keyframe by Eq. 4; Algorithm 1 line 2), and again whenever
// it is lost.
//
// Coarse-to-fine, as the paper: from a coarse pose (x, y, yaw with its uncertainty), the
// submaps around it through Tree_m, the best keyframes among theirs by the polar
// descriptor's distance (Eq. 4; the column shift gives the yaw), then registration of the
// robot's keyframe against those submaps to a 6-DoF pose with covariance, fitness and
// overlap.
//
// Global, beyond the paper: no coarse pose. Every keyframe of the map is ranked by a
// rotation-invariant retrieval key, the best by the descriptor's distance, and the best
// distinct places are each verified by registration. A pose is accepted only when its
// fitness and overlap pass and it is clearly better than the best distinct alternative;
// otherwise the answer is "not localized" with the reason: a wrong pose accepted is worse
// than a late one. HypothesisVoter then lets several keyframes vote (odometry ties them).
//
// The clouds come from a SubmapTargets source (the map server's replies in the node, the
// map directory in the tool and the bench), so that the search can name the submaps it
// needs before it has them.

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "descriptor/polar_descriptor.hpp"
#include "initializer/map_index.hpp"
#include "math/se3.hpp"
#include "pointcloud/point_cloud.hpp"
#include "registration/point_to_plane_registration.hpp"
#include "voxel_map/voxel_hash_map.hpp"

namespace liloc {

struct InitializerConfig {
  // Coarse-to-fine: submaps whose centroid lies within search_radius_m (at least; 3 sigma
  // of the coarse position beyond it) of the coarse position.
  double search_radius_m = 30.0;
  int max_search_submaps = 8;
  // Global: keyframes ranked by retrieval key, then by descriptor distance.
  int retrieval_candidates = 60;
  // Both: the best candidates by descriptor distance that are verified by registration,
  // at most one per place (candidates within distinct_m of a better one are the same
  // place).
  int verify_candidates = 4;
  double distinct_m = 8.0;
  double max_descriptor_distance = 0.6;
  // Registration target: the map's points within target_radius_m of the candidate.
  double target_radius_m = 35.0;
  // Registration runs coarse to fine: target voxels and association radii, one stage each.
  std::vector<double> stage_voxel_m{2.0, 1.0, 0.5};
  std::vector<double> stage_correspondence_m{3.0, 1.5, 0.6};
  std::vector<double> stage_plane_thickness_m{0.4, 0.15, 0.06};
  int max_query_points = 4000;
  RegistrationConfig registration = [] {
    RegistrationConfig c;
    c.max_iterations = 25;
    c.max_associations = 25;
    c.min_planarity = 0.25;
    c.threads = 2;
    return c;
  }();
  // Acceptance of a verified candidate.
  double max_fitness_m = 0.10;  // RMS point-to-plane distance at the last stage
  double min_overlap = 0.35;    // fraction of the query's points matched to a map plane
  // Global: the best must beat the best distinct alternative: its overlap at most this
  // fraction of the best's.
  double max_alternative_ratio = 0.85;
  // Covariance: the registration's information as if from this many independent matches.
  int independent_correspondences = 200;

  template <class V>
  void visit_fields(V& v) {
    v("search_radius_m", search_radius_m);
    v("max_search_submaps", max_search_submaps);
    v("retrieval_candidates", retrieval_candidates);
    v("verify_candidates", verify_candidates);
    v("distinct_m", distinct_m);
    v("max_descriptor_distance", max_descriptor_distance);
    v("target_radius_m", target_radius_m);
    v("stage_voxel_m", stage_voxel_m);
    v("stage_correspondence_m", stage_correspondence_m);
    v("stage_plane_thickness_m", stage_plane_thickness_m);
    v("max_query_points", max_query_points);
    v("registration", registration);
    v("max_fitness_m", max_fitness_m);
    v("min_overlap", min_overlap);
    v("max_alternative_ratio", max_alternative_ratio);
    v("independent_correspondences", independent_correspondences);
  }
  void validate() const;
};

// The robot's keyframe to localize: its cloud and its pose in the odometry's frame, whose
// roll and pitch are the gravity direction (the odom frame is level).
struct InitQuery {
  int64_t keyframe_id = 0;
  int64_t utime_us = 0;
  Eigen::Isometry3d T_odom_body = Eigen::Isometry3d::Identity();
  PointCloud cloud_body;
};

// A coarse pose: where a user or a program believes the robot is.
struct CoarsePose {
  double x_m = 0.0, y_m = 0.0, yaw_rad = 0.0;
  double sigma_xy_m = 5.0;
  double sigma_yaw_rad = 0.5;
};

struct InitCandidate {
  int64_t keyframe_id = -1;  // the map keyframe the descriptor matched
  int64_t submap_id = -1;
  double descriptor_distance = 1.0;
  double yaw_rad = 0.0;  // of the match (Eq. 4's column shift)
  Eigen::Isometry3d T_map_body_guess = Eigen::Isometry3d::Identity();
  // Verification (registration against the map around the keyframe):
  bool verified = false;
  Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Identity();  // right perturbation (math/se3.hpp)
  double fitness_m = 0.0;
  double overlap = 0.0;
  bool degenerate = false;
  std::string rejected;  // why it is not the answer; empty for the answer
};

struct InitResult {
  enum class Status { kLocalized, kNotLocalized, kNeedsSubmaps };
  Status status = Status::kNotLocalized;
  std::string method;  // "coarse_to_fine" or "global"
  std::string reason;  // what it did, or why it did not localize
  std::optional<InitCandidate> best;
  std::vector<InitCandidate> candidates;  // verified or not, best first
  std::vector<int64_t> missing_submaps;   // kNeedsSubmaps: the submaps to fetch first
  double time_ms = 0.0;
  bool localized() const { return status == Status::kLocalized; }
};

// The map's points around a place, as registration targets, from submaps' clouds. The
// source gives a submap's points in the map frame, or nothing if it does not have them
// (yet). Targets are cached (least recently used out beyond `capacity`).
class SubmapTargets {
 public:
  using Source = std::function<std::shared_ptr<const std::vector<Eigen::Vector3f>>(int64_t)>;
  SubmapTargets(Source source, size_t capacity = 32);

  // The submaps a target around `position` is made of (Tree_m within `radius_m`).
  static std::vector<int64_t> submaps_around(const MapIndex& index, const Eigen::Vector3d& position,
                                             double radius_m);
  // Those of `ids` the source cannot give now.
  std::vector<int64_t> missing(const std::vector<int64_t>& ids) const;
  // The voxel map of the submaps' points at `voxel_m`; null if one is missing.
  std::shared_ptr<const VoxelHashMap> target(const std::vector<int64_t>& ids, double voxel_m) const;

 private:
  Source source_;
  size_t capacity_;
  using Key = std::pair<std::vector<int64_t>, double>;
  mutable std::list<std::pair<Key, std::shared_ptr<const VoxelHashMap>>> cache_;
};

class PoseInitializer {
 public:
  PoseInitializer(const InitializerConfig& config, const PolarDescriptorConfig& descriptor);

  // Coarse-to-fine (the paper).
  InitResult coarse_to_fine(const MapIndex& index, const InitQuery& query, const CoarsePose& coarse,
                            const SubmapTargets& targets) const;
  // Global: no coarse pose.
  InitResult global(const MapIndex& index, const InitQuery& query,
                    const SubmapTargets& targets) const;

  const InitializerConfig& config() const { return config_; }

 private:
  struct Query {
    PolarDescriptor descriptor;
    Eigen::Matrix3d R_level_body;         // the body's roll and pitch (yaw removed)
    std::vector<Eigen::Vector3f> points;  // body frame, downsampled
  };
  Query prepare(const InitQuery& query) const;
  // The best candidates of `keyframes` by descriptor distance, one per place, guesses set.
  std::vector<InitCandidate> rank(const Query& query,
                                  const std::vector<const MapIndex::Keyframe*>& keyframes,
                                  const std::optional<CoarsePose>& coarse) const;
  // Registers the query from each candidate's guess; kNeedsSubmaps if a target is missing.
  InitResult verify(const MapIndex& index, const Query& query,
                    std::vector<InitCandidate> candidates, const SubmapTargets& targets,
                    bool global) const;
  void register_candidate(const Query& query, InitCandidate& candidate,
                          const std::vector<std::shared_ptr<const VoxelHashMap>>& stages) const;

  InitializerConfig config_;
  PolarDescriptorConfig descriptor_;
};

// Global initialization over several keyframes: each keyframe's verified candidates,
// carried into the odometry frame (T_map_odom = T_map_body T_odom_body^-1), vote for a
// map-from-odom transform; one that keyframes agree on (within agree_m / agree_rad) with
// no rival that another keyframe supports is the answer. Odometry ties the keyframes, so
// places that look alike from one keyframe rarely do from the next.
class HypothesisVoter {
 public:
  struct Config {
    int votes_needed = 2;
    double agree_m = 1.0;
    double agree_rad = 0.05;
    int max_keyframes = 10;  // the oldest keyframe's votes are forgotten beyond this
  };
  explicit HypothesisVoter(Config config) : config_(config) {}

  // Adds a keyframe's verified candidates (those that passed fitness and overlap); returns
  // the agreed T_map_odom once there is one.
  std::optional<Eigen::Isometry3d> add(const InitQuery& query,
                                       const std::vector<InitCandidate>& candidates);
  void clear() { keyframes_.clear(); }
  std::string summary() const;  // for status messages

 private:
  Config config_;
  std::list<std::vector<Eigen::Isometry3d>> keyframes_;  // T_map_odom hypotheses, newest last
};

}  // namespace liloc
