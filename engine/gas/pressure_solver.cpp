#include "gas/pressure_solver.h"

#include <Eigen/Dense>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace millsim {
namespace {

using RowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;
using Vector = Eigen::VectorXd;

// One multigrid level: its matrix, and the aggregate (coarse row) of each of its rows.
struct Level {
  RowMatrix a;
  Vector inverse_diagonal;
  std::vector<std::int32_t> aggregate;  // empty on the coarsest level
  std::int32_t coarse_rows = 0;
  // Where each stored value of `a` goes in the next level's values (Galerkin sum).
  std::vector<std::int32_t> coarse_slot;
};

void gauss_seidel(const Level& l, const Vector& b, Vector& x, bool forward) {
  const Eigen::Index n = l.a.rows();
  const auto sweep = [&](Eigen::Index i) {
    double sum = b[i];
    for (RowMatrix::InnerIterator it(l.a, i); it; ++it)
      if (it.col() != i) sum -= it.value() * x[it.col()];
    x[i] = sum * l.inverse_diagonal[i];
  };
  if (forward)
    for (Eigen::Index i = 0; i < n; ++i) sweep(i);
  else
    for (Eigen::Index i = n; i-- > 0;) sweep(i);
}

}  // namespace

struct PressureSolver::Impl {
  PressurePreconditioner kind;
  double tolerance = 1e-6;
  int max_iterations = 1000;
  // incomplete Cholesky
  RowMatrix row_matrix;
  Eigen::SparseMatrix<double> matrix;
  Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::NaturalOrdering<int>> ic;
  // multigrid
  std::vector<Level> levels;
  Eigen::LDLT<Eigen::MatrixXd> coarsest;
  std::vector<Vector> level_b, level_x, level_r;

  void build_multigrid(const RowMatrix& a, const std::vector<std::array<int, 3>>& cells);
  void refresh_multigrid();
  void v_cycle(std::size_t depth);
  // The entries' pattern of the last set_matrix, and where each lands in the stored values.
  std::vector<std::int64_t> pattern;
  std::vector<std::int32_t> value_slot;
  Vector precondition(const Vector& r);
};

void PressureSolver::Impl::build_multigrid(const RowMatrix& a0,
                                           const std::vector<std::array<int, 3>>& cells0) {
  levels.clear();
  levels.push_back({a0, {}, {}, 0, {}});
  levels.back().a.makeCompressed();
  std::vector<std::array<int, 3>> cells = cells0;
  constexpr Eigen::Index kCoarsest = 64;
  while (levels.back().a.rows() > kCoarsest && levels.size() < 20) {
    Level& fine = levels.back();
    std::unordered_map<std::int64_t, std::int32_t> index;
    std::vector<std::array<int, 3>> coarse_cells;
    fine.aggregate.resize(cells.size());
    for (std::size_t r = 0; r < cells.size(); ++r) {
      const std::array<int, 3> c{cells[r][0] / 2, cells[r][1] / 2, cells[r][2] / 2};
      const std::int64_t key = (std::int64_t(c[0]) << 42) | (std::int64_t(c[1]) << 21) | c[2];
      auto [it, fresh] = index.emplace(key, std::int32_t(coarse_cells.size()));
      if (fresh) coarse_cells.push_back(c);
      fine.aggregate[r] = it->second;
    }
    fine.coarse_rows = std::int32_t(coarse_cells.size());
    if (fine.coarse_rows == fine.a.rows()) break;  // nothing left to merge
    std::vector<Eigen::Triplet<double>> t;
    t.reserve(std::size_t(fine.a.nonZeros()));
    for (Eigen::Index i = 0; i < fine.a.rows(); ++i)
      for (RowMatrix::InnerIterator it(fine.a, i); it; ++it)
        t.emplace_back(fine.aggregate[std::size_t(i)], fine.aggregate[std::size_t(it.col())],
                       it.value());
    RowMatrix coarse(fine.coarse_rows, fine.coarse_rows);
    coarse.setFromTriplets(t.begin(), t.end());
    coarse.makeCompressed();
    fine.coarse_slot.clear();
    for (Eigen::Index i = 0; i < fine.a.rows(); ++i)
      for (RowMatrix::InnerIterator it(fine.a, i); it; ++it) {
        const std::int32_t ci = fine.aggregate[std::size_t(i)];
        const std::int32_t cj = fine.aggregate[std::size_t(it.col())];
        const int* begin = coarse.innerIndexPtr() + coarse.outerIndexPtr()[ci];
        const int* end = coarse.innerIndexPtr() + coarse.outerIndexPtr()[ci + 1];
        fine.coarse_slot.push_back(
            std::int32_t(std::lower_bound(begin, end, cj) - coarse.innerIndexPtr()));
      }
    levels.push_back({std::move(coarse), {}, {}, 0, {}});
    cells = std::move(coarse_cells);
  }
  for (Level& l : levels) {
    l.inverse_diagonal = l.a.diagonal().cwiseInverse();
  }
  coarsest.compute(Eigen::MatrixXd(levels.back().a));
  level_b.assign(levels.size(), Vector());
  level_x.assign(levels.size(), Vector());
  level_r.assign(levels.size(), Vector());
}

// New values on the same pattern: the Galerkin sums level by level, then the factorisation.
void PressureSolver::Impl::refresh_multigrid() {
  for (std::size_t d = 0; d + 1 < levels.size(); ++d) {
    const Level& fine = levels[d];
    RowMatrix& coarse = levels[d + 1].a;
    double* out = coarse.valuePtr();
    std::fill(out, out + coarse.nonZeros(), 0.0);
    const double* in = fine.a.valuePtr();
    for (std::size_t k = 0; k < fine.coarse_slot.size(); ++k) out[fine.coarse_slot[k]] += in[k];
  }
  for (Level& l : levels) l.inverse_diagonal = l.a.diagonal().cwiseInverse();
  coarsest.compute(Eigen::MatrixXd(levels.back().a));
}

