#pragma once
// The egocentric factor graph (paper Section IV-C, Eq. 1, Algorithm 1): a sliding window of
// the robot's keyframes (pose in the map frame, velocity, IMU biases), tied by IMU
// preintegration factors (Eq. 5) and LiDAR odometry factors (Eq. 7), and to the central
// session through the propagation model's scan-match factors (Eq. 8): a keyframe registered
// to the map at T_r gets one edge T_i^-1 T_r to each of the N_d nearest prior nodes i,
// whose noise grows with the keyframe's registration fitness against prior keyframe i. The
// prior nodes are variables held by a tighter prior than the robot's own anchor. Keyframes
// leaving the window, and prior nodes no factor needs any more, are marginalized by the
// Schur complement (Eqs. 9-10); the marginal prior is carried across mode switches.
//
// The graph knows nothing of registration or of modes' causes: the caller (the optimizer's
// pipeline) registers keyframes to submaps, decides RLM or ILM by the overlap of Eq. 11,
// and hands in what it measured.

#include <ceres/loss_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "factors/imu_preintegration.hpp"
#include "factors/marginalization.hpp"
#include "factors/se3_manifold.hpp"
#include "imu/imu_noise.hpp"
#include "imu/imu_sample.hpp"
#include "math/se3.hpp"

namespace liloc {

enum class LocalizationMode { kRelocalization, kIncremental };  // RLM, ILM

struct EgocentricGraphConfig {
  int window_rlm = 5;   // N_m^r keyframes kept in RLM
  int window_ilm = 10;  // N_m^l keyframes kept in ILM
  int prior_nodes = 3;  // N_d nearest prior nodes a scan match is propagated to
  // IMU preintegration factors (Eq. 5); keyframes without IMU samples (a LiDAR-only
  // odometry) get the odometry factor alone. They help against a map levelled by gravity
  // (docs/map_server.md) and with the odometry factors' small floor below: HDL-32E B 0.078
  // -> 0.049 m, VLP-16 B 0.073 -> 0.043 m, C and D within 1 mm (bench_efg). Against a map
  // whose attitude wanders from place to place they lost (B 0.058 -> 0.100 m): the map
  // frame has one tilt against gravity in this graph.
  bool use_imu = true;
  ImuNoiseDensities imu;
  // IMU factors only across spans this short (longer: the odometry factor alone).
  double max_imu_span_s = 3.0;
  double max_imu_gap_s = 0.1;
  // The biases' prior at the start (their turn-on spread).
  double initial_accel_bias_sigma_mps2 = 0.1;
  double initial_gyro_bias_sigma_rps = 0.01;
  // The map's tilt against gravity, estimated from the IMU factors: its prior at the start.
  double map_tilt_sigma_rad = 0.05;
  // Omega_o, the scan-match edges' base noise, at a registration fitness of
  // fitness_reference_m; the sigmas grow in proportion to the fitness beyond it. A
  // registration to the map is precise to millimetres where it passes the gates (the
  // fitness is the points' spread about their planes, not the pose's): at 5 cm the graph
  // drifted from it by 1-3 cm with the odometry, ATE 0.070 m in session C against 0.044 m.
  double scan_match_sigma_m = 0.005;
  double scan_match_sigma_rad = 0.001;
  double fitness_reference_m = 0.05;
  // Cauchy, on the whitened residual: 10 sigma, 5 cm (at 2 sigma the scan matches' small
  // disagreements with the odometry were discounted as outliers).
  double scan_match_loss_scale = 10.0;
  // Prior nodes are held by their map poses with this noise: tighter than the robot's
  // anchor (the central session is the reference, paper Section IV-C).
  double prior_node_sigma_m = 0.01;
  double prior_node_sigma_rad = 0.001;
  // The odometry factor's noise (Eq. 7): the odometry's covariances of both keyframes
  // carried onto their relative pose (odometry_covariance; large along a corridor's axis,
  // millimetres elsewhere), plus a floor and a part proportional to the motion for the
  // drift that a filter's covariance against its own local map does not hold. Where an
  // IMU factor spans the same step the floor is small: a looser one (2 cm + 1 %, 2 mrad)
  // let the IMU's noise steer the estimate in ILM, HDL-32E B 0.273 m against 0.049 m, and
  // 0.143 m with only the rotation's floor small (bench_efg). Elsewhere, and as the whole
  // noise of keyframes without a covariance, the conservative sigmas: an odometry that
  // claims millimetres and drifts 2 % is then still held to the map by the scan matches.
  bool odometry_covariance = true;
  double odometry_floor_sigma_m = 0.001;
  double odometry_floor_sigma_rad = 0.0002;
  double odometry_floor_sigma_per_m = 0.001;
  double odometry_sigma_m = 0.02;
  double odometry_sigma_rad = 0.002;
  double odometry_sigma_per_m = 0.01;
  // Cauchy, on the whitened residual (0: none). Where the floor is small an odometry that
  // claims millimetres and jumps (a bad registration it did not notice) would be followed:
  // a 1.2 m jump took the estimate 1.26 m off; at 10 sigma 0.07 m (test). No change on the
  // simulated sessions (bench_efg HDL-32E and VLP-16 B, C within 0.5 mm).
  double odometry_loss_scale = 10.0;
  int max_iterations = 10;
  // The newest pose's covariance after each solve (for <robot>.POSE).
  bool compute_covariance = true;
  // Ablations (bench): one scan-match factor on the current node instead of the
  // propagation (Block-Loc style); no fitness weighting (the public code); a growing graph.
  bool direct = false;
  bool unweighted = false;
  bool no_marginalization = false;

