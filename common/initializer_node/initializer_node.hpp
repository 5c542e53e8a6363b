#pragma once
// The initializer process's logic (docs/initialization.md): a robot's pose in the map
// frame, from its keyframes and the map server.
//   in:  <robot>.KEYFRAME, <robot>.COARSE_POSE (a coarse pose, or a request to
//        re-initialize: a huge covariance asks for a global search), MAP.INFO, and on the
//        robot's reply route <robot>.DESCRIPTORS and <robot>.SUBMAP
//   out: <robot>.INIT, <robot>.STATUS.initializer, MAP.DESCRIPTOR_REQUEST, MAP.REQUEST
// The map's keyframe index and the submaps a search needs come through a MapClient, which
// asks again for what is not answered, so it keeps working when the server starts after it
// or restarts; its status says what it waits for.

#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "descriptor/polar_descriptor.hpp"
#include "initializer/pose_initializer.hpp"
#include "map_client/map_client.hpp"
#include "node/node.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {

struct InitializerProcessConfig {
  // Initialize from the first keyframes when no coarse pose came (global search); false:
  // only when asked (a COARSE_POSE).
  bool global_without_coarse = true;
  // A coarse pose with a position sigma above this asks for a global search.
  double global_sigma_xy_m = 500.0;
  double request_period_s = 2.0;  // requests not answered by then are sent again
  double status_period_s = 1.0;
  int max_cached_submaps = 64;  // submaps' points kept (least recently received out)
  InitializerConfig search;
  HypothesisVoter::Config voting;

  template <class V>
  void visit_fields(V& v) {
    v("global_without_coarse", global_without_coarse);
    v("global_sigma_xy_m", global_sigma_xy_m);
    v("request_period_s", request_period_s);
    v("status_period_s", status_period_s);
    v("max_cached_submaps", max_cached_submaps);
    v("search", search);
  }
  void validate() const;
};

// The sections of the system config the initializer node reads.
struct InitializerNodeConfig {
  transport::ChannelConfig channels;
  PolarDescriptorConfig descriptor;
  InitializerProcessConfig initializer;

  template <class V>
  void visit_fields(V& v) {
    v("channels", channels);
    v("descriptor", descriptor);
    v("initializer", initializer);
  }
};

class InitializerNode final : public node::Node {
 public:
  InitializerNode(transport::Transport& bus, const std::string& robot_id,
                  const InitializerNodeConfig& config);

  std::string name() const override { return "initializer"; }
  // Requests not answered in time go again; status.
  void tick(int64_t now_us) override;
  std::vector<transport::Transport*> own_transports() override;

  struct Counters {
    int64_t keyframes = 0;
    int64_t attempts = 0;  // searches run to an answer
    int64_t localized = 0;
    int64_t not_localized = 0;
    int64_t rejected_messages = 0;  // that did not convert (non-finite poses, bad offsets)
  };
  const Counters& counters() const { return counters_; }
  const MapClient& map() const { return map_; }

 private:
  // Each message converted to its core type at the door (bridge/); what does not convert is
  // counted in rejected_messages.
  void on_keyframe(InitQuery query);
  void on_coarse_pose(const CoarsePose& coarse);
  // Runs a search on the newest keyframe if one is wanted and everything it needs is here.
  void try_initialize();
  void publish(const InitAnswer& answer);
  void publish_status(int64_t now_us);

  transport::Transport& bus_;
  std::string robot_id_;
  InitializerNodeConfig config_;
  PoseInitializer initializer_;
  HypothesisVoter voter_;
  MapClient map_;
  std::string init_channel_, status_channel_;

  bool wanted_ = true;  // an initialization is asked for
  std::optional<CoarsePose> coarse_;
  bool global_asked_ = false;        // a COARSE_POSE asked for a global search
  std::deque<InitQuery> keyframes_;  // the newest last

  Counters counters_;
  std::string state_;  // what it does or waits for, for the status
  int64_t last_status_us_ = 0;
};

}  // namespace liloc
