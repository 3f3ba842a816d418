// Optimal (minimum-cost) assignment between two sets: the Hungarian method with potentials, O(n^2 m).
// Used by the tracker to pair predicted tracks with detections; ROS-free.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

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

/// Total cost of an assignment as returned above (pairs only); -1 entries are skipped.
double assignmentCost(const Eigen::MatrixXd& cost, const std::vector<int>& row_to_col);

}  // namespace dqn_dovs
