#include "psmat/qzpm/solve.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "psmat/numerics/levenberg_marquardt.hpp"
#include "psmat/numerics/thread_pool.hpp"
#include "psmat/qzpm/closed_form.hpp"

namespace psmat::qzpm {

void cold_start(Shape s, const Readings& G, double r0, VecRef g, VecRef sw) {
  g = closed_form(s, G, r0);
  std::vector<double> ok;
  for (Index a = 0; a < g.size(); ++a)
    if (std::isfinite(g[a]) && g[a] > 0.0) ok.push_back(g[a]);
  double fill = 1e-3 * G.pairs.minCoeff();
  if (!ok.empty()) {
    std::nth_element(ok.begin(), ok.begin() + static_cast<long>(ok.size() / 2), ok.end());
    fill = std::min(fill, 1e-2 * ok[ok.size() / 2]);
  }
  for (Index a = 0; a < g.size(); ++a)
    if (!(std::isfinite(g[a]) && g[a] > 0.0)) g[a] = fill;
  sw.setConstant(1.0 / r0);
}

namespace {

// Work counters of a stage added to / copied into a report.
void add_counts(SolveReport& acc, const SolveReport& r) {
  acc.iterations += r.iterations;
  acc.evaluations += r.evaluations;
  acc.factorizations += r.factorizations;
}

void copy_counts(SolveReport& to, const SolveReport& from) {
  to.iterations = from.iterations;
  to.evaluations = from.evaluations;
  to.factorizations = from.factorizations;
}

// The least-squares problem of one switch mode for the core's Levenberg-Marquardt
// (numerics/levenberg_marquardt.hpp): the point theta = (cells, switches) with switches of length
// 1 (shared) or R + C (separate), steps in log theta.
class Lsq {
 public:
  // fixed_sw (R + C, optional): cells-only problem with these switches (theta = cells).
  Lsq(Shape s, const Eigen::VectorXd& G, const SolveOptions& o, Switches mode,
      const Eigen::VectorXd* fixed_sw = nullptr)
      : s_(s), G_(G), o_(o), mode_(mode), net_(s),
        np_(s.cells() + (fixed_sw ? 0 : (mode == Switches::Shared ? 1 : s.nodes()))),
        F_(G.size()), r_(G.size()), w_(G.array().inverse()), Jfull_(G.size(), n_parameters(s)) {
    if (fixed_sw) fixed_sw_ = *fixed_sw;
  }

  Index parameters() const { return np_; }

  void expand(const Eigen::VectorXd& theta, Eigen::VectorXd& g, Eigen::VectorXd& sw) const {
    g = theta.head(s_.cells());
    if (fixed_sw_.size() > 0)
      sw = fixed_sw_;
    else if (mode_ == Switches::Shared)
      sw.setConstant(s_.nodes(), theta[s_.cells()]);
    else
      sw = theta.tail(s_.nodes());
  }

  bool evaluate(const Eigen::VectorXd& theta, double& cost, double& resid) {
    expand(theta, g_, sw_);
    if (!net_.compute(g_, sw_)) return false;
    readings(net_, F_);
    r_ = (F_.array() / G_.array() - 1.0).matrix();
    if (!r_.allFinite()) return false;
    cost = 0.5 * r_.squaredNorm();
    resid = r_.cwiseAbs().maxCoeff();
    return true;
  }

  // Weighted Jacobian d r / d log theta at the last evaluated point.
  void jacobian_log(const Eigen::VectorXd& theta, Eigen::MatrixXd& Jw) {
    qzpm::jacobian(net_, Jfull_);  // the analytic Jacobian (forward.hpp), not the member below
    const Index m = G_.size(), nc = s_.cells();
    Jw.resize(m, np_);
    const Eigen::ArrayXd& w = w_;
    for (Index a = 0; a < nc; ++a) Jw.col(a) = (Jfull_.col(a).array() * w * theta[a]).matrix();
    if (fixed_sw_.size() > 0) return;
    if (mode_ == Switches::Shared) {
      Jw.col(nc) = (Jfull_.rightCols(s_.nodes()).rowwise().sum().array() * w * theta[nc]).matrix();
    } else {
      for (Index k = 0; k < s_.nodes(); ++k)
        Jw.col(nc + k) = (Jfull_.col(nc + k).array() * w * theta[nc + k]).matrix();
    }
  }

  const Eigen::VectorXd& residual() const { return r_; }

