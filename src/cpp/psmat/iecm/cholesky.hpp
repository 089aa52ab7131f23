// Float32 Cholesky factors of the preconditioners (the free block of S in free_block_solver.hpp,
// all of S in newton_operator.hpp), with Eigen's public API only.
#pragma once
#include <Eigen/Dense>

namespace psmat::iecm {

// In place: the lower triangle of A in, L (L L^T = A) out in it; the strict upper triangle is
// neither read nor kept. False where A is not numerically SPD.
// In the widest vector unit the build has and the CPU runs (simd.hpp: AVX2 + FMA, AVX-512).
bool cholesky_in_place(Eigen::Ref<Eigen::MatrixXf> A);
// The same with the build's baseline instruction set only (the independent check of the vector
// units in the C++ tests).
bool cholesky_in_place_portable(Eigen::Ref<Eigen::MatrixXf> A);

// The first `cols` columns of the factor of A (lower triangle in), and in the trailing block
// A[cols:, cols:] the Schur complement of the leading cols x cols block (lower triangle), in the
// vector unit of simd.hpp. False where the leading block is not SPD.
bool cholesky_partial_in_place(Eigen::Ref<Eigen::MatrixXf> A, Eigen::Index cols);
bool cholesky_partial_in_place_portable(Eigen::Ref<Eigen::MatrixXf> A, Eigen::Index cols);

// B <- L^-1 B (mode 0), (L L^T)^-1 B (1) or L^-T B (2) for a lower factor L (lower triangle read);
// and C -= A B. In the vector unit of simd.hpp (FreeBlockSolver::select).
void lower_solve_matrix(const Eigen::Ref<const Eigen::MatrixXf>& L, Eigen::Ref<Eigen::MatrixXf> B,
                        int mode);
void gemm_subtract(Eigen::Ref<Eigen::MatrixXf> C, const Eigen::Ref<const Eigen::MatrixXf>& A,
                   const Eigen::Ref<const Eigen::MatrixXf>& B);
// y -= A x, or y -= A^T x (transpose), in the vector unit of simd.hpp (the split preconditioner's
// products with the fringe panel and the capacitance columns, FreeBlockSolver::precondition).
void gemv_subtract(Eigen::Ref<Eigen::VectorXf> y, const Eigen::Ref<const Eigen::MatrixXf>& A,
                   const Eigen::Ref<const Eigen::VectorXf>& x, bool transpose);
// The same with the build's baseline instruction set only.
void gemv_subtract_portable(Eigen::Ref<Eigen::VectorXf> y, const Eigen::Ref<const Eigen::MatrixXf>& A,
                            const Eigen::Ref<const Eigen::VectorXf>& x, bool transpose);

// x <- (L L^T)^-1 x for a factor L from cholesky_in_place (its lower triangle read): the two
// triangular solves of a preconditioner, in the vector unit of simd.hpp (the PCG steps of the 16x16 noisy frames spent ~13 % of their time here
// with the baseline instruction set).
void cholesky_solve_in_place(const Eigen::Ref<const Eigen::MatrixXf>& L, Eigen::Ref<Eigen::VectorXf> x);
// The same with the build's baseline instruction set only.
void cholesky_solve_in_place_portable(const Eigen::Ref<const Eigen::MatrixXf>& L,
                                      Eigen::Ref<Eigen::VectorXf> x);

// Rank-1 update of a lower Cholesky factor in place: L L^T + w w^T = L' L'^T, L' into L (its
// strict upper triangle untouched); w is used as workspace (overwritten).
void cholesky_rank1_update(Eigen::Ref<Eigen::MatrixXf> L, Eigen::Ref<Eigen::VectorXf> w);

}  // namespace psmat::iecm
