#include "psmat/sensor/mpi_creep.hpp"

#include "psmat/sensor/operators.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace psmat::sensor {

namespace {
bool finite(double v) { return std::isfinite(v); }
}  // namespace

MPICreep::MPICreep(const MPICreepParams& params) : p_(params) {
  if (p_.n_ops < 1) throw std::invalid_argument("n_ops must be >= 1");
  if (!(p_.p_max > 0) || !finite(p_.p_max)) throw std::invalid_argument("p_max must be > 0 (psi)");
  if (p_.l.size() != p_.w.size())
    throw std::invalid_argument("creep rates l and weights w must have the same length");
  for (double v : {p_.rho, p_.tau, p_.a1, p_.a2, p_.a3})
    if (!finite(v)) throw std::invalid_argument("model parameters must be finite");
  for (size_t j = 0; j < p_.l.size(); ++j) {
    if (!finite(p_.l[j]) || p_.l[j] < 0) throw std::invalid_argument("creep rates l must be finite and >= 0 (1/s)");
    if (!finite(p_.w[j])) throw std::invalid_argument("creep weights w must be finite");
  }
  const int N = p_.n_ops;
  r_.resize(N);
  b_.resize(N);
  for (int i = 0; i < N; ++i) {
    r_[i] = static_cast<double>(i) / N * p_.p_max;  // r_i = (i-1)/N p_max, i = 1..N
    b_[i] = p_.rho * std::exp(-p_.tau * r_[i]);    // eq. 2.18
  }
}

MPICreepState MPICreep::rest_state(Index cells) const {
  MPICreepState s;
  s.y = Eigen::MatrixXd::Zero(p_.n_ops, cells);
  s.yc = Eigen::MatrixXd::Zero(static_cast<Index>(p_.l.size()), cells);
  s.p_prev = Eigen::VectorXd::Zero(cells);
  return s;
}

void MPICreep::decay_at(const ConstVecRef& dt, Index t, std::vector<double>& decay, double& dt_of_decay) const {
  const double d = dt.size() == 1 ? dt[0] : dt[t];
  if (d == dt_of_decay) return;
  decay.resize(p_.l.size());
  for (size_t j = 0; j < p_.l.size(); ++j) decay[j] = std::exp(-p_.l[j] * d);
  dt_of_decay = d;
}

namespace {
void check_periods(const ConstVecRef& dt, Index T) {
  if (dt.size() != 1 && dt.size() != T)
    throw std::invalid_argument("dt must hold one period or one per sample");
  for (Index k = 0; k < dt.size(); ++k)
    if (!(dt[k] > 0) || !std::isfinite(dt[k])) throw std::invalid_argument("dt must be positive and finite (s)");
}
}  // namespace

void MPICreep::direct(const ConstRowMatRef& p, double dt, MPICreepState& st, RowMatRef g) const {
  const Eigen::VectorXd one = Eigen::VectorXd::Constant(1, dt);
  direct(p, one, st, g);
}

void MPICreep::direct(const ConstRowMatRef& p, const ConstVecRef& dt, MPICreepState& st, RowMatRef g) const {
  const Index T = p.rows(), n = p.cols(), N = p_.n_ops, Nc = static_cast<Index>(p_.l.size());
  check_periods(dt, T);
  std::vector<double> decay;
  double dt_of_decay = std::numeric_limits<double>::quiet_NaN();
  for (Index t = 0; t < T; ++t) {
    decay_at(dt, t, decay, dt_of_decay);
    for (Index c = 0; c < n; ++c) {
      const double x = p(t, c);
      if (std::isnan(x)) {
        g(t, c) = std::numeric_limits<double>::quiet_NaN();
        continue;
      }
      double out = x * (p_.a1 + x * (p_.a2 + x * p_.a3));
      for (Index i = 0; i < N; ++i) {
        const double y = osp_step(x, r_[i], st.y(i, c));
        st.y(i, c) = y;
        out += b_[i] * y;
      }
      for (Index j = 0; j < Nc; ++j) {  // eq. 2.23 with the previous sample, then eq. 2.24
        st.yc(j, c) = creep_step(decay[static_cast<size_t>(j)], st.yc(j, c), st.p_prev[c]);
        out += p_.w[static_cast<size_t>(j)] * st.yc(j, c);
      }
      st.p_prev[c] = x;
      g(t, c) = out;
    }
  }
}

void MPICreep::inverse(const ConstRowMatRef& g, double dt, MPICreepState& st, RowMatRef p,
                       Index* clipped) const {
  const Eigen::VectorXd one = Eigen::VectorXd::Constant(1, dt);
  inverse(g, one, st, p, clipped);
}

