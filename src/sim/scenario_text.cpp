// The text scenario format (version 2): see scenario.h.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <optional>
#include <sstream>

#include "dqn_dovs/common/parse.h"
#include "dqn_dovs/maps/occupancy_map.h"
#include "dqn_dovs/sim/scenario.h"

namespace dqn_dovs::sim {

namespace {

constexpr const char* kHeader = "dqn_dovs scenario 2";

/// The numbers of one line after its keyword; ScenarioError naming the file and line when one is not a finite
/// number.
std::vector<double> numbers(std::istringstream& in, const std::string& where, const char* flag_word) {
  std::vector<double> out;
  std::string word;
  while (in >> word) {
    if (flag_word != nullptr && word == flag_word) {
      out.push_back(std::nan(""));  // a flag ('static', 'via'), handled by the caller
      continue;
    }
    const std::optional<double> parsed = parseNumber(word);
    const double v = parsed.value_or(std::nan(""));
    if (!std::isfinite(v)) throw ScenarioError(where + ": '" + word + "' is not a finite number");
    out.push_back(v);
  }
  return out;
}

void need(const std::vector<double>& v, size_t n, const std::string& item, const std::string& where) {
  if (v.size() != n) {
    throw ScenarioError(where + ": '" + item + "' takes " + std::to_string(n) + " numbers, got " +
                        std::to_string(v.size()));
  }
}

void inside(const Vec2& p, double half, const std::string& what, const std::string& where) {
  if (!(std::abs(p.x()) < half && std::abs(p.y()) < half)) {
    std::ostringstream os;
    os << where << ": " << what << " (" << p.x() << ", " << p.y() << ") is not inside the room (half size " << half
       << " m)";
    throw ScenarioError(os.str());
  }
}

}  // namespace

Scenario parseScenarioText(const std::string& text, const std::string& path) {
  std::istringstream lines(text);
  std::string line;
  if (!std::getline(lines, line) || line.rfind(kHeader, 0) != 0) {
    throw ScenarioError("scenario '" + path + "': the first line is not '" + kHeader + "'");
  }
  Scenario s;
  s.name = path;
  bool have_robot = false, have_goal = false;
  struct Placed {
    Vec2 p;
    std::string what, where;
  };
  std::vector<Placed> placed;  // checked against the room once its size is known
  int number = 1;
  while (std::getline(lines, line)) {
    ++number;
    const std::string where = "scenario '" + path + "' line " + std::to_string(number);
    if (const size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream in(line);
    std::string item;
    if (!(in >> item)) continue;
    if (item == "name") {
      std::string rest;
      std::getline(in, rest);
      const size_t first = rest.find_first_not_of(" \t");
      s.name = first == std::string::npos ? "" : rest.substr(first);
      continue;
    }
    if (item == "map") {
      std::string file;
      in >> file;
      if (file.empty()) throw ScenarioError(where + ": 'map' needs a file");
      std::filesystem::path map_path(file);
      if (map_path.is_relative()) map_path = std::filesystem::path(path).parent_path() / map_path;
      try {
        const std::vector<Segment> walls = mapSegments(loadOccupancyMap(map_path.string()));
        s.static_segments.insert(s.static_segments.end(), walls.begin(), walls.end());
      } catch (const MapError& e) {
        throw ScenarioError(where + ": " + e.what());
      }
      continue;
    }
    if (item == "traffic") {
      std::string side;
      in >> side;
      try {
        s.traffic.side = parseTrafficSide(side);
      } catch (const SimConfigError& e) {
        throw ScenarioError(where + ": " + e.what());
      }
      const std::vector<double> v = numbers(in, where, nullptr);
      need(v, 1, item, where);
      s.traffic.strength = v[0];
      if (const std::string e = s.traffic.validate(); !e.empty()) throw ScenarioError(where + ": " + e);
      continue;
    }
    const std::vector<double> v = numbers(in, where,
                                          item == "obstacle" ? "static"
                                          : item == "person" ? "via"
                                                             : nullptr);
    if (item == "room") {
      need(v, 1, item, where);
      if (!(v[0] > 0.0)) throw ScenarioError(where + ": the room's half size must be > 0 m");
      s.room_half_size_m = v[0];
    } else if (item == "robot") {
      need(v, 3, item, where);
      s.robot_start = {v[0], v[1], v[2]};
      placed.push_back({Vec2(v[0], v[1]), "the robot", where});
      have_robot = true;
    } else if (item == "goal") {
      need(v, 2, item, where);
      s.goal = Vec2(v[0], v[1]);
      placed.push_back({s.goal, "the goal", where});
      have_goal = true;
    } else if (item == "obstacle") {
      const bool is_static = v.size() == 7 && std::isnan(v[6]);
      need(v, is_static ? 7 : 6, item, where);
      if (!(v[5] > 0.0)) throw ScenarioError(where + ": an obstacle's radius must be > 0 m");
      if (std::abs(v[3]) > kMaxScenarioSpeedMps || std::abs(v[4]) > kMaxScenarioTurnRateRadps) {
        throw ScenarioError(where + ": the obstacle is faster than the simulator allows");
      }
      MovingObstacle o;
      o.center = Vec2(v[0], v[1]);
      o.heading = v[2];
      o.speed = is_static ? 0.0 : v[3];
      o.turn_rate = is_static ? 0.0 : v[4];
      o.radius = v[5];
      o.is_static = is_static || (v[3] == 0.0 && v[4] == 0.0);
      s.obstacles.push_back(o);
      placed.push_back({o.center, "an obstacle", where});
    } else if (item == "wall") {
      need(v, 4, item, where);
      s.static_segments.push_back({Vec2(v[0], v[1]), Vec2(v[2], v[3])});
    } else if (item == "door") {
      need(v, 5, item, where);
      Door d;
      d.center = Vec2(v[0], v[1]);
      d.across = Vec2(v[2], v[3]);
      if (d.across.norm() > 1e-9 && std::abs(d.across.norm() - 1.0) > 1e-12) d.across.normalize();
      d.width_m = v[4];
      if (const std::string e = d.validate(); !e.empty()) throw ScenarioError(where + ": " + e);
      s.doors.push_back(d);
    } else if (item == "polygon") {
      if (v.size() < 6 || v.size() % 2 != 0) throw ScenarioError(where + ": 'polygon' takes 3 or more x y pairs");
      for (size_t i = 0; i < v.size(); i += 2) {
        const size_t j = (i + 2) % v.size();
        s.static_segments.push_back({Vec2(v[i], v[i + 1]), Vec2(v[j], v[j + 1])});
      }
    } else if (item == "person") {
      const bool flags_in_place = std::none_of(v.begin(), v.begin() + std::min<std::ptrdiff_t>(7, v.size()),
                                               [](double x) { return std::isnan(x); });
      const size_t flags =
          static_cast<size_t>(std::count_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }));
      if (v.size() < 7 || !flags_in_place || (v.size() - 7 - flags) % 2 != 0) {
        throw ScenarioError(
            where + ": 'person' takes X Y HEADING RADIUS SPEED WAIT GROUP then x y pairs, each may follow 'via'");
      }
      PersonSpec p;
      p.position = Vec2(v[0], v[1]);
      p.heading_rad = v[2];
      p.body_radius_m = v[3];
      p.preferred_speed_mps = v[4];
      p.wait_s = v[5];
      p.group = static_cast<int>(v[6]);
      if (!(p.body_radius_m > 0.0 && p.preferred_speed_mps > 0.0 && p.wait_s >= 0.0 && v[6] == std::floor(v[6]))) {
        throw ScenarioError(where + ": a person needs radius > 0, speed > 0, wait >= 0 and an integer group");
      }
      for (size_t i = 7; i < v.size(); i += 2) {
        const bool via = std::isnan(v[i]);
        if (via) ++i;
        if (i + 1 >= v.size() || std::isnan(v[i]) || std::isnan(v[i + 1])) {
          throw ScenarioError(where + ": 'via' must be followed by a destination's x y");
        }
        p.destinations.push_back(Vec2(v[i], v[i + 1]));
        p.pass_through.push_back(via);
      }
      if (std::none_of(p.pass_through.begin(), p.pass_through.end(), [](bool b) { return b; })) p.pass_through.clear();
      s.people.push_back(p);
      placed.push_back({p.position, "a person", where});
    } else {
      throw ScenarioError(where + ": unknown item '" + item + "'");
    }
  }
  if (!have_robot || !have_goal) throw ScenarioError("scenario '" + path + "': it needs a 'robot' and a 'goal' line");
  for (const Placed& p : placed) inside(p.p, s.room_half_size_m, p.what, p.where);
  return s;
}

