// Velostat sensor model: modified Prandtl-Ishlinskii hysteresis + creep (thesis §2.5.1,
// docs/spec.md §4). Pressure p in psi, conductance g in S, one model shared by all cells, each cell
// with its own state. Arrays are (T, cells) row-major: a stream of T samples of every cell.
//
//   OSP operator  y_r(t_k) = max(p_k - r, min(p_k, y_r(t_{k-1}))),  y_r = 0 at rest (eq. 2.15-2.16)
//   hysteresis    g_h = a1 p + a2 p^2 + a3 p^3 + sum_i b_i y_{r_i}          (eq. 2.17)
//   weights       b_i = rho exp(-tau r_i),  r_i = (i-1)/N p_max             (eq. 2.18)
//   creep         y_c,j(t_k) = e^{-l_j T} y_c,j(t_{k-1}) + (1 - e^{-l_j T}) p(t_{k-1})   (eq. 2.23)
//                 g_c = sum_j w_j y_c,j                                      (eq. 2.24)
//   output        g = g_h + g_c
// Inverse (eq. 2.22, 2.25): u = g - P[p] - C[p] with P[p] = a2 p^2 + a3 p^3 at the *current*
// sample - an algebraic loop, solved exactly per sample (scalar, monotone where the model is
// invertible), so that direct(inverse(g)) == g.
#pragma once
#include <string>
#include <vector>

#include "psmat/types.hpp"

namespace psmat::sensor {

struct MPICreepParams {
  double rho = 0, tau = 0, a1 = 0, a2 = 0, a3 = 0;  // S/psi, 1/psi, S/psi, S/psi^2, S/psi^3
  std::vector<double> l;                            // creep rates, 1/s
  std::vector<double> w;                            // creep weights, S/psi
  int n_ops = 6;                                    // N OSP operators
  double p_max = 32.0;                              // psi; thresholds r_i = (i-1)/N p_max
};

// Per-cell state carried between chunks of a stream.
struct MPICreepState {
  Eigen::MatrixXd y;       // n_ops x cells: OSP outputs (psi)
  Eigen::MatrixXd yc;      // n_creep x cells: creep operator outputs (psi)
  Eigen::VectorXd p_prev;  // cells: previous pressure sample (psi), input of eq. 2.23
};

class MPICreep {
 public:
  // Throws std::invalid_argument for inconsistent parameters (sizes, non-finite values,
  // negative rates, n_ops < 1, p_max <= 0).
  explicit MPICreep(const MPICreepParams& params);

  const MPICreepParams& params() const { return p_; }
  const Eigen::VectorXd& thresholds() const { return r_; }  // r_i, psi
  const Eigen::VectorXd& weights() const { return b_; }     // b_i, S/psi

  // Relaxed state (sensor at rest): all operators at 0.
  MPICreepState rest_state(Index cells) const;

  // Direct model over a (T, cells) pressure stream. A NaN sample gives a NaN output and
  // leaves that cell's state untouched (the sample is skipped). `dt` is the sampling period
  // (s): one for every sample, or one per sample (T,) - sample k's creep step (eq. 2.23) is
  // dt[k], the time since the sample before it (a stream on a real clock, or one stepped over
  // missing frames).
  void direct(const ConstRowMatRef& p, double dt, MPICreepState& state, RowMatRef g) const;
  void direct(const ConstRowMatRef& p, const ConstVecRef& dt, MPICreepState& state, RowMatRef g) const;

  // Exact inverse: pressure from a (T, cells) conductance stream. NaN in, NaN out, state of
  // that cell untouched. A conductance below what zero pressure gives (g - creep < 0) is
  // returned as p = 0, one above what p_max gives as p = p_max (the model is identified and
  // checked monotone on [0, p_max] only); both are counted in `clipped` (if given).
  // `dt` as in direct().
  void inverse(const ConstRowMatRef& g, double dt, MPICreepState& state, RowMatRef p,
               Index* clipped = nullptr) const;
  void inverse(const ConstRowMatRef& g, const ConstVecRef& dt, MPICreepState& state, RowMatRef p,
               Index* clipped = nullptr) const;

  // Invertibility (docs/spec.md §4): every slope the play part can take, a1 + sum_{i<=j} b_i, must
  // be positive, and so must the total slope with the polynomial, on [0, p_max]. And the
  // inverse must be stable: it feeds its own estimate of p back through the creep state
  // (eq. 2.23), an error e in p_{k-1} moving the creep at k by at most sum_j |w_j| e while
  // the current sample divides by the slope, so sum_j |w_j| must stay below the smallest
  // slope (small-gain condition; the thesis' Table 2.11 model has a ratio of ~0.1). Returns
  // an empty string when invertible, otherwise why not.
  std::string check_invertible() const;

 private:
  // e^{-l_j dt} of eq. 2.23 for the period of sample t, recomputed only when it changes.
  void decay_at(const ConstVecRef& dt, Index t, std::vector<double>& decay, double& dt_of_decay) const;

  MPICreepParams p_;
  Eigen::VectorXd r_, b_;
};

// The inverse of the play part F[p] = a1 p + sum b_i F_{r_i}[p] as another MPI model
// (eq. 2.20-2.21): F^-1[u] = a1_hat u + sum_j b_hat_j F_{r_hat_j}[u].
struct PlayInverse {
  double a1_hat = 0;
  Eigen::VectorXd b_hat, r_hat;
};
PlayInverse play_inverse(double a1, const Eigen::VectorXd& b, const Eigen::VectorXd& r);

// Applies an MPI play model a1 u + sum_j b_j F_{r_j}[u] to a (T,) signal from rest.
Eigen::VectorXd apply_play(double a1, const Eigen::VectorXd& b, const Eigen::VectorXd& r,
                           const Eigen::VectorXd& u);

}  // namespace psmat::sensor
