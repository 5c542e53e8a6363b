#pragma once
// LiDAR-inertial odometry, the ILM front end (paper Section IV-C.2): IMU propagation and
// per-point deskew, point-to-plane registration of each sweep against an incremental
// voxel map (Eq. 6), fused with the IMU in an iterated error-state Kalman filter that
// also estimates the biases and the gravity direction; keyframes every 1 m / 0.2 rad.
// Without an IMU it runs LiDAR-only with a constant-velocity model.
//
// Data in, estimates out, no I/O: add_imu() / add_scan() as data arrives, then process()
// returns an estimate for each sweep it could finish. Sweeps wait for the IMU to cover
// them, up to imu_wait_s of newer data.

#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "imu/imu_buffer.hpp"
#include "odometry/imu_propagation.hpp"
#include "odometry/motion_profile.hpp"
#include "odometry/navigation_state.hpp"
#include "odometry/odometry_types.hpp"
#include "registration/correlative_search.hpp"
#include "registration/point_to_plane_registration.hpp"
#include "voxel_map/voxel_hash_map.hpp"

namespace liloc {

struct OdometryConfig {
  bool use_imu = true;
  // T_body_lidar and the LiDAR clock's offset (LiDAR time minus IMU time).
  Eigen::Vector3d lidar_translation_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d lidar_rpy_deg = Eigen::Vector3d::Zero();
  double lidar_time_offset_s = 0.0;
  // Points nearer (the vehicle itself) or farther than this are not used.
  double min_range_m = 1.5;
  double max_range_m = 100.0;
  double registration_voxel_m = 0.5;
  // At most this many of them (evenly strided) go to registration; the map gets all.
  int max_registration_points = 3000;
  // A sweep is added to the map only after the body moved this much since the last one
  // added: a standing sensor would otherwise pile its own range noise into the map as
  // sheets along its rays, which then hold the registration at zero motion.
  double map_insert_translation_m = 0.1;
  double map_insert_rotation_rad = 0.02;
  int min_points = 100;
  // Keyframes (paper/LIO-SAM defaults).
  double keyframe_translation_m = 1.0;
  double keyframe_rotation_rad = 0.2;
  double keyframe_voxel_m = 0.3;
  // IMU.
  ImuNoiseConfig imu;
  double init_window_s = 0.5;              // IMU before the first sweep, for gravity
  double stationary_accel_std_mps2 = 0.3;  // below: a standing start
  double stationary_gyro_std_rps = 0.03;
  double imu_wait_s = 0.2;  // then a sweep goes ahead without full IMU coverage
  // Bounds on what waits: sweeps queued for the IMU to cover them (the oldest is dropped
  // beyond this), and IMU samples kept (older than this behind the newest are dropped),
  // so that a LiDAR without IMU or an IMU without LiDAR cannot fill the memory.
  int max_queued_scans = 50;
  double imu_buffer_s = 10.0;
  // Zero-velocity update: when the filter's speed is low and the IMU says the vehicle
  // stands (mean rate ~0 and specific force steady over the sweep, beyond the white
  // noise its density predicts), velocity 0 is a measurement. It keeps a standing robot
  // from drifting while its sweeps, all from one viewpoint, constrain little. A vehicle
  // creeping off at 0.35 m/s on a smooth road has the same IMU signature: at 0.3 m/s the
  // update held such a start at zero while the filter believed 0.2 m/s, and the sweeps, a
  // VLP-16's in the open fitting 1-8 planes, could not say otherwise (campus A of world
  // seed 2: 8.5 m ATE; 0.04 m at 0.1 m/s, the default town unchanged).
  bool zero_velocity_update = true;
  double standstill_max_speed_mps = 0.1;
  double standstill_gyro_rps = 0.01;
  double standstill_accel_std_mps2 = 0.05;
  double standstill_velocity_sigma_mps = 0.01;
  // LiDAR-only constant-velocity model: expected change of velocity per second.
  double motion_translation_sigma_mps = 2.0;
  double motion_rotation_sigma_rps = 0.5;
  // Across a longer pause only the heading's rate (about the local frame's z) is
  // extrapolated, and for this long only: a turn ends, and a roll or pitch rate (a few
  // degrees per second of registration noise) carried across the pause tilted the pose by
  // up to 71 degrees, which the level search and, after a restart, every later sweep
  // inherit.
  double max_rotation_extrapolation_s = 0.5;
  // Across such a pause the last step's velocity is one guess; the body-frame velocity
  // averaged over the last second_guess_window_s is another. Where the two predictions lie
  // farther apart than the search window reaches, both are searched: one sweep registered
  // 0.6 m sideways in a turn (HDL-32E without an IMU), its velocity carried across 4.8 s,
  // put the prediction 50 m off; carrying the average instead, always, upset Mid-360's
  // close acceptances (docs/odometry.md). 0: one guess.
  double second_guess_window_s = 1.0;
  // With the IMU, the sweep after more than long_gap_s without one registered (dropped
  // sweeps, a stalled driver, a blocked LiDAR's tiny sweeps) is placed by the correlative
  // search (below) within at least long_gap_search_m, and updates pose and velocity only:
  // biases and gravity are "considered" (Schmidt-Kalman). Over seconds the prediction is
  // off by more than the covariance says, and that sweep sees what the local map barely
  // covers: a VLP-16 sweep 3.7 s after the last, predicted 0.49 m short (2.9 sigma), was
  // registered 0.13 m forward, pulled the accelerometer bias off, and the filter diverged
  // (docs/odometry.md).
  double long_gap_s = 1.0;
  double long_gap_search_m = 3.0;
  VoxelMapConfig map;
  // registration.max_correspondence_m is the floor of the association radius; it widens
  // with the predicted pose's uncertainty (this many sigmas, the rotation's taken at
  // correspondence_lever_m) up to correspondence_cap_m. A tight radius keeps a well
  // predicted sweep from latching onto wrong planes; a wide one lets a poorly predicted
  // sweep (no IMU, IMU gap, degenerate axis) still find its planes.
  RegistrationConfig registration;
  // Planes seen more edge-on than registration.min_incidence_cos (0.1) are left out: for the
  // road that is beyond ~12 m (the simulated LiDAR 1.25 m above it), and a LiDAR that sees
  // the road only at grazing angles (Mid-360: no ray below -7 degrees) then holds its
  // height through a ring 2 m wide. Where the LiDAR samples the elevations near its horizon
  // finely, the first sweep that shows them lowers that cut to sin(grazing_ring_spacings x
  // the largest elevation step there), never below min_incidence_cos_floor: 0.05 for the Mid-360
  // and the OS1-64, 0.070 for the HDL-32E, while the VLP-16, rings 2 degrees apart, keeps 0.1:
  // there the road between two rings goes unsampled for metres, the planes fitted across
  // rings tilt, and at 0.05 it diverged (docs/odometry.md, "The grazing cut"). 0: the cut
  // as configured. Without an IMU nothing holds the tilt such planes give (with one, gravity
  // does), so grazing_ring_spacings_without_imu is used instead: 5 keeps the HDL-32E at 0.1
  // and gives the OS1-64 and the Mid-360 the floor (fewer moved HDL-32E runs without an IMU
  // by up to 2 m; docs/odometry.md).
  double grazing_ring_spacings = 3.0;
  double grazing_ring_spacings_without_imu = 5.0;
  double min_incidence_cos_floor = 0.05;
  // Beyond the range where the LiDAR's elevation steps near its horizon open wider than an
  // association radius (registration.max_correspondence_m / step: VLP-16 14 m, HDL-32E
  // 21 m, OS1-64 54 m; none within the Mid-360's range), planes near level above the LiDAR
  // are not matched (RegistrationConfig::far_ceiling_beyond_m). Matched, they tilted every
  // VLP-16 and HDL-32E run traced by 0.4-1.5 degrees, nose up, in its first 50 m, and the
  // map kept it (VLP-16 campus D without an IMU: 1.44 degrees RMS, ATE 0.403 m; left out
  // 0.15 degrees, 0.036 m; docs/odometry.md). With an IMU, gravity holds the tilt, and
  // left out they cost the HDL-32E's corridor its hold along the axis (1.94 -> 37.9 m ATE):
  // far_ceilings_left_out applies with an IMU, _without_imu without one.
  bool far_ceilings_left_out = false;
  bool far_ceilings_left_out_without_imu = true;
  double correspondence_sigmas = 3.0;
  double correspondence_lever_m = 10.0;
  double correspondence_cap_m = 2.0;
  // A radius above its floor means registration starts far from the answer (no IMU, an
  // IMU gap, a long pause between sweeps): then the robust kernel widens with the radius
  // (this fraction of it, never below registration.cauchy_scale_m) and registration may
  // re-associate up to uncertain_iterations times until it converges, which is KISS-ICP's
  // adaptive threshold (kernel a ninth of it) and iterating to convergence. With a tight
  // 0.1 m kernel and 3 associations a sharp LiDAR-only turn advanced 1-3 degrees per sweep
  // against a true 5 and diverged (docs/odometry.md).
  double kernel_fraction = 0.1;
  int uncertain_iterations = 30;
  // Beyond that, after a pause (no IMU across dropped sweeps, an IMU gap): when the
  // prediction's reach (the association radius before its cap) exceeds search_beyond_m, a
  // correlative (x, y, yaw) search over the local map within that reach, at most
  // search_max_xy_m and search_max_yaw_rad, gives the starts that registration refines; the
  // one with the most points within search_inlier_m of the map wins.
  double search_beyond_m = 4.0;
  double search_max_xy_m = 20.0;
  double search_max_yaw_rad = 1.6;
  double search_max_z_m = 4.0;  // each start's height searched within this (and the reach)
  double search_inlier_m = 0.2;
  // Below this share of inliers the sweep cannot be placed (it sees what the local map
  // never did): the local map restarts from it at the predicted pose, and the estimate
  // says why (OdometryEstimate::lost_reason). After a pause of seconds the sweep sees
  // far ahead of the local map and even its true pose may fit fewer: down to
  // search_confirmed_inlier_ratio it is taken when search_confirming_starts starts (the
  // prediction among them) converged to it (within search_agree_m and search_agree_rad) and no
  // other answer came within search_runner_up_fraction of its inliers.
  double search_min_inlier_ratio = 0.3;
  double search_confirmed_inlier_ratio = 0.15;
  int search_confirming_starts = 3;
  double search_agree_m = 0.5;
  double search_agree_rad = 0.02;
  double search_runner_up_fraction = 0.8;
  // Answers that fit at least search_tie_fraction of the most inliers fit alike; where one
  // of them is search_tie_odds times as likely by its prior as the most inliers', the
  // likeliest of them is taken instead (pick_search_answer): by count alone a warped sweep (a turn
  // begun in a 0.4 s gap, HDL-32E without an IMU) took an answer 2.2 m from the prediction, 56
  // times less likely than one that fitted 3 % fewer points.
  double search_tie_fraction = 0.95;
  double search_tie_odds = 10.0;
  // A local map of its first few sweeps (the run's first, or a restart's) is as sparse as
  // they are, and after a pause of seconds even the true pose puts few of a sparse LiDAR's
  // points within search_inlier_m of it: while the local map holds fewer than
  // young_map_inserts sweeps, the confirmed floor is young_map_confirmed_inlier_ratio (the
  // confirming starts and the rival as above). Mid-360 without an IMU, drop pattern 5: in
  // local maps of one and of two sweeps, 9 % and 13 % of the sweeps after gaps of 3.0 and
  // 3.2 s fit, at answers 0.2-0.3 m from the truth that four and five starts agreed on and
  // nothing else came near (2 %, 0 %); refused, the local map restarted 7 m and 5 m off
  // and was never found again. young_map_inserts 0: no such floor.
  int young_map_inserts = 10;
  double young_map_confirmed_inlier_ratio = 0.05;
  // The search's winner is refined at a search cell's radius with a kernel as wide, which
  // pulls a start a metre off onto the map; where the sweep shares little with the map
  // (after a pause of seconds, tens of metres on) the points that do not fit pull too, and
  // tilted it: Mid-360 without an IMU, 0.2 degrees at the first sweep after a 5.1 s gap,
  // kept by every later sweep. So without an IMU (with one, gravity holds the tilt) after
  // more than search_settle_after_s without a sweep registered, and for any re-anchored
  // local map, the winner is registered once more at the same radius (the few neighbours
  // of a sparse far field are still found) with the normal kernel, which weighs the points
  // that fit, and kept where at least as many points fit. Settling every searched sweep
  // (any dropped sweep, without an IMU) moved a knife-edge acceptance in a turn and
  // restarted the local map twice (12 m).
  double search_settle_after_s = 1.0;
  // When that search after a pause is rejected (without an IMU), the local map restarts at
  // its answer rather than at the prediction where at least this many starts agree on an
  // answer that fits search_confirmed_inlier_ratio of the sweep, with the twist across the
  // pause as after an accepted search; 0: at the prediction. The constant-velocity
  // prediction across a 5 s pause is metres off, and the answers so placed were where the
  // re-anchoring later found the truth (Mid-360, sweeps dropped: 2.7-5.2 m off until
  // then). The re-anchoring still searches around the prediction.
  int restart_at_answer_starts = 2;
  // Without an IMU, a sweep registered from the prediction whose RMS point-to-plane
  // residual (Eq. 6) exceeds poor_fit_factor times the median of the last poor_fit_window
  // such sweeps that did not (once half as many are known), and poor_fit_floor_m, is
  // searched for as after a pause, within poor_fit_search_m and
  // poor_fit_search_yaw_rad of the prediction, and the search's answer taken where more of
  // its points fit. The constant-velocity model misses a quick swerve (another town's
  // campus A at 291 s: a 6.5-degree kink taken at 24 deg/s): registered from the
  // prediction, the sweeps through it settled 1.6 degrees behind and 3 beyond (0.14-0.27 m
  // against the usual 0.03 m), the local map took them in and the drive kept a 2.9-degree
  // yaw error for good (Mid-360, 1.1 m ATE, nothing reported). Kept out of the local map
  // instead, those sweeps fixed that drive too, but a dropped-sweep run diverged (13.5 m).
  // 0: never.
  double poor_fit_factor = 3.0;
  double poor_fit_floor_m = 0.1;
  int poor_fit_window = 20;
  double poor_fit_search_m = 1.0;
  double poor_fit_search_yaw_rad = 0.1;
  // Before that search a sweep whose residual exceeds poor_fit_deskew_factor times that
  // median and poor_fit_deskew_floor_m (a searched sweep too) is deskewed again along the
  // motion from the previous sweep's end to its registered pose and registered again,
  // poor_fit_deskew_passes times (0: never), and the pass that fits best kept
  // (deskew_poor_fit) if it has no fewer points on the map and a residual lower than the
  // first by at least the fraction poor_fit_deskew_min_gain. Deskewed with the previous sweep's
  // twist, a sweep in which a turn ended settles degrees short and the sweeps after it ring
  // about the truth (Mid-360 campus A: -2.5 to +1.2 degrees for a second); deskewed again,
  // campus A's LiDAR-only RPE falls from 0.137 to 0.049 % (Mid-360). A warp by a turn's end
  // takes a pass 40-80 % of the residual; passes that took 4-16 % followed twists of noise
  // (VLP-16 campus C, creeping off on open ground: kept, they took its RPE from 0.93 to
  // 2.9 %; left, 0.81 %) (docs/odometry.md).
  double poor_fit_deskew_factor = 1.5;
  double poor_fit_deskew_floor_m = 0.05;
  int poor_fit_deskew_passes = 4;
  double poor_fit_deskew_min_gain = 0.25;
  // Without an IMU, a sweep after a pause longer than max_rotation_extrapolation_s is
  // deskewed with the twist of before it, and the vehicle often changed speed in the pause
  // (campus A, 5.1 s: deskewed at 7.5 m/s, driving 4.1). Such a sweep is registered with a
  // correction to that twist (register_point_to_plane_with_twist; prior sigmas
  // motion_translation_sigma_mps and motion_rotation_sigma_rps, and the two below), deskewed
  // again along the result and registered again, and its own twist, not the average over
  // the pause, predicts the next sweep (docs/odometry.md, "The sweep's own twist after a
  // gap").
  bool own_twist_after_gap = true;
  // A ground vehicle's vertical velocity and roll and pitch rates change little in a pause,
  // and a sweep tells them poorly (16 rings, with the constant-velocity sigmas on them: pitch
  // steps of +0.4 degrees after the gaps, VLP-16 campus A pattern 0, 0.201 m ATE; 0.106 m
  // with these). So the correction's vertical velocity (m/s) and roll and pitch rates
  // (rad/s, body frame) have these tighter prior sigmas (docs/odometry.md, "The twist
  // correction made planar").
  double own_twist_vertical_sigma_mps = 0.1;
  double own_twist_tilt_rate_sigma_rps = 0.02;
  // A restart at the predicted pose keeps the prediction's error for good (after a pause of
  // 4.6 s without an IMU, a Mid-360 sweep whose true place led by 20 % of its points, a
  // rival 67 degrees off by 16 %: restarted 2.3 m short). So the local map of before is
  // kept, and once the new one holds reanchor_after_s of sweeps (more of the scene than one
  // sweep) it is searched for in the old one as a sweep is, within the restart's reach; if
  // found, the estimate and the new map move onto the old (OdometryEstimate::reanchored).
  // Its rivals are weighed by the restart's prior: one 22 m back and 53 degrees off (2.4
  // sigma) fitting 13 % of the new map must not block the true place's 16 % near the
  // restart's pose (Mid-360, 1.23 -> 0.15 m). Only discounted, relative to the answer: an
  // answer 1.6 sigma off fitting 25 % was refused for a rival at the prediction fitting
  // 5.4 % when the answer was weighed too (a 79-degree turn in a 4 s pause, the scenario
  // test). Tried reanchor_attempts times, reanchor_after_s apart; 0: never.
  double reanchor_after_s = 1.0;
  int reanchor_attempts = 3;
  // Without an IMU, a degenerate streak this long makes the estimate lost (its reason
  // says so): along the weak direction it is the constant-velocity model's guess.
  double lost_after_degenerate_s = 3.0;
  // Without an IMU, above 0 each sweep is deskewed and registered a second time, with the
  // previous sweep's twist moved this fraction of the way to the twist the first pass
  // measured (not after a pause longer than max_rotation_extrapolation_s). 0 (one pass):
  // 0.5 halved the error of some full campus sessions and made others diverge (VLP-16
  // campus C 0.95 -> 3.7 % RPE; docs/odometry.md). The extrinsic check's LiDAR-only twin
  // uses 1: one pass leaves its poses a fraction of a sweep late, which it would read as
  // a clock offset.
  double redeskew_blend = 0.0;
  // With the IMU: a sweep whose registration contradicts the IMU's prediction (the
  // normalized innovation squared of the pose, 6 degrees of freedom, above
  // imu_consistency_nis; 22.5 is the chi-square 0.999 quantile, and clean drives exceed it
  // on a few sweeps of thousands) outweighs the IMU: the prediction is widened by an acceleration
  // uncertainty of imu_distrust_accel_mps2 and an angular rate one of imu_distrust_gyro_rps,
  // doubled up to imu_distrust_doublings times until the registered pose moves less than
  // imu_distrust_settled_m / _rad, and so are the sweeps of the next imu_distrust_hold_s.
  // Without it an accelerometer off by 15 m/s^2 for 3 s ran the estimate away at 40 m/s
  // (the filter's 4 mm/s velocity sigma let the LiDAR correct nothing); with it the drive
  // holds 0.03 m ATE (docs/odometry.md). 0 turns it off.
  double imu_consistency_nis = 22.5;
  double imu_distrust_accel_mps2 = 10.0;
  double imu_distrust_gyro_rps = 1.0;
  int imu_distrust_doublings = 4;
  double imu_distrust_settled_m = 0.02;
  double imu_distrust_settled_rad = 0.002;
  double imu_distrust_hold_s = 0.5;
  // A rate fault also smears the sweep: deskewed with a rotation wrong by degrees, no pose
  // fits it, and registration stays near the wrong prediction with a small innovation
  // (gyro +1 rad/s for 1 s: 19 m in silence). So while the IMU is distrusted, and where a
  // sweep's inlier ratio (its share of points within search_inlier_m of the map) fell
  // below fit_collapse_fraction of the recent median, the sweep is also deskewed and
  // predicted with the LiDAR's own last twist; that hypothesis is taken when its inlier
  // ratio is own_motion_inlier_gain times the IMU's and at least search_min_inlier_ratio,
  // and the IMU then stays distrusted. fit_collapse_fraction 0: no collapse check.
  double own_motion_inlier_gain = 1.2;
  double fit_collapse_fraction = 0.5;
  // Health: an estimate faster than max_speed_mps or, with the IMU, whose velocity changed
  // faster than max_accel_mps2 over a sweep (not while the IMU is distrusted: the LiDAR
  // then corrects the velocity by metres per second) or that registration moved more than
  // max_jump_m from the prediction is not trusted: lost, with the reason, back to the
  // previous sweep's pose and the velocity of the last sweep that agreed with the IMU.
  // With the IMU the local map stays (these are the IMU's faults, and the next sweep is
  // searched in it); without it, and on a weak fit (below), it restarts.
  double max_speed_mps = 40.0;
  double max_accel_mps2 = 20.0;
  double max_jump_m = 2.0;
  // Lost, with or without the IMU, when over the last weak_fit_window_s (all of it on the
  // current local map) the median sweep matched fewer than weak_fit_correspondences planes:
  // the local map no longer describes what the LiDAR sees, and the estimate drifts with
  // whatever it still matches (sweeps standing still are not counted). A VLP-16 with its
  // IMU that left a 3.9 s gap 0.4 m short drifted 700 m this way at 10-20 matches a sweep;
  // healthy runs keep a median of 130 or more, and 32 at the start, before the local map
  // fills (docs/odometry.md).
  // With the IMU, also lost when that window's median inlier ratio (OdometryEstimate::
  // inlier_ratio) stayed below weak_fit_inlier_ratio: the sweeps match planes but not the
  // map's points, as when a gyro stays wrong by 1 rad/s and neither its motion nor the
  // LiDAR's own fits (0.13-0.16, 104 m in silence); healthy runs keep 0.46 or more. 0: no
  // such check.
  double weak_fit_window_s = 3.0;
  int weak_fit_correspondences = 20;
  double weak_fit_inlier_ratio = 0.3;
  // With the IMU, lost when over the last imu_fault_window_s the LiDAR overruled the IMU
  // (OdometryEstimate::imu_disagreement) on at least imu_fault_fraction of the sweeps: a
  // lasting IMU fault, said (again after each further window) but not reset, since the
  // LiDAR's own motion carries the estimate. It carries a straight road but not a turn: a
  // gyro wrong by 1 rad/s for good left 19 degrees of yaw in the local map at the next
  // corner, and with back faces refused (registration.reject_back_faces) the sweeps went
  // on fitting that turned map, 60 % of their points, 27 m off in silence. Transient faults
  // (3 s of a wrong accelerometer, 1 s of a wrong gyro) stay below the fraction and are
  // outweighed. imu_fault_window_s 0: no such check.
  double imu_fault_window_s = 5.0;
  double imu_fault_fraction = 0.8;
  // At that report the gyro bias's covariance reopens to this sigma (rad/s, uncorrelated)
  // and the distrust ends, so that the next sweeps learn a fault that lasts as the bias
  // step it most likely is: while the IMU is distrusted the biases are only considered,
  // and a gyro wrong by 0.3 rad/s for good was never learned (HDL-32E campus A: 196.5 m
  // ATE, 0.050 m learned). 0: kept.
  double imu_fault_gyro_bias_sigma_rps = 1.0;
  CorrelativeSearchConfig search;
  // Pose corrections are blended in: this fraction of what remains per sweep, at most
  // the step limits, so that the output never jumps.
  double correction_blend = 0.1;
  double correction_max_step_m = 0.02;
  double correction_max_step_rad = 0.002;
  double history_s = 120.0;  // how far back a correction may refer
  // With the IMU: the configured LiDAR rotation and clock offset checked against the
  // motion of the first seconds (OdometryEstimate::extrinsic_check).
  ExtrinsicCheckConfig extrinsic_check;

