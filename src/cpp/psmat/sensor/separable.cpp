#include "psmat/sensor/separable.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/QR>

namespace psmat::sensor {

SeparableProblem::SeparableProblem(std::vector<Experiment> experiments, int n_ops, double p_max,
                                   int n_creep)
    : ex_(std::move(experiments)), n_ops_(n_ops), p_max_(p_max), n_creep_(n_creep) {
  if (ex_.empty()) throw std::invalid_argument("SeparableProblem: no experiments");
  if (n_ops < 1 || !(p_max > 0) || n_creep < 0)
    throw std::invalid_argument("SeparableProblem: n_ops >= 1, p_max > 0, n_creep >= 0");
  r_.resize(n_ops);
  for (int i = 0; i < n_ops; ++i) r_[i] = p_max * i / n_ops;  // thresholds (i-1)/N p_max
  const double E = static_cast<double>(ex_.size());
  for (const Experiment& e : ex_) {
    if (e.p.size() != e.g.size() || e.p.size() == 0)
      throw std::invalid_argument("SeparableProblem: p and g of an experiment differ in length");
    RowMatrixXd Y(e.p.size(), n_ops);
    play_basis(e.p, r_, Y);
    play_.push_back(std::move(Y));
    weight_.push_back(1.0 / std::sqrt(E * static_cast<double>(e.p.size())));
    rows_ += e.p.size();
  }
}

void SeparableProblem::design(const Eigen::VectorXd& z, Eigen::MatrixXd& A, Eigen::VectorXd& b) const {
  if (z.size() != n_nonlinear()) throw std::invalid_argument("SeparableProblem: z = (tau, log10 l_j)");
  A.resize(rows_, n_linear());
  b.resize(rows_);
  const Eigen::VectorXd decay = (-z[0] * r_).array().exp();  // e^{-tau r_i} (eq. 2.18)
  Eigen::VectorXd l(n_creep_);
  for (int j = 0; j < n_creep_; ++j) l[j] = std::pow(10.0, z[1 + j]);
  RowMatrixXd Yc;
  Eigen::Index row = 0;
  for (size_t e = 0; e < ex_.size(); ++e) {
    const Experiment& x = ex_[e];
    const Eigen::Index T = x.p.size();
    const double w = weight_[e];
    auto blk = A.middleRows(row, T);
    blk.col(0) = w * x.p;
    blk.col(1) = w * x.p.array().square().matrix();
    blk.col(2) = w * x.p.array().cube().matrix();
    blk.col(3) = w * (play_[e] * decay);
    if (n_creep_ > 0) {
      Yc.resize(T, n_creep_);
      creep_basis(x.p, l, x.dt, Yc);
      blk.rightCols(n_creep_) = w * Yc;
    }
    b.segment(row, T) = w * x.g;
    row += T;
  }
}

Eigen::VectorXd SeparableProblem::theta(const Eigen::VectorXd& z, const Eigen::VectorXd& c) const {
  Eigen::VectorXd th(5 + 2 * n_creep_);
  th << c[3], z[0], c[0], c[1], c[2], Eigen::VectorXd::Zero(2 * n_creep_);
  for (int j = 0; j < n_creep_; ++j) {
    th[5 + j] = std::pow(10.0, z[1 + j]);
    th[5 + n_creep_ + j] = c[4 + j];
  }
  return th;
}

SeparableProblem::Solution SeparableProblem::solve(const Eigen::VectorXd& z) const {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  design(z, A, b);
  Eigen::VectorXd norms = A.colwise().norm().transpose();
  for (Eigen::Index k = 0; k < norms.size(); ++k)
    if (!(norms[k] > 0)) norms[k] = 1.0;
  const Eigen::MatrixXd As = A * norms.cwiseInverse().asDiagonal();
  const Eigen::VectorXd c = Eigen::ColPivHouseholderQR<Eigen::MatrixXd>(As).solve(b).cwiseQuotient(norms);
  Solution s;
  s.cost = (A * c - b).squaredNorm();
  s.theta = theta(z, c);
  s.invertibility_problem = MPICreep(params_from_theta(s.theta, n_ops_, p_max_)).check_invertible();
  return s;
}

AnnealResult anneal_separable(const SeparableProblem& problem, const Eigen::VectorXd& z0,
                              const Eigen::VectorXd& lo, const Eigen::VectorXd& hi,
                              const AnnealOptions& options) {
  if (z0.size() != problem.n_nonlinear())
    throw std::invalid_argument("anneal_separable: z = (tau, log10 l_1..l_Nc)");
  auto energy = [&](const Eigen::VectorXd& z) {
    const SeparableProblem::Solution s = problem.solve(z);
    if (!s.invertibility_problem.empty() || !std::isfinite(s.cost))
      return std::numeric_limits<double>::infinity();
    return std::log(s.cost + 1e-300);
  };
  return anneal(energy, z0, lo, hi, options);
}

}  // namespace psmat::sensor
