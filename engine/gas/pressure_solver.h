// PressureSolver: the symmetric positive definite pressure system of the projection, A p = b
// over the fluid cells, solved by preconditioned conjugate gradients. Two preconditioners:
//  - Multigrid (default): one symmetric V-cycle of aggregation multigrid. Cells are grouped in
//    2×2×2 blocks of the grid, level after level; the coarse matrices are Galerkin products
//    Pᵀ A P with piecewise-constant P (so masks, periodic axes and outlets coarsen by
//    themselves); Gauss–Seidel smoothing, forward before and backward after the coarse
//    correction; a dense Cholesky solve on the coarsest level. Iterations barely grow with the
//    grid.
//  - Incomplete Cholesky (Eigen's), for comparison (bench/RESULTS.md).
// Eigen stays inside pressure_solver.cpp so the engine's headers do not carry it into every
// translation unit (its internals clash with resolv.h's `_res` macro).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace millsim {

struct MatrixEntry {
  std::int32_t row, col;
  double value;
};

enum class PressurePreconditioner { Multigrid, IncompleteCholesky };

class PressureSolver {
 public:
  PressureSolver(double tolerance, int max_iterations, PressurePreconditioner preconditioner);
  ~PressureSolver();
  PressureSolver(PressureSolver&&) noexcept;
  PressureSolver& operator=(PressureSolver&&) noexcept;

  // Sets the matrix (entries may repeat: they are summed) and builds the preconditioner.
  // `cell_of_row` gives each row's grid cell (i, j, k) for the multigrid's aggregates.
  void set_matrix(std::int32_t rows, const std::vector<MatrixEntry>& entries,
                  const std::vector<std::array<int, 3>>& cell_of_row);
  // Solves in place; `x` holds the initial guess. Returns true when ‖b − A x‖ ≤ tol ‖b‖.
  bool solve(const std::vector<double>& b, std::vector<double>& x);
  int iterations() const { return iterations_; }
  double residual() const { return residual_; }  // relative, ‖b − A x‖ / ‖b‖
  int levels() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int iterations_ = 0;
  double residual_ = 0.0;
};

}  // namespace millsim
