// Observation assembly, shared by every front end (dovs_node, bag replay, the evaluation's and the training's
// Episode): what joins the tracker's output before the velocity space is built from it. The map's walls near the
// robot join the scan's as static geometry (the LIDAR does not see what is hidden), and moving tracks take the arcs
// of their learned prediction (docs/planners.md, "A learned prediction of people").
#pragma once

#include <cstddef>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/types.h"
#include "dqn_dovs/perception/people_predictor.h"

namespace dqn_dovs {

/// `map_walls` (in the map's frame; `map_in_fixed` places the map in the fixed frame) whose distance from `robot`
/// (fixed frame) is at most `range_m`, in the fixed frame, appended to `segments` in their order.
void appendMapWalls(const std::vector<Segment>& map_walls, const Pose2& map_in_fixed, const Vec2& robot, double range_m,
                    std::vector<Segment>& segments);

/// obstacles[first], obstacles[first + 1], ... on the arcs of their learned prediction at `stamp_s`: `ids` holds their
/// track ids in that order (stable across decisions), `walls` the static segments in their frame. The obstacles
/// before `first` (the room's discs, whose constant (v, w) the prediction would only blur) are left as they are.
void predictArcs(PredictedArcs& arcs, std::vector<MovingObstacle>& obstacles, size_t first, const std::vector<int>& ids,
                 double stamp_s, const std::vector<Segment>& walls);

}  // namespace dqn_dovs
