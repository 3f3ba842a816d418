// The route planner's grid from a map the simulator loaded (map_server's YAML + PGM). Header-only on purpose: it
// reads only OccupancyMap's fields, so dqn_dovs_planning keeps linking nothing of dqn_dovs_sim (the ROS front end
// builds its RouteGrid from nav_msgs/OccupancyGrid instead).
#pragma once

#include <cstdint>

#include "dqn_dovs/maps/occupancy_map.h"
#include "dqn_dovs/planning/route.h"

namespace dqn_dovs {

/// The same cells (free 0, occupied 100, unknown -1), resolution, origin and size.
inline RouteGrid routeGridFromMap(const OccupancyMap& map) {
  RouteGrid grid;
  grid.resolution_m = map.resolution_m;
  grid.origin = map.origin;
  grid.width = map.width;
  grid.height = map.height;
  grid.cells.reserve(map.cells.size());
  for (MapCell c : map.cells) grid.cells.push_back(static_cast<int8_t>(c));
  return grid;
}

}  // namespace dqn_dovs
