#include "dqn_dovs/perception/static_map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace dqn_dovs {

StaticMap::StaticMap(double cell_m, double memory_s) : cell_m_(cell_m), memory_s_(memory_s) {
  if (!(std::isfinite(cell_m) && cell_m > 0.0) || !(std::isfinite(memory_s) && memory_s > 0.0)) {
    std::ostringstream os;
    os << "static map: cell size " << cell_m << " m and memory " << memory_s << " s must both be finite and > 0";
    throw std::invalid_argument(os.str());
  }
}

bool StaticMap::key(const Vec2& p, int64_t& out) const {
  // 32 bits per axis: cells of 1 cm cover +-21,000 km, far beyond any fixed frame a robot drives in. Points
  // beyond (or non-finite ones, which a bad scan can produce) have no cell.
  constexpr double kLimit = 2.0e9;
  const double fx = std::floor(p.x() / cell_m_), fy = std::floor(p.y() / cell_m_);
  if (!(std::abs(fx) < kLimit && std::abs(fy) < kLimit)) return false;
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  out = static_cast<int64_t>((static_cast<uint64_t>(ix) << 32) ^ (static_cast<uint64_t>(iy) & 0xffffffffULL));
  return true;
}

template <typename Visit>
void StaticMap::rasterise(const Segment& segment, Visit visit) {
  const Vec2 d = segment.b - segment.a;
  const double length = d.norm();
  // Walls longer than a building are not walls (a corrupt scan); they teach nothing.
  if (!std::isfinite(length) || length > kMaxSegment_m) return;
  // Steps of a quarter cell never jump over a cell the segment crosses by more than a corner.
  const int steps = std::max(1, static_cast<int>(std::ceil(length / (0.25 * cell_m_))));
  int64_t previous = 0;
  for (int i = 0; i <= steps; ++i) {
    int64_t k = 0;
    if (!key(segment.a + d * (static_cast<double>(i) / steps), k)) continue;
    if (i > 0 && k == previous) continue;
    previous = k;
    visit(cells_[k]);
  }
}

void StaticMap::addSegment(const Segment& segment, double stamp_s) {
  rasterise(segment, [&](Cell& c) {
    if (c.scans > 0 && c.last_s == stamp_s) return;  // one count per scan
    c.scans = std::min(c.scans + 1, 1 << 20);
    c.last_s = stamp_s;
  });
}

void StaticMap::addPermanentSegment(const Segment& segment) {
  rasterise(segment, [](Cell& c) { c.permanent = true; });
}

bool StaticMap::isStructure(const Vec2& p, int min_scans) const {
  int64_t k = 0;
  if (!key(p, k)) return false;
  const auto it = cells_.find(k);
  return it != cells_.end() && (it->second.permanent || it->second.scans >= min_scans);
}

double StaticMap::structureFraction(const std::vector<Vec2>& points, int min_scans) const {
  if (points.empty() || cells_.empty()) return 0.0;
  const auto on = std::count_if(points.begin(), points.end(), [&](const Vec2& p) { return isStructure(p, min_scans); });
  return static_cast<double>(on) / static_cast<double>(points.size());
}

void StaticMap::expire(double stamp_s) {
  // A sweep of every cell, at most every thirtieth of the memory (a cell may outlive it by that much): the tracker
  // asks every scan, and the map holds thousands of cells in a building.
  if (std::abs(stamp_s - last_sweep_s_) < memory_s_ / 30.0) return;
  last_sweep_s_ = stamp_s;
  for (auto it = cells_.begin(); it != cells_.end();) {
    const bool old = !it->second.permanent && stamp_s - it->second.last_s > memory_s_;
    it = old ? cells_.erase(it) : std::next(it);
  }
}

void StaticMap::clear() {
  cells_.clear();
  last_sweep_s_ = -std::numeric_limits<double>::infinity();
}

}  // namespace dqn_dovs
