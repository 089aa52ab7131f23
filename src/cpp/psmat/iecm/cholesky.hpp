// In-place Cholesky factor of the float32 preconditioners (the free block of S in active_set.hpp,
// all of S in newton_operator.hpp): the lower triangle of A in, L (L L^T = A) out in it; the
// strict upper triangle is neither read nor kept. False where A is not numerically SPD.
#pragma once
#include <Eigen/Dense>

namespace psmat::iecm {

bool cholesky_in_place(Eigen::Ref<Eigen::MatrixXf> A);

}  // namespace psmat::iecm