  template <class V>
  void visit_fields(V& v) {
    v("use_imu", use_imu);
    v("lidar_translation_m", lidar_translation_m);
    v("lidar_rpy_deg", lidar_rpy_deg);
    v("lidar_time_offset_s", lidar_time_offset_s);
    v("min_range_m", min_range_m);
    v("max_range_m", max_range_m);
    v("registration_voxel_m", registration_voxel_m);
    v("max_registration_points", max_registration_points);
    v("map_insert_translation_m", map_insert_translation_m);
    v("map_insert_rotation_rad", map_insert_rotation_rad);
    v("min_points", min_points);
    v("keyframe_translation_m", keyframe_translation_m);
    v("keyframe_rotation_rad", keyframe_rotation_rad);
    v("keyframe_voxel_m", keyframe_voxel_m);
    v("imu", imu);
    v("init_window_s", init_window_s);
    v("stationary_accel_std_mps2", stationary_accel_std_mps2);
    v("stationary_gyro_std_rps", stationary_gyro_std_rps);
    v("imu_wait_s", imu_wait_s);
    v("max_queued_scans", max_queued_scans);
    v("imu_buffer_s", imu_buffer_s);
    v("zero_velocity_update", zero_velocity_update);
    v("standstill_max_speed_mps", standstill_max_speed_mps);
    v("standstill_gyro_rps", standstill_gyro_rps);
    v("standstill_accel_std_mps2", standstill_accel_std_mps2);
    v("standstill_velocity_sigma_mps", standstill_velocity_sigma_mps);
    v("motion_translation_sigma_mps", motion_translation_sigma_mps);
    v("motion_rotation_sigma_rps", motion_rotation_sigma_rps);
    v("max_rotation_extrapolation_s", max_rotation_extrapolation_s);
    v("second_guess_window_s", second_guess_window_s);
    v("long_gap_s", long_gap_s);
    v("long_gap_search_m", long_gap_search_m);
    v("map", map);
    v("registration", registration);
    v("grazing_ring_spacings", grazing_ring_spacings);
    v("grazing_ring_spacings_without_imu", grazing_ring_spacings_without_imu);
    v("min_incidence_cos_floor", min_incidence_cos_floor);
    v("far_ceilings_left_out", far_ceilings_left_out);
    v("far_ceilings_left_out_without_imu", far_ceilings_left_out_without_imu);
    v("correspondence_sigmas", correspondence_sigmas);
    v("correspondence_lever_m", correspondence_lever_m);
    v("correspondence_cap_m", correspondence_cap_m);
    v("kernel_fraction", kernel_fraction);
    v("uncertain_iterations", uncertain_iterations);
    v("search_beyond_m", search_beyond_m);
    v("search_max_xy_m", search_max_xy_m);
    v("search_max_yaw_rad", search_max_yaw_rad);
    v("search_max_z_m", search_max_z_m);
    v("search_inlier_m", search_inlier_m);
    v("search_min_inlier_ratio", search_min_inlier_ratio);
    v("search_confirmed_inlier_ratio", search_confirmed_inlier_ratio);
    v("search_confirming_starts", search_confirming_starts);
    v("search_agree_m", search_agree_m);
    v("search_agree_rad", search_agree_rad);
    v("search_runner_up_fraction", search_runner_up_fraction);
    v("search_tie_fraction", search_tie_fraction);
    v("search_tie_odds", search_tie_odds);
    v("young_map_inserts", young_map_inserts);
    v("young_map_confirmed_inlier_ratio", young_map_confirmed_inlier_ratio);
    v("search_settle_after_s", search_settle_after_s);
    v("restart_at_answer_starts", restart_at_answer_starts);
    v("poor_fit_factor", poor_fit_factor);
    v("poor_fit_floor_m", poor_fit_floor_m);
    v("poor_fit_window", poor_fit_window);
    v("poor_fit_search_m", poor_fit_search_m);
    v("poor_fit_search_yaw_rad", poor_fit_search_yaw_rad);
    v("poor_fit_deskew_factor", poor_fit_deskew_factor);
    v("poor_fit_deskew_floor_m", poor_fit_deskew_floor_m);
    v("poor_fit_deskew_passes", poor_fit_deskew_passes);
    v("poor_fit_deskew_min_gain", poor_fit_deskew_min_gain);
    v("own_twist_after_gap", own_twist_after_gap);
    v("own_twist_vertical_sigma_mps", own_twist_vertical_sigma_mps);
    v("own_twist_tilt_rate_sigma_rps", own_twist_tilt_rate_sigma_rps);
    v("reanchor_after_s", reanchor_after_s);
    v("reanchor_attempts", reanchor_attempts);
    v("lost_after_degenerate_s", lost_after_degenerate_s);
    v("redeskew_blend", redeskew_blend);
    v("imu_consistency_nis", imu_consistency_nis);
    v("imu_distrust_accel_mps2", imu_distrust_accel_mps2);
    v("imu_distrust_gyro_rps", imu_distrust_gyro_rps);
    v("imu_distrust_doublings", imu_distrust_doublings);
    v("imu_distrust_settled_m", imu_distrust_settled_m);
    v("imu_distrust_settled_rad", imu_distrust_settled_rad);
    v("imu_distrust_hold_s", imu_distrust_hold_s);
    v("own_motion_inlier_gain", own_motion_inlier_gain);
    v("fit_collapse_fraction", fit_collapse_fraction);
    v("max_speed_mps", max_speed_mps);
    v("max_accel_mps2", max_accel_mps2);
    v("max_jump_m", max_jump_m);
    v("weak_fit_window_s", weak_fit_window_s);
    v("weak_fit_correspondences", weak_fit_correspondences);
    v("weak_fit_inlier_ratio", weak_fit_inlier_ratio);
    v("imu_fault_window_s", imu_fault_window_s);
    v("imu_fault_fraction", imu_fault_fraction);
    v("imu_fault_gyro_bias_sigma_rps", imu_fault_gyro_bias_sigma_rps);
    v("search", search);
    v("correction_blend", correction_blend);
    v("correction_max_step_m", correction_max_step_m);
    v("correction_max_step_rad", correction_max_step_rad);
    v("history_s", history_s);
    v("extrinsic_check", extrinsic_check);
  }
  void validate() const;
  Eigen::Isometry3d T_body_lidar() const;
};

class LidarInertialOdometry {
 public:
  explicit LidarInertialOdometry(const OdometryConfig& config);

