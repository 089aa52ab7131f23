// Bindings of the C++ sensor model: psmat._core.sensor. Arrays are (T, cells) float64.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>

#include "psmat/sensor/mpi_creep.hpp"

namespace py = pybind11;
using namespace psmat;
using namespace psmat::sensor;

namespace {
using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

Eigen::Map<const RowMatrixXd> as_stream(const CArray& a) {
  if (a.ndim() != 2) throw std::invalid_argument("expected a (T, cells) array");
  return Eigen::Map<const RowMatrixXd>(a.data(), a.shape(0), a.shape(1));
}

void check_state(const MPICreep& m, const MPICreepState& s, Index cells) {
  if (s.y.rows() != m.params().n_ops || s.y.cols() != cells ||
      s.yc.rows() != static_cast<Index>(m.params().l.size()) || s.p_prev.size() != cells)
    throw std::invalid_argument("state does not match this model and number of cells");
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
      .def(
          "direct",
          [](const MPICreep& c, const CArray& p, double dt, MPICreepState& state) {
            const auto P = as_stream(p);
            check_state(c, state, P.cols());
            RowMatrixXd g(P.rows(), P.cols());
            {
              py::gil_scoped_release release;
              c.direct(P, dt, state, g);
            }
            return g;
          },
          py::arg("p"), py::arg("dt"), py::arg("state"))
      .def(
          "inverse",
          [](const MPICreep& c, const CArray& g, double dt, MPICreepState& state) {
            const auto Gs = as_stream(g);
            check_state(c, state, Gs.cols());
            RowMatrixXd p(Gs.rows(), Gs.cols());
            Index clipped = 0;
            {
              py::gil_scoped_release release;
              c.inverse(Gs, dt, state, p, &clipped);
            }
            return py::make_tuple(p, clipped);
          },
          py::arg("g"), py::arg("dt"), py::arg("state"));

  m.def(
      "play_inverse",
      [](double a1, const Eigen::VectorXd& b, const Eigen::VectorXd& r) {
        const PlayInverse inv = play_inverse(a1, b, r);
        return py::make_tuple(inv.a1_hat, inv.b_hat, inv.r_hat);
      },
      py::arg("a1"), py::arg("b"), py::arg("r"), "Analytic inverse of the play part (eq. 2.21).");
  m.def("apply_play", &apply_play, py::arg("a1"), py::arg("b"), py::arg("r"), py::arg("u"),
        "a1 u + sum_j b_j F_{r_j}[u] from rest (eq. 2.17 without the polynomial).");
}
