#include "psmat/qzpm/forward.hpp"

#include <cmath>

#include "psmat/iecm/laplacian.hpp"

namespace psmat::qzpm {

Eigen::VectorXd Readings::flat() const {
  Eigen::VectorXd v(size());
  v << pairs, rows, cols;
  return v;
}

Readings Readings::from_flat(Shape s, const ConstVecRef& v) {
  Readings r(s);
  r.pairs = v.head(s.cells());
  r.rows = v.segment(s.cells(), s.rows);
  r.cols = v.tail(s.cols);
  return r;
}

Network::Network(Shape shape)
    : shape_(shape),
      a_(shape.nodes(), shape.nodes()),
      m_(shape.nodes(), shape.nodes()),
      sw_(shape.nodes()),
      llt_(shape.nodes()) {}

bool Network::compute(const ConstVecRef& g, const ConstVecRef& sw) {
  if (g.size() != shape_.cells() || sw.size() != shape_.nodes()) return false;
  for (Index k = 0; k < sw.size(); ++k)
    if (!(sw[k] > 0.0) || !std::isfinite(sw[k])) return false;
  // eq. C.4-C.6: the IECM's cell Laplacian plus each line's switch to "in" or ground
  if (!iecm::cell_laplacian(shape_, g, a_)) return false;
  a_.diagonal() += sw;
  sw_ = sw;
  llt_.compute(a_);
  if (llt_.info() != Eigen::Success) return false;
  m_.setIdentity();
  llt_.solveInPlace(m_);
  return m_.allFinite();
}

void readings(const Network& net, VecRef G) {
  const Index R = net.shape().rows, C = net.shape().cols;
  const Eigen::MatrixXd& M = net.M();
  const Eigen::VectorXd& sw = net.switches();
  for (Index i = 0; i < R; ++i) {
    const double gi = sw[i];
    for (Index p = 0; p < C; ++p) {
      const Index q = R + p;
      const double gp = sw[q];
      G[i * C + p] = gi + gp - (gi * gi * M(i, i) + 2.0 * gi * gp * M(i, q) + gp * gp * M(q, q));
    }
  }
  for (Index k = 0; k < R + C; ++k) G[R * C + k] = sw[k] - sw[k] * sw[k] * M(k, k);
}

bool forward(const ConstVecRef& g, const ConstVecRef& g_row, const ConstVecRef& g_col,
             Network& net, Readings& out) {
  const Shape s = net.shape();
  if (g_row.size() != s.rows || g_col.size() != s.cols) return false;
  Eigen::VectorXd sw(s.nodes());
  sw << g_row, g_col;
  if (!net.compute(g, sw)) return false;
  Eigen::VectorXd G(n_readings(s));
  readings(net, G);
  out = Readings::from_flat(s, G);
  return true;
}

namespace {
// One row of the Jacobian for the reading with potentials v (V_in = 1) and selected lines
// sel[0..nsel).
void jacobian_row(Shape s, const Eigen::VectorXd& v, const Index* sel, int nsel,
                  Eigen::Ref<Eigen::RowVectorXd> row) {
  const Index R = s.rows, C = s.cols;
  for (Index j = 0; j < R; ++j)
    for (Index q = 0; q < C; ++q) {
      const double d = v[j] - v[R + q];
      row[j * C + q] = d * d;
    }
  for (Index k = 0; k < R + C; ++k) row[s.cells() + k] = v[k] * v[k];
  for (int t = 0; t < nsel; ++t) {
    const double w = 1.0 - v[sel[t]];
    row[s.cells() + sel[t]] = w * w;
  }
}
}  // namespace

void jacobian(const Network& net, RowMatRef J) {
  const Shape s = net.shape();
  const Index R = s.rows, C = s.cols;
  const Eigen::MatrixXd& M = net.M();
  const Eigen::VectorXd& sw = net.switches();
  Eigen::VectorXd v(s.nodes());
  for (Index i = 0; i < R; ++i)
    for (Index p = 0; p < C; ++p) {
      v.noalias() = sw[i] * M.col(i) + sw[R + p] * M.col(R + p);
      const Index sel[2] = {i, R + p};
      jacobian_row(s, v, sel, 2, J.row(i * C + p));
    }
  for (Index k = 0; k < R + C; ++k) {
    v.noalias() = sw[k] * M.col(k);
    jacobian_row(s, v, &k, 1, J.row(s.cells() + k));
  }
}

}  // namespace psmat::qzpm
