#include "gas/pressure_solver.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>

namespace millsim {

struct PressureSolver::Impl {
  Eigen::SparseMatrix<double> matrix;
  // Natural ordering: the grid order is already banded, and AMD's permutation cost more
  // iterations and time on the cavity test.
  Eigen::ConjugateGradient<
      Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper,
      Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::NaturalOrdering<int>>>
      cg;
};

PressureSolver::PressureSolver(double tolerance, int max_iterations)
    : impl_(std::make_unique<Impl>()) {
  impl_->cg.setTolerance(tolerance);
  impl_->cg.setMaxIterations(max_iterations);
}

PressureSolver::~PressureSolver() = default;
PressureSolver::PressureSolver(PressureSolver&&) noexcept = default;
PressureSolver& PressureSolver::operator=(PressureSolver&&) noexcept = default;

void PressureSolver::set_matrix(std::int32_t rows, const std::vector<MatrixEntry>& entries) {
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(entries.size());
  for (const MatrixEntry& e : entries) triplets.emplace_back(e.row, e.col, e.value);
  impl_->matrix.resize(rows, rows);
  impl_->matrix.setFromTriplets(triplets.begin(), triplets.end());
  impl_->cg.compute(impl_->matrix);
}

bool PressureSolver::solve(const std::vector<double>& b, std::vector<double>& x) {
  const Eigen::Index n = Eigen::Index(b.size());
  const Eigen::Map<const Eigen::VectorXd> rhs(b.data(), n);
  Eigen::Map<Eigen::VectorXd> solution(x.data(), n);
  const Eigen::VectorXd guess = solution;
  solution = impl_->cg.solveWithGuess(rhs, guess);
  iterations_ = int(impl_->cg.iterations());
  residual_ = impl_->cg.error();
  return impl_->cg.info() == Eigen::Success;
}

}  // namespace millsim
