#include "psmat/iecm/newton_operator.hpp"

#include <cmath>

#include "psmat/iecm/cholesky.hpp"

namespace psmat::iecm {

NewtonOperator::NewtonOperator(Shape shape) : shape_(shape) {}

void NewtonOperator::apply(const NodalInverse& net, const Eigen::VectorXd& G,
                           const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  v_ = G.cwiseProduct(x);
  y.resize(shape_.cells());
  hadamard_product(net, v_, y, work_);  // (T∘T)(D_G x)
  y.array() *= G.array();               // D_G (T∘T) D_G x
}

bool NewtonOperator::factor(const NodalInverse& net, const Eigen::VectorXd& G) {
  has_factor_ = false;
  for (double shift = 0.0; shift <= 1e-2; shift = shift == 0.0 ? 1e-6 : shift * 100.0) {
    scaled_hadamard(net, G, Sf_, /*lower_only=*/true);
    if (shift > 0) Sf_.diagonal().array() += static_cast<float>(shift);
    if (cholesky_in_place(Sf_)) {  // in place: no second n x n matrix
      has_factor_ = true;
      return true;
    }
  }
  return false;
}

void NewtonOperator::precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) {
  tmp_ = r.cast<float>();
  Sf_.triangularView<Eigen::Lower>().solveInPlace(tmp_);
  Sf_.triangularView<Eigen::Lower>().transpose().solveInPlace(tmp_);
  z = tmp_.cast<double>();
}

int NewtonOperator::pcg(const NodalInverse& net, const Eigen::VectorXd& G,
                        const Eigen::VectorXd& b, Eigen::VectorXd& y, double tol, int max_iter) {
  const Index n = shape_.cells();
  y.setZero(n);
  r_ = b;
  const double bnorm = b.norm();
  if (bnorm == 0.0) return 0;
  precondition(r_, z_);
  p_ = z_;
  double rz = r_.dot(z_);
  for (int k = 1; k <= max_iter; ++k) {
    apply(net, G, p_, q_);
    const double pq = p_.dot(q_);
    if (!(pq > 0.0) || !std::isfinite(pq)) return -1;  // breakdown
    const double alpha = rz / pq;
    y.noalias() += alpha * p_;
    r_.noalias() -= alpha * q_;
    if (r_.norm() <= tol * bnorm) return k;
    precondition(r_, z_);
    const double rz_new = r_.dot(z_);
    p_ = z_ + (rz_new / rz) * p_;
    rz = rz_new;
  }
  return -1;
}

}  // namespace psmat::iecm
