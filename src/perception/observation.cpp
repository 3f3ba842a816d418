#include "dqn_dovs/perception/observation.h"

#include <algorithm>
#include <iterator>

namespace dqn_dovs {

void appendMapWalls(const std::vector<Segment>& map_walls, const Pose2& map_in_fixed, const Vec2& robot, double range_m,
                    std::vector<Segment>& segments) {
  for (const Segment& wall : map_walls) {
    const Segment s{map_in_fixed.toWorld(wall.a), map_in_fixed.toWorld(wall.b)};
    if (pointSegmentDistance(robot, s) <= range_m) segments.push_back(s);
  }
}

void predictArcs(PredictedArcs& arcs, std::vector<MovingObstacle>& obstacles, size_t first, const std::vector<int>& ids,
                 double stamp_s, const std::vector<Segment>& walls) {
  if (first == 0) {
    arcs.apply(obstacles, ids, stamp_s, walls);
    return;
  }
  first = std::min(first, obstacles.size());
  std::vector<MovingObstacle> moved(obstacles.begin() + static_cast<std::ptrdiff_t>(first), obstacles.end());
  arcs.apply(moved, ids, stamp_s, walls);
  std::copy(moved.begin(), moved.end(), obstacles.begin() + static_cast<std::ptrdiff_t>(first));
}

}  // namespace dqn_dovs