  // ---- the problem for numerics::levenberg_marquardt ----
  const Eigen::VectorXd& jacobian(const Eigen::VectorXd& theta, Eigen::MatrixXd& Jw) {
    jacobian_log(theta, Jw);
    return r_;
  }
  bool fix(const Eigen::VectorXd&, const Eigen::VectorXd&,
           Eigen::Array<bool, Eigen::Dynamic, 1>&) const {
    return false;  // log parameters: no bound to hold
  }
  // the trust region |d log theta| <= max_log_step; cells kept above g_floor
  void step(const Eigen::VectorXd& theta, Eigen::VectorXd& d, Eigen::VectorXd& tt) const {
    const double mx = d.cwiseAbs().maxCoeff();
    if (mx > o_.max_log_step) d *= o_.max_log_step / mx;
    tt = (theta.array() * d.array().exp()).matrix();
    tt.head(s_.cells()) = tt.head(s_.cells()).cwiseMax(o_.g_floor);
  }

  // LM from theta (updated in place); iterations, evaluations and factorisations are added to
  // rep, its status, cost and residual set.
  void run(Eigen::VectorXd& theta, SolveReport& rep) {
    numerics::LmSettings st;
    st.max_iter = o_.max_iter;
    st.rtol = o_.rtol;
    st.ftol = o_.ftol;
    st.lambda0 = 1e-4;
    st.lambda_down = 5.0;
    st.lambda_min = 1e-14;
    st.grad_tol = 1e-14;
    numerics::levenberg_marquardt(*this, theta, st, rep, work_);
  }

 private:
  Shape s_;
  const Eigen::VectorXd& G_;
  SolveOptions o_;
  Switches mode_;
  Network net_;
  Index np_;
  Eigen::VectorXd fixed_sw_;
  Eigen::VectorXd F_, r_;
  Eigen::ArrayXd w_;         // 1 / G (weights of the relative residuals)
  Eigen::VectorXd g_, sw_;   // expanded parameters of the last evaluation (reused buffers)
  RowMatrixXd Jfull_;
  numerics::LmWork work_;
};


// Inner problem of the variable projection: cells for fixed switches sw (R*C unknowns,
// R*C + R + C readings: over-determined and well conditioned), LM on log cells from g.
// Returns the cost; r = residual at the end.
double solve_cells(Shape s, const Eigen::VectorXd& G, const SolveOptions& o,
                   const Eigen::VectorXd& sw, Eigen::VectorXd& g, Eigen::VectorXd& r,
                   SolveReport& acc) {
  SolveOptions oi = o;
  oi.max_iter = 100;
  oi.ftol = 1e-15;
  Lsq cells(s, G, oi, Switches::Separate, &sw);
  SolveReport ri;
  cells.run(g, ri);
  add_counts(acc, ri);
  if (ri.status == Status::Singular || !std::isfinite(ri.cost))
    return std::numeric_limits<double>::infinity();
  r = cells.residual();
  return ri.cost;
}

// Full separate-switch LM on the original readings G from theta (updated in place); its
// counters are added to acc. Returns the stage's report.
SolveReport polish(Shape s, const Eigen::VectorXd& G, const SolveOptions& o, Eigen::VectorXd& theta,
                   SolveReport& acc) {
  Lsq sep(s, G, o, Switches::Separate);
  SolveReport rf;
  sep.run(theta, rf);
  add_counts(acc, rf);
  return rf;
}

// The reduced problem of the variable projection for the separate-switch problem
// (docs/qzpm.md §3), for numerics::levenberg_marquardt: x = the R + C switch conductances
// (steps in log, |d log sw| <= 1), the cells eliminated: r(x) is the residual after solve_cells
// for the switches x, from cells predicted to first order. The Jacobian is the reduced one,
// J_r = (I - J_c J_c^+) J_s (Kaufman), and acceleration() the geodesic acceleration term by a
// finite difference along the step (the valleys of the reduced cost are narrow and curved).
// Inner counters are added to acc.
class Reduced {
 public:
  Reduced(Shape s, const Eigen::VectorXd& G, const SolveOptions& o, const Eigen::VectorXd& g,
          bool accel, SolveReport& acc)
      : s_(s), G_(G), o_(o), accel_(accel), acc_(acc), full_(s, G, o, Switches::Separate),
        gstart_(g), qr_(G.size(), s.cells()) {}

  // cells of the last evaluation (those of x at the end of the LM, whatever its status)
  const Eigen::VectorXd& cells() const { return g_ev_; }

