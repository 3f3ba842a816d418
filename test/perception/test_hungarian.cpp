#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include "dqn_dovs/perception/hungarian.h"

using namespace dqn_dovs;

namespace {

// Brute force over all partial injective maps rows -> cols; `full` requires min(rows, cols) pairs.
void bruteForce(const Eigen::MatrixXd& c, size_t row, std::vector<int>& cur, std::vector<bool>& used_col, double gate,
                bool full, double& best) {
  const size_t n = static_cast<size_t>(c.rows());
  if (row == n) {
    int pairs = 0;
    double total = 0.0;
    for (size_t i = 0; i < n; ++i) {
      if (cur[i] < 0) continue;
      ++pairs;
      total += c(static_cast<Eigen::Index>(i), cur[i]);
    }
    if (full) {
      if (pairs != std::min<int>(static_cast<int>(c.rows()), static_cast<int>(c.cols()))) return;
    } else {
      total += 0.5 * gate * static_cast<double>((c.rows() - pairs) + (c.cols() - pairs));
    }
    best = std::min(best, total);
    return;
  }
  cur[row] = -1;
  bruteForce(c, row + 1, cur, used_col, gate, full, best);
  for (Eigen::Index j = 0; j < c.cols(); ++j) {
    if (used_col[j]) continue;
    if (!full && !(std::isfinite(c(row, j)) && c(row, j) <= gate)) continue;
    used_col[j] = true;
    cur[row] = static_cast<int>(j);
    bruteForce(c, row + 1, cur, used_col, gate, full, best);
    used_col[j] = false;
    cur[row] = -1;
  }
}

bool isInjective(const std::vector<int>& a, int cols) {
  std::vector<bool> seen(cols, false);
  for (int j : a) {
    if (j < 0) continue;
    if (j >= cols || seen[j]) return false;
    seen[j] = true;
  }
  return true;
}

}  // namespace

TEST(Hungarian, MatchesBruteForceOnRandomRectangularMatrices) {
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> size(1, 6);
  std::uniform_real_distribution<double> value(-3.0, 10.0);
  for (int trial = 0; trial < 400; ++trial) {
    const int n = size(rng), m = size(rng);
    Eigen::MatrixXd c(n, m);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < m; ++j) c(i, j) = value(rng);
    const std::vector<int> a = solveAssignment(c);
    ASSERT_EQ(a.size(), static_cast<size_t>(n));
    ASSERT_TRUE(isInjective(a, m));
    EXPECT_EQ(std::count_if(a.begin(), a.end(), [](int j) { return j >= 0; }), std::min(n, m));
    std::vector<int> cur(n, -1);
    std::vector<bool> used(m, false);
    double best = std::numeric_limits<double>::infinity();
    bruteForce(c, 0, cur, used, 0.0, true, best);
    EXPECT_NEAR(assignmentCost(c, a), best, 1e-9) << "trial " << trial << " (" << n << "x" << m << ")";
  }
}

TEST(Hungarian, GatedMatchesBruteForceWithForbiddenPairs) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> size(1, 6);
  std::uniform_real_distribution<double> value(0.0, 20.0);
  std::bernoulli_distribution forbid(0.3);
  const double gate = 12.0;
  for (int trial = 0; trial < 400; ++trial) {
    const int n = size(rng), m = size(rng);
    Eigen::MatrixXd c(n, m);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < m; ++j) c(i, j) = forbid(rng) ? std::numeric_limits<double>::infinity() : value(rng);
    const std::vector<int> a = solveGatedAssignment(c, gate);
    ASSERT_TRUE(isInjective(a, m));
    int pairs = 0;
    for (int i = 0; i < n; ++i) {
      if (a[i] < 0) continue;
      ++pairs;
      EXPECT_LE(c(i, a[i]), gate) << "a pair outside the gate";
    }
    const double got = assignmentCost(c, a) + 0.5 * gate * ((n - pairs) + (m - pairs));
    std::vector<int> cur(n, -1);
    std::vector<bool> used(m, false);
    double best = std::numeric_limits<double>::infinity();
    bruteForce(c, 0, cur, used, gate, false, best);
    EXPECT_NEAR(got, best, 1e-9) << "trial " << trial;
  }
}

TEST(Hungarian, GatePrefersOneGoodPairOverTwoPoorOnes) {
  // Track 0 fits detection 0 very well and detection 1 poorly; track 1 fits detection 0 poorly only.
  // Pairing both (0-1, 1-0) would cost 11 + 11 = 22 > 1 + 12 (one good pair, two loose ends).
  Eigen::MatrixXd c(2, 2);
  c << 1.0, 11.0, 11.0, std::numeric_limits<double>::infinity();
  const auto a = solveGatedAssignment(c, 12.0);
  EXPECT_EQ(a[0], 0);
  EXPECT_EQ(a[1], -1);
}

TEST(Hungarian, PointsArePairedWithinReachAsManyAsPossibleThenNearest) {
  // Row 0 is nearest to column 0 (0.4 m), but taking it would leave row 1, which reaches only column 0 (0.45 m),
  // alone: both rows are paired. Out of row 1's reach, row 0 takes its nearest. Row 2 reaches nothing; an empty side
  // pairs nothing.
  const std::vector<Vec2> rows{{0.0, 0.0}, {0.85, 0.0}, {5.0, 5.0}};
  const std::vector<Vec2> cols{{0.4, 0.0}, {-0.45, 0.0}};
  EXPECT_EQ(matchWithin(rows, cols, 0.5), std::vector<int>({1, 0, -1}));
  EXPECT_EQ(matchWithin(rows, cols, 0.42), std::vector<int>({0, -1, -1}));
  EXPECT_EQ(matchWithin(rows, {}, 0.5), std::vector<int>({-1, -1, -1}));
  EXPECT_TRUE(matchWithin({}, cols, 0.5).empty());
  EXPECT_THROW(matchWithin(rows, cols, 0.0), AssignmentError);
}

TEST(Hungarian, EmptyAndBadInput) {
  EXPECT_TRUE(solveAssignment(Eigen::MatrixXd(0, 3)).empty());
  EXPECT_EQ(solveAssignment(Eigen::MatrixXd(2, 0)), std::vector<int>({-1, -1}));
  Eigen::MatrixXd c = Eigen::MatrixXd::Ones(2, 2);
  c(1, 0) = std::nan("");
  EXPECT_THROW(solveAssignment(c), AssignmentError);
  EXPECT_THROW(solveGatedAssignment(c, 5.0), AssignmentError);
  EXPECT_THROW(solveGatedAssignment(Eigen::MatrixXd::Ones(2, 2), 0.0), AssignmentError);
  try {
    solveGatedAssignment(Eigen::MatrixXd::Ones(2, 2), -1.0);
    FAIL() << "no exception";
  } catch (const AssignmentError& e) {
    EXPECT_NE(std::string(e.what()).find("max_cost"), std::string::npos);
  }
}
