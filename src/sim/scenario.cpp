#include "dqn_dovs/sim/scenario.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

namespace dqn_dovs::sim {
namespace {

constexpr size_t kValuesPerRow = 5;
constexpr size_t kRowBytes = kValuesPerRow * sizeof(double);

[[noreturn]] void fail(const std::string& path, const std::string& reason) {
  throw ScenarioError("scenario file '" + path + "': " + reason);
}

// The format is little-endian; decode explicitly so that the loader does not depend on the host byte order.
double decodeLittleEndian(const unsigned char* bytes) {
  uint64_t bits = 0;
  for (int i = 7; i >= 0; --i) bits = (bits << 8) | bytes[i];
  double value = 0.0;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

void encodeLittleEndian(double value, unsigned char* bytes) {
  uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof(bits));
  for (int i = 0; i < 8; ++i) {
    bytes[i] = static_cast<unsigned char>(bits & 0xFFu);
    bits >>= 8;
  }
}

std::string describeRow(size_t row) {
  return row == 0 ? std::string("row 0 (robot)")
                  : "row " + std::to_string(row) + " (obstacle " + std::to_string(row) + ")";
}

bool insideRoom(double x, double y, double half) { return std::abs(x) < half && std::abs(y) < half; }

// "1-5/1" for ".../rumor/1-5/1.dovs": the obstacle-count folder and the episode number identify an episode.
std::string scenarioNameFromPath(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  std::string file = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = file.find_last_of('.');
  if (dot != std::string::npos && dot > 0) file = file.substr(0, dot);
  if (slash == std::string::npos || slash == 0) return file;
  const size_t parent_start = path.find_last_of('/', slash - 1);
  const std::string parent = parent_start == std::string::npos
                                 ? path.substr(0, slash)
                                 : path.substr(parent_start + 1, slash - parent_start - 1);
  return parent.empty() ? file : parent + "/" + file;
}

void checkLoadParameters(const std::string& path, double obstacle_radius_m, double room_half_size_m) {
  if (!(std::isfinite(obstacle_radius_m) && obstacle_radius_m > 0.0)) {
    std::ostringstream os;
    os << "obstacle radius " << obstacle_radius_m << " m must be finite and positive";
    fail(path, os.str());
  }
  if (!(std::isfinite(room_half_size_m) && room_half_size_m > 0.0)) {
    std::ostringstream os;
    os << "room half size " << room_half_size_m << " m must be finite and positive";
    fail(path, os.str());
  }
}

}  // namespace

Scenario loadDovsScenario(const std::string& path, double obstacle_radius_m, double room_half_size_m) {
  checkLoadParameters(path, obstacle_radius_m, room_half_size_m);
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open for reading (") + std::strerror(errno) + ")");
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) fail(path, "read error");
  return parseDovsScenario(bytes.data(), bytes.size(), path, obstacle_radius_m, room_half_size_m);
}

