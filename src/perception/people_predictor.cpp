#include "dqn_dovs/perception/people_predictor.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <numeric>
#include <optional>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {
namespace {

constexpr char kMagic[7] = {'D', 'Q', 'N', 'D', 'P', 'P', 'v'};

/// Reads the file's bytes in order; every shortfall is an error naming the file and the field.
class Reader {
 public:
  Reader(std::string path, std::vector<char> bytes) : path_(std::move(path)), bytes_(std::move(bytes)) {}
  uint32_t u32(const char* field) {
    uint32_t v = 0;
    take(&v, sizeof v, field);
    return v;
  }
  void floats(float* out, size_t n, const char* field) {
    take(out, n * sizeof(float), field);
    for (size_t k = 0; k < n; ++k) {
      if (!std::isfinite(out[k])) fail(std::string(field) + " holds a non-finite number");
    }
  }
  /// The file's version (the magic's last character).
  int magic() {
    char m[8];
    take(m, sizeof m, "magic");
    if (std::memcmp(m, kMagic, sizeof kMagic) != 0 || (m[7] != '1' && m[7] != '2'))
      fail("not a people predictor file (magic is not DQNDPPv2 or DQNDPPv1)");
    return m[7] - '0';
  }
  void end() const {
    if (at_ != bytes_.size()) fail(std::to_string(bytes_.size() - at_) + " bytes follow the last layer");
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw PeoplePredictorError("people predictor '" + path_ + "': " + why);
  }

 private:
  void take(void* out, size_t n, const char* field) {
    if (bytes_.size() - at_ < n) fail(std::string("truncated at ") + field);
    std::memcpy(out, bytes_.data() + at_, n);
    at_ += n;
  }
  std::string path_;
  std::vector<char> bytes_;
  size_t at_ = 0;
};

/// Coordinates of w in the frame whose x axis is the unit vector `along`.
Vec2 toFrame(const Vec2& along, const Vec2& w) {
  return {along.x() * w.x() + along.y() * w.y(), -along.y() * w.x() + along.x() * w.y()};
}
Vec2 fromFrame(const Vec2& along, const Vec2& f) {
  return {along.x() * f.x() - along.y() * f.y(), along.y() * f.x() + along.x() * f.y()};
}

/// Distance from o along the unit direction d to the first wall, `range` where none is nearer.
double firstWall(const Vec2& o, const Vec2& d, const std::vector<Segment>& walls, double range) {
  double best = range;
  for (const Segment& w : walls) {
    if (const std::optional<double> t = raySegment(o, d, w); t && *t < best) best = *t;
  }
  return best;
}

}  // namespace

ArcFitter::ArcFitter(size_t points, double step_s, double max_turn_rate_rps) {
  // Along an arc of turn rate w from heading th: p(t) - from = v R(th) h(w, t), h = (sin(wt) / w, (1 - cos(wt)) / w).
  const int steps = static_cast<int>(std::round(max_turn_rate_rps / 0.02));
  for (int n = -steps; n <= steps; ++n) {
    Shape shape;
    shape.turn_rate_rps = 0.02 * n;
    const double w = shape.turn_rate_rps;
    for (size_t k = 0; k < points; ++k) {
      const double t = step_s * static_cast<double>(k + 1);
      const Vec2 h = std::abs(w) < 1e-9 ? Vec2(t, 0.0) : Vec2(std::sin(w * t) / w, (1.0 - std::cos(w * t)) / w);
      shape.h.push_back(h);
      shape.hh += h.squaredNorm();
    }
    shapes_.push_back(std::move(shape));
  }
}