  template <class V>
  void visit_fields(V& v) {
    v("window_rlm", window_rlm);
    v("window_ilm", window_ilm);
    v("prior_nodes", prior_nodes);
    v("use_imu", use_imu);
    v("imu", imu);
    v("max_imu_span_s", max_imu_span_s);
    v("max_imu_gap_s", max_imu_gap_s);
    v("initial_accel_bias_sigma_mps2", initial_accel_bias_sigma_mps2);
    v("initial_gyro_bias_sigma_rps", initial_gyro_bias_sigma_rps);
    v("map_tilt_sigma_rad", map_tilt_sigma_rad);
    v("scan_match_sigma_m", scan_match_sigma_m);
    v("scan_match_sigma_rad", scan_match_sigma_rad);
    v("fitness_reference_m", fitness_reference_m);
    v("scan_match_loss_scale", scan_match_loss_scale);
    v("prior_node_sigma_m", prior_node_sigma_m);
    v("prior_node_sigma_rad", prior_node_sigma_rad);
    v("odometry_covariance", odometry_covariance);
    v("odometry_floor_sigma_m", odometry_floor_sigma_m);
    v("odometry_floor_sigma_rad", odometry_floor_sigma_rad);
    v("odometry_floor_sigma_per_m", odometry_floor_sigma_per_m);
    v("odometry_sigma_m", odometry_sigma_m);
    v("odometry_sigma_rad", odometry_sigma_rad);
    v("odometry_sigma_per_m", odometry_sigma_per_m);
    v("odometry_loss_scale", odometry_loss_scale);
    v("max_iterations", max_iterations);
    v("compute_covariance", compute_covariance);
    v("direct", direct);
    v("unweighted", unweighted);
    v("no_marginalization", no_marginalization);
  }
  void validate() const;
};

// A prior node of the central session that a scan match is propagated to: the map
// keyframe's id and pose, and the fitness of the robot's keyframe registered against
// that keyframe's cloud (f_b^i of the scan-match factors, Eq. 8).
struct PriorNodeMatch {
  int64_t map_keyframe_id = -1;
  Eigen::Isometry3d T_map_keyframe = Eigen::Isometry3d::Identity();
  double fitness_m = 0.0;
};

// The robot's keyframe registered to the selected submap: T_r of the scan match, Eq. 8.
struct ScanMatch {
  Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
  std::vector<PriorNodeMatch> prior_nodes;  // nearest first, at most N_d used
  double fitness_m = 0.0;                   // against the submap
  // The registration's own information (right perturbation of T_map_body, independent
  // matches): in no direction are the factors more certain than it, so a degenerate
  // registration (a corridor) adds little along its weak axis. None: the base noise alone.
  std::optional<Matrix6d> information;
};

struct GraphKeyframe {
  int64_t id = 0;
  int64_t utime_us = 0;
  Eigen::Isometry3d T_odom_body = Eigen::Isometry3d::Identity();
  // The odometry's covariance of T_odom_body (right perturbation, translation m then
  // rotation rad), if it sent one.
  std::optional<Matrix6d> odometry_covariance;
  std::vector<ImuSample> imu;  // covering the time since the previous keyframe
  std::optional<ScanMatch> scan_match;
};

// A robot keyframe's pose in the map frame.
struct KeyframePose {
  int64_t keyframe_id = 0;
  int64_t utime_us = 0;
  Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
};

struct GraphEstimate {
  int64_t keyframe_id = 0;
  int64_t utime_us = 0;
  Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
  Eigen::Vector3d velocity_map = Eigen::Vector3d::Zero();
  ImuBias bias;
  int window = 0;            // robot keyframes in the window
  int prior_node_count = 0;  // prior nodes in the graph
  int scan_match_factors = 0;
  bool imu_factor = false;  // the latest keyframe is tied by IMU
  // The pose's marginal covariance in the window (right perturbation, translation m then
  // rotation rad); not ok (and identity) when the window leaves it unconstrained.
  Matrix6d covariance = Matrix6d::Identity();
  bool covariance_ok = false;
  double solve_ms = 0.0;  // JFGO
  double covariance_ms = 0.0;
  double marginalization_ms = 0.0;
  double final_cost = 0.0;
  // Keyframes that left the window at this keyframe (marginalized): their final poses.
  std::vector<KeyframePose> finalized;
};

class EgocentricFactorGraph {
 public:
  explicit EgocentricFactorGraph(const EgocentricGraphConfig& config);

