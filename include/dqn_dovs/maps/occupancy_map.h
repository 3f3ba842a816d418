// Occupancy-grid maps in the map_server format (a YAML description beside a PGM image) as static geometry for
// the simulator, the LIDAR and the DOVS: the boundaries between occupied and free cells become wall segments.
//
// The YAML keys read are map_server's: image (a path relative to the YAML file), resolution (m per cell),
// origin ([x, y, yaw] of the lower-left corner of the image, m and rad), negate (0 / 1), occupied_thresh and
// free_thresh (probabilities in [0, 1]), mode (trinary, scale or raw; default trinary). Images are 8-bit PGM,
// binary (P5) or plain (P2). A cell's occupancy is (255 - p) / 255 (p / 255 with negate = 1): above
// occupied_thresh it is occupied, below free_thresh free, otherwise unknown (trinary and scale); raw mode reads
// the pixel as the value itself (0 free, 100 occupied, anything else unknown).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

/// A map that cannot be read: the message names the file (YAML or image) and the reason.
class MapError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One cell's state.
enum class MapCell : int8_t { kUnknown = -1, kFree = 0, kOccupied = 100 };

/// A loaded occupancy grid. Cell (i, j) is column i from the left and row j from the bottom (y up), covering
/// [i, i + 1) x [j, j + 1) cells from the origin, in the origin's frame.
struct OccupancyMap {
  std::string name;            ///< the YAML file it came from
  double resolution_m = 0.05;  ///< cell side, m
  Pose2 origin;                ///< pose of the grid's lower-left corner in the map frame (m, m, rad)
  int width = 0;               ///< cells per row
  int height = 0;              ///< rows
  std::vector<MapCell> cells;  ///< row-major, bottom row first

  MapCell at(int i, int j) const { return cells[static_cast<size_t>(j) * static_cast<size_t>(width) + i]; }
  /// Occupied (unknown counts as occupied when unknown_is_occupied); false outside the grid.
  bool blocked(int i, int j, bool unknown_is_occupied) const;
  /// The map-frame point at grid coordinates (u, v), in cells from the lower-left corner.
  Vec2 toMap(double u, double v) const { return origin.toWorld(Vec2(u * resolution_m, v * resolution_m)); }
};

/// Reads the YAML description and its image. Throws MapError naming the file and the reason: a missing or
/// unreadable file, a missing or malformed key (resolution not a positive number, origin not three numbers,
/// thresholds outside [0, 1] or free_thresh above occupied_thresh, an unknown mode), an image that is not an
/// 8-bit PGM, has a non-positive size, more than 4096 x 4096 cells, or fewer pixels than its header promises.
OccupancyMap loadOccupancyMap(const std::string& yaml_path);

/// The same from texts already in memory: the YAML text (its `image` key is ignored) and the image file's
/// bytes; `yaml_name` and `image_name` name them in the errors.
OccupancyMap parseOccupancyMap(const std::string& yaml_text, const std::string& image_bytes,
                               const std::string& yaml_name, const std::string& image_name);

/// The walls of the map: every edge between a blocked cell and a cell that is not (or the outside of the grid),
/// merged into maximal straight runs, in the map frame. Unknown cells count as blocked when
/// unknown_is_occupied (the robot never enters what it does not know).
std::vector<Segment> mapSegments(const OccupancyMap& map, bool unknown_is_occupied = true);

}  // namespace dqn_dovs
