// Seeded generators of world families: the paper's room of discs and buildings with people.
//
//   room      the paper's 8 x 8 m room with disc obstacles on constant-(v, w) motions (generateScenario)
//   crowd     an 8 x 8 m room with people walking between destinations; start and goal on opposite sides
//   corridor  a corridor (width 2-3 m, 14 m long) with two-way traffic; start and goal at its two ends
//   doorway   two 6 x 6 m rooms joined by a door of 0.9-1.2 m; start in one room, goal in the other
//   clutter   an 8 x 8 m room with tables, shelves and chairs among people
//   junction  an L or T junction of corridors; start at one end, goal at another
// People walk between destinations at least destination_min_distance_m apart, through doors and junction
// centres on their way (so no plan leads into a wall), wait a moment at each, and pair up into groups at
// random. Where the family calls for it the destinations are natural ones: near the corridor's two ends (people
// walk its length), at the junction's arm ends, in the doorway's two rooms in turn (through the door); anywhere in
// the crowd and clutter rooms. The corridor, doorway and junction keep to a side (Scenario::traffic, from
// traffic_side and traffic_strength) and the doorway's door is a Door people pass one at a time
// (docs/simulator.md, "Traffic in buildings"). Everything is drawn from `seed` alone: the same configuration and seed
// give the same world on every platform.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dqn_dovs/sim/scenario.h"

namespace dqn_dovs::sim {

enum class WorldFamily { kRoom, kCrowd, kCorridor, kDoorway, kClutter, kJunction };

/// "room", "crowd", "corridor", "doorway", "clutter", "junction".
const char* worldFamilyName(WorldFamily family);
/// Throws SimConfigError naming an unknown family and the known ones.
WorldFamily parseWorldFamily(const std::string& name);
std::vector<std::string> worldFamilyNames();

/// The knobs of the families (the room family uses `room`, with `people` as its obstacle count).
struct WorldFamilyConfig {
  WorldFamily family = WorldFamily::kCrowd;
  /// People in the world (room: disc obstacles).
  int people = 8;
  double person_radius_min_m = 0.2;  ///< body radius uniform in [min, max]
  double person_radius_max_m = 0.3;
  double person_speed_min_mps = 0.5;  ///< preferred walking speed uniform in [min, max]
  double person_speed_max_mps = 1.3;
  /// Consecutive destinations of a person are at least this far apart (m).
  double destination_min_distance_m = 3.0;
  /// Pause at each destination uniform in [0, wait_max_s] (s).
  double wait_max_s = 2.0;
  /// Probability that a person joins the previous one's group (walking together to the same destinations).
  double group_probability = 0.2;
  double corridor_width_min_m = 2.0;  ///< corridor and junction width uniform in [min, max]
  double corridor_width_max_m = 3.0;
  double corridor_length_m = 14.0;  ///< corridor length; junction arms are half of it
  double door_width_min_m = 0.9;    ///< doorway width uniform in [min, max]
  double door_width_max_m = 1.2;
  int furniture_min = 6;  ///< clutter: pieces of furniture uniform in [min, max]
  int furniture_max = 10;
  /// Free space kept around the robot's start and goal (m).
  double start_goal_clearance_m = 0.8;
  /// The traffic rule of the corridor, doorway and junction (the crowd and clutter rooms have none).
  TrafficSide traffic_side = TrafficSide::kRight;
  double traffic_strength = 1.0;  ///< in [0, 1]; 0: no rule
  /// The room family's generator (its obstacle counts are replaced by `people`).
  GeneratorConfig room;
  /// Rejection-sampling budget per placed item before giving up with a ScenarioError.
  int max_attempts = 2000;

  /// Empty when consistent, otherwise a message naming the field and why.
  std::string validate() const;
};

/// A world of config.family drawn from `seed`. Throws ScenarioError naming the family, the seed and what could
/// not be placed, or SimConfigError for an inconsistent configuration.
Scenario generateWorld(const WorldFamilyConfig& config, uint64_t seed);

}  // namespace dqn_dovs::sim
