// Shared helpers of the sensor-model tests (test_sensor_model.cpp, test_sensor_fit.cpp): the
// parameters of thesis Table 2.11, the pneumatic protocols of docs/spec.md §4, and an
// independent, deliberately plain implementation of the direct model written from the
// thesis' equations (eq. 2.15-2.18, 2.23-2.24) with std::vector, used as ground truth where a
// closed form is not available. Pressure in psi, conductance in S, time in s.
#pragma once
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

// |x - want| <= rtol |want| + atol, reported at the caller's line with both values. (doctest's
// Approx adds 1 to the scale of its epsilon, so for values of order 1e-3 S it is no check.)
#define CHECK_CLOSE(x, want, rtol, atol)                                                         \
  do {                                                                                           \
    const double got_ = (x), want_ = (want);                                                     \
    CHECK_MESSAGE(std::abs(got_ - want_) <= (rtol) * std::abs(want_) + (atol),                   \
                  #x " = " << got_ << ", expected " << want_ << " (rtol " << (rtol) << ", atol " \
                           << (atol) << ")");                                                    \
  } while (0)

namespace psmat_sensor_test {

// One parameter set of the direct model (one cell).
struct RefModel {
  double rho = 0, tau = 0, a1 = 0, a2 = 0, a3 = 0;  // S/psi, 1/psi, S/psi, S/psi^2, S/psi^3
  std::vector<double> l, w;                         // creep rates (1/s) and weights (S/psi)
  int n_ops = 6;                                    // N
  double p_max = 32.0;                              // psi
};

// Thesis Table 2.11 (docs/spec.md §4), with its two creep operators.
inline RefModel table_2_11() {
  RefModel m;
  m.rho = 1.64e-4;
  m.tau = 0.269;
  m.a1 = 1.01e-4;
  m.a2 = -5.32e-6;
  m.a3 = 7.37e-8;
  m.l = {8.25e-4, 5.26e-6};
  m.w = {8.42e-6, 1.90e-6};
  return m;
}

// r_i = (i - 1)/N p_max for i = 1..N (docs/spec.md §4).
inline double threshold(const RefModel& m, int i) { return (i - 1) * m.p_max / m.n_ops; }
// b_i = rho exp(-tau r_i) (eq. 2.18).
inline double weight(const RefModel& m, int i) {
  return m.rho * std::exp(-m.tau * threshold(m, i));
}

// The direct model of one cell from rest, sample by sample, period dt: eq. 2.15-2.16 for each
// operator, eq. 2.17 for the hysteresis, eq. 2.23-2.24 for the creep (which sees the previous
// sample's pressure, 0 before the first one).
inline std::vector<double> reference_direct(const RefModel& m, const std::vector<double>& p,
                                            double dt) {
  std::vector<double> y(static_cast<size_t>(m.n_ops), 0.0), yc(m.l.size(), 0.0), g;
  double p_before = 0.0;
  for (const double x : p) {
    double out = m.a1 * x + m.a2 * x * x + m.a3 * x * x * x;
    for (int i = 1; i <= m.n_ops; ++i) {
      double& yi = y[static_cast<size_t>(i - 1)];
      yi = std::max(x - threshold(m, i), std::min(x, yi));  // f_r(x, y) of eq. 2.16
      out += weight(m, i) * yi;
    }
    for (size_t j = 0; j < m.l.size(); ++j) {
      const double e = std::exp(-m.l[j] * dt);
      yc[j] = e * yc[j] + (1.0 - e) * p_before;  // eq. 2.23
      out += m.w[j] * yc[j];                     // eq. 2.24
    }
    p_before = x;
    g.push_back(out);
  }
  return g;
}

// A staircase through the given pressures (psi) in steps of `step` psi, each held `hold`
// samples (docs/spec.md §4: 2 psi for 6 s at 2 Hz is step 2, hold 12).
inline std::vector<double> staircase(const std::vector<double>& waypoints, double step, int hold) {
  std::vector<double> p;
  double at = waypoints.front();
  for (int k = 0; k < hold; ++k) p.push_back(at);
  for (size_t n = 1; n < waypoints.size(); ++n) {
    const double to = waypoints[n];
    while (std::abs(to - at) > 1e-9) {
      at = to > at ? std::min(at + step, to) : std::max(at - step, to);
      for (int k = 0; k < hold; ++k) p.push_back(at);
    }
  }
  return p;
}

// Descending hysteresis protocol: 0 -> 32 -> 0 -> 28 -> 0 -> ... -> 4 -> 0, `reps` times.
inline std::vector<double> descending_protocol(int reps) {
  std::vector<double> w{0.0};
  for (int r = 0; r < reps; ++r)
    for (int peak = 32; peak >= 4; peak -= 4) {
      w.push_back(peak);
      w.push_back(0.0);
    }
  return staircase(w, 2.0, 12);
}

// Ascending hysteresis protocol: 0 -> 32 -> 4 -> 32 -> 0 -> 32 -> 8 -> 32 -> 0 ... -> 32 -> 28
// -> 32 -> 0, `reps` times.
inline std::vector<double> ascending_protocol(int reps) {
  std::vector<double> w{0.0};
  for (int r = 0; r < reps; ++r)
    for (int valley = 4; valley <= 28; valley += 4) {
      w.push_back(32.0);
      w.push_back(valley);
      w.push_back(32.0);
      w.push_back(0.0);
    }
  return staircase(w, 2.0, 12);
}

// A random pressure stream in [0, p_hi] psi with load reversals of every size and rests at
// 0: a reflected random walk, held at 0 for a while whenever it reaches 0. The default p_hi
// stays inside the model's range [0, p_max] with a margin.
inline std::vector<double> random_stream(size_t T, unsigned seed, double p_hi = 31.0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> step(0.0, 2.0);
  std::uniform_int_distribution<int> rest(5, 40);
  std::vector<double> p;
  double x = 0.0;
  while (p.size() < T) {
    x = std::min(p_hi, std::abs(x + step(rng)));
    if (x < 0.5) {
      for (int k = rest(rng); k > 0 && p.size() < T; --k) p.push_back(0.0);
      x = 0.0;
      continue;
    }
    p.push_back(x);
  }
  return p;
}

}  // namespace psmat_sensor_test