void saveScenarioText(const Scenario& s, const std::string& path) {
  std::ostringstream out;
  out << std::setprecision(17) << kHeader << "\nname " << s.name << "\nroom " << s.room_half_size_m << "\nrobot "
      << s.robot_start.x << " " << s.robot_start.y << " " << s.robot_start.theta << "\ngoal " << s.goal.x() << " "
      << s.goal.y() << "\n";
  bool finite = s.robot_start.isFinite() && s.goal.allFinite() && std::isfinite(s.room_half_size_m);
  for (const MovingObstacle& o : s.obstacles) {
    out << "obstacle " << o.center.x() << " " << o.center.y() << " " << o.heading << " " << o.speed << " "
        << o.turn_rate << " " << o.radius << (o.is_static ? " static" : "") << "\n";
    finite = finite && o.center.allFinite() && std::isfinite(o.heading + o.speed + o.turn_rate + o.radius);
  }
  for (const Segment& w : s.static_segments) {
    out << "wall " << w.a.x() << " " << w.a.y() << " " << w.b.x() << " " << w.b.y() << "\n";
    finite = finite && w.a.allFinite() && w.b.allFinite();
  }
  for (const PersonSpec& p : s.people) {
    out << "person " << p.position.x() << " " << p.position.y() << " " << p.heading_rad << " " << p.body_radius_m << " "
        << p.preferred_speed_mps << " " << p.wait_s << " " << p.group;
    for (size_t k = 0; k < p.destinations.size(); ++k) {
      const bool via = k < p.pass_through.size() && p.pass_through[k];
      out << (via ? " via " : " ") << p.destinations[k].x() << " " << p.destinations[k].y();
    }
    out << "\n";
    finite = finite && p.position.allFinite() && std::isfinite(p.heading_rad + p.body_radius_m + p.preferred_speed_mps);
  }
  if (s.traffic.side != TrafficSide::kNone || s.traffic.strength != 0.0) {
    out << "traffic " << trafficSideName(s.traffic.side) << " " << s.traffic.strength << "\n";
    finite = finite && std::isfinite(s.traffic.strength);
  }
  for (const Door& d : s.doors) {
    out << "door " << d.center.x() << " " << d.center.y() << " " << d.across.x() << " " << d.across.y() << " "
        << d.width_m << "\n";
    finite = finite && d.center.allFinite() && d.across.allFinite() && std::isfinite(d.width_m);
  }
  if (!finite) throw ScenarioError("cannot save scenario '" + path + "': a value is not finite");
  std::ofstream file(path);
  file << out.str();
  file.close();
  if (!file) throw ScenarioError("cannot write scenario '" + path + "'");
}

Scenario loadScenarioFile(const std::string& path, double obstacle_radius_m, double room_half_size_m) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ScenarioError("scenario '" + path + "': cannot open the file");
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string bytes = ss.str();
  if (bytes.rfind(kHeader, 0) == 0) return parseScenarioText(bytes, path);
  return parseDovsScenario(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), path, obstacle_radius_m,
                           room_half_size_m);
}

}  // namespace dqn_dovs::sim
