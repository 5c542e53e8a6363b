#include "factors/se3_manifold.hpp"

#include "math/se3.hpp"

namespace liloc {
namespace {

using Matrix76 = Eigen::Matrix<double, 7, 6, Eigen::RowMajor>;
using Matrix67 = Eigen::Matrix<double, 6, 7, Eigen::RowMajor>;

// d(q * (v/2, 1)) / dv at v = 0, rows x, y, z, w: half of [w I + [q_v]x ; -q_v^T].
Eigen::Matrix<double, 4, 3> quaternion_plus_jacobian(const double* q) {
  const Eigen::Vector3d v(q[0], q[1], q[2]);
  const double w = q[3];
  Eigen::Matrix<double, 4, 3> J;
  J.topRows<3>() << w, -v.z(), v.y(),  //
      v.z(), w, -v.x(),                //
      -v.y(), v.x(), w;
  J.row(3) = -v.transpose();
  return 0.5 * J;
}

Matrix76 plus_jacobian(const double* x) {
  Matrix76 J = Matrix76::Zero();
  J.topLeftCorner<3, 3>() = pose_of(x).linear();
  J.bottomRightCorner<4, 3>() = quaternion_plus_jacobian(x + 3);
  return J;
}

Matrix67 minus_jacobian(const double* x) {
  // The columns of the quaternion part are orthogonal with norm 1/2 (q is a unit
  // quaternion), so its left inverse is 4 times its transpose.
  const Matrix76 P = plus_jacobian(x);
  Matrix67 M = Matrix67::Zero();
  M.topLeftCorner<3, 3>() = P.topLeftCorner<3, 3>().transpose();
  M.bottomRightCorner<3, 4>() = 4.0 * P.bottomRightCorner<4, 3>().transpose();
  return M;
}

}  // namespace

PoseBlock pose_block(const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  return {
      T.translation().x(), T.translation().y(), T.translation().z(), q.x(), q.y(), q.z(), q.w()};
}

Eigen::Isometry3d pose_of(const double* block) {
  const Eigen::Quaterniond q(block[6], block[3], block[4], block[5]);
  return se3::make(q, Eigen::Vector3d(block[0], block[1], block[2]));
}

bool Se3Manifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const PoseBlock result = pose_block(se3::plus(pose_of(x), Eigen::Map<const Vector6d>(delta)));
  std::copy(result.begin(), result.end(), x_plus_delta);
  return true;
}

bool Se3Manifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Matrix76> J(jacobian);
  J = plus_jacobian(x);
  return true;
}

bool Se3Manifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  Eigen::Map<Vector6d> delta(y_minus_x);
  delta = se3::minus(pose_of(y), pose_of(x));
  return true;
}

bool Se3Manifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Matrix67> J(jacobian);
  J = minus_jacobian(x);
  return true;
}

Eigen::MatrixXd tangent_jacobian(const Eigen::MatrixXd& J_ambient, const double* x, bool pose) {
  return pose ? Eigen::MatrixXd(J_ambient * plus_jacobian(x)) : J_ambient;
}

Eigen::MatrixXd ambient_jacobian(const Eigen::MatrixXd& J_tangent, const double* x, bool pose) {
  return pose ? Eigen::MatrixXd(J_tangent * minus_jacobian(x)) : J_tangent;
}

}  // namespace liloc
