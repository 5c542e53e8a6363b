#pragma once
// Scan-to-map registration by point-to-plane distances (paper Eq. 6): every source point
// is matched to the plane through its five nearest map points; the pose minimizing the
// weighted distances (plus an optional Gaussian prior on the pose, which is how the
// odometry's Kalman update and the constant-velocity model enter) is found by
// Levenberg-Marquardt on SE(3), re-associating between iterations.
//
// Frames: the source cloud (a sweep, in its body frame) is registered to the target (a
// map); the result is T_target_source. Information matrices and priors are over the right
// perturbation of T_target_source, liloc's one tangent convention (math/se3.hpp).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "math/se3.hpp"
#include "voxel_map/voxel_hash_map.hpp"

namespace liloc {

struct RegistrationConfig {
  int max_iterations = 8;               // Gauss-Newton / LM steps
  int max_associations = 3;             // nearest-neighbour searches (the first iterations)
  double max_correspondence_m = 0.5;    // search radius of the 5 nearest neighbours
  double max_plane_thickness_m = 0.05;  // every neighbour within this of the fitted plane
  // Second over largest eigenvalue of the neighbours' scatter: below, they lie on a band
  // rather than a patch. A 16-ring LiDAR sees the ground in rings; nearby sweeps stack
  // them into narrow bands whose fitted planes tilt, and at 0.25 those pulled a VLP-16
  // run behind its motion until it diverged (docs/odometry.md).
  double min_planarity = 0.4;
  double cauchy_scale_m = 0.1;  // robust kernel: residuals well beyond are discounted
  // A plane seen nearly edge-on (|normal . ray| below this) is not used: along the ray
  // the sensor's own range noise spreads points into false planes (see fit_plane).
  double min_incidence_cos = 0.1;
  // When true, a point is not matched to a plane whose map points (where the map knows
  // their view directions) were seen from the other side: within the association radius
  // the two faces of a thin wall pull the sweep by the wall's thickness (Mid-360 after a
  // 5.1 s gap: 0.13 m; docs/odometry.md, "The other face of a thin wall"). Needs points
  // seen from one place, the sensor's at sensor_origin_source.
  bool reject_back_faces = true;
  // A point within this of the plane is refused only by its views, not by where it lies:
  // a point on a thin wall's other face lies the wall's thickness off (0.18-0.3 m in the
  // simulated worlds), while the points of the Mid-360's corridor refused within 5 cm
  // (1532 of 3318) were sides misjudged at a plane's edge, and without them the corridor
  // slid along its axis (docs/odometry.md). Only where the start is known to about this:
  // the odometry uses 0 (the views alone) where its prediction needs a wider radius than
  // max_correspondence_m (after a gap, a search's start a cell off).
  double back_face_min_offset_m = 0.1;
  // A plane within 60 degrees of level above the sensor (a ceiling: the underside of a
  // canopy or a tree crown) farther than this from it (horizontally) is not matched. Beyond
  // the range where a ring LiDAR's rings near its horizon lie more than an association
  // radius apart, the map holds such surfaces as one ring of successive sweeps, and they
  // tilted every VLP-16 campus run by 0.4-1.5 degrees in its first 50 m, which the map then
  // kept; far walls were measured not to (docs/odometry.md, "Far ceilings and the tilt").
  // 0: every ceiling is matched.
  double far_ceiling_beyond_m = 0.0;
  double point_sigma_m = 0.05;  // point-to-plane noise, sets the information scale
  double convergence_translation_m = 1e-3;
  double convergence_rotation_rad = 1e-4;
  // Degenerate: the weakest translation (rotation) direction carries less than this
  // fraction of the strongest one's information.
  double degeneracy_ratio = 0.02;
  int threads = 1;

  template <class V>
  void visit_fields(V& v) {
    v("max_iterations", max_iterations);
    v("max_associations", max_associations);
    v("max_correspondence_m", max_correspondence_m);
    v("max_plane_thickness_m", max_plane_thickness_m);
    v("min_planarity", min_planarity);
    v("cauchy_scale_m", cauchy_scale_m);
    v("min_incidence_cos", min_incidence_cos);
    v("reject_back_faces", reject_back_faces);
    v("back_face_min_offset_m", back_face_min_offset_m);
    v("far_ceiling_beyond_m", far_ceiling_beyond_m);
    v("point_sigma_m", point_sigma_m);
    v("convergence_translation_m", convergence_translation_m);
    v("convergence_rotation_rad", convergence_rotation_rad);
    v("degeneracy_ratio", degeneracy_ratio);
    v("threads", threads);
  }
  void validate() const;
};

// Registration coarse to fine, one entry per stage: the voxel of the target (and of the
// source's downsampling), the association radius and the plane thickness; the first stages
// pull a start metres off into the basin of the last.
struct RegistrationStages {
  std::vector<double> voxel_m;
  std::vector<double> correspondence_m;
  std::vector<double> plane_thickness_m;

