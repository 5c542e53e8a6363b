#include "initializer/pose_initializer.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "math/so3.hpp"
#include "math/stopwatch.hpp"
#include "pointcloud/voxel_grid.hpp"

namespace liloc {
namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kDistinctYawRad = kPi / 6;  // candidates 30 degrees apart are distinct poses
// Two registrations of the same query on the same target ended at the same pose.
constexpr double kSameConvergedM = 0.1;
constexpr double kSameConvergedRad = 0.01;
const char* const kAmbiguous = "ambiguous with another place";
const char* const kVotes = "votes: too few inliers to stand alone";

// If submaps are missing, the result asks for them first.
bool asks_for_submaps(InitResult& result) {
  if (result.missing_submaps.empty()) {
    return false;
  }
  result.status = InitResult::Status::kNeedsSubmaps;
  result.reason = std::to_string(result.missing_submaps.size()) + " submap(s) to fetch first";
  return true;
}

Eigen::Matrix3d rz(double yaw) { return so3::exp(Eigen::Vector3d(0, 0, yaw)); }

// Two poses of the same place, as far as initialization tells places apart.
bool same_place(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double distinct_m) {
  return (a.translation() - b.translation()).head<2>().norm() < distinct_m &&
         std::abs(so3::wrap_angle(so3::yaw(a.linear()) - so3::yaw(b.linear()))) < kDistinctYawRad;
}

std::string describe(const InitCandidate& c) {
  std::ostringstream out;
  out.precision(3);
  if (c.keyframe_id < 0) {
    out << "correlative start";
  } else {
    out << "keyframe " << c.keyframe_id << " (submap " << c.submap_id << ", descriptor "
        << c.descriptor_distance << ")";
  }
  if (c.verified) {
    out << " at (" << c.T_map_body.translation().x() << ", " << c.T_map_body.translation().y()
        << "): inliers " << c.inlier_ratio << ", fitness " << c.fitness_m << " m";
  }
  return out.str();
}

}  // namespace

void InitializerConfig::validate() const {
  if (!(search_radius_m > 0) || max_search_submaps < 1 || retrieval_candidates < 1 ||
      verify_candidates < 1 || !(distinct_m > 0) || !(target_radius_m > 0) ||
      max_query_points < 100) {
    throw std::invalid_argument(
        "search_radius_m, distinct_m and target_radius_m must be positive, the candidate counts "
        "at least 1, max_query_points at least 100");
  }
  if (!(max_descriptor_distance > 0 && max_descriptor_distance <= 1) || !(max_fitness_m > 0) ||
      !(min_inlier_ratio > 0 && min_inlier_ratio <= 1) ||
      !(min_inlier_ratio_coarse > 0 && min_inlier_ratio_coarse <= 1) ||
      !(min_inlier_ratio_alone >= min_inlier_ratio && min_inlier_ratio_alone <= 1) ||
      !(polish_below_inlier_ratio > 0 && polish_below_inlier_ratio <= 1) ||
      !(correlative_below_inlier_ratio >= 0 && correlative_below_inlier_ratio <= 1) ||
      !(inlier_m > 0) || !(coarse_start_spacing_m > 0) || !(coarse_distinct_m > 0) ||
      !(max_alternative_ratio > 0 && max_alternative_ratio <= 1) ||
      independent_correspondences < 1) {
    throw std::invalid_argument(
        "max_descriptor_distance, the inlier ratios, polish_below_inlier_ratio and "
        "max_alternative_ratio must be in (0, 1] "
        "(min_inlier_ratio_alone at least min_inlier_ratio; correlative_below_inlier_ratio "
        "in [0, 1]), "
        "max_fitness_m, inlier_m, coarse_start_spacing_m and coarse_distinct_m positive, "
        "independent_correspondences at least 1");
  }
  stages.validate();
  registration.validate();
}

SubmapTargets::SubmapTargets(Source source, size_t capacity)
    : source_(std::move(source)), capacity_(std::max<size_t>(capacity, 1)) {}

