#include "factors/marginalization.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "factors/se3_manifold.hpp"
#include "math/se3.hpp"

namespace liloc {
namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Eigenvalues below this (relative to the largest) are directions the factors do not observe.
constexpr double kRelativeEigenFloor = 1e-10;

struct Linearized {
  Eigen::VectorXd r;
  std::vector<Eigen::MatrixXd> J;  // tangent, per block
};

// A factor at its blocks' current values, with its loss applied as Ceres applies it
// (Triggs' correction: the loss's curvature enters the Jacobian).
Linearized linearize(const FactorRecord& f) {
  const int m = f.cost->num_residuals();
  std::vector<const double*> parameters;
  std::vector<RowMajorMatrix> J_ambient;
  std::vector<double*> jacobians;
  for (const StateBlock& b : f.blocks) {
    parameters.push_back(b.data);
    J_ambient.emplace_back(m, b.size);
  }
  for (RowMajorMatrix& J : J_ambient) {
    jacobians.push_back(J.data());
  }
  Linearized out;
  out.r.resize(m);
  if (!f.cost->Evaluate(parameters.data(), out.r.data(), jacobians.data())) {
    throw std::runtime_error("marginalization: a factor could not be evaluated");
  }
  double residual_scaling = 1.0, alpha_over_sq_norm = 0.0, sqrt_rho1 = 1.0;
  if (f.loss) {
    const double sq_norm = out.r.squaredNorm();
    double rho[3];
    f.loss->Evaluate(sq_norm, rho);
    sqrt_rho1 = std::sqrt(rho[1]);
    residual_scaling = sqrt_rho1;
    if (sq_norm > 0.0 && rho[2] > 0.0) {
      const double alpha = 1.0 - std::sqrt(1.0 + 2.0 * sq_norm * rho[2] / rho[1]);
      residual_scaling = sqrt_rho1 / (1.0 - alpha);
      alpha_over_sq_norm = alpha / sq_norm;
    }
  }
  for (size_t i = 0; i < f.blocks.size(); ++i) {
    Eigen::MatrixXd J = J_ambient[i];
    if (f.loss) {
      J = sqrt_rho1 * (J - alpha_over_sq_norm * out.r * (out.r.transpose() * J));
    }
    out.J.push_back(tangent_jacobian(J, f.blocks[i].data, f.blocks[i].pose));
  }
  out.r *= residual_scaling;
  return out;
}

bool touches(const FactorRecord& f, const std::vector<const double*>& blocks) {
  return std::any_of(f.blocks.begin(), f.blocks.end(), [&](const StateBlock& b) {
    return std::find(blocks.begin(), blocks.end(), b.data) != blocks.end();
  });
}

// The prior's cost for Ceres: blocks of the kept states, their ambient Jacobians from the
// tangent ones (a pose's through Se3Manifold's MinusJacobian; dx's own Jacobian, the
// inverse right Jacobian of SO(3), is taken as identity as in VINS-Mono's prior).
class MarginalPriorCost final : public ceres::CostFunction {
 public:
  explicit MarginalPriorCost(std::shared_ptr<const MarginalPrior> prior)
      : prior_(std::move(prior)) {
    set_num_residuals(prior_->rank());
    for (const StateBlock& b : prior_->blocks()) {
      mutable_parameter_block_sizes()->push_back(b.size);
    }
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Eigen::Map<Eigen::VectorXd>(residuals, num_residuals()) = prior_->residual_at(parameters);
    if (jacobians == nullptr) {
      return true;
    }
    int column = 0;
    for (size_t i = 0; i < prior_->blocks().size(); ++i) {
      const StateBlock& b = prior_->blocks()[i];
      if (jacobians[i] != nullptr) {
        Eigen::Map<RowMajorMatrix>(jacobians[i], num_residuals(), b.size) = ambient_jacobian(
            prior_->jacobian().middleCols(column, b.tangent_size()), parameters[i], b.pose);
      }
      column += b.tangent_size();
    }
    return true;
  }

 private:
  std::shared_ptr<const MarginalPrior> prior_;
};

}  // namespace

MarginalPrior::MarginalPrior(std::vector<StateBlock> blocks,
                             std::vector<std::vector<double>> linearization, Eigen::MatrixXd J,
                             Eigen::VectorXd r)
    : blocks_(std::move(blocks)),
      linearization_(std::move(linearization)),
      J_(std::move(J)),
      r_(std::move(r)) {}

Eigen::VectorXd MarginalPrior::residual_at(double const* const* parameters) const {
  Eigen::VectorXd dx(J_.cols());
  int column = 0;
  for (size_t i = 0; i < blocks_.size(); ++i) {
    const StateBlock& b = blocks_[i];
    const double* x0 = linearization_[i].data();
    if (b.pose) {
      dx.segment<6>(column) = se3::minus(pose_of(parameters[i]), pose_of(x0));
    } else {
      for (int k = 0; k < b.size; ++k) {
        dx(column + k) = parameters[i][k] - x0[k];
      }
    }
    column += b.tangent_size();
  }
  return r_ + J_ * dx;
}

