#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "dqn_dovs/perception/known_structure.h"

using namespace dqn_dovs;

TEST(KnownStructure, ReturnsWithinTheToleranceOfAWallOrAPieceOfFurnitureLieOnIt) {
  const KnownStructure map({{{0.0, 0.0}, {4.0, 0.0}}}, {{{2.0, 2.0}, 0.3}}, 0.1, 0.02);
  EXPECT_FALSE(map.empty());
  EXPECT_TRUE(map.contains({1.0, 0.0}));
  EXPECT_TRUE(map.contains({1.0, 0.08}));
  EXPECT_TRUE(map.contains({4.07, 0.0}));  // beyond the end, within the tolerance
  EXPECT_FALSE(map.contains({1.0, 0.15}));
  EXPECT_FALSE(map.contains({4.2, 0.0}));
  // A disc: its outline, its inside, and the tolerance around it.
  EXPECT_TRUE(map.contains({2.3, 2.0}));
  EXPECT_TRUE(map.contains({2.0, 2.0}));
  EXPECT_TRUE(map.contains({2.0, 1.62}));
  EXPECT_FALSE(map.contains({2.0, 1.55}));
  // Outside the grid and non-finite points are not structure.
  EXPECT_FALSE(map.contains({-100.0, 0.0}));
  EXPECT_FALSE(map.contains({std::nan(""), 0.0}));
}

TEST(KnownStructure, PointsAreCheckedWhereTheFixedFrameLiesInTheMap) {
  // A wall along the map's y axis at x = 3; the fixed frame (odom) lies at (1, 0) in the map turned by 90 deg, so
  // the wall is the fixed frame's line y = -2.
  const KnownStructure map({{{3.0, -5.0}, {3.0, 5.0}}}, {}, 0.05);
  const Pose2 fixed_in_map{1.0, 0.0, M_PI / 2.0};
  const std::vector<Vec2> on_wall{{0.0, -2.0}, {1.0, -2.0}, {-1.5, -2.01}};
  EXPECT_DOUBLE_EQ(map.fraction(on_wall, fixed_in_map), 1.0);
  EXPECT_DOUBLE_EQ(map.fraction(on_wall, Pose2{}), 0.0) << "read in the map's own frame they miss it";
  EXPECT_DOUBLE_EQ(map.fraction({{0.0, -2.0}, {0.0, -1.0}}, fixed_in_map), 0.5);
  EXPECT_DOUBLE_EQ(map.fraction({}, fixed_in_map), 0.0);
}

TEST(KnownStructure, AnEmptyMapHoldsNothing) {
  const KnownStructure map({}, {}, 0.1);
  EXPECT_TRUE(map.empty());
  EXPECT_FALSE(map.contains({0.0, 0.0}));
  EXPECT_DOUBLE_EQ(map.fraction({{0.0, 0.0}}, Pose2{}), 0.0);
}

TEST(KnownStructure, BadValuesAreRefusedByName) {
  const auto refusal = [](auto build) {
    try {
      build();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_NE(refusal([] { KnownStructure({}, {}, -0.1); }).find("tolerance"), std::string::npos);
  EXPECT_NE(refusal([] { KnownStructure({}, {}, std::nan("")); }).find("tolerance"), std::string::npos);
  EXPECT_NE(refusal([] { KnownStructure({}, {}, 0.1, 0.0); }).find("cell"), std::string::npos);
  EXPECT_NE(refusal([&] { KnownStructure({{{0.0, 0.0}, {inf, 0.0}}}, {}, 0.1); }).find("wall"), std::string::npos);
  EXPECT_NE(refusal([] { KnownStructure({}, {{{0.0, 0.0}, -1.0}}, 0.1); }).find("furniture"), std::string::npos);
  EXPECT_NE(refusal([] { KnownStructure({{{0.0, 0.0}, {1e5, 1e5}}}, {}, 0.1); }).find("cells"), std::string::npos);
}
