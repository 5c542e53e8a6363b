#pragma once
// Messages of the map server (requests, submap replies, updates, map info) <-> the map
// service's core types. Input from the wire is checked: non-finite poses and cloud
// offsets that do not fit the cloud are rejected with std::invalid_argument.

#include <memory>
#include <string>

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

liloc::map_info_t to_msg(const MapData& map, const MapServiceCounters& counters, int64_t utime);

liloc::keyframe_descriptors_t to_msg(const KeyframeIndexPart& part, int64_t utime);
// Throws std::invalid_argument for a non-finite pose or offsets that do not fit the bytes.
KeyframeIndexPart from_msg(const liloc::keyframe_descriptors_t& msg);

}  // namespace liloc::bridge