void PressureSolver::Impl::v_cycle(std::size_t d) {
  const Level& l = levels[d];
  Vector& x = level_x[d];
  const Vector& b = level_b[d];
  x.setZero(l.a.rows());
  if (d + 1 == levels.size()) {
    x = coarsest.solve(b);
    return;
  }
  gauss_seidel(l, b, x, true);
  level_r[d] = b - l.a * x;
  Vector& coarse_b = level_b[d + 1];
  coarse_b.setZero(l.coarse_rows);
  for (Eigen::Index i = 0; i < l.a.rows(); ++i)
    coarse_b[l.aggregate[std::size_t(i)]] += level_r[d][i];
  v_cycle(d + 1);
  const Vector& coarse_x = level_x[d + 1];
  for (Eigen::Index i = 0; i < l.a.rows(); ++i) x[i] += coarse_x[l.aggregate[std::size_t(i)]];
  gauss_seidel(l, b, x, false);
}

Vector PressureSolver::Impl::precondition(const Vector& r) {
  if (kind == PressurePreconditioner::IncompleteCholesky) return ic.solve(r);
  level_b[0] = r;
  v_cycle(0);
  return level_x[0];
}

PressureSolver::PressureSolver(double tolerance, int max_iterations,
                               PressurePreconditioner preconditioner)
    : impl_(std::make_unique<Impl>()) {
  impl_->kind = preconditioner;
  impl_->tolerance = tolerance;
  impl_->max_iterations = max_iterations;
}

PressureSolver::~PressureSolver() = default;
PressureSolver::PressureSolver(PressureSolver&&) noexcept = default;
PressureSolver& PressureSolver::operator=(PressureSolver&&) noexcept = default;

int PressureSolver::levels() const {
  return impl_->kind == PressurePreconditioner::Multigrid ? int(impl_->levels.size()) : 1;
}

void PressureSolver::set_matrix(std::int32_t rows, const std::vector<MatrixEntry>& entries,
                                const std::vector<std::array<int, 3>>& cell_of_row) {
  Impl& m = *impl_;
  const bool multigrid = m.kind == PressurePreconditioner::Multigrid;
  // Same pattern as last time (the usual case: only ε and the drag changed): refill values.
  bool same = !m.pattern.empty() && m.pattern.size() == entries.size();
  for (std::size_t k = 0; same && k < entries.size(); ++k)
    same = m.pattern[k] == (std::int64_t(entries[k].row) << 32 | std::uint32_t(entries[k].col));
  if (same) {
    RowMatrix& a = multigrid ? m.levels[0].a : m.row_matrix;
    std::fill(a.valuePtr(), a.valuePtr() + a.nonZeros(), 0.0);
    for (std::size_t k = 0; k < entries.size(); ++k)
      a.valuePtr()[m.value_slot[k]] += entries[k].value;
    if (multigrid) {
      m.refresh_multigrid();
    } else {
      m.matrix = a;
      m.ic.compute(m.matrix);
    }
    return;
  }
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(entries.size());
  for (const MatrixEntry& e : entries) triplets.emplace_back(e.row, e.col, e.value);
  RowMatrix a(rows, rows);
  a.setFromTriplets(triplets.begin(), triplets.end());
  a.makeCompressed();
  m.pattern.clear();
  m.value_slot.clear();
  for (const MatrixEntry& e : entries) {
    m.pattern.push_back(std::int64_t(e.row) << 32 | std::uint32_t(e.col));
    const int* begin = a.innerIndexPtr() + a.outerIndexPtr()[e.row];
    const int* end = a.innerIndexPtr() + a.outerIndexPtr()[e.row + 1];
    m.value_slot.push_back(std::int32_t(std::lower_bound(begin, end, e.col) - a.innerIndexPtr()));
  }
  if (multigrid) {
    m.build_multigrid(a, cell_of_row);
  } else {
    m.row_matrix = a;
    m.matrix = a;
    m.ic.compute(m.matrix);
  }
}

// Preconditioned conjugate gradients (Saad, Iterative Methods, Alg. 9.1).
bool PressureSolver::solve(const std::vector<double>& b_in, std::vector<double>& x_io) {
  const Eigen::Index n = Eigen::Index(b_in.size());
  const Eigen::Map<const Vector> b(b_in.data(), n);
  Eigen::Map<Vector> x(x_io.data(), n);
  const RowMatrix& a =
      impl_->kind == PressurePreconditioner::Multigrid ? impl_->levels[0].a : RowMatrix();
  const auto apply = [&](const Vector& v) -> Vector {
    if (impl_->kind == PressurePreconditioner::Multigrid) return a * v;
    return impl_->matrix * v;
  };
  const double b_norm = b.norm();
  iterations_ = 0;
  if (b_norm == 0.0) {
    x.setZero();
    residual_ = 0.0;
    return true;
  }
  Vector r = b - apply(x);
  residual_ = r.norm() / b_norm;
  if (residual_ <= impl_->tolerance) return true;
  Vector z = impl_->precondition(r);
  Vector p = z;
  double rz = r.dot(z);
  while (iterations_ < impl_->max_iterations) {
    const Vector ap = apply(p);
    const double alpha = rz / p.dot(ap);
    x += alpha * p;
    r -= alpha * ap;
    ++iterations_;
    residual_ = r.norm() / b_norm;
    if (!std::isfinite(residual_)) return false;
    if (residual_ <= impl_->tolerance) return true;
    z = impl_->precondition(r);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  return false;
}

}  // namespace millsim
