#include "bridge/map_conversions.hpp"

#include <cmath>
#include <stdexcept>

#include "bridge/lcm_conversions.hpp"

namespace liloc::bridge {
namespace {

// Map updates: full clouds one after another; offsets[k] is where cloud k starts.
liloc::point_cloud_t concatenate(const std::vector<std::shared_ptr<const PointCloud>>& clouds,
                                 std::vector<int32_t>& offsets) {
  PointCloud all;
  for (const auto& c : clouds) {
    offsets.push_back(static_cast<int32_t>(all.size()));
    all.points.insert(all.points.end(), c->points.begin(), c->points.end());
    all.intensities.insert(all.intensities.end(), c->intensities.begin(), c->intensities.end());
  }
  return to_msg(all);
}

// Splits a concatenated cloud by offsets; throws if they do not fit.
std::vector<PointCloud> split(const liloc::point_cloud_t& cloud,
                              const std::vector<int32_t>& offsets) {
  std::vector<PointCloud> out;
  for (size_t i = 0; i < offsets.size(); ++i) {
    const int32_t begin = offsets[i];
    const int32_t end = i + 1 < offsets.size() ? offsets[i + 1] : cloud.num_points;
    if (begin < 0 || end < begin || end > cloud.num_points) {
      throw std::invalid_argument("cloud_offsets do not fit the cloud of " +
                                  std::to_string(cloud.num_points) + " points");
    }
    PointCloud c;
    for (int32_t k = begin; k < end; ++k) {
      const Eigen::Vector3f p(cloud.x[k], cloud.y[k], cloud.z[k]);
      if (p.allFinite()) {
        c.push_back(p, std::isfinite(cloud.intensity[k]) ? cloud.intensity[k] : 0.0f);
      }
    }
    out.push_back(std::move(c));
  }
  return out;
}

void put_bounds(const BoundsXY& b, double (&out)[4]) {
  out[0] = b.min_x;
  out[1] = b.max_x;
  out[2] = b.min_y;
  out[3] = b.max_y;
}

BoundsXY get_bounds(const double (&in)[4]) { return {in[0], in[1], in[2], in[3]}; }
}  // namespace

SubmapQuery from_msg(const liloc::submap_request_t& msg) {
  SubmapQuery q;
  q.robot_id = msg.header.robot_id;
  q.request_id = msg.request_id;
  q.by_id = msg.query == liloc::submap_request_t::QUERY_BY_ID;
  q.position = Eigen::Vector3d(msg.position[0], msg.position[1], msg.position[2]);
  if (!q.by_id && !q.position.allFinite()) {
    throw std::invalid_argument("submap request: non-finite position");
  }
  q.radius_m = std::isfinite(msg.radius_m) ? std::max(0.0, msg.radius_m) : 0.0;
  q.max_submaps = msg.max_submaps;
  q.submap_ids = msg.submap_ids;
  q.include_clouds = msg.include_clouds;
  q.reply_url = msg.reply_url;
  return q;
}

liloc::submap_request_t to_msg(const SubmapQuery& q, int64_t utime) {
  liloc::submap_request_t msg;
  msg.header = make_header(utime, q.robot_id, "map");
  msg.request_id = q.request_id;
  msg.query =
      q.by_id ? liloc::submap_request_t::QUERY_BY_ID : liloc::submap_request_t::QUERY_BY_POSITION;
  for (int i = 0; i < 3; ++i) {
    msg.position[i] = q.position[i];
  }
  msg.radius_m = q.radius_m;
  msg.max_submaps = q.max_submaps;
  msg.submap_ids = q.submap_ids;
  msg.num_ids = static_cast<int32_t>(q.submap_ids.size());
  msg.include_clouds = q.include_clouds;
  msg.reply_url = q.reply_url;
  return msg;
}

liloc::submap_t to_msg(const SubmapReplyPart& part, int64_t utime) {
  liloc::submap_t msg;
  msg.header = make_header(utime, part.robot_id, "map");
  msg.request_id = part.request_id;
  msg.reply_index = part.reply_index;
  msg.reply_count = part.reply_count;
  msg.map_version = part.map_version;
  msg.submap_id = part.submap ? part.submap->id : -1;
  msg.chunk_index = part.chunk_index;
  msg.num_chunks = part.num_chunks;
  msg.submap_num_keyframes =
      part.submap ? static_cast<int32_t>(part.submap->keyframe_ids.size()) : 0;
  const Eigen::Vector3d centroid = part.submap ? part.submap->centroid : Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i) {
    msg.centroid[i] = centroid[i];
  }
  put_bounds(part.submap ? part.submap->bounds : BoundsXY{}, msg.bounds_xy);
  msg.num_keyframes = static_cast<int32_t>(part.keyframes.size());
  for (const MapKeyframe& kf : part.keyframes) {
    msg.keyframe_ids.push_back(kf.id);
    msg.keyframe_poses.push_back(to_msg(kf.T_map_body));
    msg.keyframe_fitness.push_back(static_cast<float>(kf.fitness_m));
  }
  if (part.clouds) {
    if (part.clouds->keyframes() != part.keyframes.size()) {
      throw std::invalid_argument("reply part: clouds of " +
                                  std::to_string(part.clouds->keyframes()) + " keyframes for " +
                                  std::to_string(part.keyframes.size()));
    }
    msg.cloud_offsets.assign(part.clouds->offsets.begin(), part.clouds->offsets.end() - 1);
    msg.cloud = to_msg(part.clouds->cloud);
  } else {
    // No clouds asked for: step 0 tells it from clouds that happen to have no points.
    msg.cloud_offsets.assign(part.keyframes.size(), 0);
    msg.cloud = to_msg(CompactCloud{});
    msg.cloud.resolution_m = 0.0f;
    msg.cloud.intensity_scale = 0.0f;
  }
  return msg;
}