void MPICreep::inverse(const ConstRowMatRef& g, const ConstVecRef& dt, MPICreepState& st, RowMatRef p,
                       Index* clipped) const {
  const Index T = g.rows(), n = g.cols(), N = p_.n_ops, Nc = static_cast<Index>(p_.l.size());
  check_periods(dt, T);
  std::vector<double> decay;
  double dt_of_decay = std::numeric_limits<double>::quiet_NaN();
  Index n_clipped = 0;
  std::vector<double> ycn(static_cast<size_t>(Nc));
  for (Index t = 0; t < T; ++t) {
    decay_at(dt, t, decay, dt_of_decay);
    for (Index c = 0; c < n; ++c) {
      const double gv = g(t, c);
      if (std::isnan(gv)) {
        p(t, c) = std::numeric_limits<double>::quiet_NaN();
        continue;
      }
      // creep at t_k depends only on the past (eq. 2.23): known before solving for p_k
      double creep = 0;
      for (Index j = 0; j < Nc; ++j) {
        ycn[static_cast<size_t>(j)] = creep_step(decay[static_cast<size_t>(j)], st.yc(j, c), st.p_prev[c]);
        creep += p_.w[static_cast<size_t>(j)] * ycn[static_cast<size_t>(j)];
      }
      const double target = gv - creep;  // = P[p_k] + F[p_k], eq. 2.25
      // h(x) = a1 x + a2 x^2 + a3 x^3 + sum b_i osp(x, r_i, y_i): h(0) = 0, increasing. Each
      // operator is linear in x in three pieces (below y_i it follows x, above y_i + r_i it
      // follows x - r_i, between it is flat at y_i), so h has kinks; at the previous sample's
      // pressure, where Newton starts, it sits on them (the operators that moved with it). Its
      // slopes to the right (up) and to the left (down) are returned apart, and Newton takes the
      // one of the direction it steps in; within a piece h is the cubic plus a line, so Halley's
      // step (with h'' = 2 a2 + 6 a3 x) converges cubically there. On 300 frames of a simulated
      // balance trial's cells after IECM (16x16, scaled by f = 0.5 as in the SCHC search): 0.81
      // evaluations of h a sample against 1.52 with the two-sided slope and Newton after a
      // doubling bracket from the previous pressure (quiet cells need none); 10-21 % less time
      // over such trials at f = 0.3, 0.5, 0.8 (alternating in one process), the pressures within
      // 5.4e-12 relative of the earlier code's, direct(inverse(g)) = g to 1.2e-15.
      auto h = [&](double x, double& up, double& down) {
        double v = x * (p_.a1 + x * (p_.a2 + x * p_.a3));
        const double poly = p_.a1 + x * (2.0 * p_.a2 + 3.0 * x * p_.a3);
        up = poly;
        down = poly;
        for (Index i = 0; i < N; ++i) {
          const double y = st.y(i, c), r = r_[i], b = b_[i];
          const bool below = x <= y, above_play = x >= y + r;
          v += b * (below ? x : (above_play ? x - r : y));
          up += (x < y || above_play) ? b : 0.0;
          down += (below || x > y + r) ? b : 0.0;
        }
        return v;
      };
      // the same away from the kinks (the iterates after the first): one slope, both sides
      auto h1 = [&](double x, double& slope) {
        double v = x * (p_.a1 + x * (p_.a2 + x * p_.a3));
        slope = p_.a1 + x * (2.0 * p_.a2 + 3.0 * x * p_.a3);
        for (Index i = 0; i < N; ++i) {
          const double y = st.y(i, c), r = r_[i], b = b_[i];
          const bool below = x <= y, above_play = x >= y + r;
          v += b * (below ? x : (above_play ? x - r : y));
          slope += (below || above_play) ? b : 0.0;
        }
        return v;
      };
      const double p_max = p_.p_max;
      double x;
      if (!(target > 0)) {
        x = 0.0;
        ++n_clipped;
      } else {
        // safeguarded Newton-Halley in [lo, hi]: h(lo) < target from the start (h(0) = 0); hi =
        // p_max is only known to hold the root once h there has been seen >= target (a target
        // above h(p_max) is clipped: the model is identified and checked monotone on [0, p_max]
        // only, docs/spec.md §4; beyond, the polynomial may turn down)
        double lo = 0.0, hi = p_max;
        bool hi_known = false, above = false;
        x = std::min(std::max(st.p_prev[c], 0.0), p_max);
        double up = 0, down = 0;
        double hx = h(x, up, down);
        for (int it = 0; it < 100; ++it) {
          const double f = hx - target;
          if (std::abs(f) <= 1e-15 * target + 1e-300) break;
          if (f > 0) {
            hi = x;
            hi_known = true;
          } else {
            lo = x;
          }
          const double s = f < 0 ? up : down;  // the slope on the side the root is
          double xn = 0.5 * (lo + hi);
          if (s > 0) {
            xn = x - f / s;
            const double den = 2.0 * s * s - f * (2.0 * p_.a2 + 6.0 * p_.a3 * x);
            if (den > 0) xn = x - 2.0 * f * s / den;  // Halley
          }
          if (!hi_known && (!(s > 0) || !(xn < hi))) {  // the root may be beyond p_max: is it?
            if (lo == p_max) {
              above = true;
              break;
            }
            double u;
            if (h1(p_max, u) < target) {
              above = true;
              break;
            }
            hi_known = true;
          }
          if (!(xn > lo && xn < hi)) xn = 0.5 * (lo + hi);  // keep the step inside the bracket
          if (hi - lo <= 1e-15 * hi) {
            x = xn;
            break;
          }
          x = xn;
          hx = h1(x, up);
          down = up;
        }
        if (above) {
          x = p_max;
          ++n_clipped;
        }
      }
      for (Index i = 0; i < N; ++i) st.y(i, c) = osp_step(x, r_[i], st.y(i, c));
      for (Index j = 0; j < Nc; ++j) st.yc(j, c) = ycn[static_cast<size_t>(j)];
      st.p_prev[c] = x;
      p(t, c) = x;
    }
  }
  if (clipped) *clipped = n_clipped;
}

