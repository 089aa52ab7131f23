// Float32 Cholesky factors of the preconditioners (the free block of S in free_block_solver.hpp,
// all of S in newton_operator.hpp), with Eigen's public API only.
#pragma once
#include <Eigen/Dense>

namespace psmat::iecm {

// In place: the lower triangle of A in, L (L L^T = A) out in it; the strict upper triangle is
// neither read nor kept. False where A is not numerically SPD.
bool cholesky_in_place(Eigen::Ref<Eigen::MatrixXf> A);

// Rank-1 update of a lower Cholesky factor in place: L L^T + w w^T = L' L'^T, L' into L (its
// strict upper triangle untouched); w is used as workspace (overwritten).
void cholesky_rank1_update(Eigen::Ref<Eigen::MatrixXf> L, Eigen::Ref<Eigen::VectorXf> w);

}  // namespace psmat::iecm
