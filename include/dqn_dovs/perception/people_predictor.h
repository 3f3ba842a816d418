// A learned prediction of where walking people will be over the next seconds, from what can be seen of them now:
// each one's last second of positions, its nearest neighbours' positions and velocities, and the walls around it. A
// small multilayer perceptron (trained by python/dqn_dovs_py/people_predictor.py on generated worlds, file format
// below) adds its correction to a constant-velocity extrapolation. Used by the oracle's diagnostic
// (OracleConfig::learned_prediction, docs/planners.md "What the prediction costs") and by the planners' predicted
// arcs (PredictedArcs).
//
// File (little-endian): 8 bytes "DQNDPPv2" (or "DQNDPPv1"); uint32 history_steps, future_steps, neighbours, step_ms;
// uint32 layer count L; per layer uint32 outputs and inputs; then float32 input mean[inputs], input scale[inputs];
// then per layer the weights (outputs x inputs, row-major) and the biases. Nothing may follow. Hidden layers use ReLU.
// The versions differ in the last 8 inputs, the walls (any static segments: a room's, a building's, a map's):
//   v2: the distance to the first wall along 8 rays from the person, every 45 deg from its direction of motion,
//       kWallRayRange_m where none is nearer (any world);
//   v1: the offset to the first wall along the fixed frame's +x, -x, +y, -y axes, in the person's frame (learned in
//       the square room, whose walls are all it knows).
#pragma once

#include <Eigen/Dense>
#include <deque>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dqn_dovs/common/types.h"

namespace dqn_dovs {

/// A predictor file that cannot be used; the message names the file and the reason.
class PeoplePredictorError : public std::runtime_error {
 public:
  explicit PeoplePredictorError(const std::string& what) : std::runtime_error(what) {}
};

/// A unicycle motion: heading (rad), speed (m/s), turn rate (rad/s).
struct ArcMotion {
  double heading_rad = 0.0, speed_mps = 0.0, turn_rate_rps = 0.0;
};

/// The constant (speed, turn rate) motion from `from` that comes closest (least squares) to `path`, whose k-th point
/// is (k + 1) * step_s ahead: what a velocity space of arcs can take from a predicted path. Turn rates within
/// +-max_turn_rate_rps, searched in steps of 0.02 rad/s; for each, heading and speed in closed form.
ArcMotion fitArc(const Vec2& from, const std::vector<Vec2>& path, double step_s, double max_turn_rate_rps = 1.5);

/// fitArc for many paths of `points` points: the arcs' unit shapes are computed once (what PredictedArcs runs).
class ArcFitter {
 public:
  ArcFitter(size_t points, double step_s, double max_turn_rate_rps = 1.5);
  /// fitArc(from, path, step_s, max_turn_rate_rps); path must hold `points` points.
  ArcMotion fit(const Vec2& from, const std::vector<Vec2>& path) const;

 private:
  struct Shape {
    double turn_rate_rps = 0.0, hh = 0.0;
    std::vector<Vec2> h;  ///< per point: (sin(wt) / w, (1 - cos(wt)) / w), or (t, 0) for w = 0
  };
  std::vector<Shape> shapes_;
};

class PeoplePredictor {
 public:
  /// The reach of a v2 file's wall rays (m).
  static constexpr double kWallRayRange_m = 5.0;

  /// Throws PeoplePredictorError naming `path` and what is wrong (missing, bad magic, shapes, truncated, trailing
  /// bytes, non-finite numbers).
  static PeoplePredictor load(const std::string& path);

  /// The file's layout: 1 or 2 (the wall inputs, above).
  int version() const { return version_; }
  int historySteps() const { return history_steps_; }
  int futureSteps() const { return future_steps_; }
  int neighbours() const { return neighbours_; }
  double stepSeconds() const { return step_s_; }
  /// Length of the input vector: 2 per history step, the speed, 5 per neighbour, 8 for the walls.
  int inputSize() const { return 2 * history_steps_ + 1 + 5 * neighbours_ + 8; }

  /// The input of person i. tracks[k] holds person k's positions at steps t - historySteps() .. t, oldest first,
  /// stepSeconds() apart; walls: the static segments around, in the same frame.
  Eigen::VectorXf features(const std::vector<std::vector<Vec2>>& tracks, size_t i,
                           const std::vector<Segment>& walls) const;
  /// Person i's positions at steps t + 1 .. t + futureSteps() (the tracks' frame).
  std::vector<Vec2> predict(const std::vector<std::vector<Vec2>>& tracks, size_t i,
                            const std::vector<Segment>& walls) const;

 private:
  struct Layer {
    Eigen::MatrixXf w;
    Eigen::VectorXf b;
  };
  /// The frame of person i: x along its motion (its last step, else its last second), y to its left.
  void frameOf(const std::vector<Vec2>& track, Vec2& velocity, Vec2& along) const;

  int version_ = 2, history_steps_ = 0, future_steps_ = 0, neighbours_ = 0;
  double step_s_ = 0.0;
  Eigen::VectorXf mean_, scale_;
  std::vector<Layer> layers_;
};

/// Gives the planners the learned prediction as the arcs their velocity space takes: remembers the positions of the
/// moving obstacles at the last calls by id and stamp, and replaces each one's (speed, heading, turn rate) with the arc
/// that fits its predicted path (fitArc). Calls may come at any rate (a decision every control period, a tracker's
/// every scan): the history the predictor takes, PeoplePredictor::stepSeconds() apart, is read from the positions
/// seen at those times, interpolated between two calls, and walked back at the present velocity before the first
/// call that saw the obstacle. An id missing from a call starts afresh; a stamp earlier than the last forgets all.
class PredictedArcs {
 public:
  explicit PredictedArcs(std::shared_ptr<const PeoplePredictor> predictor);
  void reset();
  /// obstacles[k] carries id ids[k] (stable across decisions); those not is_static get the fitted arc. A second call
  /// at the same stamp_s does not add to the history. walls: the static segments, in the obstacles' frame.
  void apply(std::vector<MovingObstacle>& obstacles, const std::vector<int>& ids, double stamp_s,
             const std::vector<Segment>& walls);
  /// The predicted positions (futureSteps() of them, stepSeconds() apart) of every obstacle not is_static, empty for
  /// the others; it keeps the history as apply() does (apply is this, then fitArc). The oracle's learned prediction.
  std::vector<std::vector<Vec2>> predictPaths(const std::vector<MovingObstacle>& obstacles, const std::vector<int>& ids,
                                              double stamp_s, const std::vector<Segment>& walls);
  const PeoplePredictor& predictor() const { return *predictor_; }

 private:
  std::shared_ptr<const PeoplePredictor> predictor_;
  ArcFitter fitter_;
  std::map<int, std::deque<std::pair<double, Vec2>>> history_;  ///< by id: (stamp, position), oldest first
  double last_stamp_s_ = -1.0;
};

}  // namespace dqn_dovs