Eigen::VectorXd MarginalPrior::residual() const {
  std::vector<const double*> parameters;
  for (const StateBlock& b : blocks_) {
    parameters.push_back(b.data);
  }
  return residual_at(parameters.data());
}

FactorRecord MarginalPrior::factor() const {
  FactorRecord f;
  f.cost = std::make_shared<MarginalPriorCost>(shared_from_this());
  f.blocks = blocks_;
  return f;
}

std::shared_ptr<MarginalPrior> marginalize(const std::vector<FactorRecord>& factors,
                                           const std::vector<const double*>& dropped) {
  // The blocks involved: dropped ones first, then the kept ones, each with its offset.
  std::vector<StateBlock> blocks;
  std::map<const double*, int> offset;
  int dropped_size = 0, size = 0;
  size_t dropped_blocks = 0;
  for (const bool drop : {true, false}) {
    for (const FactorRecord& f : factors) {
      if (!touches(f, dropped)) {
        continue;
      }
      for (const StateBlock& b : f.blocks) {
        const bool is_dropped = std::find(dropped.begin(), dropped.end(), b.data) != dropped.end();
        if (is_dropped == drop && offset.emplace(b.data, size).second) {
          blocks.push_back(b);
          size += b.tangent_size();
        }
      }
    }
    if (drop) {
      dropped_size = size;
      dropped_blocks = blocks.size();
    }
  }
  if (size == dropped_size) {
    return nullptr;
  }
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(size, size);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(size);
  for (const FactorRecord& f : factors) {
    if (!touches(f, dropped)) {
      continue;
    }
    const Linearized l = linearize(f);
    for (size_t i = 0; i < f.blocks.size(); ++i) {
      const int oi = offset.at(f.blocks[i].data);
      b.segment(oi, l.J[i].cols()) += l.J[i].transpose() * l.r;
      for (size_t j = 0; j < f.blocks.size(); ++j) {
        const int oj = offset.at(f.blocks[j].data);
        H.block(oi, oj, l.J[i].cols(), l.J[j].cols()) += l.J[i].transpose() * l.J[j];
      }
    }
  }
  // Eqs. 9-10: the Schur complement of the dropped states (a pseudo-inverse, in case the
  // factors leave a dropped direction unobserved).
  const int m = dropped_size, k = size - dropped_size;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen_mm(H.topLeftCorner(m, m));
  const Eigen::VectorXd s_mm = eigen_mm.eigenvalues();
  const double floor_mm = kRelativeEigenFloor * std::max(s_mm.maxCoeff(), 1e-300);
  const Eigen::VectorXd s_inverse = (s_mm.array() > floor_mm).select(s_mm.array().inverse(), 0.0);
  const Eigen::MatrixXd H_mm_inverse =
      eigen_mm.eigenvectors() * s_inverse.asDiagonal() * eigen_mm.eigenvectors().transpose();
  const Eigen::MatrixXd H_km = H.bottomLeftCorner(k, m);
  const Eigen::MatrixXd H_star = H.bottomRightCorner(k, k) - H_km * H_mm_inverse * H_km.transpose();
  const Eigen::VectorXd b_star = b.tail(k) - H_km * H_mm_inverse * b.head(m);
  // H* = J*^T J*: J* = S^1/2 V^T over the observed directions, r* = S^-1/2 V^T b*.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(0.5 * (H_star + H_star.transpose()));
  const double floor = kRelativeEigenFloor * std::max(eigen.eigenvalues().maxCoeff(), 1e-300);
  std::vector<int> observed;
  for (int i = 0; i < k; ++i) {
    if (eigen.eigenvalues()(i) > floor) {
      observed.push_back(i);
    }
  }
  Eigen::MatrixXd J(observed.size(), k);
  Eigen::VectorXd r(observed.size());
  for (size_t row = 0; row < observed.size(); ++row) {
    const double s = eigen.eigenvalues()(observed[row]);
    const Eigen::VectorXd v = eigen.eigenvectors().col(observed[row]);
    J.row(static_cast<Eigen::Index>(row)) = std::sqrt(s) * v.transpose();
    r(static_cast<Eigen::Index>(row)) = v.dot(b_star) / std::sqrt(s);
  }
  std::vector<StateBlock> kept(blocks.begin() + static_cast<std::ptrdiff_t>(dropped_blocks),
                               blocks.end());
  std::vector<std::vector<double>> linearization;
  for (const StateBlock& s : kept) {
    linearization.emplace_back(s.data, s.data + s.size);
  }
  return std::make_shared<MarginalPrior>(std::move(kept), std::move(linearization), std::move(J),
                                         std::move(r));
}

}  // namespace liloc
