#include "psmat/iecm/free_block_solver.hpp"

#include <algorithm>
#include <cmath>

#include "psmat/iecm/cholesky.hpp"
#include "psmat/iecm/jacobian.hpp"

namespace psmat::iecm {

Index FreeBlockSolver::changes(const std::vector<Index>& free_cells) const {
  if (!valid_) return static_cast<Index>(free_cells.size());
  Index in_both = 0;
  for (Index c : free_cells) in_both += pos_[static_cast<size_t>(c)] >= 0;
  return static_cast<Index>(free_cells.size()) + size() - 2 * in_both;
}

bool FreeBlockSolver::factor(const NodalInverse& net, const Eigen::VectorXd& G,
                             const std::vector<Index>& free_cells) {
  valid_ = false;
  const Index m = static_cast<Index>(free_cells.size()), n = G.size();
  cells_ = free_cells;
  used_ = m;
  holes_ = 0;
  pos_.assign(static_cast<size_t>(n), -1);
  for (Index k = 0; k < m; ++k) pos_[static_cast<size_t>(cells_[static_cast<size_t>(k)])] = k;
  // room for cells that join later (update)
  const Index room = std::min(n, m + std::max<Index>(16, m / 4));
  if (L_.rows() < room) L_.resize(room, room);
  // a preconditioner only: where float32 round-off makes S_II indefinite (eigenvalues
  // near 1e-7 of its unit diagonal), a small diagonal shift keeps it usable, as in
  // NewtonOperator::factor
  auto block = L_.topLeftCorner(m, m);
  for (double shift = 0.0; shift <= 1e-2; shift = shift == 0.0 ? 1e-6 : shift * 100.0) {
    scaled_hadamard_block<float>(net, G, cells_, block);
    if (shift > 0) block.diagonal().array() += static_cast<float>(shift);
    if (cholesky_in_place(block)) {
      valid_ = true;
      return true;
    }
  }
  return false;
}

void FreeBlockSolver::remove_position(Index k) {
  // L = [L11 0 0; l21' l22 0; L31 l32 L33]: without row/column k the factor is [L11 0; L31 L33']
  // with L33' L33'^T = L33 L33^T + l32 l32^T, a rank-1 update.
  const Index rest = used_ - k - 1;
  if (rest > 0) {
    col_ = L_.col(k).segment(k + 1, rest);
    cholesky_rank1_update(L_.block(k + 1, k + 1, rest, rest), col_);
    L_.col(k).segment(k + 1, rest).setZero();
  }
  L_.row(k).head(k).setZero();
  L_(k, k) = 1.0f;  // an identity row: decoupled, its right-hand side is 0
}

bool FreeBlockSolver::update(const NodalInverse& net, const Eigen::VectorXd& G,
                             const std::vector<Index>& free_cells) {
  if (!valid_) return false;
  const Index n = G.size();
  mark_.assign(static_cast<size_t>(n), 0);
  Index joining = 0;
  for (Index c : free_cells) {
    mark_[static_cast<size_t>(c)] = 1;
    joining += pos_[static_cast<size_t>(c)] < 0;
  }
  if (used_ + joining > L_.rows()) {
    valid_ = false;
    return false;
  }
  for (Index k = 0; k < used_; ++k) {  // leaving: P \ I
    const Index c = cells_[static_cast<size_t>(k)];
    if (c < 0 || mark_[static_cast<size_t>(c)]) continue;
    remove_position(k);
    cells_[static_cast<size_t>(k)] = -1;
    pos_[static_cast<size_t>(c)] = -1;
    ++holes_;
  }
  for (Index c : free_cells) {  // joining: I \ P, as new last rows [l' d], L l = S_Pc
    if (pos_[static_cast<size_t>(c)] >= 0) continue;
    const Index k = used_;
    col_.resize(k);
    scaled_hadamard_column(net, G, cells_, c, col_);
    L_.topLeftCorner(k, k).triangularView<Eigen::Lower>().solveInPlace(col_);
    const double d2 = 1.0 - static_cast<double>(col_.squaredNorm());  // S has a unit diagonal
    if (!(d2 > 1e-6)) {
      valid_ = false;
      return false;
    }
    L_.row(k).head(k) = col_.transpose();
    L_(k, k) = static_cast<float>(std::sqrt(d2));
    cells_.push_back(c);
    pos_[static_cast<size_t>(c)] = k;
    ++used_;
  }
  return true;
}

void FreeBlockSolver::apply(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G,
                            const Eigen::VectorXd& v, Eigen::VectorXd& out) {
  x_ = v.cwiseProduct(i_mask_);
  op.apply(net, G, x_, Sx_);
  // on I: S v; identity rows on P \ I; 0 elsewhere
  out = i_mask_.cwiseProduct(Sx_) + p_only_.cwiseProduct(v);
}

void FreeBlockSolver::precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) {
  tmp_.resize(used_);
  for (Index k = 0; k < used_; ++k) {
    const Index c = cells_[static_cast<size_t>(k)];
    tmp_[k] = c >= 0 ? static_cast<float>(r[c]) : 0.0f;
  }
  cholesky_solve_in_place(L_.topLeftCorner(used_, used_), tmp_);
  z = i_mask_.cwiseProduct(r);  // I \ P: the unit diagonal of S
  for (Index k = 0; k < used_; ++k) {
    const Index c = cells_[static_cast<size_t>(k)];
    if (c >= 0) z[c] = tmp_[k];
  }
}

int FreeBlockSolver::solve(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G,
                           const std::vector<Index>& free_cells, const Eigen::VectorXd& b,
                           Eigen::VectorXd& y, Eigen::VectorXd& Sy, double tol, int max_iter) {
  const Index n = G.size();
  i_mask_.setZero(n);
  for (Index c : free_cells) i_mask_[c] = 1.0;
  p_only_.setZero(n);  // P \ I
  for (Index k = 0; k < used_; ++k) {
    const Index c = cells_[static_cast<size_t>(k)];
    if (c >= 0 && i_mask_[c] == 0.0) p_only_[c] = 1.0;
  }
  b_.setZero(n);
  for (Index c : free_cells) b_[c] = b[c];  // b on I, 0 on P \ I (and elsewhere)
  Sy.setZero(n);
  const int used = numerics::pcg(
      b_, y, tol, max_iter, pcg_,
      [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) { apply(op, net, G, v, out); },
      [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { precondition(r, z); },
      [&](double alpha) { Sy.noalias() += alpha * Sx_; });  // S (p on I): apply() left it in Sx_
  y = y.cwiseProduct(i_mask_);  // P \ I: the identity rows' solution is 0 up to the tolerance
  return used;
}

}  // namespace psmat::iecm
