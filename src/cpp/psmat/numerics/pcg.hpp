// Preconditioned conjugate gradients for an SPD system A y = b: the one Krylov loop of the core,
// used for the Newton matrix S of IECM (iecm/newton_operator.hpp) and for its free blocks
// (iecm/free_block_solver.hpp). The operator, the preconditioner and a hook after each update
// of y are callables, so the loop is inlined into each caller with its own matrix-free product.
#pragma once
#include <Eigen/Dense>
#include <cmath>

namespace psmat::numerics {

// Vectors of one PCG solve, kept by the caller so that repeated solves do not allocate.
struct PcgWork {
  Eigen::VectorXd r, z, p, q;
};

namespace detail {
// The PCG recurrence from the residual w.r = b - A y of the current y (bnorm = ||b|| > 0).
template <class Apply, class Precondition, class OnStep>
int pcg_steps(double bnorm, Eigen::VectorXd& y, double tol, int max_iter, PcgWork& w,
              Apply&& apply, Precondition&& precondition, OnStep&& on_step) {
  precondition(w.r, w.z);
  w.p = w.z;
  double rz = w.r.dot(w.z);
  for (int k = 1; k <= max_iter; ++k) {
    apply(w.p, w.q);
    const double pq = w.p.dot(w.q);
    if (!(pq > 0.0) || !std::isfinite(pq)) return -1;  // breakdown
    const double alpha = rz / pq;
    y.noalias() += alpha * w.p;
    on_step(alpha);
    w.r.noalias() -= alpha * w.q;
    if (w.r.norm() <= tol * bnorm) return k;
    precondition(w.r, w.z);
    const double rz_new = w.r.dot(w.z);
    w.p = w.z + (rz_new / rz) * w.p;
    rz = rz_new;
  }
  return -1;
}
}  // namespace detail

// Solves A y = b from y = 0 to ||b - A y|| <= tol ||b||.
//   apply(p, q):        q = A p  (q is resized by the callee)
//   precondition(r, z): z = P^-1 r, P SPD  (z is resized by the callee)
//   on_step(alpha):     called after each y += alpha p, with the product A p still in w.q
//                       (e.g. to accumulate another product of the same direction)
// Returns the iterations used (0 when b = 0), or -1 when max_iter was reached or the recurrence
// broke down (p'Ap not positive and finite); y then holds the last iterate.
template <class Apply, class Precondition, class OnStep>
int pcg(const Eigen::VectorXd& b, Eigen::VectorXd& y, double tol, int max_iter, PcgWork& w,
        Apply&& apply, Precondition&& precondition, OnStep&& on_step) {
  y.setZero(b.size());
  w.r = b;
  const double bnorm = b.norm();
  if (bnorm == 0.0) return 0;
  return detail::pcg_steps(bnorm, y, tol, max_iter, w, apply, precondition, on_step);
}

// The same from the initial guess in y (one more product, A y, after which on_start() is called
// with it in w.q). Returns 0 when the guess already meets the tolerance.
template <class Apply, class Precondition, class OnStep, class OnStart>
int pcg_from(const Eigen::VectorXd& b, Eigen::VectorXd& y, double tol, int max_iter, PcgWork& w,
             Apply&& apply, Precondition&& precondition, OnStep&& on_step, OnStart&& on_start) {
  const double bnorm = b.norm();
  if (bnorm == 0.0) {
    y.setZero(b.size());
    return 0;
  }
  apply(y, w.q);
  on_start();
  w.r = b - w.q;
  if (w.r.norm() <= tol * bnorm) return 0;
  return detail::pcg_steps(bnorm, y, tol, max_iter, w, apply, precondition, on_step);
}

// Without a hook.
template <class Apply, class Precondition>
int pcg(const Eigen::VectorXd& b, Eigen::VectorXd& y, double tol, int max_iter, PcgWork& w,
        Apply&& apply, Precondition&& precondition) {
  return pcg(b, y, tol, max_iter, w, apply, precondition, [](double) {});
}

}  // namespace psmat::numerics
