#include "psmat/iecm/newton_operator.hpp"

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
  cholesky_solve_in_place(Sf_, tmp_);
  z = tmp_.cast<double>();
}

int NewtonOperator::pcg(const NodalInverse& net, const Eigen::VectorXd& G,
                        const Eigen::VectorXd& b, Eigen::VectorXd& y, double tol, int max_iter) {
  return numerics::pcg(
      b, y, tol, max_iter, pcg_,
      [&](const Eigen::VectorXd& p, Eigen::VectorXd& q) { apply(net, G, p, q); },
      [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { precondition(r, z); });
}

}  // namespace psmat::iecm
