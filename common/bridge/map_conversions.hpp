#pragma once
// Messages of the map server (requests, submap replies, updates, map info) <-> the map
// service's core types. Input from the wire is checked: non-finite poses and cloud
// offsets that do not fit the cloud are rejected with std::invalid_argument.

#include <memory>
#include <optional>
#include <string>

#include "liloc/descriptor_request_t.hpp"
#include "liloc/keyframe_descriptors_t.hpp"
#include "liloc/map_info_t.hpp"
#include "liloc/map_update_t.hpp"
#include "liloc/submap_request_t.hpp"
#include "liloc/submap_t.hpp"
#include "map_service/map_service.hpp"

namespace liloc::bridge {

SubmapQuery from_msg(const liloc::submap_request_t& msg);
liloc::submap_request_t to_msg(const SubmapQuery& query, int64_t utime);

liloc::submap_t to_msg(const SubmapReplyPart& part, int64_t utime);
SubmapReplyPart from_msg(const liloc::submap_t& msg);

MapUpdatePart from_msg(const liloc::map_update_t& msg);
liloc::map_update_t to_msg(const MapUpdatePart& part, int64_t utime);

// A MAP.UPDATE chunk as it arrived: its content, or, when it does not convert, its identity
// and why (for the rejection's counters and log).
struct ReceivedMapUpdate {
  std::optional<MapUpdatePart> part;
  std::string robot_id, session_id;
  int64_t update_id = 0;
  std::string malformed;
};
ReceivedMapUpdate receive_update(const liloc::map_update_t& msg);

liloc::map_info_t to_msg(const MapData& map, const MapServiceCounters& counters, int64_t utime);
// The map's version, id and submaps (id, centroid, bounds, session), no keyframes. Throws
// std::invalid_argument for a non-finite centroid or bounds.
MapData from_msg(const liloc::map_info_t& msg);

// A request for the map's keyframe index, and who asked for which.
struct DescriptorRequest {
  std::string robot_id;
  int64_t request_id = 0;
  int64_t utime_us = 0;
};
liloc::descriptor_request_t to_msg(const DescriptorRequest& request);
DescriptorRequest from_msg(const liloc::descriptor_request_t& msg);

liloc::keyframe_descriptors_t to_msg(const KeyframeIndexPart& part, int64_t utime);
// Throws std::invalid_argument for a non-finite pose or offsets that do not fit the bytes.
KeyframeIndexPart from_msg(const liloc::keyframe_descriptors_t& msg);

}  // namespace liloc::bridge
