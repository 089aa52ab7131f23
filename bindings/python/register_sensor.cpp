// Bindings of the C++ sensor model: psmat._core.sensor. Arrays are (T, cells) float64.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <cstdint>
#include <stdexcept>

#include "psmat/sensor/fit.hpp"
#include "psmat/sensor/mpi_creep.hpp"
#include "psmat/sensor/separable.hpp"

namespace py = pybind11;
using namespace psmat;
using namespace psmat::sensor;

namespace {
using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

Eigen::Map<const RowMatrixXd> as_stream(const CArray& a) {
  if (a.ndim() != 2) throw std::invalid_argument("expected a (T, cells) array");
  return Eigen::Map<const RowMatrixXd>(a.data(), a.shape(0), a.shape(1));
}

std::vector<Experiment> experiments(const std::vector<Eigen::VectorXd>& p,
                                    const std::vector<Eigen::VectorXd>& g,
                                    const std::vector<double>& dt) {
  if (p.size() != g.size() || p.size() != dt.size() || p.empty())
    throw std::invalid_argument("one p, g and dt per experiment");
  std::vector<Experiment> ex(p.size());
  for (size_t e = 0; e < p.size(); ++e) {
    if (p[e].size() != g[e].size() || p[e].size() == 0)
      throw std::invalid_argument("p and g of an experiment must have the same, non-zero length");
    ex[e] = Experiment{p[e], g[e], dt[e]};
  }
  return ex;
}

AnnealOptions anneal_options(int max_evals, double t0, double t_end, std::uint64_t seed,
                             std::atomic<int>* progress) {
  AnnealOptions o;
  o.max_evals = max_evals;
  o.t0 = t0;
  o.t_end = t_end;
  o.seed = seed;
  o.progress = progress;
  return o;
}

// theta (optional) is inserted after x, as anneal_fit reports it.
py::dict anneal_dict(const AnnealResult& r, const Eigen::VectorXd* theta = nullptr) {
  py::dict d;
  d["x"] = r.x;
  if (theta) d["theta"] = *theta;
  d["sse_n"] = r.sse_n;
  d["evaluations"] = r.evaluations;
  d["accepted"] = r.accepted;
  return d;
}

void check_state(const MPICreep& m, const MPICreepState& s, Index cells) {
  if (s.y.rows() != m.params().n_ops || s.y.cols() != cells ||
      s.yc.rows() != static_cast<Index>(m.params().l.size()) || s.p_prev.size() != cells)
    throw std::invalid_argument("state does not match this model and number of cells");
}

// MPICreep.direct / .inverse over a (T, cells) stream; Dt is one period (double) or one per
// sample (VectorXd), both accepted by the core.
template <class Dt>
RowMatrixXd direct_stream(const MPICreep& c, const CArray& p, const Dt& dt, MPICreepState& state) {
  const auto P = as_stream(p);
  check_state(c, state, P.cols());
  RowMatrixXd g(P.rows(), P.cols());
  {
    py::gil_scoped_release release;
    c.direct(P, dt, state, g);
  }
  return g;
}

template <class Dt>
py::tuple inverse_stream(const MPICreep& c, const CArray& g, const Dt& dt, MPICreepState& state) {
  const auto Gs = as_stream(g);
  check_state(c, state, Gs.cols());
  RowMatrixXd p(Gs.rows(), Gs.cols());
  Index clipped = 0;
  {
    py::gil_scoped_release release;
    c.inverse(Gs, dt, state, p, &clipped);
  }
  return py::make_tuple(p, clipped);
}

}  // namespace

