#include "psmat/iecm/uncertainty.hpp"

#include "psmat/iecm/forward.hpp"
#include "psmat/iecm/jacobian.hpp"

namespace psmat::iecm {

namespace {
// S^-1 and G at g; false if singular.
bool inverse_newton_matrix(Shape shape, const ConstVecRef& g, Eigen::MatrixXd& Sinv,
                           Eigen::VectorXd& G) {
  NodalInverse net(shape);
  G.resize(shape.cells());
  if (!forward(g, net, G)) return false;
  Eigen::MatrixXd S;
  scaled_hadamard(net, G, S, /*lower_only=*/true);
  Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) return false;
  Sinv = Eigen::MatrixXd::Identity(shape.cells(), shape.cells());
  llt.solveInPlace(Sinv);
  return Sinv.allFinite();
}
}  // namespace

bool inverse_jacobian(Shape shape, const ConstVecRef& g, RowMatRef dgdG) {
  Eigen::MatrixXd Sinv;
  Eigen::VectorXd G;
  if (!inverse_newton_matrix(shape, g, Sinv, G)) return false;
  // (J^-1)[b,a] = G_b (S^-1)[b,a] / G_a
  dgdG = G.asDiagonal() * Sinv * G.cwiseInverse().asDiagonal();
  return true;
}

bool propagate_uncertainty(Shape shape, const ConstVecRef& g, const ConstVecRef& sigma_G,
                           VecRef sigma_g) {
  Eigen::MatrixXd Sinv;
  Eigen::VectorXd G;
  if (!inverse_newton_matrix(shape, g, Sinv, G)) return false;
  // sigma_g[b]^2 = G_b^2 sum_a (S^-1[b,a])^2 (sigma_G[a]/G_a)^2      (eq. 2.11 with eq. 2.14)
  const Eigen::VectorXd rel2 = (sigma_G.array() / G.array()).square().matrix();
  sigma_g = (G.array() * (Sinv.array().square().matrix() * rel2).array().sqrt()).matrix();
  return true;
}

}  // namespace psmat::iecm
