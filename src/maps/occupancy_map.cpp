#include "dqn_dovs/maps/occupancy_map.h"

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace dqn_dovs {

namespace {

constexpr int kMaxMapSide = 4096;

std::string readFile(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MapError(what + " '" + path + "': cannot open the file");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw MapError(what + " '" + path + "': cannot read the file");
  return ss.str();
}

std::string trim(const std::string& s) {
  size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

/// The top-level `key: value` pairs of a map_server YAML file (comments and blank lines skipped).
std::map<std::string, std::string> yamlPairs(const std::string& text, const std::string& name) {
  std::map<std::string, std::string> out;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line = line.substr(0, hash);
    if (trim(line).empty()) continue;
    const size_t colon = line.find(':');
    if (colon == std::string::npos) {
      throw MapError("map '" + name + "': line " + std::to_string(number) + " is not 'key: value'");
    }
    std::string value = trim(line.substr(colon + 1));
    if (value.size() >= 2 && (value.front() == '"' || value.front() == '\'') && value.back() == value.front())
      value = value.substr(1, value.size() - 2);
    out[trim(line.substr(0, colon))] = value;
  }
  return out;
}

double number(const std::map<std::string, std::string>& kv, const std::string& key, const std::string& name,
              double fallback, bool required) {
  const auto it = kv.find(key);
  if (it == kv.end()) {
    if (required) throw MapError("map '" + name + "': key '" + key + "' is missing");
    return fallback;
  }
  size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(it->second, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || trim(it->second.substr(used)) != "" || !std::isfinite(v)) {
    throw MapError("map '" + name + "': key '" + key + "' = '" + it->second + "' is not a finite number");
  }
  return v;
}

Pose2 parseOrigin(const std::map<std::string, std::string>& kv, const std::string& name) {
  const auto it = kv.find("origin");
  if (it == kv.end()) throw MapError("map '" + name + "': key 'origin' is missing");
  std::string s = trim(it->second);
  if (s.size() < 2 || s.front() != '[' || s.back() != ']') {
    throw MapError("map '" + name + "': origin '" + it->second + "' is not [x, y, yaw]");
  }
  std::vector<double> v;
  std::stringstream ss(s.substr(1, s.size() - 2));
  std::string item;
  while (std::getline(ss, item, ',')) {
    size_t used = 0;
    double x = 0.0;
    try {
      x = std::stod(trim(item), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != trim(item).size() || !std::isfinite(x)) {
      throw MapError("map '" + name + "': origin '" + it->second + "' holds a value that is not a finite number");
    }
    v.push_back(x);
  }
  if (v.size() != 3) throw MapError("map '" + name + "': origin '" + it->second + "' is not [x, y, yaw]");
  return {v[0], v[1], v[2]};
}

/// An 8-bit PGM image (P5 or P2): width, height and the pixels, top row first.
struct Pgm {
  int width = 0, height = 0, maxval = 255;
  std::vector<int> pixels;
};

Pgm parsePgm(const std::string& bytes, const std::string& name) {
  size_t pos = 0;
  auto bad = [&](const std::string& why) { return MapError("map image '" + name + "': " + why); };
  auto skipSpaceAndComments = [&]() {
    while (pos < bytes.size()) {
      if (std::isspace(static_cast<unsigned char>(bytes[pos]))) {
        ++pos;
      } else if (bytes[pos] == '#') {
        while (pos < bytes.size() && bytes[pos] != '\n') ++pos;
      } else {
        break;
      }
    }
  };
  auto readInt = [&](const char* what) {
    skipSpaceAndComments();
    const size_t start = pos;
    long v = 0;
    while (pos < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[pos])) && pos - start < 9)
      v = v * 10 + (bytes[pos++] - '0');
    if (pos == start) throw bad(std::string("the header's ") + what + " is missing or not a number");
    return static_cast<int>(v);
  };
  if (bytes.size() < 2 || bytes[0] != 'P' || (bytes[1] != '5' && bytes[1] != '2')) {
    throw bad("not a PGM image (it must start with P5 or P2)");
  }
  const bool binary = bytes[1] == '5';
  pos = 2;
  Pgm img;
  img.width = readInt("width");
  img.height = readInt("height");
  img.maxval = readInt("maximum value");
  if (img.width <= 0 || img.height <= 0) throw bad("its size is not positive");
  if (img.width > kMaxMapSide || img.height > kMaxMapSide) {
    throw bad(std::to_string(img.width) + " x " + std::to_string(img.height) + " cells is more than " +
              std::to_string(kMaxMapSide) + " x " + std::to_string(kMaxMapSide));
  }
  if (img.maxval <= 0 || img.maxval > 255) throw bad("only 8-bit images are read (maximum value 1..255)");
  const size_t n = static_cast<size_t>(img.width) * static_cast<size_t>(img.height);
  img.pixels.resize(n);
  if (binary) {
    if (pos >= bytes.size() || !std::isspace(static_cast<unsigned char>(bytes[pos])))
      throw bad("no whitespace after the header");
    ++pos;
    if (bytes.size() - pos < n) {
      throw bad("holds " + std::to_string(bytes.size() - pos) + " pixel bytes, its header promises " +
                std::to_string(n));
    }
    for (size_t k = 0; k < n; ++k) img.pixels[k] = static_cast<unsigned char>(bytes[pos + k]);
  } else {
    for (size_t k = 0; k < n; ++k) {
      skipSpaceAndComments();
      if (pos >= bytes.size()) {
        throw bad("holds " + std::to_string(k) + " pixels, its header promises " + std::to_string(n));
      }
      img.pixels[k] = readInt("pixel");
    }
  }
  for (int& p : img.pixels) {
    if (p > img.maxval) throw bad("a pixel exceeds the maximum value " + std::to_string(img.maxval));
    // Scale to 0..255 as map_server reads images.
    if (img.maxval != 255) p = static_cast<int>(std::lround(255.0 * p / img.maxval));
  }
  return img;
}

}  // namespace