  // Refused samples (non-finite, repeated, out of order) are counted.
  void add_imu(const ImuSample& sample);
  // Sweeps starting before the previous one ended, or repeated, are counted and dropped;
  // beyond max_queued_scans waiting, the oldest is dropped and counted.
  void add_scan(LidarScan scan);
  // Biases and velocity apply at once; a pose correction is blended in over the
  // following sweeps. Corrections for times outside the history are counted, ignored.
  void add_correction(const OdometryCorrection& correction);

  // Estimates for every sweep that can be processed now, in order. A sweep whose
  // processing fails is dropped, counted (scans_failed) and its reason kept.
  std::vector<OdometryEstimate> process();
  // Processes every waiting sweep, whether or not the IMU covers it (end of data).
  std::vector<OdometryEstimate> flush();

  const OdometryCounters& counters() const;
  // Sweeps waiting for the IMU to cover them.
  size_t queued_scans() const { return scans_.size(); }
  bool has_imu() const { return !imu_.empty(); }
  // Why the last sweep that failed failed (empty if none did).
  const std::string& last_failure() const { return last_failure_; }
  const NavState& state() const { return x_; }
  const StateMatrix& covariance() const { return P_; }
  size_t map_points() const { return map_.num_points(); }
  // The cut for planes seen edge-on in effect: registration.min_incidence_cos, lowered once
  // a sweep shows the LiDAR's horizon (grazing_ring_spacings, or _without_imu).
  double min_incidence_cos() const { return config_.registration.min_incidence_cos; }

