#include "psmat/iecm/laplacian.hpp"

namespace psmat::iecm {

NodalInverse::NodalInverse(Shape shape)
    : shape_(shape),
      cmat_(shape.nodes() - 1, shape.nodes() - 1),
      llt_(shape.nodes() - 1),
      m_(Eigen::MatrixXd::Zero(shape.nodes(), shape.nodes())) {}

bool NodalInverse::compute(const ConstVecRef& g) {
  const Index R = shape_.rows, C = shape_.cols, n = shape_.nodes();
  // eq. 2.7: diagonal = sum of the conductances at the node, off-diagonal = -g between a
  // row node and a column node; index k-1 for node k (node 0 is ground and dropped).
  cmat_.setZero();
  for (Index i = 0; i < R; ++i) {
    for (Index p = 0; p < C; ++p) {
      const double gip = g[i * C + p];
      const Index col = R + p - 1;
      cmat_(col, col) += gip;
      if (i > 0) {
        cmat_(i - 1, i - 1) += gip;
        cmat_(i - 1, col) = -gip;
        cmat_(col, i - 1) = -gip;
      }
    }
  }
  llt_.compute(cmat_);
  if (llt_.info() != Eigen::Success) return false;
  auto inner = m_.bottomRightCorner(n - 1, n - 1);
  inner.setIdentity();
  llt_.solveInPlace(inner);
  return inner.allFinite();
}

}  // namespace psmat::iecm
