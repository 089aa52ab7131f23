// Float32 Cholesky factors of the preconditioners (the free block of S in free_block_solver.hpp,
// all of S in newton_operator.hpp), with Eigen's public API only.
#pragma once
#include <Eigen/Dense>

namespace psmat::iecm {

// In place: the lower triangle of A in, L (L L^T = A) out in it; the strict upper triangle is
// neither read nor kept. False where A is not numerically SPD.
// Uses AVX2 + FMA where the build and the CPU have them (cholesky_avx2.hpp).
bool cholesky_in_place(Eigen::Ref<Eigen::MatrixXf> A);
// The same with the build's baseline instruction set only (the independent check of the AVX2
// path in the C++ tests).
bool cholesky_in_place_portable(Eigen::Ref<Eigen::MatrixXf> A);

// Rank-1 update of a lower Cholesky factor in place: L L^T + w w^T = L' L'^T, L' into L (its
// strict upper triangle untouched); w is used as workspace (overwritten).
void cholesky_rank1_update(Eigen::Ref<Eigen::MatrixXf> L, Eigen::Ref<Eigen::VectorXf> w);

}  // namespace psmat::iecm