void register_sensor(py::module_& m) {
  py::class_<MPICreepParams>(m, "MPICreepParams")
      .def(py::init<>())
      .def_readwrite("rho", &MPICreepParams::rho)
      .def_readwrite("tau", &MPICreepParams::tau)
      .def_readwrite("a1", &MPICreepParams::a1)
      .def_readwrite("a2", &MPICreepParams::a2)
      .def_readwrite("a3", &MPICreepParams::a3)
      .def_readwrite("l", &MPICreepParams::l)
      .def_readwrite("w", &MPICreepParams::w)
      .def_readwrite("n_ops", &MPICreepParams::n_ops)
      .def_readwrite("p_max", &MPICreepParams::p_max);

  py::class_<MPICreepState>(m, "MPICreepState", "Per-cell operator state carried between chunks")
      .def_property(
          "y", [](const MPICreepState& s) { return Eigen::MatrixXd(s.y); },
          [](MPICreepState& s, const Eigen::MatrixXd& v) { s.y = v; })
      .def_property(
          "yc", [](const MPICreepState& s) { return Eigen::MatrixXd(s.yc); },
          [](MPICreepState& s, const Eigen::MatrixXd& v) { s.yc = v; })
      .def_property(
          "p_prev", [](const MPICreepState& s) { return Eigen::VectorXd(s.p_prev); },
          [](MPICreepState& s, const Eigen::VectorXd& v) { s.p_prev = v; })
      .def("copy", [](const MPICreepState& s) { return MPICreepState(s); });

  py::class_<MPICreep>(m, "MPICreep", "MPI hysteresis + creep model (thesis §2.5.1)")
      .def(py::init<const MPICreepParams&>(), py::arg("params"))
      .def_property_readonly("thresholds", [](const MPICreep& c) { return Eigen::VectorXd(c.thresholds()); })
      .def_property_readonly("weights", [](const MPICreep& c) { return Eigen::VectorXd(c.weights()); })
      .def("rest_state", &MPICreep::rest_state, py::arg("cells"))
      .def("check_invertible", &MPICreep::check_invertible)
      // dt: one period for every sample, or one per sample (s) - a real clock, missing frames
      .def("direct", &direct_stream<double>, py::arg("p"), py::arg("dt"), py::arg("state"))
      .def("direct", &direct_stream<Eigen::VectorXd>, py::arg("p"), py::arg("dt"), py::arg("state"))
      .def("inverse", &inverse_stream<double>, py::arg("g"), py::arg("dt"), py::arg("state"))
      .def("inverse", &inverse_stream<Eigen::VectorXd>, py::arg("g"), py::arg("dt"), py::arg("state"));

  m.def(
      "play_inverse",
      [](double a1, const Eigen::VectorXd& b, const Eigen::VectorXd& r) {
        const PlayInverse inv = play_inverse(a1, b, r);
        return py::make_tuple(inv.a1_hat, inv.b_hat, inv.r_hat);
      },
      py::arg("a1"), py::arg("b"), py::arg("r"), "Analytic inverse of the play part (eq. 2.21).");
  m.def("apply_play", &apply_play, py::arg("a1"), py::arg("b"), py::arg("r"), py::arg("u"),
        "a1 u + sum_j b_j F_{r_j}[u] from rest (eq. 2.17 without the polynomial).");

  m.def(
      "sse_n_each",
      [](const Eigen::VectorXd& theta, const std::vector<Eigen::VectorXd>& p,
         const std::vector<Eigen::VectorXd>& g, const std::vector<double>& dt, int n_ops,
         double p_max) {
        const auto ex = experiments(p, g, dt);
        const MPICreep model(params_from_theta(theta, n_ops, p_max));
        py::gil_scoped_release release;
        return Eigen::VectorXd(sse_n_each(model, ex));
      },
      py::arg("theta"), py::arg("p"), py::arg("g"), py::arg("dt"), py::arg("n_ops"), py::arg("p_max"),
      "SSE_N (eq. 2.26) of each experiment, each simulated from rest; theta = (rho, tau, a1, a2, a3, l.., w..).");
  m.def(
      "play_basis",
      [](const Eigen::VectorXd& p, const Eigen::VectorXd& r) {
        RowMatrixXd Y(p.size(), r.size());
        play_basis(p, r, Y);
        return Y;
      },
      py::arg("p"), py::arg("r"), "OSP outputs (T, N) of p from rest (eq. 2.15-2.16).");
  m.def(
      "creep_basis",
      [](const Eigen::VectorXd& p, const Eigen::VectorXd& l, double dt) {
        RowMatrixXd Y(p.size(), l.size());
        creep_basis(p, l, dt, Y);
        return Y;
      },
      py::arg("p"), py::arg("l"), py::arg("dt"), "Creep operator outputs (T, Nc) from rest (eq. 2.23).");
  py::class_<std::atomic<int>>(m, "Counter", "A counter the C++ core increments (progress bars)")
      .def(py::init([]() { return new std::atomic<int>(0); }))
      .def_property_readonly("value", [](const std::atomic<int>& c) { return c.load(); });

  m.def("theta_from_x", &theta_from_x, py::arg("x"), py::arg("scale"), py::arg("log10"),
        "Model parameters from the annealing space (x_2 is the initial slope a1 + rho).");
  m.def(
      "anneal_fit",
      [](const std::vector<Eigen::VectorXd>& p, const std::vector<Eigen::VectorXd>& g,
         const std::vector<double>& dt, int n_ops, double p_max, const Eigen::VectorXd& x0,
         const Eigen::VectorXd& lo, const Eigen::VectorXd& hi, const Eigen::VectorXd& scale,
         const std::vector<bool>& log10, int max_evals, double t0, double t_end, std::uint64_t seed,
         std::atomic<int>* progress) {
        const auto ex = experiments(p, g, dt);
        const AnnealOptions o = anneal_options(max_evals, t0, t_end, seed, progress);
        AnnealResult r;
        {
          py::gil_scoped_release release;
          r = anneal_fit(ex, n_ops, p_max, x0, lo, hi, scale, log10, o);
        }
        const Eigen::VectorXd theta = theta_from_x(r.x, scale, log10);
        return anneal_dict(r, &theta);
      },
      py::arg("p"), py::arg("g"), py::arg("dt"), py::arg("n_ops"), py::arg("p_max"), py::arg("x0"),
      py::arg("lo"), py::arg("hi"), py::arg("scale"), py::arg("log10"), py::arg("max_evals"),
      py::arg("t0"), py::arg("t_end"), py::arg("seed"), py::arg("progress") = nullptr,
      "Simulated annealing of the model parameters on log(mean SSE_N) (thesis §2.5.1).");

  py::class_<SeparableProblem>(m, "SeparableProblem",
                               "Variable projection of the MPI + creep fit: for z = (tau, log10 l_j) "
                               "the parameters (a1, a2, a3, rho, w_j) are an exact linear solve.")
      .def(py::init([](const std::vector<Eigen::VectorXd>& p, const std::vector<Eigen::VectorXd>& g,
                       const std::vector<double>& dt, int n_ops, double p_max, int n_creep) {
             return SeparableProblem(experiments(p, g, dt), n_ops, p_max, n_creep);
           }),
           py::arg("p"), py::arg("g"), py::arg("dt"), py::arg("n_ops"), py::arg("p_max"), py::arg("n_creep"))
      .def_property_readonly("n_nonlinear", &SeparableProblem::n_nonlinear)
      .def_property_readonly("n_linear", &SeparableProblem::n_linear)
      .def(
          "design",
          [](const SeparableProblem& s, const Eigen::VectorXd& z) {
            Eigen::MatrixXd A;
            Eigen::VectorXd b;
            {
              py::gil_scoped_release release;
              s.design(z, A, b);
            }
            return py::make_tuple(A, b);
          },
          py::arg("z"), "Weighted design matrix A (rows, n_linear) and b: ||A c - b||^2 = mean SSE_N.")
      .def(
          "solve",
          [](const SeparableProblem& s, const Eigen::VectorXd& z) {
            SeparableProblem::Solution sol;
            {
              py::gil_scoped_release release;
              sol = s.solve(z);
            }
            return py::make_tuple(sol.cost, sol.theta, sol.invertibility_problem);
          },
          py::arg("z"), "Unconstrained solve at z: (mean SSE_N, theta, invertibility problem or '').")
      .def("theta", &SeparableProblem::theta, py::arg("z"), py::arg("c"),
           "theta = (rho, tau, a1, a2, a3, l.., w..) from z and c = (a1, a2, a3, rho, w..).");
  m.def(
      "anneal_separable",
      [](const SeparableProblem& s, const Eigen::VectorXd& z0, const Eigen::VectorXd& lo,
         const Eigen::VectorXd& hi, int max_evals, double t0, double t_end, std::uint64_t seed,
         std::atomic<int>* progress) {
        const AnnealOptions o = anneal_options(max_evals, t0, t_end, seed, progress);
        AnnealResult r;
        {
          py::gil_scoped_release release;
          r = anneal_separable(s, z0, lo, hi, o);
        }
        return anneal_dict(r);
      },
      py::arg("problem"), py::arg("z0"), py::arg("lo"), py::arg("hi"), py::arg("max_evals"), py::arg("t0"),
      py::arg("t_end"), py::arg("seed"), py::arg("progress") = nullptr,
      "Simulated annealing over z = (tau, log10 l_j) of the variable-projection cost (thesis §2.5.1).");
}
