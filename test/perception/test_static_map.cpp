#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

#include "dqn_dovs/perception/static_map.h"

using namespace dqn_dovs;

TEST(StaticMap, CellsAlongAWallCountOncePerScan) {
  StaticMap map(0.1, 30.0);
  const Segment wall{{0.0, 1.05}, {3.0, 1.05}};
  map.addSegment(wall, 0.0);
  map.addSegment(wall, 0.0);  // the same scan again: still one scan
  EXPECT_FALSE(map.isStructure({1.5, 1.05}, 2));
  EXPECT_TRUE(map.isStructure({1.5, 1.05}, 1));
  map.addSegment(wall, 0.1);
  EXPECT_TRUE(map.isStructure({1.5, 1.05}, 2));
  EXPECT_TRUE(map.isStructure({0.02, 1.01}, 2));
  EXPECT_TRUE(map.isStructure({2.99, 1.09}, 2));
  // A cell beside the wall (a leg 0.15 m in front of it) and beyond its end are free.
  EXPECT_FALSE(map.isStructure({1.5, 0.9}, 1));
  EXPECT_FALSE(map.isStructure({3.2, 1.05}, 1));
  EXPECT_FALSE(map.isStructure({-1.5, -1.05}, 1));  // negative coordinates hash to their own cells
}

TEST(StaticMap, FractionOfPointsOnStructure) {
  StaticMap map(0.1, 30.0);
  EXPECT_DOUBLE_EQ(map.structureFraction({{0.0, 0.0}}, 1), 0.0);
  map.addSegment({{-2.0, -0.55}, {-2.0, 2.0}}, 1.0);
  const std::vector<Vec2> on_wall{{-2.0, 0.0}, {-2.0, 0.1}, {-2.0, 0.2}, {-1.5, 0.3}};
  EXPECT_DOUBLE_EQ(map.structureFraction(on_wall, 1), 0.75);
  EXPECT_DOUBLE_EQ(map.structureFraction({}, 1), 0.0);
}

TEST(StaticMap, OldCellsAreForgottenPermanentOnesKept) {
  StaticMap map(0.1, 5.0);
  map.addSegment({{0.0, 0.0}, {1.0, 0.0}}, 0.0);
  map.addPermanentSegment({{0.0, 2.0}, {1.0, 2.0}});
  map.addSegment({{0.0, 4.0}, {1.0, 4.0}}, 4.0);
  map.expire(6.0);
  EXPECT_FALSE(map.isStructure({0.5, 0.0}, 1)) << "seen 6 s ago with a 5 s memory";
  EXPECT_TRUE(map.isStructure({0.5, 2.0}, 100)) << "permanent structure counts whatever the scans";
  EXPECT_TRUE(map.isStructure({0.5, 4.0}, 1));
  const size_t held = map.size();
  EXPECT_GT(held, 0u);
  map.clear();
  EXPECT_EQ(map.size(), 0u);
}

TEST(StaticMap, BadSizesAreRefusedWithTheirValues) {
  EXPECT_THROW(StaticMap(0.0, 1.0), std::invalid_argument);
  EXPECT_THROW(StaticMap(0.1, -1.0), std::invalid_argument);
  try {
    StaticMap bad(std::nan(""), 1.0);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cell size"), std::string::npos);
  }
}

TEST(StaticMap, FarAndNonFinitePointsHaveNoCell) {
  // A corrupt scan can put returns anywhere: they must neither crash the map nor mark cells.
  StaticMap map(0.1, 30.0);
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  map.addSegment({{1e300, 0.0}, {1e300, 1.0}}, 0.0);
  map.addSegment({{0.0, 0.0}, {1e12, 0.0}}, 0.0);  // longer than any building: ignored
  map.addSegment({{nan, 0.0}, {1.0, 0.0}}, 0.0);
  map.addSegment({{0.0, 0.0}, {inf, 0.0}}, 0.0);
  EXPECT_EQ(map.size(), 0u);
  EXPECT_FALSE(map.isStructure({1e300, 0.0}, 1));
  EXPECT_FALSE(map.isStructure({nan, nan}, 1));
  EXPECT_DOUBLE_EQ(map.structureFraction({{inf, 0.0}, {-inf, 1.0}}, 1), 0.0);
  map.addSegment({{0.0, 0.0}, {1.0, 0.0}}, 0.0);
  EXPECT_GT(map.size(), 0u);
  EXPECT_FALSE(map.isStructure({-1e300, 0.0}, 1));
}
