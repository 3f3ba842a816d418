// Memory of the static structure (walls, furniture) the tracker has seen, in the fixed frame. ROS-free.
//
// Long straight pieces of a scan are walls; a LIDAR also returns short pieces of the same walls (seen between
// people, at grazing angles, near the end of its range, broken by missing returns) that look like small objects
// and would start tracks that drift along the wall. The map keeps a sparse grid of the cells that wall pieces
// crossed in recent scans; a detection whose returns lie mostly on such cells is structure, never an obstacle.
// Cells not seen as wall for memory_s are forgotten, so slow odometry drift and moved furniture age out.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

class StaticMap {
 public:
  /// cell_m > 0: grid resolution (m); memory_s > 0: a cell unseen as wall this long is forgotten (s).
  /// Throws std::invalid_argument on non-positive or non-finite values.
  StaticMap(double cell_m, double memory_s);

  /// Marks the cells along `segment` as seen in the scan of stamp_s (at most one count per cell and scan).
  void addSegment(const Segment& segment, double stamp_s);
  /// Marks the cells along `segment` as permanent structure, in the fixed frame: never forgotten. (A map that
  /// localisation places anew at each scan is KnownStructure, known_structure.h.)
  void addPermanentSegment(const Segment& segment);
  /// Whether `p` lies on a cell seen as wall in at least min_scans scans (or permanent).
  bool isStructure(const Vec2& p, int min_scans) const;
  /// Fraction of `points` that lie on structure (0 for no points).
  double structureFraction(const std::vector<Vec2>& points, int min_scans) const;
  /// Forgets cells last seen more than memory_s before stamp_s (sweeping at most every memory_s / 30).
  void expire(double stamp_s);
  void clear();
  /// Number of cells held.
  size_t size() const { return cells_.size(); }
  double cellSize_m() const { return cell_m_; }

 private:
  struct Cell {
    int scans = 0;
    double last_s = 0.0;
    bool permanent = false;
  };
  /// The cell of `p`; false for non-finite points and points beyond +-2e9 cells.
  bool key(const Vec2& p, int64_t& out) const;
  /// Longest segment rasterised (m): longer ones (a corrupt scan) are ignored.
  static constexpr double kMaxSegment_m = 1000.0;
  template <typename Visit>
  void rasterise(const Segment& segment, Visit visit);

  double cell_m_;
  double memory_s_;
  double last_sweep_s_ = -std::numeric_limits<double>::infinity();
  std::unordered_map<int64_t, Cell> cells_;
};

}  // namespace dqn_dovs
