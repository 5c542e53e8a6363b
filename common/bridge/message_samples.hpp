#pragma once
// One example of every liloc message type, with every field set to a distinct, valid
// value: the fixtures of the round-trip tests and of `liloc_log sample`, which writes
// them to a log for checking lcm-logplayer and lcm-spy. Add a sample with each new type
// (LILOC_FOR_EACH_LCM_TYPE makes the tests fail to compile without one).

#include <string>
#include <type_traits>

#include "liloc/all_types.hpp"

namespace liloc::bridge {

// True for the message types that carry a header_t (all but nested parts).
template <class T, class = void>
struct HasHeader : std::false_type {};
template <class T>
struct HasHeader<T, std::void_t<decltype(std::declval<T&>().header.seq)>> : std::true_type {};

template <class Msg>
Msg make_sample(const std::string& robot_id);

#define LILOC_DECLARE_SAMPLE(type) \
  template <>                      \
  liloc::type make_sample<liloc::type>(const std::string& robot_id);
LILOC_FOR_EACH_LCM_TYPE(LILOC_DECLARE_SAMPLE)
#undef LILOC_DECLARE_SAMPLE

}  // namespace liloc::bridge
