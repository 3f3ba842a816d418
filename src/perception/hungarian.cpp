#include "dqn_dovs/perception/hungarian.h"

#include <cmath>
#include <limits>
#include <sstream>

namespace dqn_dovs {
namespace {

// Shortest augmenting path Hungarian method with row/column potentials for rows <= cols.
// Indices are 1-based internally (0 is the virtual column the augmenting path starts from).
std::vector<int> solveWide(const Eigen::MatrixXd& a) {
  const int n = static_cast<int>(a.rows());
  const int m = static_cast<int>(a.cols());
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0);
  std::vector<int> p(m + 1, 0), way(m + 1, 0);
  std::vector<double> minv(m + 1);
  std::vector<char> used(m + 1);
  for (int i = 1; i <= n; ++i) {
    p[0] = i;
    int j0 = 0;
    std::fill(minv.begin(), minv.end(), inf);
    std::fill(used.begin(), used.end(), 0);
    do {
      used[j0] = 1;
      const int i0 = p[j0];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= m; ++j) {
        if (used[j]) continue;
        const double cur = a(i0 - 1, j - 1) - u[i0] - v[j];
        if (cur < minv[j]) {
          minv[j] = cur;
          way[j] = j0;
        }
        if (minv[j] < delta) {
          delta = minv[j];
          j1 = j;
        }
      }
      for (int j = 0; j <= m; ++j) {
        if (used[j]) {
          u[p[j]] += delta;
          v[j] -= delta;
        } else {
          minv[j] -= delta;
        }
      }
      j0 = j1;
    } while (p[j0] != 0);
    do {
      const int j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  std::vector<int> row_to_col(n, -1);
  for (int j = 1; j <= m; ++j) {
    if (p[j] != 0) row_to_col[p[j] - 1] = j - 1;
  }
  return row_to_col;
}

}  // namespace

std::vector<int> solveAssignment(const Eigen::MatrixXd& cost) {
  for (Eigen::Index i = 0; i < cost.rows(); ++i) {
    for (Eigen::Index j = 0; j < cost.cols(); ++j) {
      if (!std::isfinite(cost(i, j))) {
        std::ostringstream os;
        os << "assignment cost (" << i << ", " << j << ") = " << cost(i, j) << ": costs must be finite";
        throw AssignmentError(os.str());
      }
    }
  }
  if (cost.rows() == 0 || cost.cols() == 0) return std::vector<int>(cost.rows(), -1);
  if (cost.rows() <= cost.cols()) return solveWide(cost);
  const std::vector<int> col_to_row = solveWide(cost.transpose());
  std::vector<int> row_to_col(cost.rows(), -1);
  for (size_t j = 0; j < col_to_row.size(); ++j) {
    if (col_to_row[j] >= 0) row_to_col[col_to_row[j]] = static_cast<int>(j);
  }
  return row_to_col;
}

std::vector<int> solveGatedAssignment(const Eigen::MatrixXd& cost, double max_cost) {
  if (!(std::isfinite(max_cost) && max_cost > 0.0)) {
    std::ostringstream os;
    os << "assignment gate max_cost = " << max_cost << ": must be finite and positive";
    throw AssignmentError(os.str());
  }
  const Eigen::Index n = cost.rows(), m = cost.cols();
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) {
      if (std::isnan(cost(i, j))) {
        std::ostringstream os;
        os << "assignment cost (" << i << ", " << j << ") is NaN";
        throw AssignmentError(os.str());
      }
    }
  }
  if (n == 0 || m == 0) return std::vector<int>(n, -1);
  // Square (n + m) problem: real rows/cols, a private "unpaired" dummy column per row and dummy row per
  // column (cost max_cost / 2 each), and free dummy-dummy pairs. Forbidden cells get a cost no optimum can
  // pay: more than leaving every row and column unpaired.
  const double forbidden = max_cost * static_cast<double>(n + m + 1);
  const double half = 0.5 * max_cost;
  Eigen::MatrixXd big = Eigen::MatrixXd::Constant(n + m, n + m, forbidden);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) {
      const double c = cost(i, j);
      if (std::isfinite(c) && c <= max_cost) big(i, j) = c;
    }
    big(i, m + i) = half;
  }
  for (Eigen::Index j = 0; j < m; ++j) big(n + j, j) = half;
  big.bottomRightCorner(m, n).setZero();
  const std::vector<int> full = solveWide(big);
  std::vector<int> row_to_col(n, -1);
  for (Eigen::Index i = 0; i < n; ++i) {
    const int j = full[i];
    if (j >= 0 && j < m && big(i, j) < forbidden) row_to_col[i] = j;
  }
  return row_to_col;
}

std::vector<int> matchWithin(const std::vector<Vec2>& rows, const std::vector<Vec2>& cols, double max_distance_m) {
  if (rows.empty() || cols.empty()) return std::vector<int>(rows.size(), -1);
  Eigen::MatrixXd cost(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(cols.size()));
  for (size_t i = 0; i < rows.size(); ++i) {
    for (size_t j = 0; j < cols.size(); ++j) {
      const double d = (rows[i] - cols[j]).norm();
      cost(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
          d <= max_distance_m ? d : std::numeric_limits<double>::infinity();
    }
  }
  return solveGatedAssignment(cost, 2.0 * max_distance_m);
}

double assignmentCost(const Eigen::MatrixXd& cost, const std::vector<int>& row_to_col) {
  double total = 0.0;
  for (size_t i = 0; i < row_to_col.size(); ++i) {
    if (row_to_col[i] >= 0) total += cost(static_cast<Eigen::Index>(i), row_to_col[i]);
  }
  return total;
}

}  // namespace dqn_dovs
