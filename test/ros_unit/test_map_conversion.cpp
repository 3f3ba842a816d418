// simulator_node's map message: the grid of a known world as map_server would publish it, read back by the
// nodes' own reader (occupancyMapFromMsg) cell for cell.
#include <gtest/gtest.h>

#include <vector>

#include "conversions.h"
#include "dqn_dovs/planning/route.h"

namespace dqn_dovs {
namespace {

TEST(MapConversion, AKnownWorldsGridReadsBackCellForCell) {
  const std::vector<Segment> walls = {{Vec2(-1, -1), Vec2(4, -1)}, {Vec2(4, -1), Vec2(4, 2)}};
  const RouteGrid grid = knownWorldGrid(walls, {{Vec2(1.5, 0.5), 0.3}}, {Vec2(0, 0), Vec2(3, 1)}, 0.05);
  nav_msgs::OccupancyGrid msg = occupancyGridToMsg(grid);
  msg.header.frame_id = "map";
  EXPECT_EQ(msg.info.width, static_cast<uint32_t>(grid.width));
  EXPECT_EQ(msg.info.height, static_cast<uint32_t>(grid.height));
  EXPECT_FLOAT_EQ(msg.info.resolution, 0.05f);
  EXPECT_DOUBLE_EQ(msg.info.origin.position.x, grid.origin.x);
  EXPECT_DOUBLE_EQ(msg.info.origin.position.y, grid.origin.y);
  EXPECT_DOUBLE_EQ(msg.info.origin.orientation.w, 1.0);

  OccupancyMap map;
  ASSERT_EQ(occupancyMapFromMsg(msg, map), "");
  ASSERT_EQ(map.cells.size(), grid.cells.size());
  size_t occupied = 0;
  for (size_t i = 0; i < grid.cells.size(); ++i) {
    const bool wall = grid.cells[i] == 100;
    occupied += wall;
    EXPECT_EQ(map.cells[i], wall ? MapCell::kOccupied : MapCell::kFree) << "cell " << i;
  }
  EXPECT_GT(occupied, 100u);
  // Unknown cells stay unknown.
  RouteGrid unknown = grid;
  unknown.cells[0] = -1;
  EXPECT_EQ(occupancyGridToMsg(unknown).data[0], -1);
}

}  // namespace
}  // namespace dqn_dovs
