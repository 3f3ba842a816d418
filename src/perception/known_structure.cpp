#include "dqn_dovs/perception/known_structure.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace dqn_dovs {

namespace {

bool finite(const Vec2& p) { return std::isfinite(p.x()) && std::isfinite(p.y()); }

[[noreturn]] void refuse(const std::string& what) { throw std::invalid_argument("known structure: " + what); }

}  // namespace

KnownStructure::KnownStructure(const std::vector<Segment>& walls, const std::vector<Circle>& furniture,
                               double tolerance_m, double cell_m)
    : tolerance_m_(tolerance_m), cell_m_(cell_m) {
  if (!(std::isfinite(tolerance_m) && tolerance_m >= 0.0)) {
    refuse("tolerance " + std::to_string(tolerance_m) + " m must be finite and >= 0");
  }
  if (!(std::isfinite(cell_m) && cell_m > 0.0)) refuse("cell " + std::to_string(cell_m) + " m must be finite and > 0");
  Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity());
  Vec2 hi = -lo;
  for (const Segment& w : walls) {
    if (!finite(w.a) || !finite(w.b)) refuse("a wall has a non-finite end");
    lo = lo.cwiseMin(w.a).cwiseMin(w.b);
    hi = hi.cwiseMax(w.a).cwiseMax(w.b);
  }
  for (const Circle& c : furniture) {
    if (!finite(c.center) || !(std::isfinite(c.radius) && c.radius >= 0.0)) {
      refuse("a piece of furniture has a non-finite centre or a negative radius");
    }
    lo = lo.cwiseMin(c.center - Vec2::Constant(c.radius));
    hi = hi.cwiseMax(c.center + Vec2::Constant(c.radius));
  }
  if (walls.empty() && furniture.empty()) return;
  origin_ = lo - Vec2::Constant(tolerance_m + cell_m);
  const Vec2 size = (hi + Vec2::Constant(tolerance_m + cell_m) - origin_) / cell_m;
  if (!(size.x() * size.y() <= static_cast<double>(kMaxCells))) {
    std::ostringstream os;
    os << "a map of " << (hi - lo).x() << " x " << (hi - lo).y() << " m at " << cell_m << " m cells is more than "
       << kMaxCells << " cells";
    refuse(os.str());
  }
  width_ = static_cast<int64_t>(std::ceil(size.x())) + 1;
  height_ = static_cast<int64_t>(std::ceil(size.y())) + 1;
  cells_.assign(static_cast<size_t>(width_ * height_), 0);

  // A cell is structure when its centre is within the tolerance of a wall or of a disc.
  auto mark = [&](const Vec2& box_lo, const Vec2& box_hi, auto&& near) {
    const int64_t i0 = std::max<int64_t>(0, static_cast<int64_t>(std::floor((box_lo.x() - origin_.x()) / cell_m_)));
    const int64_t j0 = std::max<int64_t>(0, static_cast<int64_t>(std::floor((box_lo.y() - origin_.y()) / cell_m_)));
    const int64_t i1 = std::min(width_ - 1, static_cast<int64_t>(std::floor((box_hi.x() - origin_.x()) / cell_m_)));
    const int64_t j1 = std::min(height_ - 1, static_cast<int64_t>(std::floor((box_hi.y() - origin_.y()) / cell_m_)));
    for (int64_t j = j0; j <= j1; ++j) {
      for (int64_t i = i0; i <= i1; ++i) {
        uint8_t& c = cells_[static_cast<size_t>(j * width_ + i)];
        if (c != 0) continue;
        const Vec2 centre =
            origin_ + Vec2((static_cast<double>(i) + 0.5) * cell_m_, (static_cast<double>(j) + 0.5) * cell_m_);
        if (near(centre)) {
          c = 1;
          ++occupied_;
        }
      }
    }
  };
  const Vec2 reach = Vec2::Constant(tolerance_m + cell_m);
  for (const Segment& w : walls) {
    mark(w.a.cwiseMin(w.b) - reach, w.a.cwiseMax(w.b) + reach,
         [&](const Vec2& p) { return pointSegmentDistance(p, w) <= tolerance_m_; });
  }
  for (const Circle& c : furniture) {
    const Vec2 r = Vec2::Constant(c.radius) + reach;
    mark(c.center - r, c.center + r, [&](const Vec2& p) { return (p - c.center).norm() <= c.radius + tolerance_m_; });
  }
}

bool KnownStructure::cell(const Vec2& p, int64_t& index) const {
  if (!finite(p) || cells_.empty()) return false;
  const double u = std::floor((p.x() - origin_.x()) / cell_m_);
  const double v = std::floor((p.y() - origin_.y()) / cell_m_);
  if (u < 0.0 || v < 0.0 || u >= static_cast<double>(width_) || v >= static_cast<double>(height_)) return false;
  index = static_cast<int64_t>(v) * width_ + static_cast<int64_t>(u);
  return true;
}

bool KnownStructure::contains(const Vec2& p) const {
  int64_t index = 0;
  return cell(p, index) && cells_[static_cast<size_t>(index)] != 0;
}

double KnownStructure::fraction(const std::vector<Vec2>& points, const Pose2& fixed_in_map) const {
  if (points.empty() || empty()) return 0.0;
  const auto on =
      std::count_if(points.begin(), points.end(), [&](const Vec2& p) { return contains(fixed_in_map.toWorld(p)); });
  return static_cast<double>(on) / static_cast<double>(points.size());
}

}  // namespace dqn_dovs
