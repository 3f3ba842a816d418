// Occupancy-grid maps (map_server YAML + PGM): cell states, frames, the wall segments, and clear errors for
// malformed maps.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "dqn_dovs/maps/occupancy_map.h"
#include "sim_test_helpers.h"

namespace dqn_dovs {
namespace {

/// A binary PGM of `rows` (top row first; '#' occupied = 0, '.' free = 254, '?' unknown = 205).
std::string pgm(const std::vector<std::string>& rows) {
  std::string out =
      "P5\n# made by the test\n" + std::to_string(rows[0].size()) + " " + std::to_string(rows.size()) + "\n255\n";
  for (const std::string& r : rows) {
    for (char c : r) out.push_back(static_cast<char>(c == '#' ? 0 : c == '.' ? 254 : 205));
  }
  return out;
}

const char* kYaml =
    "image: room.pgm\nresolution: 0.5\norigin: [-1.0, -2.0, 0.0]\nnegate: 0\n"
    "occupied_thresh: 0.65\nfree_thresh: 0.196  # map_server's defaults\n";

void write(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

std::string errorOf(const std::string& yaml, const std::string& image) {
  try {
    parseOccupancyMap(yaml, image, "m.yaml", "m.pgm");
  } catch (const MapError& e) {
    return e.what();
  }
  return "";
}

TEST(Map, LoadsCellsBottomRowFirstWithTheOriginAndThresholds) {
  test::TempDir dir;
  write(dir.file("room.yaml"), kYaml);
  write(dir.file("room.pgm"), pgm({"##?", "#..", "###"}));
  const OccupancyMap m = loadOccupancyMap(dir.path() + "/room.yaml");
  EXPECT_EQ(m.width, 3);
  EXPECT_EQ(m.height, 3);
  EXPECT_DOUBLE_EQ(m.resolution_m, 0.5);
  EXPECT_EQ(m.at(0, 0), MapCell::kOccupied);  // bottom-left: the image's last row
  EXPECT_EQ(m.at(1, 1), MapCell::kFree);
  EXPECT_EQ(m.at(2, 2), MapCell::kUnknown);  // top-right: 205 is (255 - 205) / 255 = 0.196.., between the thresholds
  EXPECT_TRUE(m.blocked(2, 2, true));
  EXPECT_FALSE(m.blocked(2, 2, false));
  EXPECT_FALSE(m.blocked(-1, 0, true));
  const Vec2 corner = m.toMap(3.0, 3.0);
  EXPECT_NEAR(corner.x(), 0.5, 1e-12);
  EXPECT_NEAR(corner.y(), -0.5, 1e-12);
}

TEST(Map, PlainPgmNegateAndRawModes) {
  // P2 with maxval 100: values are scaled to 0..255 first.
  const std::string plain = "P2\n2 1\n100\n0 100\n";
  OccupancyMap m = parseOccupancyMap("resolution: 1\norigin: [0, 0, 0]\n", plain, "a.yaml", "a.pgm");
  EXPECT_EQ(m.at(0, 0), MapCell::kOccupied);
  EXPECT_EQ(m.at(1, 0), MapCell::kFree);
  m = parseOccupancyMap("resolution: 1\norigin: [0, 0, 0]\nnegate: 1\n", plain, "a.yaml", "a.pgm");
  EXPECT_EQ(m.at(0, 0), MapCell::kFree);
  EXPECT_EQ(m.at(1, 0), MapCell::kOccupied);
  const std::string raw = "P2\n3 1\n255\n0 100 7\n";
  m = parseOccupancyMap("resolution: 1\norigin: [0, 0, 0]\nmode: raw\n", raw, "a.yaml", "a.pgm");
  EXPECT_EQ(m.at(0, 0), MapCell::kFree);
  EXPECT_EQ(m.at(1, 0), MapCell::kOccupied);
  EXPECT_EQ(m.at(2, 0), MapCell::kUnknown);
}

TEST(Map, WallSegmentsAreMergedRunsAroundBlockedCells) {
  // A hollow 4 x 4 square, one cell thick: an outer and an inner outline, 4 segments each.
  const OccupancyMap m = parseOccupancyMap("resolution: 0.25\norigin: [1.0, 2.0, 0.0]\n",
                                           pgm({"####", "#..#", "#..#", "####"}), "sq.yaml", "sq.pgm");
  const std::vector<Segment> s = mapSegments(m);
  ASSERT_EQ(s.size(), 8u);
  double total = 0.0;
  for (const Segment& seg : s) {
    total += seg.length();
    EXPECT_TRUE(std::abs(seg.a.x() - seg.b.x()) < 1e-12 || std::abs(seg.a.y() - seg.b.y()) < 1e-12);
  }
  EXPECT_NEAR(total, 4 * 1.0 + 4 * 0.5, 1e-12);  // outer side 4 cells, inner side 2 cells, 0.25 m each
  const auto has = [&](Vec2 a, Vec2 b) {
    return std::any_of(s.begin(), s.end(), [&](const Segment& g) {
      return ((g.a - a).norm() < 1e-9 && (g.b - b).norm() < 1e-9) ||
             ((g.a - b).norm() < 1e-9 && (g.b - a).norm() < 1e-9);
    });
  };
  EXPECT_TRUE(has({1.0, 2.0}, {2.0, 2.0}));      // outer bottom edge, in the map frame
  EXPECT_TRUE(has({1.25, 2.25}, {1.75, 2.25}));  // inner bottom edge
  // A rotated origin turns the segments with it.
  const OccupancyMap r =
      parseOccupancyMap("resolution: 1\norigin: [0, 0, 1.5707963267948966]\n", pgm({"#"}), "r.yaml", "r.pgm");
  bool found = false;
  for (const Segment& g : mapSegments(r)) found |= (g.a - Vec2(0, 0)).norm() < 1e-9 && (g.b - Vec2(0, 1)).norm() < 1e-9;
  EXPECT_TRUE(found) << "the cell's bottom edge should lie on the map's y axis";
  // Unknown cells are walls only when asked.
  const OccupancyMap u = parseOccupancyMap("resolution: 1\norigin: [0, 0, 0]\n", pgm({"?.."}), "u.yaml", "u.pgm");
  EXPECT_EQ(mapSegments(u, true).size(), 4u);
  EXPECT_TRUE(mapSegments(u, false).empty());
}

TEST(Map, MalformedMapsAreNamedWithTheReason) {
  const std::string good = pgm({"#."});
  const std::string yaml = "resolution: 0.05\norigin: [0, 0, 0]\n";
  EXPECT_NE(errorOf("origin: [0, 0, 0]\n", good).find("'m.yaml': key 'resolution' is missing"), std::string::npos);
  EXPECT_NE(errorOf("resolution: -1\norigin: [0, 0, 0]\n", good).find("resolution must be a positive"),
            std::string::npos);
  EXPECT_NE(errorOf("resolution: abc\norigin: [0, 0, 0]\n", good).find("'abc' is not a finite number"),
            std::string::npos);
  EXPECT_NE(errorOf("resolution: 1\norigin: [0, 0]\n", good).find("is not [x, y, yaw]"), std::string::npos);
  EXPECT_NE(errorOf("resolution: 1\norigin: [0, nan, 0]\n", good).find("not a finite number"), std::string::npos);
  EXPECT_NE(errorOf(yaml + "free_thresh: 0.9\n", good).find("free_thresh <= occupied_thresh"), std::string::npos);
  EXPECT_NE(errorOf(yaml + "mode: fancy\n", good).find("mode 'fancy'"), std::string::npos);
  EXPECT_NE(errorOf(yaml + "just words\n", good).find("line 3 is not 'key: value'"), std::string::npos);
  EXPECT_NE(errorOf(yaml, "GIF89a").find("'m.pgm': not a PGM image"), std::string::npos);
  EXPECT_NE(errorOf(yaml, "P5\n2 2\n255\nab").find("holds 2 pixel bytes, its header promises 4"), std::string::npos);
  EXPECT_NE(errorOf(yaml, "P5\n2 2\n65535\n").find("only 8-bit"), std::string::npos);
  EXPECT_NE(errorOf(yaml, "P5\n0 2\n255\n").find("size is not positive"), std::string::npos);
  EXPECT_NE(errorOf(yaml, "P5\n5000 2\n255\n").find("more than 4096"), std::string::npos);
  EXPECT_NE(errorOf(yaml, "P2\n2 1\n10\n3 11\n").find("exceeds the maximum value 10"), std::string::npos);
  EXPECT_NE(errorOf(yaml, "P2\n2 1\n255\n3\n").find("holds 1 pixels, its header promises 2"), std::string::npos);
  // Files: a missing YAML, a YAML without an image, a missing image.
  test::TempDir dir;
  try {
    loadOccupancyMap(dir.path() + "/nothing.yaml");
    FAIL() << "no error for a missing map";
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("nothing.yaml': cannot open"), std::string::npos) << e.what();
  }
  write(dir.file("noimage.yaml"), yaml);
  EXPECT_THROW(loadOccupancyMap(dir.path() + "/noimage.yaml"), MapError);
  write(dir.file("lost.yaml"), yaml + "image: lost.pgm\n");
  try {
    loadOccupancyMap(dir.path() + "/lost.yaml");
    FAIL() << "no error for a missing image";
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("map image '" + dir.path() + "/lost.pgm': cannot open"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dqn_dovs