  bool evaluate(const Eigen::VectorXd& sw, double& cost, double& resid) {
    if (has_cur_ && sw == sw_cur_) {  // back at the current point: its cells, no new solve
      g_ev_ = g_cur_;
      r_ev_ = r_cur_;
    } else {
      g_ev_ = gstart_;
      if (!std::isfinite(solve_cells(s_, G_, o_, sw, g_ev_, r_ev_, acc_))) return false;
    }
    cost = 0.5 * r_ev_.squaredNorm();
    resid = r_ev_.cwiseAbs().maxCoeff();
    return true;
  }

  const Eigen::VectorXd& jacobian(const Eigen::VectorXd& sw, Eigen::MatrixXd& Jw) {
    const Index nc = s_.cells(), nn = s_.nodes();
    sw_cur_ = sw;  // the point of the last evaluation becomes the current one
    g_cur_ = g_ev_;
    r_cur_ = r_ev_;
    has_cur_ = true;
    theta_.resize(nc + nn);
    theta_ << g_cur_, sw;
    double c = 0, rr = 0;
    full_.evaluate(theta_, c, rr);
    full_.jacobian_log(theta_, Jfull_);
    qr_.compute(Jfull_.leftCols(nc));
    QtJs_ = qr_.householderQ().transpose() * Jfull_.rightCols(nn);
    P_ = QtJs_;
    P_.topRows(nc).setZero();
    Jw.noalias() = qr_.householderQ() * P_;
    return r_cur_;
  }

  bool fix(const Eigen::VectorXd&, const Eigen::VectorXd&,
           Eigen::Array<bool, Eigen::Dynamic, 1>&) const {
    return false;  // log switches: no bound to hold
  }

  void step(const Eigen::VectorXd& sw, Eigen::VectorXd& d, Eigen::VectorXd& swt) {
    const double mx = d.cwiseAbs().maxCoeff();
    if (mx > 1.0) d /= mx;
    swt = (sw.array() * d.array().exp()).matrix();
    cells_for(d, gstart_);
  }

  // second directional derivative of the reduced residual along d, by the finite difference
  // (2/h) ((r(sw e^{h d}) - r) / h - J_r d), h = 0.1
  bool acceleration(const Eigen::VectorXd& sw, const Eigen::VectorXd& d, const Eigen::VectorXd& Jd,
                    Eigen::VectorXd& rpp) {
    if (!accel_) return false;
    const double h = 0.1;
    e_ = h * d;
    swh_ = (sw.array() * e_.array().exp()).matrix();
    cells_for(e_, gh_);
    if (!std::isfinite(solve_cells(s_, G_, o_, swh_, gh_, rh_, acc_))) return false;
    rpp = (2.0 / h) * ((rh_ - r_cur_) / h - Jd);
    return true;
  }

 private:
  // first-order change of the (eliminated) cells for a switch step e: -J_c^+ J_s e (the QR of
  // J_c at the current point), cells kept above g_floor
  void cells_for(const Eigen::VectorXd& e, Eigen::VectorXd& out) {
    const Index nc = s_.cells();
    y_.noalias() = QtJs_.topRows(nc) * e;
    dx_ = -qr_.matrixQR().topLeftCorner(nc, nc).triangularView<Eigen::Upper>().solve(y_);
    if (!dx_.allFinite()) dx_.setZero();
    out = (g_cur_.array() * dx_.array().max(-2.0).min(2.0).exp()).matrix().cwiseMax(o_.g_floor);
  }

