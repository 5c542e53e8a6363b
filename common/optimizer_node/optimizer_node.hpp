#pragma once
// The optimizer process's logic (docs/optimizer.md): a robot's pose in the map frame from
// its odometry's keyframes, the initializer's answer and the map server's submaps (paper
// Algorithm 1 after line 2).
//   in:  <robot>.KEYFRAME, <robot>.ODOM, <robot>.INIT, <robot>.IMU (when the graph uses
//        IMU factors), MAP.INFO, and on the robot's reply route <robot>.DESCRIPTORS and
//        <robot>.SUBMAP
//   out: <robot>.POSE (map frame, with covariance), <robot>.STATUS.optimizer,
//        <robot>.COARSE_POSE (re-initialization when tracking is lost), MAP.UPDATE (ILM
//        stretches: the map grows), MAP.REQUEST, MAP.DESCRIPTOR_REQUEST
// An INIT that localized one of the robot's keyframes (re)starts the egocentric factor
// graph there; the keyframes after it are then optimized one by one (Localizer). POSE comes
// for every keyframe after optimization and, between keyframes, as the odometry carried by
// the latest map-from-odom, so that users get a pose at the scan rate. Tracking is lost
// after lost_after_keyframes keyframes in the mapped area (RLM) whose registration the
// gates refused in a row: the status says LOST and why, and a COARSE_POSE around the
// current estimate asks the initializer to localize again (repeated while lost, at last as a
// global search). Keyframes optimized in ILM go to the map server once their poses are
// final (MapGrowth).

#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "descriptor/polar_descriptor.hpp"
#include "imu/imu_buffer.hpp"
#include "initializer/pose_initializer.hpp"
#include "map_client/map_client.hpp"
#include "node/node.hpp"
#include "optimizer/localizer.hpp"
#include "optimizer_node/map_growth.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {

struct OptimizerProcessConfig {
  double request_period_s = 2.0;  // map server requests not answered by then go again
  double status_period_s = 1.0;
  int max_cached_submaps = 64;
  // The robot's latest keyframes kept for an INIT that names one of them (the initializer
  // answers a keyframe it searched on, a few hundred milliseconds old).
  int keep_keyframes = 100;
  // Tracking loss: this many keyframes in a row in RLM without a scan match that passed.
  int lost_after_keyframes = 10;
  // The coarse pose of a re-initialization: the current estimate with these sigmas.
  double reinit_sigma_xy_m = 5.0;
  double reinit_sigma_yaw_rad = 0.5;
  // Lost before any scan match since the start: the start itself was wrong (an initializer
  // answer metres along a street), and the estimate is no place to search around. The
  // coarse pose then carries this sigma, above the initializer's global_sigma_xy_m (500 m),
  // which asks it for a global search.
  double reinit_global_sigma_xy_m = 1000.0;
  // While lost, the request goes again every reinit_repeat_keyframes keyframes, around the
  // estimate then (the robot drove on from where the first request placed it, and a request
  // can be lost on the wire); after reinit_local_requests requests around the estimate
  // unanswered, as a global search (the estimate is no longer worth searching around).
  int reinit_repeat_keyframes = 20;
  int reinit_local_requests = 3;
  // POSE between keyframes: the odometry (ODOM) carried by the latest map-from-odom.
  bool pose_between_keyframes = true;
  LocalizerConfig localizer;
  MapGrowthConfig map_growth;  // MAP.UPDATE from ILM stretches

  template <class V>
  void visit_fields(V& v) {
    v("request_period_s", request_period_s);
    v("status_period_s", status_period_s);
    v("max_cached_submaps", max_cached_submaps);
    v("keep_keyframes", keep_keyframes);
    v("lost_after_keyframes", lost_after_keyframes);
    v("reinit_sigma_xy_m", reinit_sigma_xy_m);
    v("reinit_sigma_yaw_rad", reinit_sigma_yaw_rad);
    v("reinit_global_sigma_xy_m", reinit_global_sigma_xy_m);
    v("reinit_repeat_keyframes", reinit_repeat_keyframes);
    v("reinit_local_requests", reinit_local_requests);
    v("pose_between_keyframes", pose_between_keyframes);
    v("localizer", localizer);
    v("map_growth", map_growth);
  }
  void validate() const;
};