 private:
  struct HistoryEntry {
    int64_t utime_us;
    Eigen::Isometry3d T_local_body;
  };

  // One sweep on its way through process_scan().
  struct Sweep {
    int64_t start_utime = 0;
    int64_t end_utime = 0;
    std::vector<LidarPoint> valid;             // within the range limits
    std::vector<LidarPoint> sparse;            // one per registration voxel
    MotionProfile motion;                      // the body's motion over the sweep
    std::vector<Eigen::Vector3f> points_body;  // sparse, deskewed to the sweep's end
    // The state before this sweep's prediction: the previous sweep's end.
    Eigen::Isometry3d T_local_body_before = Eigen::Isometry3d::Identity();
    Eigen::Vector3d velocity_before = Eigen::Vector3d::Zero();
    int64_t utime_before = 0;
    int64_t registered_before_utime = 0;  // the end of the last sweep registered
    // Without an IMU, across a pause: the pose predicted with the last second's velocity
    // (second_guess_window_s).
    std::optional<Eigen::Isometry3d> T_local_body_second_guess;
    // After a pause without an IMU: the twist its own points showed (body frame at its end).
    std::optional<Vector6d> own_twist;
    // Seconds the prediction spanned: from the previous sweep's end to this one's.
    double gap_s() const { return (end_utime - utime_before) * 1e-6; }
    // Seconds since a sweep last checked the prediction: longer than gap_s() after sweeps
    // too small to register (a blocked LiDAR).
    double unregistered_s() const { return (end_utime - registered_before_utime) * 1e-6; }
  };