  Shape s_;
  const Eigen::VectorXd& G_;
  SolveOptions o_;
  bool accel_;
  SolveReport& acc_;
  Lsq full_;
  Eigen::VectorXd gstart_;  // start of the next cells solve
  Eigen::VectorXd g_ev_, r_ev_;  // cells and residual of the last evaluation
  bool has_cur_ = false;
  Eigen::VectorXd sw_cur_, g_cur_, r_cur_;  // the current point (that of the Jacobian)
  Eigen::VectorXd theta_, e_, swh_, gh_, rh_, y_, dx_;  // buffers reused across iterations
  Eigen::MatrixXd Jfull_, QtJs_, P_;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr_;
};

// Variable projection from (g, sw): the core's LM on the reduced problem (geodesic acceleration
// when accel). Returns theta = (cells, switches) at the end; the caller polishes with the full
// LM. Iterations and factorisations (and the inner cells solves) are added to acc.
Eigen::VectorXd varpro(Shape s, const Eigen::VectorXd& G, const SolveOptions& o,
                       const Eigen::VectorXd& g, Eigen::VectorXd sw, SolveReport& acc, bool accel) {
  Reduced pb(s, G, o, g, accel, acc);
  numerics::LmSettings st;
  st.max_iter = 200;
  st.rtol = std::max(o.rtol, 1e-12);
  st.ftol = 0.0;      // runs until converged or no decrease for any lambda
  st.grad_tol = 0.0;
  st.lambda0 = 1e-3;
  st.lambda_down = 5.0;
  st.lambda_min = 1e-14;
  st.lambda_up = 4.0;
  st.lambda_max = 1e12;
  st.accept_ratio = 0.0;  // any decrease
  SolveReport rv;
  numerics::LmWork work;
  numerics::levenberg_marquardt(pb, sw, st, rv, work);
  acc.iterations += rv.iterations;
  acc.factorizations += rv.factorizations;
  Eigen::VectorXd theta(s.cells() + s.nodes());
  theta << pb.cells(), sw;
  return theta;
}
}  // namespace

Solution solve(Shape s, const Readings& Gr, const SolveOptions& o, const Eigen::VectorXd& g0,
               const Eigen::VectorXd& sw0) {
  Solution sol;
  const Index nc = s.cells(), nn = s.nodes();
  const Eigen::VectorXd G = Gr.flat();
  Eigen::VectorXd g(nc), sw(nn);
  cold_start(s, Gr, o.r_switch0, g, sw);
  const bool warm = g0.size() == nc;
  if (warm) g = g0.cwiseMax(o.g_floor);
  if (sw0.size() == nn) sw = sw0;
  SolveReport& rep = sol.report;
  if (!G.allFinite() || (G.array() <= 0.0).any()) {
    rep.status = Status::Singular;
    sol.g = Eigen::VectorXd::Constant(nc, std::nan(""));
    sol.g_row = Eigen::VectorXd::Constant(s.rows, std::nan(""));
    sol.g_col = Eigen::VectorXd::Constant(s.cols, std::nan(""));
    return sol;
  }

  // Separate switches: variable projection (cells eliminated, LM with geodesic acceleration
  // on the switches) from the start / cold starts, polished by the full LM; the older path
  // (shared solution, homotopy, restarts) below only when none of these converges.
  Eigen::VectorXd vp_best;
  SolveReport vp_rep;
  vp_rep.cost = std::numeric_limits<double>::infinity();
  if (o.switches == Switches::Separate) {
    SolveReport acc;
    std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>> starts;
    if (warm || sw0.size() == nn) starts.emplace_back(g, sw);
    for (double f : {1.0, 0.5, 2.0}) {
      Eigen::VectorXd gc(nc), swc(nn);
      cold_start(s, Gr, o.r_switch0 * f, gc, swc);
      starts.emplace_back(gc, swc);
    }
    // each start with geodesic acceleration (faster in the curved valleys), then without
    // (it stalls less on some draws)
    std::vector<std::pair<size_t, bool>> runs;
    for (size_t k = 0; k < starts.size(); ++k) runs.emplace_back(k, true);
    for (size_t k = 0; k < starts.size(); ++k) runs.emplace_back(k, false);
    for (auto& run : runs) {
      const auto& st = starts[run.first];
      Eigen::VectorXd th = varpro(s, G, o, st.first, st.second, acc, run.second);
      const SolveReport rf = polish(s, G, o, th, acc);
      if (rf.cost < vp_rep.cost || vp_best.size() == 0) {
        vp_best = th;
        vp_rep.status = rf.status;
        vp_rep.cost = rf.cost;
        vp_rep.residual = rf.residual;
      }
      if (rf.status == Status::Converged) break;
    }
    copy_counts(vp_rep, acc);
    if (vp_rep.status == Status::Converged) {
      rep = vp_rep;
      sol.g = vp_best.head(nc);
      sol.g_row = vp_best.segment(nc, s.rows);
      sol.g_col = vp_best.tail(s.cols);
      return sol;
    }
    copy_counts(rep, acc);
  }

  // stage 1: one shared switch conductance (the only stage in shared mode; in separate mode
  // a well-posed start for stage 2 unless the caller gave separate switches)
  const bool separate_start = sw0.size() == nn && (sw0.array() != sw0[0]).any();
  Eigen::VectorXd theta;
  if (o.switches == Switches::Shared || !separate_start) {
    SolveOptions o1 = o;
    if (o.switches == Switches::Separate) o1.ftol = std::max(o.ftol, 1e-10);  // a start only
    Lsq shared(s, G, o1, Switches::Shared);
    theta.resize(nc + 1);
    theta << g, sw.mean();
    shared.run(theta, rep);
    g = theta.head(nc);
    sw.setConstant(theta[nc]);
  }
  if (o.switches == Switches::Separate) {
    // Homotopy in the readings from those of the start (exactly matched at t = 0) to G:
    // log G(t) = (1 - t) log F(start) + t log G, each step warm-started from the last, the step
    // halved when LM does not converge. Plain LM from the shared-switch solution often ends in
    // a spurious minimum (a switch running to 0 or infinity); the path avoids most of them.
    // When it still fails, restart from cold starts with other switch resistances; keep the best.
    auto homotopy = [&](Eigen::VectorXd th, SolveReport& acc) {
      Network net(s);
      Eigen::VectorXd F0(G.size());
      if (net.compute(th.head(nc), th.tail(nn))) {
        readings(net, F0);
        const Eigen::ArrayXd l0 = F0.array().log(), l1 = G.array().log();
        SolveOptions ot = o;
        ot.rtol = std::max(o.rtol, 1e-7);
        ot.max_iter = 30;
        double t = 0.0, dt = 0.25;
        Eigen::VectorXd Gt(G.size()), keep;
        while (t < 1.0 && dt > 1e-4) {
          const double t1 = std::min(1.0, t + dt);
          Gt = ((1.0 - t1) * l0 + t1 * l1).exp().matrix();
          keep = th;
          Lsq step(s, Gt, ot, Switches::Separate);
          SolveReport rs;
          step.run(th, rs);
          add_counts(acc, rs);
          if (rs.status == Status::Converged) {
            t = t1;
            dt = std::min(1.0, dt * 2.0);
          } else {
            th = keep;
            dt /= 2.0;
          }
        }
      }
      const SolveReport rf = polish(s, G, o, th, acc);
      acc.status = rf.status;
      acc.residual = rf.residual;
      acc.cost = rf.cost;
      return th;
    };
    SolveReport acc = rep;
    theta.resize(nc + nn);
    theta << g, sw;
    Eigen::VectorXd best = homotopy(theta, acc);
    SolveReport best_rep = acc;
    const double factors[] = {1.0, 0.5, 2.0, 0.7, 1.4};
    for (double f : factors) {
      if (best_rep.status == Status::Converged) break;
      Eigen::VectorXd gc(nc), swc(nn);
      cold_start(s, Gr, o.r_switch0 * f, gc, swc);
      theta << gc, swc;
      SolveReport r = acc;
      r.status = Status::MaxIterations;
      Eigen::VectorXd th = homotopy(theta, r);
      copy_counts(acc, r);
      if (r.cost < best_rep.cost || r.status == Status::Converged) {
        best = th;
        best_rep = r;
      }
    }
    copy_counts(best_rep, acc);
    if (vp_best.size() > 0 && vp_rep.cost <= best_rep.cost) {
      best = vp_best;
      best_rep.status = vp_rep.status;
      best_rep.cost = vp_rep.cost;
      best_rep.residual = vp_rep.residual;
    }
    rep = best_rep;
    g = best.head(nc);
    sw = best.tail(nn);
  }
  sol.g = g;
  sol.g_row = sw.head(s.rows);
  sol.g_col = sw.tail(s.cols);
  return sol;
}

std::vector<Solution> solve_batch(Shape s, const RowMatrixXd& G, const SolveOptions& o,
                                  int n_threads) {
  const Index T = G.rows();
  std::vector<Solution> out(static_cast<size_t>(T));
  const int nt = static_cast<int>(std::min<Index>(std::max(1, n_threads), std::max<Index>(T, 1)));
  numerics::ThreadPool pool(nt);
  std::vector<std::future<void>> done;
  done.reserve(static_cast<size_t>(T));
  for (Index t = 0; t < T; ++t)
    done.push_back(pool.submit([&, t](int) {
      const Eigen::VectorXd row = G.row(t).transpose();
      out[static_cast<size_t>(t)] = solve(s, Readings::from_flat(s, row), o);
    }));
  for (auto& f : done) f.get();  // in order; rethrows what a problem threw
  return out;
}

}  // namespace psmat::qzpm