std::string MPICreep::check_invertible() const {
  std::ostringstream why;
  double cum = p_.a1;
  for (int j = 0; j < p_.n_ops; ++j) {
    cum += b_[j];
    if (!(cum > 0)) {
      why << "play-part slope a1 + sum_{i<=" << j + 1 << "} b_i = " << cum << " S/psi is not positive";
      return why.str();
    }
  }
  // total slope: the smallest play slope plus the polynomial's slope, on [0, p_max]
  double min_play = p_.a1 + b_[0];  // r_1 = 0: that operator always follows p
  cum = p_.a1;
  for (int j = 0; j < p_.n_ops; ++j) min_play = std::min(min_play, cum += b_[j]);
  const int samples = 2000;
  double min_slope = HUGE_VAL;
  for (int k = 0; k <= samples; ++k) {
    const double x = p_.p_max * k / samples;
    const double slope = min_play + x * (2.0 * p_.a2 + 3.0 * x * p_.a3);
    if (!(slope > 0)) {
      why << "total slope " << slope << " S/psi at p = " << x
          << " psi is not positive (the polynomial's negative slope outweighs the play part)";
      return why.str();
    }
    min_slope = std::min(min_slope, slope);
  }
  double creep_gain = 0;
  for (const double w : p_.w) creep_gain += std::abs(w);
  if (!(creep_gain < min_slope)) {
    why << "creep weights sum |w_j| = " << creep_gain << " S/psi reach the smallest slope "
        << min_slope << " S/psi: the inverse would amplify its own errors through the creep state";
    return why.str();
  }
  return {};
}

PlayInverse play_inverse(double a1, const Eigen::VectorXd& b, const Eigen::VectorXd& r) {
  const Index N = b.size();
  PlayInverse inv;
  inv.a1_hat = 1.0 / a1;  // eq. 2.21
  inv.b_hat.resize(N);
  inv.r_hat.resize(N);
  double before = a1;  // a1 + sum_{i<j} b_i
  for (Index j = 0; j < N; ++j) {
    const double after = before + b[j];
    inv.b_hat[j] = -b[j] / (before * after);
    double rh = a1 * r[j];
    for (Index i = 0; i < j; ++i) rh += b[i] * (r[j] - r[i]);
    inv.r_hat[j] = rh;
    before = after;
  }
  return inv;
}

Eigen::VectorXd apply_play(double a1, const Eigen::VectorXd& b, const Eigen::VectorXd& r,
                           const Eigen::VectorXd& u) {
  Eigen::VectorXd y = Eigen::VectorXd::Zero(b.size()), out(u.size());
  for (Index t = 0; t < u.size(); ++t) {
    double v = a1 * u[t];
    for (Index i = 0; i < b.size(); ++i) v += b[i] * (y[i] = osp_step(u[t], r[i], y[i]));
    out[t] = v;
  }
  return out;
}

}  // namespace psmat::sensor