  // A sweep's motion at a constant body-frame twist from the previous sweep's end, and its
  // points deskewed along it (deskew_at_twist).
  struct Deskewed {
    MotionProfile motion;
    std::vector<Eigen::Vector3f> points_body;
  };

  std::vector<OdometryEstimate> run(bool force);
  // Sets the initial state from the IMU before `start_utime`; false if there is too
  // little IMU yet.
  bool initialize(int64_t start_utime);
  // The pipeline of one sweep (docs/odometry.md), each step timed in est.timings.
  OdometryEstimate process_scan(const LidarScan& scan, int64_t start_utime, int64_t end_utime);
  Sweep preprocess(const LidarScan& scan, int64_t start_utime, int64_t end_utime) const;
  void predict_and_deskew(Sweep& sweep, OdometryEstimate& est);
  void register_sweep(Sweep& sweep, OdometryEstimate& est);
  void update_map(const Sweep& sweep);
  std::optional<Keyframe> make_keyframe(const Sweep& sweep);
  void finish_estimate(OdometryEstimate& est);

  // Propagates the state to the sweep's end: the sweep's motion and, without an IMU
  // across a pause, its second guess.
  void predict(Sweep& sweep);
  // The body's motion at a constant body-frame twist (linear m/s, angular rad/s).
  static MotionProfile constant_twist_motion(const Eigen::Isometry3d& T_start, int64_t t0_us,
                                             int64_t t1_us, const Vector6d& twist);
  Deskewed deskew_at_twist(const Sweep& sweep, const Vector6d& twist) const;
  // The twist from the previous sweep's end to the current state (body frame).
  Vector6d measured_twist(const Sweep& sweep) const;
  // The constant body-frame twist from the previous sweep's end to `T_local_body`.
  static Vector6d twist_to(const Sweep& sweep, const Eigen::Isometry3d& T_local_body);
  // Without an IMU: twist_ from measured_twist, and the velocity from it.
  void update_twist(const Sweep& sweep);
  // The body-frame velocity averaged over the pose history's last second_guess_window_s
  // (none if it holds fewer than two poses there).
  std::optional<Eigen::Vector3d> average_body_velocity() const;
  // With update_biases false, biases and gravity keep their estimate and covariance
  // (long_gap_s).
  void update(const RegistrationResult& result, bool update_biases);
  // True if the IMU samples of (t0, t1] show a standing vehicle.
  bool standing_still(int64_t t0_us, int64_t t1_us) const;
  // The registration settings at an association radius (at least the floor,
  // registration.max_correspondence_m): above the floor the kernel widens and the
  // iterations grow (kernel_fraction, uncertain_iterations).
  RegistrationConfig registration_config(double radius_m) const;
  // How far the prediction may be off at a point correspondence_lever_m away, at
  // correspondence_sigmas.
  double prediction_reach_m() const;
  // Once a sweep shows the LiDAR's elevation steps near its horizon: lowers
  // registration.min_incidence_cos by them (grazing_ring_spacings, or _without_imu) and sets
  // registration.far_ceiling_beyond_m (far_ceilings_left_out, or _without_imu); says what
  // it chose.
  std::string adapt_to_rings(const LidarScan& scan);
  // The same for a pose covariance (translation, rotation).
  double reach_of(const Matrix6d& pose_covariance) const;
  // What the constant-velocity model leaves uncertain in the pose over dt_s (variances,
  // translation then rotation): the LiDAR-only prediction's process noise.
  Vector6d constant_velocity_variance(double dt_s) const;
  // At most max_registration_points of them, evenly spaced.
  std::vector<Eigen::Vector3f> registration_points(
      const std::vector<Eigen::Vector3f>& points) const;
  // Registration from the starts of correlative searches around each guess (within
  // reach_m, prediction_reach_m(); each guess is the prior of its starts' refinement): the
  // answer pick_search_answer takes by its points within search_inlier_m of the map and its
  // prior (search_tie_fraction, search_tie_odds; with `settle`, settled with the normal
  // kernel: search_settle_after_s), and how well it is confirmed.
  struct SearchOutcome {
    RegistrationResult result;
    double inlier_ratio = 0.0;
    int agreeing_starts = 0;       // starts that converged to the answer
    double runner_up_ratio = 0.0;  // the best answer elsewhere
    // The runner-up discounted by how much less likely its guess's prior makes it than the
    // answer (the ratio of their densities exp(-d^2 / 2), d: the Mahalanobis distance from
    // the guess), never raised: the prior decides between answers that fit alike, not
    // against one that fits several times more points.
    double weighted_runner_up = 0.0;
  };
  // What the searched points are: one sweep, seen from the LiDAR, or a local map, seen from
  // wherever the body was (whose points' side of a wall the LiDAR now cannot tell).
  enum class SearchSource { kSweep, kLocalMap };
  SearchOutcome register_by_search(const VoxelHashMap& target,
                                   const std::vector<Eigen::Vector3f>& source,
                                   SearchSource source_kind, const std::vector<PosePrior>& guesses,
                                   double reach_m, bool settle) const;
  // At least search_min_inlier_ratio, or confirmed_inlier_ratio confirmed by
  // search_confirming_starts with no rival within search_runner_up_fraction of it (with
  // weigh_by_prior, the rival weighed: SearchOutcome::weighted_runner_up).
  bool search_accepts(const SearchOutcome& found, bool weigh_by_prior,
                      double confirmed_inlier_ratio) const;
  // The confirmed floor of a search in the current local map (young_map_inserts).
  double local_map_confirmed_inlier_ratio() const;
  // The local map of before a restart by a rejected search (reanchor_after_s).
  struct Anchor {
    VoxelHashMap map;
    Matrix6d information;             // of the pose at the (first) restart
    double reach_m = 0.0;             // the search's reach then
    int64_t first_restart_utime = 0;  // history from here on is in the new map's frame
    int64_t new_map_utime = 0;        // when the current local map started
    int attempts = 0;
    int64_t map_inserts = 0;  // its sweeps: found again, the merged map is as old as both
    // Moves the new local map's frame to where it would be had it restarted at the
    // prediction (restart_at_answer_starts): the re-anchoring's prior is centred there.
    Eigen::Isometry3d T_predicted_restarted = Eigen::Isometry3d::Identity();
  };
  // After a rejected search: keeps the local map for re-anchoring, then restarts it at the
  // current pose, which T_predicted_restarted moves to the prediction.
  void restart_keeping_anchor(const Matrix6d& information, double reach_m,
                              const Eigen::Isometry3d& T_predicted_restarted);
  // Searches for the local map in the anchor's when it is due (reanchor_after_s) and
  // moves onto it if found; est.reanchored says by how much.
  void reanchor(OdometryEstimate& est);
  // Re-expresses the state, its covariance, the pose history from since_utime on and the
  // pose bookkeeping in another local frame.
  void move_local_frame(const Eigen::Isometry3d& T_old_new, int64_t since_utime);
  // Registration of `source` (body frame) against the local map from the guess, with the
  // association radius radius_m.
  RegistrationResult register_in_local_map(const std::vector<Eigen::Vector3f>& source,
                                           const Eigen::Isometry3d& T_local_body_guess,
                                           const PosePrior& prior, double radius_m) const;
  // With the IMU: the sweep ends within imu_distrust_hold_s of a sweep that contradicted
  // the IMU, or of a reset; its prediction is then widened (outweigh_imu).
  bool imu_distrusted(const Sweep& sweep) const;
  // The normalized innovation squared of a registration that had the prediction as its
  // prior: the LiDAR's own pose, recovered from the posterior, against the prediction.
  double innovation_nis(const RegistrationResult& result) const;
  // With the IMU: where the registration contradicts the prediction (imu_consistency_nis),
  // or within imu_distrust_hold_s of such a sweep, registers again from a widened
  // prediction; there and where the fit collapsed (fit_collapse_fraction) the sweep's own
  // motion (register_own_motion) replaces the sweep and its result if it fits better.
  // est.imu_disagreement says by how much.
  RegistrationResult outweigh_imu(Sweep& sweep, const std::vector<Eigen::Vector3f>& source,
                                  PosePrior prior, double reach_m, RegistrationResult result,
                                  OdometryEstimate& est);
  // The sweep deskewed, predicted and registered with the LiDAR's own last twist (twist_)
  // and a LiDAR-only prediction's spread: the hypothesis that the IMU's motion is wrong.
  struct OwnMotion {
    MotionProfile motion;
    std::vector<Eigen::Vector3f> points_body;
    RegistrationResult result;
    double inlier_ratio = 0.0;  // of the registered points, within search_inlier_m of the map
  };
  OwnMotion register_own_motion(const Sweep& sweep, double reach_m) const;
  // With the IMU: a sweep's inlier ratio below fit_collapse_fraction of the median over the
  // last weak_fit_window_s (at least 10 sweeps).
  bool fit_collapsed(int64_t now_us, double inlier_ratio) const;
  // The share of `source` (body frame) within search_inlier_m of the local map at the pose.
  double inlier_ratio(const Eigen::Isometry3d& T_local_body,
                      const std::vector<Eigen::Vector3f>& source) const;
  // Points of `source` (body frame) within search_inlier_m of a map point at pose T.
  int inliers(const VoxelHashMap& target, const Eigen::Isometry3d& T_target_body,
              const std::vector<Eigen::Vector3f>& source) const;
  // Adds to the predicted covariance what an acceleration and an angular rate uncertain by
  // accel_mps2 and gyro_rps over dt_s leave in the pose and velocity.
  void widen_prediction(double accel_mps2, double gyro_rps, double dt_s);
  struct HealthProblem {
    std::string reason;
    bool local_map_suspect = false;  // not the IMU's motion: the local map restarts
  };
  // Why the state after this sweep's update is not trusted (nullopt if it is); the pose
  // before the update was p_predicted.
  std::optional<HealthProblem> health_problem(const Sweep& sweep,
                                              const Eigen::Vector3d& p_predicted);
  // The medians of the sweeps over the last weak_fit_window_s, if that window lies on the
  // current local map and holds at least 10 sweeps; drops older entries of recent_fits_.
  struct WindowFit {
    int correspondences = 0;
    double inlier_ratio = 0.0;
  };
  std::optional<WindowFit> window_fit(int64_t now_us);
  // The fewest sweeps a window's median or share is taken over (window_fit, fit_collapsed,
  // imu_overruled_fraction): after a pause of seconds a window may hold one.
  static constexpr size_t kMinWindowSweeps = 10;
  // The share of the sweeps over the last imu_fault_window_s (if the window is full and
  // holds at least 10) on which the LiDAR overruled the IMU; drops older verdicts.
  std::optional<double> imu_overruled_fraction(int64_t now_us);
  // With the IMU: lost (est.lost_reason, no reset) when the LiDAR overruled the IMU on
  // imu_fault_fraction of the sweeps over imu_fault_window_s.
  void report_lasting_imu_fault(const Sweep& sweep, OdometryEstimate& est);
  // Back to the sweep's starting pose with the last trusted velocity (health_problem), and
  // a new local map if restart_map.
  void reset_to(const Sweep& sweep, bool restart_map);
  void restart_local_map();
  void zero_velocity_update();
  void blend_correction();
  std::optional<Eigen::Isometry3d> pose_in_history(int64_t utime_us) const;
  Eigen::Isometry3d T_local_body() const;
  void set_T_local_body(const Eigen::Isometry3d& T_local_body);

