// The Newton matrix of IECM as an operator, with a reusable preconditioner (docs/spec.md §3).
//
//   S = D_G (T∘T) D_G   (SPD, unit diagonal; J = D_G S D_G^-1, see jacobian.hpp)
//
// apply():  S x through the matrix-free product (T∘T) v in O(n^3) (n = R + C), never the
//           (RC)^2 matrix — exact at the current point.
// factor(): a float32 Cholesky of S at the current point. It is only a preconditioner, so
//           single precision costs no accuracy (the operator and residuals stay double) and
//           halves the time and memory of the O((RC)^3) factorisation and its solves.
// pcg():    preconditioned conjugate gradients (numerics/pcg.hpp) for S y = b. With a fresh
//           factor PCG takes 1-3 iterations; with the factor of a nearby frame (streaming) a
//           handful — so the expensive factorisation is reused across many frames and rebuilt
//           only when PCG slows down.
#pragma once
#include "psmat/iecm/jacobian.hpp"
#include "psmat/iecm/laplacian.hpp"
#include "psmat/numerics/pcg.hpp"

namespace psmat::iecm {

class NewtonOperator {
 public:
  explicit NewtonOperator(Shape shape);

  // y = S x at the point described by (net, G).
  void apply(const NodalInverse& net, const Eigen::VectorXd& G, const Eigen::VectorXd& x,
             Eigen::VectorXd& y);
  // Builds and factorises S (float32) at (net, G). False if not positive definite even
  // after a small diagonal shift.
  bool factor(const NodalInverse& net, const Eigen::VectorXd& G);
  bool has_factor() const { return has_factor_; }
  void reset() { has_factor_ = false; }
  // z = P^-1 r with the stored factor.
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z);
  // Solves S y = b (y starts at 0) to ||S y - b|| <= tol ||b||. Returns the iterations used,
  // or -1 when max_iter was reached or the recurrence broke down (y then holds the best
  // iterate so far).
  int pcg(const NodalInverse& net, const Eigen::VectorXd& G, const Eigen::VectorXd& b,
          Eigen::VectorXd& y, double tol, int max_iter);

 private:
  Shape shape_;
  Eigen::MatrixXf Sf_;  // lower triangle: S, then its Cholesky factor (in place)
  bool has_factor_ = false;
  HadamardWork work_;
  Eigen::VectorXd v_;
  numerics::PcgWork pcg_;
  Eigen::VectorXf tmp_;
};

}  // namespace psmat::iecm
