// Optimal (minimum-cost) assignment between two sets: the Hungarian method with potentials, O(n^2 m).
// Used by the tracker to pair predicted tracks with detections; ROS-free.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

/// Bad input to an assignment solver (NaN costs, a negative gate, ...).
class AssignmentError : public std::runtime_error {
 public:
  explicit AssignmentError(const std::string& what) : std::runtime_error(what) {}
};

/// Minimum-cost assignment of a rows x cols matrix of finite costs: every row gets a distinct column when
/// rows <= cols, otherwise every column gets a distinct row. Returns, for each row, its column or -1.
/// Throws AssignmentError on a non-finite cost.
std::vector<int> solveAssignment(const Eigen::MatrixXd& cost);

/// Gated assignment: pairs (i, j) with cost(i, j) > max_cost or a non-finite cost (use +inf for "forbidden")
/// are never made, and leaving a row or a column unpaired costs max_cost / 2 each. The result minimises
/// sum(cost of pairs) + max_cost / 2 * (unpaired rows + unpaired columns), so a pair is only made when it is
/// cheaper than leaving both of its ends alone. Returns, for each row, its column or -1.
/// Throws AssignmentError when max_cost is not finite and positive or a cost is NaN.
std::vector<int> solveGatedAssignment(const Eigen::MatrixXd& cost, double max_cost);

/// Pairs points of `rows` with points of `cols` no farther apart than max_distance_m: as many pairs as possible, then
/// the least total distance (solveGatedAssignment on the distances with a gate of 2 max_distance_m, so every pair
/// within reach is cheaper than its two loose ends). Returns, for each row, its column or -1. Used to match tracks to
/// the true bodies they follow (scoring, diagnostics). Throws AssignmentError when max_distance_m is not positive.
std::vector<int> matchWithin(const std::vector<Vec2>& rows, const std::vector<Vec2>& cols, double max_distance_m);

/// Total cost of an assignment as returned above (pairs only); -1 entries are skipped.
double assignmentCost(const Eigen::MatrixXd& cost, const std::vector<int>& row_to_col);

}  // namespace dqn_dovs
