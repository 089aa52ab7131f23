// Variable projection (separable least squares) for the MPI + creep model (docs/spec.md §4).
//
// For fixed nonlinear parameters z = (tau, log10 l_1, ..., log10 l_Nc) the model output is
// linear in c = (a1, a2, a3, rho, w_1, ..., w_Nc):
//   g = a1 p + a2 p^2 + a3 p^3 + rho sum_i e^{-tau r_i} y_{r_i}[p] + sum_j w_j y_c[p; l_j]
// (eq. 2.17-2.18 and 2.22-2.25). The rows of experiment e are weighted by 1/sqrt(E N_e), so
// ||A c - b||^2 is the mean over the E experiments of SSE_N (eq. 2.26). Only z is searched;
// c is an exact linear solve. One home for the reduced problem: the grid/BOBYQA search and
// the annealing both call it.
#pragma once
#include <vector>

#include "psmat/sensor/anneal.hpp"
#include "psmat/sensor/fit.hpp"

namespace psmat::sensor {

class SeparableProblem {
 public:
  SeparableProblem(std::vector<Experiment> experiments, int n_ops, double p_max, int n_creep);

  int n_nonlinear() const { return 1 + n_creep_; }  // tau, log10 l_j
  int n_linear() const { return 4 + n_creep_; }     // a1, a2, a3, rho, w_j
  Eigen::Index rows() const { return rows_; }

  // Weighted design matrix A (rows x n_linear) and right-hand side b at z.
  void design(const Eigen::VectorXd& z, Eigen::MatrixXd& A, Eigen::VectorXd& b) const;

  struct Solution {
    double cost = 0;        // ||A c - b||^2 = mean SSE_N, S^2
    Eigen::VectorXd theta;  // (rho, tau, a1, a2, a3, l.., w..)
    std::string invertibility_problem;  // empty when the model can be inverted
  };
  // Unconstrained linear least squares at z (Householder QR on scaled columns).
  Solution solve(const Eigen::VectorXd& z) const;
  // theta from z and the linear coefficients c.
  Eigen::VectorXd theta(const Eigen::VectorXd& z, const Eigen::VectorXd& c) const;

 private:
  std::vector<Experiment> ex_;
  std::vector<RowMatrixXd> play_;  // OSP outputs from rest, per experiment (T_e x n_ops)
  std::vector<double> weight_;
  Eigen::VectorXd r_;
  int n_ops_;
  double p_max_;
  int n_creep_;
  Eigen::Index rows_ = 0;
};

// Simulated annealing over z only (the energy is log of the variable-projection cost; a
// least-squares solution that cannot be inverted is rejected).
AnnealResult anneal_separable(const SeparableProblem& problem, const Eigen::VectorXd& z0,
                              const Eigen::VectorXd& lo, const Eigen::VectorXd& hi,
                              const AnnealOptions& options);

}  // namespace psmat::sensor
