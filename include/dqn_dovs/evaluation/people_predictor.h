// A learned prediction of where walking people will be over the next seconds, from what can be seen of them now:
// each one's last second of positions, its nearest neighbours' positions and velocities, and the room's walls. A
// small multilayer perceptron (trained by python/dqn_dovs_py/people_predictor.py on generated crowds, file format
// below) adds its correction to a constant-velocity extrapolation. Used by the oracle's diagnostic
// (OracleConfig::learned_prediction, docs/planners.md "What the prediction costs").
//
// File (little-endian): 8 bytes "DQNDPPv1"; uint32 history_steps, future_steps, neighbours, step_ms; uint32 layer
// count L; per layer uint32 outputs and inputs; then float32 input mean[inputs], input scale[inputs]; then per layer
// the weights (outputs x inputs, row-major) and the biases. Nothing may follow. Hidden layers use ReLU.
#pragma once

#include <Eigen/Dense>
#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/common/types.h"

namespace dqn_dovs {

/// A predictor file that cannot be used; the message names the file and the reason.
class PeoplePredictorError : public std::runtime_error {
 public:
  explicit PeoplePredictorError(const std::string& what) : std::runtime_error(what) {}
};

class PeoplePredictor {
 public:
  /// Throws PeoplePredictorError naming `path` and what is wrong (missing, bad magic, shapes, truncated, trailing
  /// bytes, non-finite numbers).
  static PeoplePredictor load(const std::string& path);

  int historySteps() const { return history_steps_; }
  int futureSteps() const { return future_steps_; }
  int neighbours() const { return neighbours_; }
  double stepSeconds() const { return step_s_; }
  /// Length of the input vector: 2 per history step, the speed, 5 per neighbour, 8 for the four walls.
  int inputSize() const { return 2 * history_steps_ + 1 + 5 * neighbours_ + 8; }

  /// The input of person i. tracks[k] holds person k's positions at steps t - historySteps() .. t, oldest first,
  /// stepSeconds() apart; room_half_size_m: the walls at x, y = +-h.
  Eigen::VectorXf features(const std::vector<std::vector<Vec2>>& tracks, size_t i, double room_half_size_m) const;
  /// Person i's positions at steps t + 1 .. t + futureSteps() (fixed frame).
  std::vector<Vec2> predict(const std::vector<std::vector<Vec2>>& tracks, size_t i, double room_half_size_m) const;

 private:
  struct Layer {
    Eigen::MatrixXf w;
    Eigen::VectorXf b;
  };
  /// The frame of person i: x along its motion (its last step, else its last second), y to its left.
  void frameOf(const std::vector<Vec2>& track, Vec2& velocity, Vec2& along) const;

  int history_steps_ = 0, future_steps_ = 0, neighbours_ = 0;
  double step_s_ = 0.0;
  Eigen::VectorXf mean_, scale_;
  std::vector<Layer> layers_;
};

}  // namespace dqn_dovs