// The sections of the system config the optimizer node reads.
struct OptimizerNodeConfig {
  transport::ChannelConfig channels;
  PolarDescriptorConfig descriptor;
  OptimizerProcessConfig optimizer;

  template <class V>
  void visit_fields(V& v) {
    v("channels", channels);
    v("descriptor", descriptor);
    v("optimizer", optimizer);
  }
};

class OptimizerNode final : public node::Node {
 public:
  OptimizerNode(transport::Transport& bus, const std::string& robot_id,
                const OptimizerNodeConfig& config);

  std::string name() const override { return "optimizer"; }
  void tick(int64_t now_us) override;
  // Sends what is kept of an ILM stretch, final or not (the session ends).
  bool finish() override;
  std::vector<transport::Transport*> own_transports() override { return map_.own_transports(); }

  struct Counters {
    int64_t keyframes = 0;
    int64_t optimized = 0;        // keyframes through the graph
    int64_t scan_matched = 0;     // of those, with scan-match factors
    int64_t gated = 0;            // RLM keyframes whose registration the gates refused
    int64_t starts = 0;           // INITs that (re)started the graph
    int64_t inits_unmatched = 0;  // INITs naming a keyframe no longer (or not yet) kept
    int64_t lost = 0;
    int64_t reinit_requests = 0;  // COARSE_POSEs sent while lost (the first and repeats)
    int64_t poses = 0;
    int64_t map_updates = 0;              // MAP.UPDATEs sent (each in one or more messages)
    int64_t ilm_keyframes_sent = 0;       // in them
    int64_t ilm_keyframes_discarded = 0;  // kept when tracking was lost: not trusted
    // Their covariance was not one: the odometry factor took the configured sigmas.
    int64_t keyframes_without_covariance = 0;
    int64_t rejected_messages = 0;
  };
  const Counters& counters() const { return counters_; }
  bool lost() const { return lost_; }

 private:
  void on_keyframe(LocalizerKeyframe keyframe);
  void on_init(const InitAnswer& answer);
  void on_odometry(const Eigen::Isometry3d& T_odom_body, const Eigen::Vector3d& velocity_odom,
                   int64_t utime_us);
  // Starts the graph at the INIT's keyframe once the index and that keyframe are here, then
  // optimizes the keyframes after it.
  void try_start();
  void optimize(const LocalizerKeyframe& keyframe, bool publish);
  void publish_pose(int64_t utime_us, const Eigen::Isometry3d& T_map_body,
                    const Eigen::Vector3d& velocity_map);
  void declare_lost(const std::string& reason, const Eigen::Isometry3d& T_map_body);
  // COARSE_POSE around T_map_body, or a global search when no scan match passed since the
  // start or reinit_local_requests went unanswered.
  void ask_reinitialization(const Eigen::Isometry3d& T_map_body);
  // MAP.UPDATE with the ILM keyframes that are due (all kept ones if `flush`).
  void send_map_update(bool flush);
  void publish_status(int64_t now_us);

  transport::Transport& bus_;
  std::string robot_id_;
  OptimizerNodeConfig config_;
  MapClient map_;
  ImuBuffer imu_;
  MapGrowth growth_;
  std::string session_id_;  // the robot's session, as the map will name it
  std::string pose_channel_, status_channel_, coarse_pose_channel_;

  std::unique_ptr<Localizer> localizer_;
  const MapIndex* localizer_index_ = nullptr;  // the index the localizer was given
  std::deque<LocalizerKeyframe> keyframes_;    // the latest, oldest first
  std::optional<InitAnswer> init_;             // to start from, once its keyframe is here
  std::optional<LocalizerOutput> last_;
  double upkeep_ms_ = 0.0;  // Localizer::upkeep after the last POSE (not in its latency)
  Matrix6d covariance_ = Matrix6d::Identity();  // of the latest keyframe's pose
  int unmatched_in_a_row_ = 0;
  int64_t scan_matched_since_start_ = 0;
  bool lost_ = false;
  std::string lost_reason_;
  int requests_while_lost_ = 0;  // since the loss
  int keyframes_since_request_ = 0;

  Counters counters_;
  std::string state_;  // what it does or waits for, or why it is lost
  int64_t last_status_us_ = 0;
};

}  // namespace liloc
