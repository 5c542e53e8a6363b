#pragma once
// Marginalization by the Schur complement (paper Eqs. 9-10): the factors that touch the
// states leaving a sliding window are linearized at the current estimate,
//   H = sum J^T J,  b = sum J^T r   over [dropped | kept] tangent coordinates,
//   H* = H_kk - H_km H_mm^-1 H_mk,   b* = b_k - H_km H_mm^-1 b_m,
// and replaced by one prior on the kept states, 0.5 |J* dx + r*|^2 with J*^T J* = H* and
// J*^T r* = b*, dx the kept blocks' tangent offsets from their linearization point (right
// perturbation for poses, as Se3Manifold). Robust losses enter as Ceres applies them
// (Triggs' correction), so the prior carries what the optimizer saw.

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <Eigen/Core>
#include <map>
#include <memory>
#include <vector>

namespace liloc {

// A parameter block as the marginalization sees it: its memory, its size, and whether it
// is a pose (Se3Manifold: 7 ambient, 6 tangent) or a plain vector.
struct StateBlock {
  double* data = nullptr;
  int size = 0;
  bool pose = false;
  int tangent_size() const { return pose ? 6 : size; }
};

// A factor: its cost, its loss (null for none) and its blocks, in the cost's order.
struct FactorRecord {
  std::shared_ptr<ceres::CostFunction> cost;
  std::shared_ptr<ceres::LossFunction> loss;
  std::vector<StateBlock> blocks;
};

// The prior that marginalization leaves on the kept blocks.
class MarginalPrior : public std::enable_shared_from_this<MarginalPrior> {
 public:
  MarginalPrior(std::vector<StateBlock> blocks, std::vector<std::vector<double>> linearization,
                Eigen::MatrixXd J, Eigen::VectorXd r);
  const std::vector<StateBlock>& blocks() const { return blocks_; }
  // The residual and its Jacobian (tangent) at the blocks' current values.
  Eigen::VectorXd residual() const;
  const Eigen::MatrixXd& jacobian() const { return J_; }
  int rank() const { return static_cast<int>(J_.rows()); }
  // As a factor for Ceres (it points at the blocks' memory). The prior must be owned by a
  // shared_ptr (marginalize() returns one).
  FactorRecord factor() const;
  // The residual at the given blocks' values (in blocks() order).
  Eigen::VectorXd residual_at(double const* const* parameters) const;

 private:
  std::vector<StateBlock> blocks_;
  std::vector<std::vector<double>> linearization_;  // the blocks' values when marginalized
  Eigen::MatrixXd J_;
  Eigen::VectorXd r_;
};

// Marginalizes `dropped` (block memory) out of `factors` (those touching a dropped block;
// others are ignored). Returns the prior on the remaining blocks those factors touch, or null
// when they touch none.
std::shared_ptr<MarginalPrior> marginalize(const std::vector<FactorRecord>& factors,
                                           const std::vector<const double*>& dropped);

}  // namespace liloc