bool OccupancyMap::blocked(int i, int j, bool unknown_is_occupied) const {
  if (i < 0 || j < 0 || i >= width || j >= height) return false;
  const MapCell c = at(i, j);
  return c == MapCell::kOccupied || (unknown_is_occupied && c == MapCell::kUnknown);
}

OccupancyMap parseOccupancyMap(const std::string& yaml_text, const std::string& image_bytes,
                               const std::string& yaml_name, const std::string& image_name) {
  const std::map<std::string, std::string> kv = yamlPairs(yaml_text, yaml_name);
  OccupancyMap m;
  m.name = yaml_name;
  m.resolution_m = number(kv, "resolution", yaml_name, 0.0, true);
  if (!(m.resolution_m > 0.0)) throw MapError("map '" + yaml_name + "': resolution must be a positive number (m)");
  m.origin = parseOrigin(kv, yaml_name);
  const bool negate = number(kv, "negate", yaml_name, 0.0, false) != 0.0;
  const double occupied = number(kv, "occupied_thresh", yaml_name, 0.65, false);
  const double free = number(kv, "free_thresh", yaml_name, 0.196, false);
  if (occupied < 0.0 || occupied > 1.0 || free < 0.0 || free > 1.0 || free > occupied) {
    throw MapError("map '" + yaml_name + "': thresholds must satisfy 0 <= free_thresh <= occupied_thresh <= 1");
  }
  const auto mode_it = kv.find("mode");
  const std::string mode = mode_it == kv.end() ? "trinary" : mode_it->second;
  if (mode != "trinary" && mode != "scale" && mode != "raw") {
    throw MapError("map '" + yaml_name + "': mode '" + mode + "' is not trinary, scale or raw");
  }
  const Pgm img = parsePgm(image_bytes, image_name);
  m.width = img.width;
  m.height = img.height;
  m.cells.resize(img.pixels.size());
  for (int row = 0; row < img.height; ++row) {
    const int j = img.height - 1 - row;  // image rows run top to bottom, the grid's bottom to top
    for (int i = 0; i < img.width; ++i) {
      const int p = img.pixels[static_cast<size_t>(row) * static_cast<size_t>(img.width) + i];
      MapCell c = MapCell::kUnknown;
      if (mode == "raw") {
        c = p == 0 ? MapCell::kFree : p == 100 ? MapCell::kOccupied : MapCell::kUnknown;
      } else {
        const double occ = negate ? p / 255.0 : (255.0 - p) / 255.0;
        c = occ > occupied ? MapCell::kOccupied : occ < free ? MapCell::kFree : MapCell::kUnknown;
      }
      m.cells[static_cast<size_t>(j) * static_cast<size_t>(img.width) + i] = c;
    }
  }
  return m;
}

OccupancyMap loadOccupancyMap(const std::string& yaml_path) {
  const std::string yaml = readFile(yaml_path, "map");
  const std::map<std::string, std::string> kv = yamlPairs(yaml, yaml_path);
  const auto image = kv.find("image");
  if (image == kv.end() || image->second.empty()) throw MapError("map '" + yaml_path + "': key 'image' is missing");
  std::filesystem::path image_path(image->second);
  if (image_path.is_relative()) image_path = std::filesystem::path(yaml_path).parent_path() / image_path;
  const std::string image_name = image_path.string();
  return parseOccupancyMap(yaml, readFile(image_name, "map image"), yaml_path, image_name);
}

std::vector<Segment> mapSegments(const OccupancyMap& map, bool unknown_is_occupied) {
  std::vector<Segment> out;
  auto blocked = [&](int i, int j) { return map.blocked(i, j, unknown_is_occupied); };
  auto add = [&](double u0, double v0, double u1, double v1) {
    out.push_back(Segment{map.toMap(u0, v0), map.toMap(u1, v1)});
  };
  // Horizontal edges: on the line v = j between rows j - 1 and j, where exactly one side is blocked; runs of
  // consecutive cells with the same blocked side merge into one segment.
  for (int j = 0; j <= map.height; ++j) {
    int run_start = -1, run_side = 0;
    for (int i = 0; i <= map.width; ++i) {
      int side = 0;
      if (i < map.width) {
        const bool below = blocked(i, j - 1), above = blocked(i, j);
        side = below == above ? 0 : (below ? 1 : -1);
      }
      if (side != run_side) {
        if (run_side != 0) add(run_start, j, i, j);
        run_start = i;
        run_side = side;
      }
    }
  }
  // Vertical edges: on the line u = i between columns i - 1 and i.
  for (int i = 0; i <= map.width; ++i) {
    int run_start = -1, run_side = 0;
    for (int j = 0; j <= map.height; ++j) {
      int side = 0;
      if (j < map.height) {
        const bool left = blocked(i - 1, j), right = blocked(i, j);
        side = left == right ? 0 : (left ? 1 : -1);
      }
      if (side != run_side) {
        if (run_side != 0) add(i, run_start, i, j);
        run_start = j;
        run_side = side;
      }
    }
  }
  return out;
}

}  // namespace dqn_dovs
