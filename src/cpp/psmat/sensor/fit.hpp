// Identification of the sensor model from pneumatic experiments (thesis §2.5.1, docs/spec.md §4).
//
//   SSE_N = sum_t (g_exp,t - g_m,t)^2 / N_t                                   (eq. 2.26)
// averaged over independent experiments (each simulated from rest: the sensor rests between
// them). Parameter vector theta = (rho, tau, a1, a2, a3, l_1..l_Nc, w_1..w_Nc).
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>
#include <vector>

#include "psmat/sensor/anneal.hpp"
#include "psmat/sensor/mpi_creep.hpp"

namespace psmat::sensor {

struct Experiment {
  Eigen::VectorXd p;  // applied pressure, psi
  Eigen::VectorXd g;  // measured conductance, S
  double dt = 0.5;    // sampling period, s
};

MPICreepParams params_from_theta(const Eigen::VectorXd& theta, int n_ops, double p_max);

// Mean over experiments of SSE_N (eq. 2.26), S^2.
double mean_sse_n(const MPICreep& model, const std::vector<Experiment>& experiments);
// SSE_N of each experiment.
Eigen::VectorXd sse_n_each(const MPICreep& model, const std::vector<Experiment>& experiments);

// Regression basis for separable least squares: OSP outputs y_i(t) for thresholds r
// (T x N) and creep outputs y_c,j(t) for rates l (T x Nc), from rest.
void play_basis(const Eigen::VectorXd& p, const Eigen::VectorXd& r, RowMatRef Y);
void creep_basis(const Eigen::VectorXd& p, const Eigen::VectorXd& l, double dt, RowMatRef Yc);

// Simulated annealing (thesis §2.5.1, sensor/anneal.hpp) over all parameters on
// E = log(mean SSE_N) in a scaled space x: theta_k = scale_k * x_k, or 10^x_k where log10_k,
// except that x_2 is the initial slope a1 + rho (so a1 = scale_2 x_2 - rho): the first
// operator has r_1 = 0, so y_{r_1} = p and a1, rho are collinear; searching over their sum
// and rho decorrelates the valley. Parameters that make the model non-invertible are
// rejected (docs/spec.md §4: the fit must stay usable for compensation).
AnnealResult anneal_fit(const std::vector<Experiment>& experiments, int n_ops, double p_max,
                        const Eigen::VectorXd& x0, const Eigen::VectorXd& lo,
                        const Eigen::VectorXd& hi, const Eigen::VectorXd& scale,
                        const std::vector<bool>& log10, const AnnealOptions& options);

// theta from x (see the comment above AnnealOptions)
Eigen::VectorXd theta_from_x(const Eigen::VectorXd& x, const Eigen::VectorXd& scale,
                             const std::vector<bool>& log10);

}  // namespace psmat::sensor