SubmapReplyPart from_msg(const liloc::submap_t& msg) {
  SubmapReplyPart part;
  part.robot_id = msg.header.robot_id;
  part.request_id = msg.request_id;
  part.reply_index = msg.reply_index;
  part.reply_count = msg.reply_count;
  part.map_version = msg.map_version;
  part.chunk_index = msg.chunk_index;
  part.num_chunks = msg.num_chunks;
  if (msg.submap_id >= 0) {
    Submap s;
    s.id = msg.submap_id;
    s.centroid = Eigen::Vector3d(msg.centroid[0], msg.centroid[1], msg.centroid[2]);
    s.bounds = get_bounds(msg.bounds_xy);
    part.submap = s;
  }
  for (int32_t i = 0; i < msg.num_keyframes; ++i) {
    MapKeyframe kf;
    kf.id = msg.keyframe_ids[i];
    kf.T_map_body = from_msg(msg.keyframe_poses[i]);
    kf.fitness_m = msg.keyframe_fitness[i];
    kf.submap_id = msg.submap_id;
    part.keyframes.push_back(kf);
    if (part.submap) {
      part.submap->keyframe_ids.push_back(kf.id);
    }
  }
  if (msg.cloud.resolution_m != 0.0f || msg.cloud.num_points != 0) {
    SubmapClouds clouds;
    clouds.cloud = from_msg(msg.cloud);
    clouds.offsets.assign(msg.cloud_offsets.begin(), msg.cloud_offsets.end());
    clouds.offsets.push_back(static_cast<uint32_t>(clouds.cloud.size()));
    bool fit = msg.cloud_offsets.empty() || msg.cloud_offsets.front() == 0;
    for (size_t k = 0; k < msg.cloud_offsets.size(); ++k) {
      fit = fit && msg.cloud_offsets[k] >= 0 && clouds.offsets[k] <= clouds.offsets[k + 1];
    }
    if (!fit) {
      throw std::invalid_argument("cloud_offsets do not fit the cloud of " +
                                  std::to_string(clouds.cloud.size()) + " points");
    }
    part.clouds = std::move(clouds);
  }
  return part;
}

MapUpdatePart from_msg(const liloc::map_update_t& msg) {
  MapUpdatePart part;
  part.robot_id = msg.header.robot_id;
  part.session_id = msg.session_id;
  part.update_id = msg.update_id;
  part.chunk_index = msg.chunk_index;
  part.num_chunks = msg.num_chunks;
  part.base_map_version = msg.base_map_version;
  std::vector<PointCloud> clouds = split(msg.cloud, msg.cloud_offsets);
  for (int32_t i = 0; i < msg.num_keyframes; ++i) {
    UpdateKeyframe kf;
    kf.sender_keyframe_id = msg.keyframe_ids[i];
    kf.utime_us = msg.keyframe_utimes[i];
    kf.T_map_body = from_msg(msg.keyframe_poses[i]);  // throws on a non-finite pose
    kf.fitness_m = msg.keyframe_fitness[i];
    kf.cloud_body = std::move(clouds[i]);
    part.keyframes.push_back(std::move(kf));
  }
  return part;
}

liloc::map_update_t to_msg(const MapUpdatePart& part, int64_t utime) {
  liloc::map_update_t msg;
  msg.header = make_header(utime, part.robot_id, "map");
  msg.session_id = part.session_id;
  msg.update_id = part.update_id;
  msg.chunk_index = part.chunk_index;
  msg.num_chunks = part.num_chunks;
  msg.base_map_version = part.base_map_version;
  msg.num_keyframes = static_cast<int32_t>(part.keyframes.size());
  std::vector<std::shared_ptr<const PointCloud>> clouds;
  for (const UpdateKeyframe& kf : part.keyframes) {
    msg.keyframe_ids.push_back(kf.sender_keyframe_id);
    msg.keyframe_utimes.push_back(kf.utime_us);
    msg.keyframe_poses.push_back(to_msg(kf.T_map_body));
    msg.keyframe_fitness.push_back(static_cast<float>(kf.fitness_m));
    clouds.push_back(std::shared_ptr<const PointCloud>(&kf.cloud_body, [](const PointCloud*) {}));
  }
  msg.cloud = concatenate(clouds, msg.cloud_offsets);
  return msg;
}

