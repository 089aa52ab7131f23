#include "psmat/sensor/fit.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "psmat/sensor/operators.hpp"

namespace psmat::sensor {

MPICreepParams params_from_theta(const Eigen::VectorXd& theta, int n_ops, double p_max) {
  if (theta.size() < 5 || (theta.size() - 5) % 2 != 0)
    throw std::invalid_argument("theta = (rho, tau, a1, a2, a3, l_1..l_Nc, w_1..w_Nc)");
  const Index nc = (theta.size() - 5) / 2;
  MPICreepParams p;
  p.rho = theta[0];
  p.tau = theta[1];
  p.a1 = theta[2];
  p.a2 = theta[3];
  p.a3 = theta[4];
  for (Index j = 0; j < nc; ++j) {
    p.l.push_back(theta[5 + j]);
    p.w.push_back(theta[5 + nc + j]);
  }
  p.n_ops = n_ops;
  p.p_max = p_max;
  return p;
}

Eigen::VectorXd sse_n_each(const MPICreep& model, const std::vector<Experiment>& experiments) {
  Eigen::VectorXd out(static_cast<Index>(experiments.size()));
  for (size_t e = 0; e < experiments.size(); ++e) {
    const Experiment& ex = experiments[e];
    const Index T = ex.p.size();
    MPICreepState st = model.rest_state(1);  // independent experiments start at rest
    RowMatrixXd g(T, 1);
    model.direct(Eigen::Map<const RowMatrixXd>(ex.p.data(), T, 1), ex.dt, st, g);
    out[static_cast<Index>(e)] = (g.col(0) - ex.g).squaredNorm() / static_cast<double>(T);  // eq. 2.26
  }
  return out;
}

double mean_sse_n(const MPICreep& model, const std::vector<Experiment>& experiments) {
  return sse_n_each(model, experiments).mean();
}

void play_basis(const Eigen::VectorXd& p, const Eigen::VectorXd& r, RowMatRef Y) {
  Eigen::VectorXd y = Eigen::VectorXd::Zero(r.size());
  for (Index t = 0; t < p.size(); ++t)
    for (Index i = 0; i < r.size(); ++i) Y(t, i) = y[i] = osp_step(p[t], r[i], y[i]);
}

void creep_basis(const Eigen::VectorXd& p, const Eigen::VectorXd& l, double dt, RowMatRef Yc) {
  for (Index j = 0; j < l.size(); ++j) {
    const double decay = std::exp(-l[j] * dt);
    double y = 0, p_prev = 0;  // rest
    for (Index t = 0; t < p.size(); ++t) {
      Yc(t, j) = y = creep_step(decay, y, p_prev);
      p_prev = p[t];
    }
  }
}

Eigen::VectorXd theta_from_x(const Eigen::VectorXd& x, const Eigen::VectorXd& scale,
                             const std::vector<bool>& log10) {
  Eigen::VectorXd th(x.size());
  for (Index k = 0; k < x.size(); ++k)
    th[k] = log10[static_cast<size_t>(k)] ? std::pow(10.0, x[k]) : scale[k] * x[k];
  if (th.size() > 2) th[2] -= th[0];  // x_2 is the initial slope a1 + rho
  return th;
}

AnnealResult anneal_fit(const std::vector<Experiment>& experiments, int n_ops, double p_max,
                        const Eigen::VectorXd& x0, const Eigen::VectorXd& lo,
                        const Eigen::VectorXd& hi, const Eigen::VectorXd& scale,
                        const std::vector<bool>& log10, const AnnealOptions& o) {
  const Index d = x0.size();
  if (lo.size() != d || hi.size() != d || scale.size() != d || static_cast<Index>(log10.size()) != d)
    throw std::invalid_argument("x0, lo, hi, scale and log10 must have the same length");
  auto energy = [&](const Eigen::VectorXd& x) {
    const MPICreep m(params_from_theta(theta_from_x(x, scale, log10), n_ops, p_max));
    if (!m.check_invertible().empty()) return std::numeric_limits<double>::infinity();
    const double s = mean_sse_n(m, experiments);
    return std::isfinite(s) ? std::log(s + 1e-300) : std::numeric_limits<double>::infinity();
  };
  return anneal(energy, x0, lo, hi, o);
}

}  // namespace psmat::sensor