ArcMotion ArcFitter::fit(const Vec2& from, const std::vector<Vec2>& path) const {
  // As complex numbers d_k = v e^{i th} h_k: for a given w, z = sum conj(h_k) d_k gives th = arg z and
  // v = |z| / sum |h_k|^2, leaving sum |d_k|^2 - |z|^2 / sum |h_k|^2; the best w has the largest |z|^2 / sum |h_k|^2.
  ArcMotion best;
  double best_fit = -1.0;
  for (const Shape& shape : shapes_) {
    double zr = 0.0, zi = 0.0;
    for (size_t k = 0; k < path.size() && k < shape.h.size(); ++k) {
      const Vec2 d = path[k] - from;
      const Vec2& h = shape.h[k];
      zr += h.x() * d.x() + h.y() * d.y();
      zi += h.x() * d.y() - h.y() * d.x();
    }
    const double fit = shape.hh > 0.0 ? (zr * zr + zi * zi) / shape.hh : 0.0;
    if (fit > best_fit) {
      best_fit = fit;
      best.turn_rate_rps = shape.turn_rate_rps;
      best.heading_rad = std::atan2(zi, zr);
      best.speed_mps = shape.hh > 0.0 ? std::sqrt(zr * zr + zi * zi) / shape.hh : 0.0;
    }
  }
  return best;
}

ArcMotion fitArc(const Vec2& from, const std::vector<Vec2>& path, double step_s, double max_turn_rate_rps) {
  return ArcFitter(path.size(), step_s, max_turn_rate_rps).fit(from, path);
}

PeoplePredictor PeoplePredictor::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw PeoplePredictorError("people predictor '" + path + "': cannot be opened");
  Reader r(path, std::vector<char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()));
  PeoplePredictor p;
  p.version_ = r.magic();
  const uint32_t history = r.u32("history_steps"), future = r.u32("future_steps"), neighbours = r.u32("neighbours"),
                 step_ms = r.u32("step_ms");
  if (history < 1 || history > 50) r.fail("history_steps " + std::to_string(history) + " not in [1, 50]");
  if (future < 1 || future > 100) r.fail("future_steps " + std::to_string(future) + " not in [1, 100]");
  if (neighbours > 50) r.fail("neighbours " + std::to_string(neighbours) + " not in [0, 50]");
  if (step_ms < 10 || step_ms > 2000) r.fail("step_ms " + std::to_string(step_ms) + " not in [10, 2000]");
  p.history_steps_ = static_cast<int>(history);
  p.future_steps_ = static_cast<int>(future);
  p.neighbours_ = static_cast<int>(neighbours);
  p.step_s_ = 1e-3 * step_ms;
  const uint32_t count = r.u32("layer count");
  if (count < 1 || count > 16) r.fail("layer count " + std::to_string(count) + " not in [1, 16]");
  std::vector<std::pair<uint32_t, uint32_t>> shapes;
  uint32_t expected_inputs = static_cast<uint32_t>(p.inputSize());
  for (uint32_t k = 0; k < count; ++k) {
    const uint32_t outputs = r.u32("layer outputs"), inputs = r.u32("layer inputs");
    if (inputs != expected_inputs) {
      r.fail("layer " + std::to_string(k) + " takes " + std::to_string(inputs) + " inputs where " +
             std::to_string(expected_inputs) + " come");
    }
    if (outputs < 1 || outputs > 4096)
      r.fail("layer " + std::to_string(k) + " has " + std::to_string(outputs) + " outputs");
    shapes.emplace_back(outputs, inputs);
    expected_inputs = outputs;
  }
  if (expected_inputs != 2 * future) {
    r.fail("the last layer gives " + std::to_string(expected_inputs) + " outputs where future_steps needs " +
           std::to_string(2 * future));
  }
  p.mean_.resize(p.inputSize());
  p.scale_.resize(p.inputSize());
  r.floats(p.mean_.data(), p.mean_.size(), "input mean");
  r.floats(p.scale_.data(), p.scale_.size(), "input scale");
  if ((p.scale_.array() <= 0.0f).any()) r.fail("input scale holds a value <= 0");
  for (const auto& [outputs, inputs] : shapes) {
    Layer layer;
    Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> w(outputs, inputs);
    r.floats(w.data(), w.size(), "layer weights");
    layer.w = w;
    layer.b.resize(outputs);
    r.floats(layer.b.data(), layer.b.size(), "layer biases");
    p.layers_.push_back(std::move(layer));
  }
  r.end();
  return p;
}

void PeoplePredictor::frameOf(const std::vector<Vec2>& track, Vec2& velocity, Vec2& along) const {
  const Vec2& now = track.back();
  velocity = (now - track[track.size() - 2]) / step_s_;
  const double speed = velocity.norm();
  const Vec2 walked = now - track.front();
  if (speed > 1e-3) {
    along = velocity / speed;
  } else if (walked.norm() > 1e-6) {
    along = walked / walked.norm();
  } else {
    along = Vec2(1.0, 0.0);
  }
}

