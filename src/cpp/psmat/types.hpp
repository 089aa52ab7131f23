// Common array types of the psmat C++ core.
// Cell arrays are flattened row-major: cell (i, p) of an R x C array is index a = i*C + p (docs/spec.md §1).
#pragma once
#include <Eigen/Dense>

namespace psmat {

using Index = Eigen::Index;
using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using VecRef = Eigen::Ref<Eigen::VectorXd>;
using ConstVecRef = Eigen::Ref<const Eigen::VectorXd>;
using RowMatRef = Eigen::Ref<RowMatrixXd>;
using ConstRowMatRef = Eigen::Ref<const RowMatrixXd>;

// Shape of a sensor array: R rows x C columns.
struct Shape {
  Index rows = 0;
  Index cols = 0;
  Index cells() const { return rows * cols; }
  Index nodes() const { return rows + cols; }  // n = R + C nodes of the bipartite network
};

}  // namespace psmat