  OdometryConfig config_;
  bool adapted_to_rings_ = false;
  Eigen::Isometry3d T_body_lidar_;
  ImuBuffer imu_;
  std::deque<LidarScan> scans_;
  VoxelHashMap map_;
  // While the extrinsic check gathers motion: a LiDAR-only twin whose poses owe nothing to
  // the IMU (the filter's own poses follow the IMU wherever registration is weak, and so
  // would agree with a wrong extrinsic).
  std::optional<ExtrinsicCheck> extrinsic_check_;
  std::unique_ptr<LidarInertialOdometry> lidar_only_;
  mutable OdometryCounters counters_;

  bool initialized_ = false;
  int64_t state_utime_ = 0;  // time of x_ (end of the last sweep)
  int64_t last_scan_end_utime_ = 0;
  int64_t last_registered_utime_ = 0;
  NavState x_;
  StateMatrix P_ = StateMatrix::Identity();
  // The twist of the last sweep-to-sweep motion (body frame): the LiDAR-only prediction,
  // and with the IMU the motion that a distrusted IMU is checked against.
  Vector6d twist_ = Vector6d::Zero();
  Eigen::Vector3d last_omega_ = Eigen::Vector3d::Zero();

  Eigen::Isometry3d T_odom_local_ = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> T_odom_local_target_;
  std::deque<HistoryEntry> history_;