Eigen::VectorXf PeoplePredictor::features(const std::vector<std::vector<Vec2>>& tracks, size_t i,
                                          const std::vector<Segment>& walls) const {
  const size_t steps = static_cast<size_t>(history_steps_) + 1;
  for (const auto& t : tracks) {
    if (t.size() != steps) {
      throw PeoplePredictorError("people predictor: a track of " + std::to_string(t.size()) + " positions where " +
                                 std::to_string(steps) + " are needed");
    }
  }
  Eigen::VectorXf x(inputSize());
  int k = 0;
  Vec2 v, along;
  frameOf(tracks[i], v, along);
  const Vec2 now = tracks[i].back();
  for (size_t s = 0; s + 1 < steps; ++s) {
    const Vec2 f = toFrame(along, tracks[i][s] - now);
    x(k++) = static_cast<float>(f.x());
    x(k++) = static_cast<float>(f.y());
  }
  x(k++) = static_cast<float>(v.norm());
  std::vector<size_t> others;
  for (size_t j = 0; j < tracks.size(); ++j) {
    if (j != i) others.push_back(j);
  }
  std::stable_sort(others.begin(), others.end(), [&](size_t a, size_t b) {
    return (tracks[a].back() - now).norm() < (tracks[b].back() - now).norm();
  });
  for (int n = 0; n < neighbours_; ++n) {
    if (n < static_cast<int>(others.size())) {
      Vec2 vj, unused;
      frameOf(tracks[others[n]], vj, unused);
      const Vec2 rel = toFrame(along, tracks[others[n]].back() - now), dv = toFrame(along, vj - v);
      x.segment<5>(k) << static_cast<float>(rel.x()), static_cast<float>(rel.y()), static_cast<float>(dv.x()),
          static_cast<float>(dv.y()), 1.0f;
    } else {
      x.segment<5>(k) << 10.0f, 0.0f, 0.0f, 0.0f, 0.0f;
    }
    k += 5;
  }
  if (version_ == 1) {
    const Vec2 axes[4] = {{1.0, 0.0}, {-1.0, 0.0}, {0.0, 1.0}, {0.0, -1.0}};
    for (const Vec2& d : axes) {
      const Vec2 f = toFrame(along, firstWall(now, d, walls, 10.0) * d);
      x(k++) = static_cast<float>(f.x());
      x(k++) = static_cast<float>(f.y());
    }
  } else {
    for (int r = 0; r < 8; ++r) {
      const Vec2 d = fromFrame(along, Vec2(std::cos(r * M_PI / 4.0), std::sin(r * M_PI / 4.0)));
      x(k++) = static_cast<float>(firstWall(now, d, walls, kWallRayRange_m));
    }
  }
  return x;
}

std::vector<Vec2> PeoplePredictor::predict(const std::vector<std::vector<Vec2>>& tracks, size_t i,
                                           const std::vector<Segment>& walls) const {
  Eigen::VectorXf a = (features(tracks, i, walls) - mean_).cwiseQuotient(scale_);
  for (size_t l = 0; l < layers_.size(); ++l) {
    Eigen::VectorXf z = layers_[l].w * a + layers_[l].b;
    a = l + 1 < layers_.size() ? Eigen::VectorXf(z.cwiseMax(0.0f)) : z;
  }
  Vec2 v, along;
  frameOf(tracks[i], v, along);
  const Vec2 vf = toFrame(along, v);
  std::vector<Vec2> out;
  for (int s = 0; s < future_steps_; ++s) {
    const double ahead = step_s_ * (s + 1);
    const Vec2 f(vf.x() * ahead + a(2 * s), vf.y() * ahead + a(2 * s + 1));
    out.push_back(tracks[i].back() + fromFrame(along, f));
  }
  return out;
}

PredictedArcs::PredictedArcs(std::shared_ptr<const PeoplePredictor> predictor)
    : predictor_(predictor ? std::move(predictor) : throw PeoplePredictorError("predicted arcs: no predictor")),
      fitter_(static_cast<size_t>(predictor_->futureSteps()), predictor_->stepSeconds()) {}

