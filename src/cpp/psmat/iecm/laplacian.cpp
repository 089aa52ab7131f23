#include "psmat/iecm/laplacian.hpp"

#include "psmat/iecm/nodal_inverse_kernel.hpp"
#include "psmat/iecm/simd.hpp"

#include <cmath>
#include <numeric>
#include <vector>

namespace psmat::iecm {

namespace {
// True when the cells with g > 0 connect all R + C lines into one network. Cholesky alone
// cannot tell: round-off can leave a tiny positive pivot for an isolated ground row.
bool connected(const Shape& s, const ConstVecRef& g, std::vector<Index>& parent) {
  const Index n = s.nodes();
  parent.resize(static_cast<size_t>(n));
  std::iota(parent.begin(), parent.end(), Index{0});
  auto find = [&](Index a) {
    while (parent[static_cast<size_t>(a)] != a) {
      parent[static_cast<size_t>(a)] = parent[static_cast<size_t>(parent[static_cast<size_t>(a)])];
      a = parent[static_cast<size_t>(a)];
    }
    return a;
  };
  Index components = n;
  for (Index i = 0; i < s.rows; ++i)
    for (Index p = 0; p < s.cols; ++p) {
      const double gip = g[i * s.cols + p];
      if (!(gip >= 0.0) || !std::isfinite(gip)) return false;  // negative or NaN
      if (gip == 0.0) continue;
      const Index a = find(i), b = find(s.rows + p);
      if (a != b) {
        parent[static_cast<size_t>(a)] = b;
        --components;
      }
    }
  return components == 1;
}
}  // namespace

bool cell_laplacian(const Shape& s, const ConstVecRef& g, Eigen::MatrixXd& L) {
  const Index R = s.rows, C = s.cols;
  if (g.size() != s.cells()) return false;
  L.setZero(s.nodes(), s.nodes());
  for (Index i = 0; i < R; ++i)
    for (Index p = 0; p < C; ++p) {
      const double gip = g[i * C + p];
      if (!(gip >= 0.0) || !std::isfinite(gip)) return false;  // negative or NaN/inf
      L(i, i) += gip;
      L(R + p, R + p) += gip;
      L(i, R + p) = -gip;
      L(R + p, i) = -gip;
    }
  return true;
}

std::ptrdiff_t nodal_inverse_work_size(std::ptrdiff_t R, std::ptrdiff_t C) {
  return nodal_inverse_work_doubles(R, C);
}

NodalInverse::NodalInverse(Shape shape)
    : shape_(shape),
      m_(Eigen::MatrixXd::Zero(shape.nodes(), shape.nodes())) {}

bool NodalInverse::compute(const ConstVecRef& g, bool portable) {
  const Index R = shape_.rows, C = shape_.cols;
  if (g.size() != shape_.cells()) return false;
  // every cell conducting (the bounded solvers keep g >= g_floor > 0): one piece by construction
  const bool all_conduct = g.allFinite() && g.minCoeff() > 0.0;
  if (!all_conduct && !connected(shape_, g, parent_)) return false;
  // eq. 2.7 with node 0 (row 0, ground) dropped, by blocks (header; nodal_inverse_kernel.hpp),
  // in the widest vector unit the CPU runs (simd.hpp)
  work_.resize(nodal_inverse_work_doubles(R, C));
  const SimdKernels* k = portable ? nullptr : simd_kernels();
  const bool spd = k ? k->nodal_inverse(g.data(), R, C, m_.data(), work_.data())
                     : nodal_inverse_kernel(g.data(), R, C, m_.data(), work_.data());
  if (!spd) return false;
  return m_.allFinite();
}

}  // namespace psmat::iecm