  int64_t map_inserts_ = 0;  // sweeps inserted into the current local map (young_map_inserts)
  Eigen::Isometry3d last_insert_T_local_body_ = Eigen::Isometry3d::Identity();
  bool have_keyframe_ = false;
  Eigen::Isometry3d last_keyframe_T_local_body_ = Eigen::Isometry3d::Identity();
  int64_t next_keyframe_id_ = 0;
  int64_t sweeps_since_cleanup_ = 0;
  int64_t degenerate_since_us_ = std::numeric_limits<int64_t>::max();  // the streak's start
  // Correspondences and inlier ratios of the sweeps registered on the current local map
  // while moving, with their end times, over the last weak_fit_window_s (health_problem,
  // fit_collapsed).
  struct RecentFit {
    int64_t utime_us = 0;
    int correspondences = 0;
    double inlier_ratio = 0.0;  // with the IMU (OdometryEstimate::inlier_ratio)
  };
  std::deque<RecentFit> recent_fits_;
  // Whether the LiDAR overruled the IMU, per sweep since the last health reset, over the
  // last imu_fault_window_s (utime, overruled).
  std::deque<std::pair<int64_t, bool>> recent_imu_verdicts_;
  // The RMS residuals (m) of the last sweeps registered without an IMU (poor_fit_window).
  std::deque<double> recent_fitness_m_;
  // Without an IMU: whether a sweep registered from the prediction with this residual fits
  // far worse than the sweeps before it (poor_fit_factor); remembers it if not.
  bool fits_far_worse(double rms_residual_m);
  // The median of recent_fitness_m_ once half a window is known.
  std::optional<double> usual_fit_m() const;
  // Whether the residual exceeds `factor` times usual_fit_m() (once known) and `floor_m`.
  bool fits_worse_than_usual(double rms_residual_m, double factor, double floor_m) const;
  // A sweep that fit worse deskewed and registered again along the motion registration
  // measured (poor_fit_deskew_passes); the pass that fits best, with the sweep's points,
  // motion and registration points (`source`), or `result`.
  RegistrationResult deskew_poor_fit(Sweep& sweep, std::vector<Eigen::Vector3f>& source,
                                     const PosePrior& prior, double radius_m,
                                     RegistrationResult result);
  // A sweep after a pause without an IMU registered with the correction to its deskew's
  // twist (own_twist_after_gap), deskewed and registered again along its own twist (kept in
  // sweep.own_twist); with the sweep's points, motion and registration points (`source`).
  RegistrationResult register_with_own_twist(Sweep& sweep, std::vector<Eigen::Vector3f>& source,
                                             const PosePrior& prior, double radius_m,
                                             const RegistrationResult& result);
  // A sweep that fit far worse registered again by a search around the prediction
  // (poor_fit_factor); the search's answer where more of its points fit, else `result`.
  RegistrationResult search_poor_fit(const std::vector<Eigen::Vector3f>& source,
                                     const PosePrior& prior, RegistrationResult result);
  // The IMU's prediction is widened for the sweeps ending up to here (outweigh_imu, and
  // after a reset).
  int64_t imu_distrusted_until_us_ = std::numeric_limits<int64_t>::min();
  // The velocity after the last sweep that agreed with the IMU and was healthy (reset_to).
  Eigen::Vector3d trusted_velocity_ = Eigen::Vector3d::Zero();
  std::optional<Anchor> anchor_;
  std::string last_failure_;
};

}  // namespace liloc