liloc::map_info_t to_msg(const MapData& map, const MapServiceCounters& counters, int64_t utime) {
  liloc::map_info_t msg;
  msg.header = make_header(utime, "map_server", "map");
  msg.map_id = map.map_id;
  msg.map_version = map.version;
  msg.num_keyframes = static_cast<int64_t>(map.keyframes.size());
  msg.updates_merged = counters.updates_merged;
  msg.updates_rejected = counters.updates_rejected + counters.updates_expired;
  for (const Submap& s : map.submaps) {
    liloc::submap_info_t info;
    info.submap_id = s.id;
    info.num_keyframes = static_cast<int32_t>(s.keyframe_ids.size());
    for (int i = 0; i < 3; ++i) {
      info.centroid[i] = s.centroid[i];
    }
    put_bounds(s.bounds, info.bounds_xy);
    info.source_session = s.source_session;
    msg.submaps.push_back(info);
  }
  msg.num_submaps = static_cast<int32_t>(msg.submaps.size());
  return msg;
}

ReceivedMapUpdate receive_update(const liloc::map_update_t& msg) {
  ReceivedMapUpdate received;
  received.robot_id = msg.header.robot_id;
  received.session_id = msg.session_id;
  received.update_id = msg.update_id;
  try {
    received.part = from_msg(msg);
  } catch (const std::invalid_argument& e) {
    received.malformed = e.what();
  }
  return received;
}

MapData from_msg(const liloc::map_info_t& msg) {
  MapData map;
  map.map_id = msg.map_id;
  map.version = msg.map_version;
  for (const liloc::submap_info_t& info : msg.submaps) {
    Submap s;
    s.id = info.submap_id;
    s.centroid = Eigen::Vector3d(info.centroid[0], info.centroid[1], info.centroid[2]);
    s.bounds = get_bounds(info.bounds_xy);
    s.source_session = info.source_session;
    const bool finite_bounds = std::isfinite(s.bounds.min_x) && std::isfinite(s.bounds.max_x) &&
                               std::isfinite(s.bounds.min_y) && std::isfinite(s.bounds.max_y);
    if (!s.centroid.allFinite() || !finite_bounds) {
      throw std::invalid_argument("map info: submap " + std::to_string(s.id) +
                                  " has a non-finite centroid or bounds");
    }
    map.submaps.push_back(s);
  }
  return map;
}

liloc::descriptor_request_t to_msg(const DescriptorRequest& request) {
  liloc::descriptor_request_t msg;
  msg.header = make_header(request.utime_us, request.robot_id, "map");
  msg.request_id = request.request_id;
  return msg;
}

DescriptorRequest from_msg(const liloc::descriptor_request_t& msg) {
  return {msg.header.robot_id, msg.request_id, msg.header.utime};
}

liloc::keyframe_descriptors_t to_msg(const KeyframeIndexPart& part, int64_t utime) {
  liloc::keyframe_descriptors_t msg;
  msg.header = make_header(utime, part.robot_id, "map");
  msg.request_id = part.request_id;
  msg.map_version = part.map_version;
  msg.chunk_index = part.chunk_index;
  msg.num_chunks = part.num_chunks;
  for (const IndexedKeyframe& kf : part.keyframes) {
    msg.keyframe_ids.push_back(kf.id);
    msg.submap_ids.push_back(kf.submap_id);
    msg.keyframe_poses.push_back(to_msg(kf.T_map_body));
    msg.descriptor_offsets.push_back(static_cast<int32_t>(msg.descriptors.size()));
    msg.descriptors.insert(msg.descriptors.end(), kf.descriptor->begin(), kf.descriptor->end());
  }
  msg.num_keyframes = static_cast<int32_t>(part.keyframes.size());
  msg.num_bytes = static_cast<int32_t>(msg.descriptors.size());
  return msg;
}

KeyframeIndexPart from_msg(const liloc::keyframe_descriptors_t& msg) {
  KeyframeIndexPart part;
  part.robot_id = msg.header.robot_id;
  part.request_id = msg.request_id;
  part.map_version = msg.map_version;
  part.chunk_index = msg.chunk_index;
  part.num_chunks = msg.num_chunks;
  for (int32_t i = 0; i < msg.num_keyframes; ++i) {
    const int32_t begin = msg.descriptor_offsets[i];
    const int32_t end = i + 1 < msg.num_keyframes ? msg.descriptor_offsets[i + 1] : msg.num_bytes;
    if (begin < 0 || end < begin || end > msg.num_bytes) {
      throw std::invalid_argument("keyframe descriptors: offsets do not fit the " +
                                  std::to_string(msg.num_bytes) + " bytes");
    }
    IndexedKeyframe kf;
    kf.id = msg.keyframe_ids[i];
    kf.submap_id = msg.submap_ids[i];
    kf.T_map_body = from_msg(msg.keyframe_poses[i]);  // throws for a non-finite pose
    kf.descriptor = std::make_shared<const std::vector<uint8_t>>(msg.descriptors.begin() + begin,
                                                                 msg.descriptors.begin() + end);
    part.keyframes.push_back(std::move(kf));
  }
  return part;
}

}  // namespace liloc::bridge
