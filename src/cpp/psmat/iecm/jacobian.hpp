// Jacobian of the IECM forward model (thesis eq. 2.13 / App. B eq. B.23, docs/spec.md §3).
//
//   T[(i,p),(j,q)] = (e_j - e_q')^T M (e_p' - e_i) = V_ip,j - V_ip,q      (p' = R+p, q' = R+q)
//                  = A[j,p] + A[i,q] - Mrr[i,j] - Mcc[p,q]
//   dG[i,p]/dg[j,q] = G[i,p]^2 * T[(i,p),(j,q)]^2                          (eq. 2.13; diagonal = 1)
//
// T is symmetric and T∘T (Hadamard square) is positive semidefinite (Schur product theorem),
// definite where the inverse problem is well posed. The solvers work with the scaled form
//   S = D_G (T∘T) D_G  = D_G^-1 J D_G          (similar to J: same eigenvalues, unit diagonal)
// so that a Newton step J dg = -r becomes the SPD system S y = -r/G, dg = G∘y.
#pragma once
#include <vector>

#include "psmat/iecm/laplacian.hpp"

namespace psmat::iecm {

// Dense dG/dg, (R*C) x (R*C), row a = (i,p), column b = (j,q), row-major cell order.
void jacobian(const NodalInverse& net, const ConstVecRef& G, RowMatRef J);

// S = D_G (T∘T) D_G (column-major, for Eigen's Cholesky). With lower_only, only the blocks
// j >= i (the lower triangle and a little more) are written.
// Defined for Eigen::MatrixXd and Eigen::MatrixXf (a float32 preconditioner).
template <class Matrix>
void scaled_hadamard(const NodalInverse& net, const ConstVecRef& G, Matrix& S, bool lower_only);

// The principal submatrix of S on `cells` (ascending or not) into K (cells x cells, e.g. the
// corner of a larger matrix): K(r, q) = S[cells[r], cells[q]] for r >= q (lower triangle; the
// strict upper triangle is not written). O(cells^2), for the free block of the active-set
// method without the full (RC)^2 matrix. Defined for double and float (a preconditioner).
template <class Scalar>
void scaled_hadamard_block(const NodalInverse& net, const ConstVecRef& G,
                           const std::vector<Index>& cells,
                           Eigen::Ref<Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>> K);

// One column of S in float: out[r] = S[cells[r], b], 0 where cells[r] < 0. O(cells): the new
// row of a factor that gains cell b (FreeBlockSolver::update).
void scaled_hadamard_column(const NodalInverse& net, const ConstVecRef& G,
                            const std::vector<Index>& cells, Index b, Eigen::Ref<Eigen::VectorXf> out);

// Matrix-free product out = (T∘T) v in O(n^3) instead of O((RC)^2) (docs/spec.md §3):
//   ((T∘T) v)[i,p] = K[i,i] + K[p',p'] - 2 K[i,p'],   K = M L_v M,
// with L_v the Laplacian of the same graph weighted by v (the loops: hadamard_kernel.hpp; in the
// widest vector unit the build has and the CPU runs, simd.hpp). `work` is resized as
// needed.
struct HadamardWork {
  Eigen::MatrixXd P;      // (L_v M)^T, n x n
  Eigen::VectorXd kdiag;  // diagonal of K (n), then up to four columns of its R x C block (4 R)
};
void hadamard_product(const NodalInverse& net, const ConstVecRef& v, VecRef out,
                      HadamardWork& work);
// The same with the build's baseline instruction set only (the independent check of the vector
// units in the C++ tests).
void hadamard_product_portable(const NodalInverse& net, const ConstVecRef& v, VecRef out,
                               HadamardWork& work);

}  // namespace psmat::iecm
