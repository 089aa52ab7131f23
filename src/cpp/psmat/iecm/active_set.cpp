#include "psmat/iecm/active_set.hpp"

#include <cmath>

#include "psmat/iecm/cholesky.hpp"
#include "psmat/iecm/jacobian.hpp"

namespace psmat::iecm {

Index FreeBlockSolver::changes(const std::vector<Index>& free_cells) const {
  if (!valid_) return static_cast<Index>(free_cells.size());
  Index in_both = 0;
  for (Index c : free_cells) in_both += in_p_[static_cast<size_t>(c)];
  return static_cast<Index>(free_cells.size() + cells_.size()) - 2 * in_both;
}

bool FreeBlockSolver::factor(const NodalInverse& net, const Eigen::VectorXd& G,
                             const std::vector<Index>& free_cells, double mu) {
  valid_ = false;
  cells_ = free_cells;
  in_p_.assign(static_cast<size_t>(G.size()), 0);
  for (Index c : cells_) in_p_[static_cast<size_t>(c)] = 1;
  // a preconditioner only: where float32 round-off makes S_II + mu I indefinite (eigenvalues
  // near 1e-7 of its unit diagonal), a small diagonal shift keeps it usable, as in
  // NewtonOperator::factor
  for (double shift = 0.0; shift <= 1e-2; shift = shift == 0.0 ? 1e-6 : shift * 100.0) {
    scaled_hadamard_block(net, G, cells_, L_);
    L_.diagonal().array() += static_cast<float>(mu + shift);
    if (cholesky_in_place(L_)) {
      valid_ = true;
      return true;
    }
  }
  return false;
}

void FreeBlockSolver::apply(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G,
                            double mu, const Eigen::VectorXd& v, Eigen::VectorXd& out) {
  const Index n = v.size();
  for (Index c = 0; c < n; ++c) x_[c] = in_i_[static_cast<size_t>(c)] ? v[c] : 0.0;
  op.apply(net, G, x_, Sx_);
  for (Index c = 0; c < n; ++c) {
    const size_t k = static_cast<size_t>(c);
    out[c] = in_i_[k] ? Sx_[c] + mu * v[c] : (in_p_[k] ? v[c] : 0.0);  // identity rows: P \ I
  }
}

void FreeBlockSolver::precondition(const Eigen::VectorXd& r, double mu, Eigen::VectorXd& z) {
  const Index m = static_cast<Index>(cells_.size());
  tmp_.resize(m);
  for (Index k = 0; k < m; ++k) tmp_[k] = static_cast<float>(r[cells_[static_cast<size_t>(k)]]);
  L_.triangularView<Eigen::Lower>().solveInPlace(tmp_);
  L_.triangularView<Eigen::Lower>().transpose().solveInPlace(tmp_);
  for (Index c = 0; c < r.size(); ++c)  // I \ P: the unit diagonal of S
    z[c] = in_i_[static_cast<size_t>(c)] ? r[c] / (1.0 + mu) : 0.0;
  for (Index k = 0; k < m; ++k) z[cells_[static_cast<size_t>(k)]] = tmp_[k];
}

int FreeBlockSolver::solve(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G,
                           const std::vector<Index>& free_cells, double mu,
                           const Eigen::VectorXd& b, Eigen::VectorXd& y, Eigen::VectorXd& Sy,
                           double tol, int max_iter) {
  const Index n = G.size();
  in_i_.assign(static_cast<size_t>(n), 0);
  for (Index c : free_cells) in_i_[static_cast<size_t>(c)] = 1;
  x_.resize(n);
  r_.setZero(n);
  for (Index c : free_cells) r_[c] = b[c];  // y = 0: residual = b on I, 0 on P \ I
  z_.resize(n);
  q_.resize(n);
  y.setZero(n);
  Sy.setZero(n);
  const double bnorm = r_.norm();
  if (bnorm == 0.0) return 0;
  precondition(r_, mu, z_);
  p_ = z_;
  double rz = r_.dot(z_);
  int used = -1;
  for (int k = 1; k <= max_iter; ++k) {
    apply(op, net, G, mu, p_, q_);
    const double pq = p_.dot(q_);
    if (!(pq > 0.0) || !std::isfinite(pq)) break;  // breakdown
    const double alpha = rz / pq;
    y.noalias() += alpha * p_;
    Sy.noalias() += alpha * Sx_;  // S (p_ on I): apply() left it there
    r_.noalias() -= alpha * q_;
    if (r_.norm() <= tol * bnorm) {
      used = k;
      break;
    }
    precondition(r_, mu, z_);
    const double rz_new = r_.dot(z_);
    p_ = z_ + (rz_new / rz) * p_;
    rz = rz_new;
  }
  for (Index c = 0; c < n; ++c)  // P \ I: the identity rows' solution is 0 up to the tolerance
    if (!in_i_[static_cast<size_t>(c)]) y[c] = 0.0;
  return used;
}

}  // namespace psmat::iecm
