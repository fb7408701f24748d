// Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations (Golub & Van Loan,
// Matrix Computations, sec. 8.5). Used once per clump template for its principal axes.
#pragma once
#include "core/mat3.hpp"

namespace biodem {

struct SymEigen {
  Vec3 values;   // ascending
  Mat3 vectors;  // columns are the unit eigenvectors, right-handed
};

SymEigen sym_eigen(const Mat3& a);

}  // namespace biodem
