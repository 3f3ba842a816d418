// The structure a map gives (walls, furniture), for the tracker. ROS-free.
//
// The tracker's own memory (StaticMap) learns walls from long straight pieces of the scans it has seen; a map
// knows more: the furniture, the walls behind people, the chair that was never seen whole. Given one, a detection
// whose returns lie mostly on it is structure, reported as a segment and never tracked (ObstacleTracker::update),
// so a chair among people's legs is never reported walking. The map is held in its own frame; each scan is
// checked through the pose of the tracker's fixed frame in the map's (the localisation), so drifting odometry
// moves nothing here.
#pragma once

#include <cstdint>
#include <vector>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

class KnownStructure {
 public:
  /// walls: segments (a map's walls, furniture outlines); furniture: discs, each filled. A return lies on the
  /// structure when it is within about tolerance_m of it (to within half a cell's diagonal): the map's and the
  /// localisation's error plus the scanner's noise. cell_m: resolution of the grid it is held in.
  /// Throws std::invalid_argument naming the value: a negative or non-finite tolerance, a non-positive cell, a
  /// non-finite point or radius, or more than kMaxCells cells.
  KnownStructure(const std::vector<Segment>& walls, const std::vector<Circle>& furniture, double tolerance_m,
                 double cell_m = 0.05);

  /// Whether `p` (map frame) lies on the structure.
  bool contains(const Vec2& p) const;
  /// Fraction of `points` (tracker's fixed frame) on the structure, `fixed_in_map` the pose of that frame in the
  /// map's (0 for no points).
  double fraction(const std::vector<Vec2>& points, const Pose2& fixed_in_map) const;
  /// No cell is structure (no walls, no furniture).
  bool empty() const { return occupied_ == 0; }
  double tolerance_m() const { return tolerance_m_; }
  double cellSize_m() const { return cell_m_; }
  /// Largest grid held (cells): a 200 x 200 m building at 5 cm.
  static constexpr int64_t kMaxCells = int64_t{4000} * 4000;

 private:
  bool cell(const Vec2& p, int64_t& index) const;

  double tolerance_m_;
  double cell_m_;
  Vec2 origin_ = Vec2::Zero();  // lower-left corner of cell (0, 0)
  int64_t width_ = 0, height_ = 0;
  int64_t occupied_ = 0;
  std::vector<uint8_t> cells_;
};

/// A map's structure as one scan sees it: the structure, and the pose of the tracker's fixed frame in the map's
/// frame at the scan's stamp. Without a structure the map is not used.
struct MapStructureView {
  const KnownStructure* structure = nullptr;
  Pose2 fixed_in_map;
};

}  // namespace dqn_dovs