  // Starts the session at its first keyframe's pose in the map frame (the initializer's),
  // with that pose's covariance (right perturbation) as the robot's anchor Q^b.
  void start(const GraphKeyframe& keyframe, const Eigen::Isometry3d& T_map_body,
             const Matrix6d& covariance);
  bool started() const { return !nodes_.empty(); }

  // Adds the next keyframe with its factors, optimizes the window (JFGO) and marginalizes
  // what leaves it.
  GraphEstimate add(const GraphKeyframe& keyframe);

  // RLM keeps window_rlm keyframes, ILM window_ilm (the change takes effect at the next add).
  void set_mode(LocalizationMode mode) { mode_ = mode; }
  LocalizationMode mode() const { return mode_; }
  // Map-from-odom of the latest keyframe: poses between keyframes are the odometry's,
  // carried by it.
  Eigen::Isometry3d T_map_odom() const;

 private:
  struct Node {
    int64_t id = 0;
    int64_t utime_us = 0;
    Eigen::Isometry3d T_odom_body = Eigen::Isometry3d::Identity();
    std::optional<Matrix6d> odometry_covariance;
    PoseBlock pose{};
    std::array<double, 3> velocity{};
    std::array<double, 6> bias{};  // accelerometer, gyroscope
    // A factor holds the biases: their prior, or an IMU factor into this node.
    bool bias_held = false;
  };
  struct Prior {
    PoseBlock pose{};
    StateBlock block() { return {pose.data(), 7, true}; }
  };

  void add_factor(ceres::CostFunction* cost, std::shared_ptr<ceres::LossFunction> loss,
                  std::vector<StateBlock> blocks);
  int add_scan_match(Node& node, const ScanMatch& match);
  // The biases within their turn-on spread about their current value.
  void add_bias_prior(Node& node);
  // Eq. 5 between consecutive nodes, if the samples span them; a chain of IMU factors that
  // starts at `from` gives its biases their prior (one factor alone leaves the
  // accelerometer bias and the velocity trading off: a rank-deficient covariance).
  bool add_imu(Node& from, Node& to, const std::vector<ImuSample>& imu);
  // JFGO over the window; the newest node's covariance into `estimate` if asked for.
  double solve(Node& newest, GraphEstimate& estimate);
  // Marginalizes what leaves the window; the final poses of its keyframes into `estimate`.
  void marginalize_old(GraphEstimate& estimate);

  EgocentricGraphConfig config_;
  LocalizationMode mode_ = LocalizationMode::kRelocalization;
  std::deque<std::unique_ptr<Node>> nodes_;
  std::map<int64_t, std::unique_ptr<Prior>> priors_;  // by map keyframe id
  std::vector<FactorRecord> factors_;                 // the marginal prior among them
  // The map frame's tilt against gravity (roll, pitch): one state for the whole session.
  std::array<double, 2> map_tilt_{};
  std::shared_ptr<ceres::Manifold> se3_ = std::make_shared<Se3Manifold>();
};

}  // namespace liloc