std::vector<int64_t> SubmapTargets::submaps_around(const MapIndex& index,
                                                   const Eigen::Vector3d& position,
                                                   double radius_m) {
  std::vector<int64_t> ids;
  for (const KdTree::Hit& hit : index.submaps().submaps_within(position, radius_m)) {
    ids.push_back(hit.id);
  }
  if (ids.empty()) {
    for (const KdTree::Hit& hit : index.submaps().nearest_submaps(position, 1)) {
      ids.push_back(hit.id);
    }
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::vector<int64_t> SubmapTargets::missing(const std::vector<int64_t>& ids) const {
  std::vector<int64_t> out;
  for (const int64_t id : ids) {
    if (!source_(id)) {
      out.push_back(id);
    }
  }
  return out;
}

std::shared_ptr<const VoxelHashMap> SubmapTargets::target(const std::vector<int64_t>& ids,
                                                          double voxel_m) const {
  const Key key(ids, voxel_m);
  for (auto it = cache_.begin(); it != cache_.end(); ++it) {
    if (it->first == key) {
      cache_.splice(cache_.begin(), cache_, it);  // most recently used first
      return cache_.front().second;
    }
  }
  VoxelMapConfig config;
  config.voxel_m = voxel_m;
  config.min_point_spacing_m = voxel_m / 5.0;
  config.keep_radius_m = 1e6;
  auto map = std::make_shared<VoxelHashMap>(config);
  // From the nearest finer target of the same submaps if there is one: its points are
  // already thinned, and inserting points is most of a target's cost.
  std::shared_ptr<const VoxelHashMap> finer;
  for (const auto& [k, cached] : cache_) {
    if (k.first == ids && k.second < voxel_m && (!finer || k.second > finer->config().voxel_m)) {
      finer = cached;
    }
  }
  if (finer) {
    map->insert(finer->points());
  } else {
    for (const int64_t id : ids) {
      const std::shared_ptr<const std::vector<Eigen::Vector3f>> points = source_(id);
      if (!points) {
        return nullptr;
      }
      map->insert(*points);
    }
  }
  cache_.emplace_front(key, map);
  if (cache_.size() > capacity_) {
    cache_.pop_back();
  }
  return map;
}

PoseInitializer::PoseInitializer(const InitializerConfig& config,
                                 const PolarDescriptorConfig& descriptor)
    : config_(config), descriptor_(descriptor) {
  config_.validate();
  descriptor_.validate();
}

PoseInitializer::Query PoseInitializer::prepare(const InitQuery& query) const {
  Query q;
  const Eigen::Matrix3d R_odom_body = query.T_odom_body.linear();
  q.descriptor = make_level_polar_descriptor(query.cloud_body, R_odom_body, descriptor_);
  q.R_level_body = rz(-so3::yaw(R_odom_body)) * R_odom_body;
  for (const double voxel_m : config_.stages.voxel_m) {
    q.stage_points.push_back(sparse_points(query.cloud_body, static_cast<float>(voxel_m),
                                           static_cast<size_t>(config_.max_query_points)));
  }
  return q;
}

std::vector<InitCandidate> PoseInitializer::rank(
    const Query& query, const std::vector<const MapIndex::Keyframe*>& keyframes,
    const std::optional<CoarsePose>& coarse) const {
  const double sector_rad = 2.0 * kPi / descriptor_.sectors;
  std::vector<InitCandidate> all;
  for (const MapIndex::Keyframe* kf : keyframes) {
    // Eq. 4: the descriptor distance, minimized over column shifts; the shift is the yaw
    // of R_candidate_query about gravity.
    const DescriptorMatch match = compare(query.descriptor, kf->descriptor);
    if (!coarse && match.distance > config_.max_descriptor_distance) {
      continue;
    }
    InitCandidate c;
    c.keyframe_id = kf->id;
    c.submap_id = kf->submap_id;
    c.descriptor_distance = match.distance;
    c.yaw_rad = match.yaw_rad;
    const double yaw = so3::yaw(kf->T_map_body.linear()) + match.yaw_rad;
    if (coarse && std::abs(so3::wrap_angle(yaw - coarse->yaw_rad)) >
                      std::max(3.0 * coarse->sigma_yaw_rad, 2.0 * sector_rad)) {
      continue;  // a heading the coarse pose rules out
    }
    c.T_map_body_guess = se3::make(rz(yaw) * query.R_level_body, kf->T_map_body.translation());
    all.push_back(c);
  }
  std::sort(all.begin(), all.end(), [](const InitCandidate& a, const InitCandidate& b) {
    return a.descriptor_distance < b.descriptor_distance;
  });
  std::vector<InitCandidate> kept;
  for (const InitCandidate& c : all) {
    if (static_cast<int>(kept.size()) >= config_.verify_candidates) {
      break;
    }
    const double spacing_m = coarse ? config_.coarse_start_spacing_m : config_.distinct_m;
    const bool seen = std::any_of(kept.begin(), kept.end(), [&](const InitCandidate& k) {
      return same_place(k.T_map_body_guess, c.T_map_body_guess, spacing_m);
    });
    if (!seen) {
      kept.push_back(c);
    }
  }
  return kept;
}

std::vector<int64_t> PoseInitializer::union_target(
    const MapIndex& index, const std::vector<Eigen::Vector3d>& positions) const {
  std::vector<int64_t> all;
  for (const Eigen::Vector3d& position : positions) {
    const std::vector<int64_t> ids =
        SubmapTargets::submaps_around(index, position, config_.target_radius_m);
    all.insert(all.end(), ids.begin(), ids.end());
  }
  std::sort(all.begin(), all.end());
  all.erase(std::unique(all.begin(), all.end()), all.end());
  return all;
}

InitResult PoseInitializer::correlative_round(
    const MapIndex& index, const Query& query, const CoarsePose& coarse,
    const std::vector<const MapIndex::Keyframe*>& keyframes, const SubmapTargets& targets) const {
  const Eigen::Vector3d position(coarse.x_m, coarse.y_m, 0.0);
  const std::vector<int64_t> ids = union_target(index, {position});
  InitResult result;
  result.method = "coarse_to_fine";
  result.missing_submaps = targets.missing(ids);
  if (asks_for_submaps(result)) {
    return result;
  }
  // The occupancy from the second stage's target (cached by the first round, usually).
  const size_t stage = std::min<size_t>(1, config_.stages.size() - 1);
  const CorrelativeSearch search(targets.target(ids, config_.stages.voxel_m[stage])->points(),
                                 config_.correlative);
  SearchWindow window;
  window.x_m = coarse.x_m;
  window.y_m = coarse.y_m;
  window.yaw_rad = coarse.yaw_rad;
  window.half_xy_m = std::min(config_.correlative_window_sigmas * coarse.sigma_xy_m,
                              config_.correlative_max_half_xy_m);
  window.half_yaw_rad = std::min(config_.correlative_window_sigmas * coarse.sigma_yaw_rad,
                                 config_.correlative_max_half_yaw_deg * kPi / 180.0);
  // The ground's height: the nearest map keyframe's.
  double nearest_m = std::numeric_limits<double>::infinity();
  for (const MapIndex::Keyframe* kf : keyframes) {
    const double d = (kf->T_map_body.translation() - position).head<2>().norm();
    if (d < nearest_m) {
      nearest_m = d;
      window.z_m = kf->T_map_body.translation().z();
    }
  }
  std::vector<InitCandidate> starts;
  for (const ScoredPose& peak :
       search.search(query.stage_points.front(), query.R_level_body, window)) {
    InitCandidate c;
    c.T_map_body_guess = peak.T_map_body;
    starts.push_back(c);
  }
  return verify(index, query, std::move(starts), targets, false);
}

void PoseInitializer::register_stages(const Query& query, Track& track, size_t first,
                                      size_t last) const {
  for (size_t s = first; s < last; ++s) {
    track.result =
        register_point_to_plane(query.stage_points[s], *track.stages[s], track.T_map_body,
                                std::nullopt, config_.stages.stage(s, config_.registration));
    track.T_map_body = track.result.T_target_source;
  }
}

void PoseInitializer::score(const Query& query, const Track& track, InitCandidate& c) const {
  const std::vector<Eigen::Vector3f>& points = query.stage_points.back();
  const RegistrationResult& result = track.result;
  c.verified = true;
  c.T_map_body = track.T_map_body;
  c.fitness_m = result.rms_residual_m;
  c.overlap = points.empty() ? 0.0 : static_cast<double>(result.correspondences) / points.size();
  c.degenerate = result.degenerate;
  const VoxelHashMap& finest = *track.stages.back();
  const float inlier_m = static_cast<float>(config_.inlier_m);
  const Eigen::Isometry3f T = track.T_map_body.cast<float>();
  size_t inliers = 0;
  for (const Eigen::Vector3f& p : points) {
    inliers += finest.nearest<1>(T * p, inlier_m).count > 0;
  }
  c.inlier_ratio = points.empty() ? 0.0 : static_cast<double>(inliers) / points.size();
  const Matrix6d information = result.independent_information(config_.independent_correspondences);
  Matrix6d covariance = Matrix6d::Identity();
  if (information.allFinite() && information.determinant() > 0.0) {
    covariance = information.inverse();
  }
  c.covariance = 0.5 * (covariance + covariance.transpose());
}

void PoseInitializer::polish(const Query& query, Track& track, InitCandidate& c) const {
  // The weakest horizontal direction of the translation's information (body frame).
  const Eigen::Matrix2d info_xy = track.result.information.topLeftCorner<2, 2>();
  if (!info_xy.allFinite()) {
    return;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(info_xy);
  const Eigen::Vector3d weak_body(eigen.eigenvectors()(0, 0), eigen.eigenvectors()(1, 0), 0.0);
  for (const double offset_m : config_.polish_offsets_m) {
    for (const double sign : {-1.0, 1.0}) {
      Track shifted = track;
      shifted.T_map_body.translate(sign * offset_m * weak_body);
      register_stages(query, shifted, std::min<size_t>(1, shifted.stages.size() - 1),
                      shifted.stages.size());
      InitCandidate trial = c;
      score(query, shifted, trial);
      if (trial.inlier_ratio > c.inlier_ratio + config_.polish_min_gain) {
        c = trial;
        track = shifted;
      }
    }
  }
}

InitResult PoseInitializer::verify(const MapIndex& index, const Query& query,
                                   std::vector<InitCandidate> candidates,
                                   const SubmapTargets& targets, bool global) const {
  InitResult result;
  result.method = global ? "global" : "coarse_to_fine";
  // Global: each candidate's own place. Coarse-to-fine: one target for all, the union of
  // theirs, so that starts converging to the same pose can be told and merged.
  std::vector<std::vector<int64_t>> target_ids;
  if (global) {
    for (const InitCandidate& c : candidates) {
      target_ids.push_back(union_target(index, {c.T_map_body_guess.translation()}));
    }
  } else if (!candidates.empty()) {
    std::vector<Eigen::Vector3d> positions;
    for (const InitCandidate& c : candidates) {
      positions.push_back(c.T_map_body_guess.translation());
    }
    target_ids.assign(candidates.size(), union_target(index, positions));
  }
  for (const std::vector<int64_t>& ids : target_ids) {
    for (const int64_t id : targets.missing(ids)) {
      if (std::find(result.missing_submaps.begin(), result.missing_submaps.end(), id) ==
          result.missing_submaps.end()) {
        result.missing_submaps.push_back(id);
      }
    }
  }
  if (asks_for_submaps(result)) {
    result.candidates = std::move(candidates);
    return result;
  }
  const Stopwatch targets_watch;
  std::vector<Track> tracks(candidates.size());
  for (size_t i = 0; i < candidates.size(); ++i) {
    // The finest stage first: the coarser ones are made of its points.
    tracks[i].stages.resize(config_.stages.size());
    for (size_t s = config_.stages.size(); s-- > 0;) {
      tracks[i].stages[s] = targets.target(target_ids[i], config_.stages.voxel_m[s]);
    }
    tracks[i].T_map_body = candidates[i].T_map_body_guess;
  }
  result.targets_ms = targets_watch.ms();
  const Stopwatch registration_watch;
  // Stage by stage; a start that reaches a better-ranked start's pose goes no further.
  std::vector<size_t> active(candidates.size());
  std::iota(active.begin(), active.end(), 0);
  for (size_t s = 0; s < config_.stages.size(); ++s) {
    std::vector<size_t> kept;
    for (const size_t i : active) {
      Track& track = tracks[i];
      register_stages(query, track, s, s + 1);
      const auto same = std::find_if(kept.begin(), kept.end(), [&](size_t k) {
        return target_ids[k] == target_ids[i] &&
               (tracks[k].T_map_body.translation() - track.T_map_body.translation()).norm() <
                   kSameConvergedM &&
               se3::rotation_angle(tracks[k].T_map_body.inverse() * track.T_map_body) <
                   kSameConvergedRad;
      });
      if (same == kept.end()) {
        kept.push_back(i);
      } else {
        candidates[i].rejected =
            "converged with the start of keyframe " + std::to_string(candidates[*same].keyframe_id);
      }
    }
    active = std::move(kept);
  }
  for (const size_t i : active) {
    score(query, tracks[i], candidates[i]);
  }
  if (!active.empty()) {
    const size_t best = *std::max_element(active.begin(), active.end(), [&](size_t a, size_t b) {
      return candidates[a].inlier_ratio < candidates[b].inlier_ratio;
    });
    if (candidates[best].inlier_ratio < config_.polish_below_inlier_ratio) {
      polish(query, tracks[best], candidates[best]);
    }
  }
  result.registration_ms = registration_watch.ms();
  for (const size_t i : active) {
    InitCandidate& c = candidates[i];
    // A degenerate registration's position along its weak axis is not the map's answer:
    // the coarse pose's looser bound does not apply (bench_init --calibrate: a Mid-360 start
    // 8 m along a street, degenerate, 0.62 inliers; no right pose was degenerate).
    const double min_inlier_ratio =
        global || c.degenerate ? config_.min_inlier_ratio : config_.min_inlier_ratio_coarse;
    if (c.inlier_ratio < min_inlier_ratio) {
      c.rejected = "inlier ratio " + std::to_string(c.inlier_ratio) + " below " +
                   std::to_string(min_inlier_ratio);
    } else if (c.fitness_m > config_.max_fitness_m) {
      c.rejected = "fitness " + std::to_string(c.fitness_m) + " m above " +
                   std::to_string(config_.max_fitness_m);
    }
  }
  // The answer: the passing candidate with the most inliers.
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const InitCandidate& a, const InitCandidate& b) {
                     if (a.rejected.empty() != b.rejected.empty()) {
                       return a.rejected.empty();
                     }
                     return a.inlier_ratio > b.inlier_ratio;
                   });
  if (candidates.empty() || !candidates.front().rejected.empty()) {
    const std::string none =
        global ? "no map keyframe's descriptor is within " +
                     std::to_string(config_.max_descriptor_distance) + " of the query's"
               : "no map keyframe near the coarse pose with a heading it allows";
    result.reason = candidates.empty()
                        ? none
                        : "no candidate passed verification: best " + describe(candidates.front()) +
                              ": " + candidates.front().rejected;
    result.candidates = std::move(candidates);
    return result;
  }
  InitCandidate& best = candidates.front();
  {
    // The best distinct alternative, verified: it must clearly lose. (Coarse-to-fine: two
    // starts that converged apart along a street of repeating facades.)
    const double distinct_m = global ? config_.distinct_m : config_.coarse_distinct_m;
    for (size_t i = 1; i < candidates.size(); ++i) {
      InitCandidate& other = candidates[i];
      if (!other.verified || same_place(other.T_map_body, best.T_map_body, distinct_m)) {
        continue;
      }
      if (other.inlier_ratio > config_.max_alternative_ratio * best.inlier_ratio) {
        result.reason = "ambiguous: " + describe(best) + " and " + describe(other);
        best.rejected = other.rejected = kAmbiguous;
        result.candidates = std::move(candidates);
        return result;
      }
      break;
    }
  }
  for (size_t i = 1; i < candidates.size(); ++i) {
    if (candidates[i].rejected.empty()) {
      candidates[i].rejected = "fewer inliers than the answer";
    }
  }
  result.status = InitResult::Status::kLocalized;
  result.reason = "localized at " + describe(best);
  result.best = best;
  result.candidates = std::move(candidates);
  return result;
}

InitResult PoseInitializer::coarse_to_fine(const MapIndex& index, const InitQuery& query,
                                           const CoarsePose& coarse,
                                           const SubmapTargets& targets) const {
  const Stopwatch watch;
  const Query q = prepare(query);
  // The submaps around the coarse position (Tree_m), then their keyframes.
  const Eigen::Vector3d position(coarse.x_m, coarse.y_m, 0.0);
  const double radius = std::max(config_.search_radius_m, 3.0 * coarse.sigma_xy_m + 10.0);
  std::vector<KdTree::Hit> submaps = index.submaps().submaps_within(position, radius);
  if (submaps.empty()) {
    submaps = index.submaps().nearest_submaps(position, 1);
  }
  if (static_cast<int>(submaps.size()) > config_.max_search_submaps) {
    submaps.resize(static_cast<size_t>(config_.max_search_submaps));
  }
  std::vector<const MapIndex::Keyframe*> keyframes;
  for (const MapIndex::Keyframe& kf : index.keyframes()) {
    const bool in_submap = std::any_of(submaps.begin(), submaps.end(),
                                       [&](const KdTree::Hit& h) { return h.id == kf.submap_id; });
    if (in_submap && (kf.T_map_body.translation() - position).head<2>().norm() <= radius) {
      keyframes.push_back(&kf);
    }
  }
  InitResult result = verify(index, q, rank(q, keyframes, coarse), targets, false);
  const bool ambiguous =
      std::any_of(result.candidates.begin(), result.candidates.end(),
                  [](const InitCandidate& c) { return c.rejected == kAmbiguous; });
  const bool weak =
      result.localized() && result.best->inlier_ratio < config_.correlative_below_inlier_ratio;
  if ((result.status == InitResult::Status::kNotLocalized && !ambiguous) || weak) {
    result = merge_coarse_rounds(std::move(result),
                                 correlative_round(index, q, coarse, keyframes, targets), config_);
  }
  result.time_ms = watch.ms();
  return result;
}

InitResult PoseInitializer::global(const MapIndex& index, const InitQuery& query,
                                   const SubmapTargets& targets) const {
  const Stopwatch watch;
  const Query q = prepare(query);
  // Every keyframe ranked by its retrieval key's distance to the query's; the best
  // retrieval_candidates go on to the descriptor's distance.
  const std::vector<float> key = retrieval_key(q.descriptor);
  std::vector<std::pair<float, const MapIndex::Keyframe*>> ranked;
  ranked.reserve(index.keyframes().size());
  for (const MapIndex::Keyframe& kf : index.keyframes()) {
    float d = 0.0f;
    for (size_t i = 0; i < key.size(); ++i) {
      d += (key[i] - kf.key[i]) * (key[i] - kf.key[i]);
    }
    ranked.emplace_back(d, &kf);
  }
  const size_t n = std::min(ranked.size(), static_cast<size_t>(config_.retrieval_candidates));
  std::partial_sort(ranked.begin(), ranked.begin() + static_cast<ptrdiff_t>(n), ranked.end(),
                    [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<const MapIndex::Keyframe*> keyframes;
  for (size_t i = 0; i < n; ++i) {
    keyframes.push_back(ranked[i].second);
  }
  InitResult result = verify(index, q, rank(q, keyframes, std::nullopt), targets, true);
  if (result.localized() && result.best->inlier_ratio < config_.min_inlier_ratio_alone) {
    result.status = InitResult::Status::kNotLocalized;
    result.reason = "not alone: " + describe(*result.best) + " below " +
                    std::to_string(config_.min_inlier_ratio_alone) +
                    " inliers; it votes with the next keyframes";
    result.candidates.front().rejected = kVotes;
    result.best.reset();
  }
  result.time_ms = watch.ms();
  return result;
}

InitResult PoseInitializer::refine(const MapIndex& index, const InitQuery& query,
                                   const Eigen::Isometry3d& T_map_body_guess,
                                   const SubmapTargets& targets) const {
  const Stopwatch watch;
  InitCandidate c;
  c.T_map_body_guess = T_map_body_guess;
  InitResult result = verify(index, prepare(query), {c}, targets, false);
  result.time_ms = watch.ms();
  return result;
}

InitAnswer answer_of(const InitResult& result, const InitQuery& query) {
  InitAnswer a;
  a.localized = result.localized();
  a.method = result.method;
  a.message = result.reason;
  a.keyframe_id = query.keyframe_id;
  a.utime_us = query.utime_us;
  a.time_ms = result.time_ms;
  const InitCandidate* c = result.best
                               ? &*result.best
                               : (result.candidates.empty() ? nullptr : &result.candidates.front());
  if (c != nullptr) {
    a.T_map_body = c->verified ? c->T_map_body : c->T_map_body_guess;
    a.covariance = c->covariance;
    a.fitness_m = c->fitness_m;
    a.descriptor_distance = c->descriptor_distance;
    a.matched_submap_id = c->submap_id;
    a.matched_keyframe_id = c->keyframe_id;
  }
  return a;
}

std::optional<Eigen::Isometry3d> HypothesisVoter::add(
    const InitQuery& query, const std::vector<InitCandidate>& candidates) {
  std::vector<Eigen::Isometry3d> hypotheses;
  for (const InitCandidate& c : candidates) {
    if (c.verified && (c.rejected.empty() || c.rejected == kAmbiguous || c.rejected == kVotes)) {
      hypotheses.push_back(c.T_map_body * query.T_odom_body.inverse());
    }
  }
  keyframes_.push_back(std::move(hypotheses));
  while (static_cast<int>(keyframes_.size()) > config_.max_keyframes) {
    keyframes_.pop_front();
  }
  const auto agree = [&](const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
    return (a.translation() - b.translation()).norm() <= config_.agree_m &&
           se3::rotation_angle(a.inverse() * b) <= config_.agree_rad;
  };
  // Keyframes with a hypothesis that agrees with h.
  const auto support = [&](const Eigen::Isometry3d& h) {
    int votes = 0;
    for (const std::vector<Eigen::Isometry3d>& keyframe : keyframes_) {
      votes += std::any_of(keyframe.begin(), keyframe.end(),
                           [&](const Eigen::Isometry3d& g) { return agree(g, h); });
    }
    return votes;
  };
  for (const Eigen::Isometry3d& h : keyframes_.back()) {
    if (support(h) < config_.votes_needed) {
      continue;
    }
    bool rival = false;
    for (const std::vector<Eigen::Isometry3d>& keyframe : keyframes_) {
      for (const Eigen::Isometry3d& g : keyframe) {
        rival = rival || (!agree(g, h) && support(g) >= config_.votes_needed);
      }
    }
    if (!rival) {
      return h;
    }
  }
  return std::nullopt;
}

std::string HypothesisVoter::summary() const {
  size_t hypotheses = 0;
  for (const auto& keyframe : keyframes_) {
    hypotheses += keyframe.size();
  }
  return std::to_string(keyframes_.size()) + " keyframe(s) voting, " + std::to_string(hypotheses) +
         " hypotheses";
}

InitResult merge_coarse_rounds(InitResult first, InitResult second,
                               const InitializerConfig& config) {
  const auto keep = [](InitResult& answer, InitResult& other) {
    answer.candidates.insert(answer.candidates.end(),
                             std::make_move_iterator(other.candidates.begin()),
                             std::make_move_iterator(other.candidates.end()));
    answer.targets_ms += other.targets_ms;
    answer.registration_ms += other.registration_ms;
    return std::move(answer);
  };
  if (second.status == InitResult::Status::kNeedsSubmaps) {
    return keep(second, first);  // asked again when they are there
  }
  if (first.localized() &&
      !(second.localized() && second.best->inlier_ratio > first.best->inlier_ratio)) {
    // Every unmarked one: an ambiguous round leaves the candidates between its two places
    // unmarked, not only its best.
    for (InitCandidate& c : second.candidates) {
      if (c.rejected.empty()) {
        c.rejected = "fewer inliers than the answer";
      }
    }
    return keep(first, second);
  }
  if (first.localized()) {
    // Both rounds answered and the search's has more inliers: where the two are distinct
    // places, the other must clearly lose, as within a round.
    if (!same_place(first.best->T_map_body, second.best->T_map_body, config.coarse_distinct_m) &&
        first.best->inlier_ratio > config.max_alternative_ratio * second.best->inlier_ratio) {
      second.status = InitResult::Status::kNotLocalized;
      second.reason = "ambiguous: " + describe(*second.best) + " and " + describe(*first.best);
      for (InitCandidate* c : {&second.candidates.front(), &first.candidates.front()}) {
        c->rejected = kAmbiguous;
      }
      second.best.reset();
      return keep(second, first);
    }
    first.candidates.front().rejected = "fewer inliers than the answer";
  }
  if (second.status == InitResult::Status::kNotLocalized) {
    second.reason = "from the map's keyframes: " + first.reason +
                    "; from a correlative search: " + second.reason;
  } else if (second.localized()) {
    second.reason = "localized from a correlative search at " + describe(*second.best);
  }
  return keep(second, first);
}

}  // namespace liloc
