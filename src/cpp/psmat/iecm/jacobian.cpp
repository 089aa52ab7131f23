#include "psmat/iecm/jacobian.hpp"

#include "psmat/iecm/simd.hpp"
#include "psmat/iecm/hadamard_kernel.hpp"

namespace psmat::iecm {

namespace {
// Calls f(a, j, Tseg) for every cell a = (i,p) and row j, where Tseg(q) = T[(i,p),(j,q)]
// for q = 0..C-1 (eq. 2.13 in terms of the blocks of M).
template <class F>
void for_each_T_segment(const NodalInverse& net, bool lower_only, F&& f) {
  const Index R = net.shape().rows, C = net.shape().cols;
  const RowMatrixXd A = net.A();
  const Eigen::MatrixXd Mrr = net.Mrr();
  const RowMatrixXd Mcc = net.Mcc();
  Eigen::ArrayXd w(C), seg(C);
  for (Index i = 0; i < R; ++i) {
    for (Index p = 0; p < C; ++p) {
      const Index a = i * C + p;
      w = A.row(i).array() - Mcc.row(p).array();  // A[i,q] - Mcc[p,q]
      for (Index j = lower_only ? i : 0; j < R; ++j) {
        seg = w + (A(j, p) - Mrr(i, j));          // + A[j,p] - Mrr[i,j]
        f(a, j, seg);
      }
    }
  }
}
}  // namespace

void jacobian(const NodalInverse& net, const ConstVecRef& G, RowMatRef J) {
  const Index C = net.shape().cols;
  for_each_T_segment(net, false, [&](Index a, Index j, const Eigen::ArrayXd& T) {
    J.row(a).segment(j * C, C) = (G[a] * G[a]) * T.square().matrix().transpose();
  });
}

template <class Matrix>
void scaled_hadamard(const NodalInverse& net, const ConstVecRef& G, Matrix& S, bool lower_only) {
  using Scalar = typename Matrix::Scalar;
  const Index C = net.shape().cols;
  S.resize(net.shape().cells(), net.shape().cells());
  for_each_T_segment(net, lower_only, [&](Index a, Index j, const Eigen::ArrayXd& T) {
    // column a of S (= row a, S is symmetric): G_a G_b T[a,b]^2
    S.col(a).segment(j * C, C) =
        (G[a] * (G.segment(j * C, C).array() * T.square())).matrix().template cast<Scalar>();
  });
}

template void scaled_hadamard<Eigen::MatrixXd>(const NodalInverse&, const ConstVecRef&,
                                               Eigen::MatrixXd&, bool);
template void scaled_hadamard<Eigen::MatrixXf>(const NodalInverse&, const ConstVecRef&,
                                               Eigen::MatrixXf&, bool);

namespace {
// For a fixed column cell b = (j,q), T[(i,p),b] = w[i] + u[p] (eq. 2.13 in the blocks of M):
//   w[i] = M[i,q'] - M[i,j],   u[p] = M[j,p'] - M[p',q']
// so each entry of S's column b is two look-ups in short vectors instead of four in M.
void transfer_column(const NodalInverse& net, Index b, Eigen::VectorXd& w, Eigen::VectorXd& u) {
  const Index R = net.shape().rows, C = net.shape().cols;
  const Eigen::MatrixXd& M = net.M();
  const Index j = b / C, qq = R + b % C;
  w = M.col(qq).head(R) - M.col(j).head(R);  // M is symmetric: columns are rows
  u = M.col(j).tail(C) - M.col(qq).tail(C);
}
}  // namespace

template <class Scalar>
void scaled_hadamard_block(const NodalInverse& net, const ConstVecRef& G,
                           const std::vector<Index>& cells,
                           Eigen::Ref<Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>> K) {
  const Index R = net.shape().rows, C = net.shape().cols;
  const Index m = static_cast<Index>(cells.size());
  std::vector<Index> row(static_cast<size_t>(m)), col(static_cast<size_t>(m));
  Eigen::VectorXd Gc(m), w(R), u(C);
  for (Index r = 0; r < m; ++r) {
    const Index a = cells[static_cast<size_t>(r)];
    row[static_cast<size_t>(r)] = a / C;
    col[static_cast<size_t>(r)] = a % C;
    Gc[r] = G[a];
  }
  for (Index q = 0; q < m; ++q) {
    transfer_column(net, cells[static_cast<size_t>(q)], w, u);
    const double Gb = Gc[q];
    for (Index r = q; r < m; ++r) {
      const double T = w[row[static_cast<size_t>(r)]] + u[col[static_cast<size_t>(r)]];
      K(r, q) = static_cast<Scalar>(Gb * Gc[r] * T * T);
    }
  }
}

template void scaled_hadamard_block<double>(const NodalInverse&, const ConstVecRef&,
                                            const std::vector<Index>&, Eigen::Ref<Eigen::MatrixXd>);
template void scaled_hadamard_block<float>(const NodalInverse&, const ConstVecRef&,
                                           const std::vector<Index>&, Eigen::Ref<Eigen::MatrixXf>);

void scaled_hadamard_column(const NodalInverse& net, const ConstVecRef& G,
                            const std::vector<Index>& cells, Index b, Eigen::Ref<Eigen::VectorXf> out) {
  const Index R = net.shape().rows, C = net.shape().cols;
  Eigen::VectorXd w(R), u(C);
  transfer_column(net, b, w, u);
  const double Gb = G[b];
  for (size_t r = 0; r < cells.size(); ++r) {
    const Index a = cells[r];
    if (a < 0) {
      out[static_cast<Index>(r)] = 0.0f;
      continue;
    }
    const double T = w[a / C] + u[a % C];
    out[static_cast<Index>(r)] = static_cast<float>(Gb * G[a] * T * T);
  }
}

void hadamard_product_portable(const NodalInverse& net, const ConstVecRef& v, VecRef out,
                               HadamardWork& work) {
  const Index R = net.shape().rows, C = net.shape().cols, n = net.shape().nodes();
  work.P.resize(n, n);
  work.kdiag.resize(n + 4 * R);
  hadamard_kernel(net.M().data(), R, C, v.data(), out.data(), work.P.data(), work.kdiag.data());
}

void hadamard_product(const NodalInverse& net, const ConstVecRef& v, VecRef out,
                      HadamardWork& work) {
  const SimdKernels* k = simd_kernels();
  if (k == nullptr) {
    hadamard_product_portable(net, v, out, work);
    return;
  }
  const Index R = net.shape().rows, C = net.shape().cols, n = net.shape().nodes();
  work.P.resize(n, n);
  work.kdiag.resize(n + 4 * R);
  k->hadamard_kernel(net.M().data(), R, C, v.data(), out.data(), work.P.data(), work.kdiag.data());
}

}  // namespace psmat::iecm
