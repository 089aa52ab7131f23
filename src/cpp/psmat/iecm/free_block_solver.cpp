#include "psmat/iecm/free_block_solver.hpp"

#include <algorithm>
#include <cmath>

#include "psmat/iecm/cholesky.hpp"
#include "psmat/iecm/jacobian.hpp"

namespace psmat::iecm {

Index FreeBlockSolver::changes(const std::vector<Index>& free_cells) const {
  if (!valid_) return static_cast<Index>(free_cells.size());
  // split: the core cells outside I at the last select (out_pos_) are not part of the
  // preconditioner's free set, so an unchanged I is no change
  Index in_both = 0, out = 0;
  for (Index c : free_cells) {
    const Index k = pos_[static_cast<size_t>(c)];
    const bool was_out = split_ && k >= 0 && k < nc_ && core_out_[static_cast<size_t>(k)];
    in_both += k >= 0 && !was_out;
  }
  if (split_) out = static_cast<Index>(out_pos_.size());
  return static_cast<Index>(free_cells.size()) + size() - out - 2 * in_both;
}

bool FreeBlockSolver::factor(const NodalInverse& net, const Eigen::VectorXd& G,
                             const std::vector<Index>& free_cells) {
  valid_ = false;
  split_ = false;
  fringe_factored_ = false;
  out_pos_.clear();
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

namespace {
// Row k of the factor L (its leading used x used corner) made an identity row: with
// L = [L11 0 0; l21' l22 0; L31 l32 L33], without row/column k the factor is [L11 0; L31 L33']
// with L33' L33'^T = L33 L33^T + l32 l32^T, a rank-1 update. work: workspace.
void decouple_row(Eigen::MatrixXf& L, Index used, Index k, Eigen::VectorXf& work) {
  const Index rest = used - k - 1;
  if (rest > 0) {
    work = L.col(k).segment(k + 1, rest);
    cholesky_rank1_update(L.block(k + 1, k + 1, rest, rest), work);
    L.col(k).segment(k + 1, rest).setZero();
  }
  L.row(k).head(k).setZero();
  L(k, k) = 1.0f;  // an identity row: decoupled, its right-hand side is 0
}
}  // namespace

void FreeBlockSolver::remove_position(Index k) { decouple_row(L_, used_, k, col_); }

bool FreeBlockSolver::update(const NodalInverse& net, const Eigen::VectorXd& G,
                             const std::vector<Index>& free_cells) {
  if (!valid_ || split_) return false;
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

bool FreeBlockSolver::factor_split(const NodalInverse& net, const Eigen::VectorXd& G,
                                   const std::vector<Index>& core,
                                   const std::vector<Index>& fringe) {
  valid_ = false;
  split_ = false;
  fringe_factored_ = false;
  out_pos_.clear();
  const Index nc = static_cast<Index>(core.size()), nf = static_cast<Index>(fringe.size());
  const Index m = nc + nf, n = G.size();
  cells_ = core;
  cells_.insert(cells_.end(), fringe.begin(), fringe.end());
  used_ = m;
  holes_ = 0;
  pos_.assign(static_cast<size_t>(n), -1);
  for (Index k = 0; k < m; ++k) pos_[static_cast<size_t>(cells_[static_cast<size_t>(k)])] = k;
  const Index room = std::min(n, m + std::max<Index>(16, m / 4));  // for cells that join
  if (L_.rows() < room) L_.resize(room, room);
  auto block = L_.topLeftCorner(m, m);
  bool ok = false;
  for (double shift = 0.0; shift <= 1e-2; shift = shift == 0.0 ? 1e-6 : shift * 100.0) {
    scaled_hadamard_block<float>(net, G, cells_, block);
    if (shift > 0) block.diagonal().array() += static_cast<float>(shift);
    if (cholesky_partial_in_place(block, nc)) {
      ok = true;
      break;
    }
  }
  if (!ok) return false;
  nc_ = nc;
  core_cells_ = core;
  fringe_ = fringe;
  fidx_.assign(static_cast<size_t>(n), -1);
  for (Index j = 0; j < nf; ++j) fidx_[static_cast<size_t>(fringe[static_cast<size_t>(j)])] = j;
  const Index froom = L_.rows() - nc;
  W_.resize(froom, nc);
  W_.topRows(nf) = L_.block(nc, 0, nf, nc);
  if (Z_.rows() < froom) Z_.resize(froom, froom);
  Z_.topLeftCorner(nf, nf).triangularView<Eigen::Lower>() = L_.block(nc, nc, nf, nf);
  yc_col_.assign(static_cast<size_t>(nc), -1);
  n_yc_ = 0;
  if (Yc_.rows() != nc) Yc_.resize(nc, std::max<Index>(64, Yc_.cols()));
  split_ = true;
  valid_ = true;
  return true;
}

Index FreeBlockSolver::core_outside(const std::vector<Index>& free_cells) const {
  if (!is_split()) return 0;
  Index in = 0;
  for (Index c : free_cells) {
    const Index k = pos_[static_cast<size_t>(c)];
    in += k >= 0 && k < nc_;
  }
  return nc_ - in;
}

bool FreeBlockSolver::select(const NodalInverse& net, const Eigen::VectorXd& G,
                             const std::vector<Index>& free_cells) {
  if (!is_split()) return false;
  const Index n = G.size();
  mark_.assign(static_cast<size_t>(n), 0);
  std::vector<Index> joining;
  for (Index c : free_cells) {
    const size_t k = static_cast<size_t>(c);
    mark_[k] = 1;
    const bool core = pos_[k] >= 0 && pos_[k] < nc_;
    if (!core && fidx_[k] < 0) joining.push_back(c);
  }
  const Index kj = static_cast<Index>(joining.size());
  // the fringe keeps every cell that joined it since the factor; out of room, it keeps those in I
  if (nc_ + static_cast<Index>(fringe_.size()) + kj > L_.rows()) compact_fringe();
  const Index nf0 = static_cast<Index>(fringe_.size());
  if (kj > 0) {  // new fringe rows: W_J = (L_CC^-1 S_CJ)^T, Z_(F+J),J = S_(F+J),J - W W_J^T
    if (nc_ + nf0 + kj > L_.rows()) {
      valid_ = false;
      return false;
    }
    for (Index c : joining) {
      fidx_[static_cast<size_t>(c)] = static_cast<Index>(fringe_.size());
      fringe_.push_back(c);
    }
    const Index nf = nf0 + kj;
    Eigen::MatrixXf B(nc_, kj), Sz(nf, kj);
    for (Index i = 0; i < kj; ++i) {
      const Index c = joining[static_cast<size_t>(i)];
      scaled_hadamard_column(net, G, core_cells_, c, B.col(i));
      scaled_hadamard_column(net, G, fringe_, c, Sz.col(i));
    }
    lower_solve_matrix(L_.topLeftCorner(nc_, nc_), B, false);
    W_.middleRows(nf0, kj) = B.transpose();
    gemm_subtract(Sz, W_.topRows(nf), B);
    for (Index i = 0; i < kj; ++i) {
      const Index j = nf0 + i;
      if (!(Sz(j, i) > 1e-6f)) {
        valid_ = false;
        return false;
      }
      Z_.row(j).head(j + 1) = Sz.col(i).head(j + 1).transpose();
    }
  }
  // the active fringe J, Z_JJ and its factor L_JJ: updated cell by cell from the last select's
  // when few fringe cells changed (update_fringe), else gathered and factorised anew
  const Index nf = static_cast<Index>(fringe_.size());
  if (!(fringe_factored_ && update_fringe())) {
    active_.clear();
    actpos_.assign(static_cast<size_t>(nf), -1);
    for (Index j = 0; j < nf; ++j)
      if (mark_[static_cast<size_t>(fringe_[static_cast<size_t>(j)])]) {
        actpos_[static_cast<size_t>(j)] = static_cast<Index>(active_.size());
        active_.push_back(j);
      }
    act_holes_ = 0;
    const Index na = static_cast<Index>(active_.size());
    reserve_fringe_factor(na);
    for (Index q = 0; q < na; ++q)
      for (Index r = q; r < na; ++r)
        Zs_(r, q) = Z_(active_[static_cast<size_t>(r)], active_[static_cast<size_t>(q)]);
    if (!cholesky_in_place(Zs_.topLeftCorner(na, na))) {
      valid_ = false;
      return false;
    }
    // the factor of S_PP, P = C + J, by blocks: [L_CC 0; W_J L_JJ] (precondition), W_J gathered
    // column by column (active_ ascends: each column of W_ read forward; row by row, every
    // element was a cache line of its own: 2.2 ms a 64x64 frame)
    for (Index k = 0; k < nc_; ++k) {
      const float* src = W_.col(k).data();
      float* dst = Wa_.col(k).data();
      for (Index r = 0; r < na; ++r) dst[r] = src[active_[static_cast<size_t>(r)]];
    }
    fringe_factored_ = true;
  }
  const Index na = static_cast<Index>(active_.size());
  used_ = nc_ + nf;
  holes_ = nf - (na - act_holes_);
  cells_.resize(static_cast<size_t>(used_));
  for (Index j = 0; j < nf; ++j) {
    const Index p = nc_ + j, c = fringe_[static_cast<size_t>(j)];
    const bool a = mark_[static_cast<size_t>(c)] != 0;
    cells_[static_cast<size_t>(p)] = a ? c : -1;
    pos_[static_cast<size_t>(c)] = a ? p : -1;
  }
  // core cells outside I: the capacitance correction (precondition)
  out_pos_.clear();
  core_out_.assign(static_cast<size_t>(nc_), 0);
  for (Index k = 0; k < nc_; ++k)
    if (!mark_[static_cast<size_t>(cells_[static_cast<size_t>(k)])]) {
      out_pos_.push_back(k);
      core_out_[static_cast<size_t>(k)] = 1;
    }
  const Index ko = static_cast<Index>(out_pos_.size());
  if (ko > 0) {
    std::vector<Index> fresh;  // core positions without their L_CC^-1 e_o yet
    for (Index k : out_pos_)
      if (yc_col_[static_cast<size_t>(k)] < 0) fresh.push_back(k);
    const Index kf = static_cast<Index>(fresh.size());
    if (kf > 0) {
      if (n_yc_ + kf > Yc_.cols()) {
        Eigen::MatrixXf grown(nc_, std::max<Index>(2 * (n_yc_ + kf), 64));
        grown.leftCols(n_yc_) = Yc_.leftCols(n_yc_);
        Yc_.swap(grown);
      }
      auto E = Yc_.middleCols(n_yc_, kf);
      E.setZero();
      for (Index i = 0; i < kf; ++i) {
        E(fresh[static_cast<size_t>(i)], i) = 1.0f;
        yc_col_[static_cast<size_t>(fresh[static_cast<size_t>(i)])] = n_yc_ + i;
      }
      lower_solve_matrix(L_.topLeftCorner(nc_, nc_), E, 0);
      n_yc_ += kf;
    }
    Y_.resize(nc_ + na, ko);  // rows: the core, then the active fringe
    for (Index i = 0; i < ko; ++i)
      Y_.col(i).head(nc_) = Yc_.col(yc_col_[static_cast<size_t>(out_pos_[static_cast<size_t>(i)])]);
    // fringe rows: L_JJ^-1 (0 - W_J Y_C)
    Y_.bottomRows(na).setZero();
    gemm_subtract(Y_.bottomRows(na), Wa_.topRows(na), Y_.topRows(nc_));
    lower_solve_matrix(Zs_.topLeftCorner(na, na), Y_.bottomRows(na), 0);
    // K in double from the float Y: the projection I - Y K^-1 Y^T stays one (positive
    // semidefinite) where K is ill-conditioned
    const Eigen::MatrixXd Yd = Y_.cast<double>();
    Eigen::MatrixXd K = Eigen::MatrixXd::Zero(ko, ko);
    K.selfadjointView<Eigen::Lower>().rankUpdate(Yd.transpose());
    K_.compute(K);
    if (K_.info() != Eigen::Success) {
      valid_ = false;
      return false;
    }
  }
  return true;
}

void FreeBlockSolver::compact_fringe() {
  // rows and columns of W and Z gathered in place (kept indices only decrease), L_JJ dropped
  const Index nf = static_cast<Index>(fringe_.size());
  keep_.resize(static_cast<size_t>(nf));
  for (Index j = 0; j < nf; ++j) keep_[static_cast<size_t>(j)] = mark_[static_cast<size_t>(fringe_[static_cast<size_t>(j)])];
  Index q2 = 0;
  for (Index q = 0; q < nf; ++q) {
    if (!keep_[static_cast<size_t>(q)]) continue;
    Index r2 = q2;
    for (Index r = q; r < nf; ++r)
      if (keep_[static_cast<size_t>(r)]) Z_(r2++, q2) = Z_(r, q);
    ++q2;
  }
  Index kept = 0;
  for (Index j = 0; j < nf; ++j) {
    const Index c = fringe_[static_cast<size_t>(j)];
    if (!keep_[static_cast<size_t>(j)]) {
      fidx_[static_cast<size_t>(c)] = -1;
      pos_[static_cast<size_t>(c)] = -1;
      continue;
    }
    fringe_[static_cast<size_t>(kept)] = c;
    fidx_[static_cast<size_t>(c)] = kept;
    ++kept;
  }
  fringe_.resize(static_cast<size_t>(kept));
  for (Index k = 0; k < nc_; ++k) {  // W's kept rows, column by column (as the gather in select)
    float* w = W_.col(k).data();
    Index r2 = 0;
    for (Index j = 0; j < nf; ++j)
      if (keep_[static_cast<size_t>(j)]) w[r2++] = w[j];
  }
  fringe_factored_ = false;
}

void FreeBlockSolver::reserve_fringe_factor(Index na) {
  // room for fringe cells that join later (update_fringe)
  const Index room = na + std::max<Index>(32, na / 4);
  if (Zs_.rows() < room) {
    Eigen::MatrixXf grown(room, room);
    grown.topLeftCorner(Zs_.rows(), Zs_.cols()) = Zs_;
    Zs_.swap(grown);
  }
  if (Wa_.rows() < room || Wa_.cols() != nc_) {
    Eigen::MatrixXf grown(room, nc_);
    if (Wa_.cols() == nc_) grown.topRows(Wa_.rows()) = Wa_;
    Wa_.swap(grown);
  }
}

bool FreeBlockSolver::update_fringe() {
  // the fringe cells that leave J and join it since the last select (mark_ holds the new I)
  const Index nf = static_cast<Index>(fringe_.size()), na = static_cast<Index>(active_.size());
  actpos_.resize(static_cast<size_t>(nf), -1);
  leaving_.clear();
  joining_.clear();
  for (Index i = 0; i < na; ++i) {
    const Index j = active_[static_cast<size_t>(i)];
    if (j >= 0 && !mark_[static_cast<size_t>(fringe_[static_cast<size_t>(j)])]) leaving_.push_back(i);
  }
  for (Index j = 0; j < nf; ++j)
    if (actpos_[static_cast<size_t>(j)] < 0 && mark_[static_cast<size_t>(fringe_[static_cast<size_t>(j)])])
      joining_.push_back(j);
  const Index changed = static_cast<Index>(leaving_.size() + joining_.size());
  if (changed > kFringeUpdateMax || act_holes_ + static_cast<Index>(leaving_.size()) > na / 4)
    return false;
  reserve_fringe_factor(na + static_cast<Index>(joining_.size()));
  // a cell that leaves: a rank-1 update of the factor below its row, which becomes an identity
  // row (a hole)
  for (Index q : leaving_) {
    decouple_row(Zs_, na, q, col_);
    Wa_.row(q).setZero();
    actpos_[static_cast<size_t>(active_[static_cast<size_t>(q)])] = -1;
    active_[static_cast<size_t>(q)] = -1;
    ++act_holes_;
  }
  // a cell that joins: a new last row [l' d], L_JJ l = Z_Jj (0 on the holes)
  for (Index j : joining_) {
    const Index p = static_cast<Index>(active_.size());
    col_.resize(p);
    for (Index i = 0; i < p; ++i) {
      const Index a = active_[static_cast<size_t>(i)];
      col_[i] = a < 0 ? 0.0f : (a > j ? Z_(a, j) : Z_(j, a));
    }
    Zs_.topLeftCorner(p, p).triangularView<Eigen::Lower>().solveInPlace(col_);
    const double d2 = static_cast<double>(Z_(j, j)) - static_cast<double>(col_.squaredNorm());
    if (!(d2 > 1e-6)) return false;  // (the caller refactorises J from the start)
    Zs_.row(p).head(p) = col_.transpose();
    Zs_(p, p) = static_cast<float>(std::sqrt(d2));
    Wa_.row(p) = W_.row(j);
    actpos_[static_cast<size_t>(j)] = p;
    active_.push_back(j);
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
  if (split_) {  // by blocks (select): the core, then the active fringe J
    const Index na = static_cast<Index>(active_.size());
    tmp_.resize(nc_ + na);
    for (Index k = 0; k < nc_; ++k) tmp_[k] = static_cast<float>(r[cells_[static_cast<size_t>(k)]]);
    for (Index i = 0; i < na; ++i) {  // a hole (update_fringe): an identity row, 0 here
      const Index j = active_[static_cast<size_t>(i)];
      tmp_[nc_ + i] = j >= 0 ? static_cast<float>(r[fringe_[static_cast<size_t>(j)]]) : 0.0f;
    }
    const auto Lc = L_.topLeftCorner(nc_, nc_);
    const auto Lj = Zs_.topLeftCorner(na, na);
    auto uc = tmp_.head(nc_);
    auto uj = tmp_.tail(na);
    lower_solve_matrix(Lc, uc, 0);
    gemv_subtract(uj, Wa_.topRows(na), uc, false);
    lower_solve_matrix(Lj, uj, 0);
    if (!out_pos_.empty()) {  // the capacitance correction (header)
      ytu_.setZero(Y_.cols());
      gemv_subtract(ytu_, Y_, tmp_, true);  // -Y^T u
      mu_ = K_.solve(-ytu_.cast<double>());
      ytu_ = mu_.cast<float>();
      gemv_subtract(tmp_, Y_, ytu_, false);
    }
    lower_solve_matrix(Lj, uj, 2);
    gemv_subtract(uc, Wa_.topRows(na), uj, true);
    lower_solve_matrix(Lc, uc, 2);
    // the core cells out: the identity rows of PCG's operator (their z is 0 up to round-off,
    // which PCG could not correct)
    for (Index k : out_pos_) tmp_[k] = static_cast<float>(r[cells_[static_cast<size_t>(k)]]);
    z = i_mask_.cwiseProduct(r);
    for (Index k = 0; k < nc_; ++k) z[cells_[static_cast<size_t>(k)]] = tmp_[k];
    for (Index i = 0; i < na; ++i) {
      const Index j = active_[static_cast<size_t>(i)];
      if (j >= 0) z[fringe_[static_cast<size_t>(j)]] = tmp_[nc_ + i];
    }
    return;
  }
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
                           Eigen::VectorXd& y, Eigen::VectorXd& Sy, double tol, int max_iter,
                           bool from_guess) {
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
  auto op_apply = [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) { apply(op, net, G, v, out); };
  auto pre = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { precondition(r, z); };
  // S (p on I): apply() left it in Sx_
  auto step = [&](double alpha) { Sy.noalias() += alpha * Sx_; };
  int used;
  if (from_guess) {
    y = y.cwiseProduct(i_mask_);  // the guess on I
    used = numerics::pcg_from(b_, y, tol, max_iter, pcg_, op_apply, pre, step, [&] { Sy = Sx_; });
  } else {
    used = numerics::pcg(b_, y, tol, max_iter, pcg_, op_apply, pre, step);
  }
  y = y.cwiseProduct(i_mask_);  // P \ I: the identity rows' solution is 0 up to the tolerance
  return used;
}

}  // namespace psmat::iecm
