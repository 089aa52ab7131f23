#include "psmat/sensor/anneal.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace psmat::sensor {

using Index = Eigen::Index;

AnnealResult anneal(const std::function<double(const Eigen::VectorXd&)>& energy,
                    const Eigen::VectorXd& x0, const Eigen::VectorXd& lo,
                    const Eigen::VectorXd& hi, const AnnealOptions& o) {
  const Index d = x0.size();
  if (d == 0 || lo.size() != d || hi.size() != d)
    throw std::invalid_argument("anneal: x0, lo and hi must have the same, non-zero length");
  if (!((hi - lo).array() >= 0).all()) throw std::invalid_argument("anneal: lo must be <= hi");
  if (!(o.t0 > 0 && o.t_end > 0 && o.max_evals > 0))
    throw std::invalid_argument("anneal: t0, t_end and max_evals must be positive");
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> unif(0.0, 1.0);
  std::uniform_int_distribution<Index> pick(0, d - 1);

  AnnealResult res;
  auto E = [&](const Eigen::VectorXd& x) {
    ++res.evaluations;
    if (o.progress) o.progress->fetch_add(1, std::memory_order_relaxed);
    const double e = energy(x);
    return std::isnan(e) ? HUGE_VAL : e;
  };
  Eigen::VectorXd x = x0.cwiseMax(lo).cwiseMin(hi), best = x, xn;
  double e = E(x), e_best = e;
  Eigen::VectorXd width = 0.1 * (hi - lo);
  Eigen::VectorXi tried = Eigen::VectorXi::Zero(d), ok = Eigen::VectorXi::Zero(d);
  const double cool = std::pow(o.t_end / o.t0, 1.0 / o.max_evals);
  double temp = o.t0;
  while (res.evaluations < o.max_evals) {
    const Index k = pick(rng);
    xn = x;
    xn[k] = std::min(hi[k], std::max(lo[k], x[k] + width[k] * normal(rng)));
    const double en = E(xn);
    ++tried[k];
    if (en <= e || unif(rng) < std::exp(-(en - e) / temp)) {  // Metropolis
      x = xn;
      e = en;
      ++ok[k];
      ++res.accepted;
      if (e < e_best) {
        e_best = e;
        best = x;
      }
    }
    if (tried[k] == 20) {  // adapt the move width towards ~40 % acceptance
      width[k] *= ok[k] > 8 ? 1.5 : 0.7;
      width[k] = std::min(width[k], hi[k] - lo[k]);
      tried[k] = ok[k] = 0;
    }
    temp *= cool;
  }
  res.x = best;
  res.energy = e_best;
  res.sse_n = std::exp(e_best);
  return res;
}

}  // namespace psmat::sensor
