#include "psmat/iecm/forward.hpp"

namespace psmat::iecm {

void equivalent_conductance(const NodalInverse& net, VecRef G) {
  const Index R = net.shape().rows, C = net.shape().cols;
  const Eigen::MatrixXd& M = net.M();
  for (Index i = 0; i < R; ++i) {
    const double mii = M(i, i);
    for (Index p = 0; p < C; ++p) {
      const Index pn = R + p;
      G[i * C + p] = 1.0 / (mii + M(pn, pn) - 2.0 * M(i, pn));  // eq. 2.5
    }
  }
}

bool forward(const ConstVecRef& g, NodalInverse& net, VecRef G) {
  if (!net.compute(g)) return false;
  equivalent_conductance(net, G);
  return true;
}

}  // namespace psmat::iecm
