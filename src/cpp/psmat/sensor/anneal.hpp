// Simulated annealing (thesis §2.5.1): the global search of the sensor-model identification.
//
// Generic over the energy E(x) on a box [lo, hi]: one coordinate moved at a time by a
// Gaussian step whose per-coordinate width adapts towards ~40 % acceptance, Metropolis
// acceptance exp(-(E' - E)/T), geometric cooling from t0 to t_end over max_evals
// evaluations, seeded (std::mt19937_64) and so reproducible. An infinite energy rejects a
// point (the fit uses this for parameters that make the model non-invertible, docs/spec.md §4).
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>

#include <Eigen/Core>

namespace psmat::sensor {

struct AnnealOptions {
  int max_evals = 20000;
  double t0 = 1.0;      // initial temperature, in units of the energy
  double t_end = 1e-3;  // final temperature
  std::uint64_t seed = 0;
  std::atomic<int>* progress = nullptr;  // if set, incremented at every evaluation (progress bars)
};

struct AnnealResult {
  Eigen::VectorXd x;  // best point
  double energy = 0;  // its energy
  double sse_n = 0;   // exp(energy) for the log(SSE_N) energies of the fit
  int evaluations = 0;
  int accepted = 0;
};

AnnealResult anneal(const std::function<double(const Eigen::VectorXd&)>& energy,
                    const Eigen::VectorXd& x0, const Eigen::VectorXd& lo,
                    const Eigen::VectorXd& hi, const AnnealOptions& options);

}  // namespace psmat::sensor