void PredictedArcs::reset() {
  history_.clear();
  last_stamp_s_ = -1.0;
}

std::vector<std::vector<Vec2>> PredictedArcs::predictPaths(const std::vector<MovingObstacle>& obstacles,
                                                           const std::vector<int>& ids, double stamp_s,
                                                           const std::vector<Segment>& walls) {
  if (ids.size() != obstacles.size()) {
    throw PeoplePredictorError("predicted arcs: " + std::to_string(ids.size()) + " ids for " +
                               std::to_string(obstacles.size()) + " obstacles");
  }
  if (!std::isfinite(stamp_s)) throw PeoplePredictorError("predicted arcs: the stamp is not finite");
  if (stamp_s < last_stamp_s_) reset();  // time went backwards (a replayed bag, a restarted clock): start afresh
  const int steps = predictor_->historySteps() + 1;
  const double step = predictor_->stepSeconds();
  const double oldest_needed = stamp_s - step * static_cast<double>(steps);
  last_stamp_s_ = stamp_s;
  std::vector<size_t> moving;
  std::map<int, std::deque<std::pair<double, Vec2>>> seen;
  for (size_t k = 0; k < obstacles.size(); ++k) {
    if (obstacles[k].is_static) continue;
    moving.push_back(k);
    std::deque<std::pair<double, Vec2>> h;
    if (const auto it = history_.find(ids[k]); it != history_.end()) h = std::move(it->second);
    if (!h.empty() && h.back().first == stamp_s) h.pop_back();  // a second call at the same stamp replaces it
    h.emplace_back(stamp_s, obstacles[k].center);
    while (h.size() > 1 && h[1].first <= oldest_needed) h.pop_front();  // keep one entry before the oldest needed
    seen[ids[k]] = std::move(h);
  }
  history_ = std::move(seen);  // an id not seen at this call starts afresh
  constexpr double kSameStamp_s = 1e-6;
  std::vector<std::vector<Vec2>> tracks;
  for (const size_t k : moving) {
    const MovingObstacle& o = obstacles[k];
    const std::deque<std::pair<double, Vec2>>& h = history_[ids[k]];
    const Vec2 velocity = o.speed * Vec2(std::cos(o.heading), std::sin(o.heading));
    std::vector<Vec2> track;
    size_t j = 0;  // h[j] is the first entry at or after the time wanted (the times wanted rise)
    for (int back = steps - 1; back >= 0; --back) {
      const double at = stamp_s - step * static_cast<double>(back);
      while (j + 1 < h.size() && h[j].first < at - kSameStamp_s) ++j;
      if (std::abs(h[j].first - at) <= kSameStamp_s) {
        track.push_back(h[j].second);  // seen at that time (every call a step apart: always)
      } else if (j > 0 && h[j - 1].first < at && at < h[j].first) {
        const double f = (at - h[j - 1].first) / (h[j].first - h[j - 1].first);
        track.push_back(h[j - 1].second + f * (h[j].second - h[j - 1].second));  // between two calls
      } else {
        track.push_back(o.center - static_cast<double>(back) * step * velocity);  // before its first call
      }
    }
    tracks.push_back(std::move(track));
  }
  std::vector<std::vector<Vec2>> paths(obstacles.size());
  for (size_t m = 0; m < moving.size(); ++m) paths[moving[m]] = predictor_->predict(tracks, m, walls);
  return paths;
}

void PredictedArcs::apply(std::vector<MovingObstacle>& obstacles, const std::vector<int>& ids, double stamp_s,
                          const std::vector<Segment>& walls) {
  const std::vector<std::vector<Vec2>> paths = predictPaths(obstacles, ids, stamp_s, walls);
  for (size_t k = 0; k < obstacles.size(); ++k) {
    if (paths[k].empty()) continue;
    const ArcMotion a = fitter_.fit(obstacles[k].center, paths[k]);
    obstacles[k].heading = a.heading_rad;
    obstacles[k].speed = a.speed_mps;
    obstacles[k].turn_rate = a.turn_rate_rps;
  }
}

}  // namespace dqn_dovs
