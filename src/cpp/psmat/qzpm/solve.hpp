// Inverse of the QZPM readout (thesis App. C, eq. C.8-C.9): cell conductances AND switch
// conductances from the R*C + R + C readings,
//     minimise 0.5 * sum_a ((F(theta)_a - G_a) / G_a)^2,   g >= 0, g_k > 0,
// by Levenberg-Marquardt in log-parameters (positivity by construction), with the analytic
// Jacobian of forward.hpp: the core's LM (numerics/levenberg_marquardt.hpp), also that of IECM's
// least squares (iecm/solve_lsq.cpp), with the same Status / SolveReport (psmat/solve_report.hpp). Switches are one shared conductance g_s (R*C + 1 unknowns) or R + C
// separate ones (R*C + R + C unknowns: as many as readings). Cold start from the closed form
// (closed_form.hpp) with an assumed switch resistance. The separate-switch solve uses variable
// projection (cells eliminated for given switches by LM; LM with geodesic acceleration on the
// R + C log switches, reduced Jacobian (I - J_c J_c^+) J_s) from the start / cold starts with
// r_switch0 x {1, 0.5, 2} (each with, then without, geodesic acceleration), then the full LM; only if none converges, the former path (shared
// solution, homotopy in the readings, restarts), keeping the lowest cost.
#pragma once
#include <vector>

#include "psmat/qzpm/forward.hpp"
#include "psmat/solve_report.hpp"

namespace psmat::qzpm {

using psmat::SolveReport;
using psmat::Status;

enum class Switches { Shared = 0, Separate = 1 };

struct SolveOptions {
  Switches switches = Switches::Shared;
  int max_iter = 300;          // LM iterations per stage
  double rtol = 1e-13;         // stop when max_a |F_a - G_a| / G_a <= rtol
  double ftol = 1e-16;         // stop (least squares) when the cost decreases by less, relatively
  double max_log_step = 2.0;   // trust region: |delta log theta| per parameter and iteration
  double r_switch0 = 10.0;     // Ohm, switch resistance of the cold start
  double g_floor = 1e-15;      // S; cells are kept above it (log parameters)
};

struct Solution {
  Eigen::VectorXd g;      // R*C cells, row-major (S)
  Eigen::VectorXd g_row;  // R row switch conductances (S)
  Eigen::VectorXd g_col;  // C column switch conductances (S)
  SolveReport report;     // iterations / evaluations / factorizations summed over stages
};

// Starting point from the readings: closed-form cells with r_switch0 (invalid or non-positive
// estimates replaced by a small positive value), switches 1/r_switch0.
void cold_start(Shape s, const Readings& G, double r_switch0, VecRef g, VecRef sw);

// Solves one problem. g0 / sw0 (R*C and R+C, optional: empty = cold start) is the start.
Solution solve(Shape s, const Readings& G, const SolveOptions& o,
               const Eigen::VectorXd& g0 = Eigen::VectorXd(),
               const Eigen::VectorXd& sw0 = Eigen::VectorXd());

// Independent problems (rows of G: T x (R*C+R+C), flat readings) on a pool of n_threads
// threads (numerics/thread_pool.hpp).
std::vector<Solution> solve_batch(Shape s, const RowMatrixXd& G, const SolveOptions& o,
                                  int n_threads);

}  // namespace psmat::qzpm