Scenario parseDovsScenario(const unsigned char* data, size_t size, const std::string& path, double obstacle_radius_m,
                           double room_half_size_m) {
  checkLoadParameters(path, obstacle_radius_m, room_half_size_m);
  if (size == 0) fail(path, "file is empty (expected at least the robot row of 40 bytes)");
  if (size % kRowBytes != 0) {
    fail(path, "size " + std::to_string(size) + " bytes is not a multiple of " + std::to_string(kRowBytes) +
                   " (rows of 5 little-endian float64): truncated or not a .dovs file");
  }
  const size_t rows = size / kRowBytes;
  std::vector<double> v(rows * kValuesPerRow);
  for (size_t i = 0; i < v.size(); ++i) {
    v[i] = decodeLittleEndian(data + i * sizeof(double));
    if (!std::isfinite(v[i])) {
      std::ostringstream os;
      os << describeRow(i / kValuesPerRow) << " column " << i % kValuesPerRow << " is " << v[i]
         << " (every value must be finite)";
      fail(path, os.str());
    }
  }

  Scenario s;
  s.name = scenarioNameFromPath(path);
  s.room_half_size_m = room_half_size_m;
  s.robot_start = {v[0], v[1], normalizeAngle(v[2])};
  s.goal = {v[3], v[4]};
  auto checkInside = [&](double x, double y, const std::string& what) {
    if (!insideRoom(x, y, room_half_size_m)) {
      std::ostringstream os;
      os << what << " position (" << x << ", " << y << ") is outside the room (walls at +-" << room_half_size_m
         << " m)";
      fail(path, os.str());
    }
  };
  checkInside(v[0], v[1], "robot");
  checkInside(v[3], v[4], "goal");
  s.obstacles.reserve(rows - 1);
  for (size_t r = 1; r < rows; ++r) {
    const double* row = &v[r * kValuesPerRow];
    checkInside(row[0], row[1], describeRow(r));
    if (std::abs(row[3]) > kMaxScenarioSpeedMps || std::abs(row[4]) > kMaxScenarioTurnRateRadps) {
      std::ostringstream os;
      os << describeRow(r) << " motion v = " << row[3] << " m/s, w = " << row[4]
         << " rad/s exceeds the limits |v| <= " << kMaxScenarioSpeedMps << " m/s, |w| <= " << kMaxScenarioTurnRateRadps
         << " rad/s";
      fail(path, os.str());
    }
    MovingObstacle o;
    o.center = {row[0], row[1]};
    o.radius = obstacle_radius_m;
    o.heading = normalizeAngle(row[2]);
    o.speed = row[3];
    o.turn_rate = row[4];
    if (o.speed < 0.0) {
      // Same motion with a forward speed: heading is the direction of travel everywhere in the core.
      o.speed = -o.speed;
      o.heading = normalizeAngle(o.heading + kPi);
    }
    o.is_static = o.speed == 0.0 && o.turn_rate == 0.0;
    s.obstacles.push_back(o);
  }
  return s;
}

void saveDovsScenario(const Scenario& scenario, const std::string& path) {
  if (!scenario.static_segments.empty()) {
    fail(path, "scenario '" + scenario.name + "' has " + std::to_string(scenario.static_segments.size()) +
                   " static segments, which the .dovs format cannot store");
  }
  std::vector<double> values = {scenario.robot_start.x, scenario.robot_start.y, scenario.robot_start.theta,
                                scenario.goal.x(), scenario.goal.y()};
  for (const MovingObstacle& o : scenario.obstacles) {
    const bool still = o.is_static;
    values.insert(values.end(),
                  {o.center.x(), o.center.y(), o.heading, still ? 0.0 : o.speed, still ? 0.0 : o.turn_rate});
  }
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      std::ostringstream os;
      os << describeRow(i / kValuesPerRow) << " column " << i % kValuesPerRow << " is " << values[i]
         << " (every value must be finite)";
      fail(path, os.str());
    }
  }
  std::vector<unsigned char> bytes(values.size() * sizeof(double));
  for (size_t i = 0; i < values.size(); ++i) encodeLittleEndian(values[i], bytes.data() + i * sizeof(double));
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) fail(path, std::string("cannot open for writing (") + std::strerror(errno) + ")");
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) fail(path, "write error");
}

std::vector<Circle> furnitureOf(const Scenario& scenario) {
  std::vector<Circle> out;
  for (const MovingObstacle& o : scenario.obstacles) {
    if (o.is_static) out.push_back({o.center, o.radius});
  }
  return out;
}

void applyDynamicFraction(Scenario& scenario, double dynamic_fraction) {
  if (!(dynamic_fraction >= 0.0 && dynamic_fraction <= 1.0)) {
    std::ostringstream os;
    os << "scenario '" << scenario.name << "': dynamic fraction " << dynamic_fraction << " must be in [0, 1]";
    throw ScenarioError(os.str());
  }
  const size_t n = scenario.obstacles.size();
  // The tiny bias keeps exact halves (e.g. 0.15 * 10 = 1.5) rounding up as the protocol's round() does, even
  // when 1 - dynamic_fraction is not exactly representable.
  const double wanted = std::round((1.0 - dynamic_fraction) * static_cast<double>(n) + 1e-9);
  const size_t n_static = std::min(n, static_cast<size_t>(std::max(0.0, wanted)));
  for (size_t i = n - n_static; i < n; ++i) {
    MovingObstacle& o = scenario.obstacles[i];
    o.speed = 0.0;
    o.turn_rate = 0.0;
    o.is_static = true;
  }
}

}  // namespace dqn_dovs::sim
