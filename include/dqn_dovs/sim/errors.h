// Exceptions of the simulator. Every message is complete on its own: it names the file, parameter or
// argument concerned and the reason.
#pragma once

#include <stdexcept>

namespace dqn_dovs::sim {

/// Base of every simulator error.
class SimError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A simulator component was given an inconsistent configuration or argument; the message names the field.
class SimConfigError : public SimError {
 public:
  using SimError::SimError;
};

/// A scenario file could not be read or written, or a scenario is inconsistent.
/// The message names the file or scenario and the reason.
class ScenarioError : public SimError {
 public:
  using SimError::SimError;
};

}  // namespace dqn_dovs::sim