  size_t size() const { return voxel_m.size(); }
  // `base` with stage s's association radius and plane thickness.
  RegistrationConfig stage(size_t s, const RegistrationConfig& base) const {
    RegistrationConfig c = base;
    c.max_correspondence_m = correspondence_m[s];
    c.max_plane_thickness_m = plane_thickness_m[s];
    return c;
  }
  template <class V>
  void visit_fields(V& v) {
    v("voxel_m", voxel_m);
    v("correspondence_m", correspondence_m);
    v("plane_thickness_m", plane_thickness_m);
  }
  void validate() const;
};

// A Gaussian prior on the pose: mean and information (6x6, right perturbation at the mean).
struct PosePrior {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  Matrix6d information = Matrix6d::Zero();
};

struct RegistrationResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  // Information of the point-to-plane residuals alone (no prior) at the solution, over the
  // right perturbation of T_target_source.
  Matrix6d information = Matrix6d::Zero();
  int iterations = 0;
  int correspondences = 0;      // points matched to a valid plane in the last iteration
  double rms_residual_m = 0.0;  // fitness: RMS point-to-plane distance of the matches
  // The last step was below the convergence thresholds. False when the iterations ran out
  // or Levenberg-Marquardt stalled (no damped step lowered the cost while the undamped
  // one was still large): the pose is then the last one that lowered the cost.
  bool converged = false;
  bool degenerate = false;
  // Smallest / largest eigenvalue of the translation and rotation blocks of
  // `information` (the degeneracy measure).
  double translation_eigen_ratio = 0.0;
  double rotation_eigen_ratio = 0.0;

  // `information` as if from at most `independent` independent matches: the matches share
  // planes, so counting each as independent overstates what the pose is known to.
  Matrix6d independent_information(int independent) const;
};

// A plane n.x + d = 0 through neighbouring points, if they are planar enough.
struct Plane {
  Eigen::Vector3d normal;  // unit
  double offset;           // d
  double thickness_m;      // largest point distance from the plane
};
std::optional<Plane> fit_plane(const Eigen::Vector3f* points, int count, double max_thickness_m,
                               double min_planarity);

// The directions a registration determines: the projector (6x6, right perturbation) onto the
// eigenvectors of the information's translation and rotation blocks whose eigenvalue is at
// least degeneracy_ratio of the block's largest. Identity for a well-constrained
// registration; in a corridor it drops the tunnel's axis.
Matrix6d constrained_directions(const Matrix6d& information, double degeneracy_ratio);

// Registers source points (source frame; measured from sensor_origin_source) to the
// target map, starting at T_target_source_guess.
RegistrationResult register_point_to_plane(
    const std::vector<Eigen::Vector3f>& source, const VoxelHashMap& target,
    const Eigen::Isometry3d& T_target_source_guess, const std::optional<PosePrior>& prior,
    const RegistrationConfig& config,
    const Eigen::Vector3d& sensor_origin_source = Eigen::Vector3d::Zero());

// A sweep deskewed with a twist in doubt (without an IMU, after a gap: the twist of before
// it) is registered together with the correction to that twist its own points show: point i,
// tau_s[i] (<= 0) before the sweep's end, moves to first order by tau (v + omega x p), which a
// pose alone cannot absorb. twist_information is a zero-mean prior on the correction.
struct TwistRegistrationResult {
  RegistrationResult pose;  // T_target_source at the sweep's end
  // Body frame at the sweep's end: [v (m/s); omega (rad/s)], to add to the deskew's twist.
  Vector6d twist_correction = Vector6d::Zero();
  Matrix6d twist_information = Matrix6d::Zero();  // of the residuals alone, the pose held
};
TwistRegistrationResult register_point_to_plane_with_twist(
    const std::vector<Eigen::Vector3f>& source, const std::vector<double>& tau_s,
    const VoxelHashMap& target, const Eigen::Isometry3d& T_target_source_guess,
    const std::optional<PosePrior>& prior, const Matrix6d& twist_information,
    const RegistrationConfig& config,
    const Eigen::Vector3d& sensor_origin_source = Eigen::Vector3d::Zero());

}  // namespace liloc
