// The two operators of the Velostat sensor model (thesis §2.5.1), one home for both the
// model (mpi_creep.cpp) and the identification basis (fit.cpp).
#pragma once
#include <algorithm>
#include <cmath>

namespace psmat::sensor {

// One-side play operator step (eq. 2.15-2.16): y_r(t_k) = max(p_k - r, min(p_k, y_r(t_{k-1}))).
inline double osp_step(double p, double r, double y_prev) { return std::max(p - r, std::min(p, y_prev)); }

// Creep operator step (eq. 2.23): y_c(t_k) = e^{-l T} y_c(t_{k-1}) + (1 - e^{-l T}) p(t_{k-1}),
// with decay = e^{-l T} precomputed.
inline double creep_step(double decay, double y_prev, double p_prev) {
  return decay * y_prev + (1.0 - decay) * p_prev;
}

}  // namespace psmat::sensor
