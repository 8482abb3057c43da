// The preconditioned conjugate-gradient pressure solve against a dense direct solve of the same
// system, on a grid with a solid block, a periodic axis and an outlet, with the strongly
// varying coefficients a packed bed gives (both preconditioners), and the multigrid iteration
// count growing slowly as the grid is refined.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "gas/gas_solver.h"
#include "gas/pressure_solver.h"

namespace millsim {
namespace {

struct System {
  int rows = 0;
  std::vector<MatrixEntry> entries;
  std::vector<std::array<int, 3>> cells;
};

// A 7-point operator on an n³ grid (periodic along x, a solid block in the middle, Dirichlet
// on the top layer) with face weights spanning four decades.
System make_system(int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> log_weight(-2.0, 2.0);
  std::vector<int> row(std::size_t(n * n * n), -1);
  System s;
  const auto id = [n](int i, int j, int k) { return std::size_t(i + n * (j + n * k)); };
  const auto solid = [n](int i, int j, int k) {
    return i >= n / 3 && i < 2 * n / 3 && j >= n / 3 && j < 2 * n / 3 && k < n / 2;
  };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        if (!solid(i, j, k)) row[id(i, j, k)] = s.rows++, s.cells.push_back({i, j, k});
  std::vector<double> diagonal(std::size_t(s.rows), 0.0);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int r = row[id(i, j, k)];
        if (r < 0) continue;
        const int nb[3][3] = {{(i + 1) % n, j, k}, {i, j + 1, k}, {i, j, k + 1}};
        for (const auto& q : nb) {
          if (q[1] >= n || q[2] >= n) continue;
          const int c = row[id(q[0], q[1], q[2])];
          if (c < 0) continue;
          const double w = std::pow(10.0, log_weight(rng));
          s.entries.push_back({r, c, -w});
          s.entries.push_back({c, r, -w});
          diagonal[std::size_t(r)] += w;
          diagonal[std::size_t(c)] += w;
        }
        if (k == n - 1) diagonal[std::size_t(r)] += 2.0;  // outlet
      }
  for (int r = 0; r < s.rows; ++r) s.entries.push_back({r, r, diagonal[std::size_t(r)]});
  return s;
}

TEST(PressureSolver, MatchesADenseDirectSolve) {
  const System sys = make_system(10, 3);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(sys.rows, sys.rows);
  for (const MatrixEntry& e : sys.entries) dense(e.row, e.col) += e.value;
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  std::vector<double> b(std::size_t(sys.rows));
  for (double& v : b) v = normal(rng);
  const Eigen::VectorXd exact =
      dense.ldlt().solve(Eigen::Map<const Eigen::VectorXd>(b.data(), sys.rows));
  for (PressurePreconditioner kind :
       {PressurePreconditioner::Multigrid, PressurePreconditioner::IncompleteCholesky}) {
    PressureSolver solver(1e-12, 2000, kind);
    solver.set_matrix(sys.rows, sys.entries, sys.cells);
    std::vector<double> x(b.size(), 0.0);
    ASSERT_TRUE(solver.solve(b, x));
    const double error =
        (Eigen::Map<const Eigen::VectorXd>(x.data(), sys.rows) - exact).norm() / exact.norm();
    EXPECT_LT(error, 1e-8) << (kind == PressurePreconditioner::Multigrid ? "multigrid" : "IC");
    // The same pattern with new values takes the refill path and must solve the new system.
    std::vector<MatrixEntry> scaled = sys.entries;
    for (MatrixEntry& e : scaled) e.value *= 3.0;
    solver.set_matrix(sys.rows, scaled, sys.cells);
    std::vector<double> y(b.size(), 0.0);
    ASSERT_TRUE(solver.solve(b, y));
    for (std::size_t k = 0; k < y.size(); ++k) EXPECT_NEAR(3.0 * y[k], x[k], 1e-8 * exact.norm());
  }
}

TEST(PressureSolver, MultigridIterationsGrowSlowlyUnderRefinement) {
  int first = 0;
  for (int n : {8, 16, 32}) {
    const System sys = make_system(n, 11);
    PressureSolver solver(1e-8, 2000, PressurePreconditioner::Multigrid);
    solver.set_matrix(sys.rows, sys.entries, sys.cells);
    std::vector<double> b(std::size_t(sys.rows), 1.0), x(b.size(), 0.0);
    ASSERT_TRUE(solver.solve(b, x));
    if (n == 8) first = solver.iterations();
    std::printf("n = %d: %d rows, %d levels, %d iterations\n", n, sys.rows, solver.levels(),
                solver.iterations());
    EXPECT_LE(solver.iterations(), 3 * first);
  }
}

}  // namespace
}  // namespace millsim
