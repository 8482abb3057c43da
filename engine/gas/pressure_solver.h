// PressureSolver: the symmetric positive (semi-)definite pressure system of the projection,
// A p = b over the fluid cells, solved by conjugate gradients with an incomplete-Cholesky
// preconditioner (Eigen). Eigen stays inside pressure_solver.cpp so the headers of the engine
// do not carry it into every translation unit (its internals clash with resolv.h's `_res`).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

namespace millsim {

struct MatrixEntry {
  std::int32_t row, col;
  double value;
};

class PressureSolver {
 public:
  PressureSolver(double tolerance, int max_iterations);
  ~PressureSolver();
  PressureSolver(PressureSolver&&) noexcept;
  PressureSolver& operator=(PressureSolver&&) noexcept;

  // Sets the matrix (entries may repeat: they are summed) and factorises the preconditioner.
  void set_matrix(std::int32_t rows, const std::vector<MatrixEntry>& entries);
  // Solves in place; `x` holds the initial guess. Returns true when converged.
  bool solve(const std::vector<double>& b, std::vector<double>& x);
  int iterations() const { return iterations_; }
  double residual() const { return residual_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int iterations_ = 0;
  double residual_ = 0.0;
};

}  // namespace millsim
