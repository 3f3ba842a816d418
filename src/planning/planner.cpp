// The planner factory and the shared fallback command.
#include "dqn_dovs/planning/planner.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>

#include "dqn_dovs/planning/dqn_dovs_planner.h"
#include "dqn_dovs/planning/dwa.h"
#include "dqn_dovs/planning/orca.h"
#include "dqn_dovs/planning/s_dovs.h"

namespace dqn_dovs {

namespace {

/// A planner's factory: the model path (ignored by planners without a model) and the DQN-DOVS planners' base
/// configuration (its model path and shield already set).
using PlannerFactory = std::function<std::unique_ptr<Planner>(DqnDovsConfig config)>;

/// Every planner the project builds by name, in the order plannerNames() lists them. A new planner is added
/// here with one line: its name and its factory.
const std::vector<std::pair<std::string, PlannerFactory>>& registry() {
  static const std::vector<std::pair<std::string, PlannerFactory>> planners = {
      {"dqn_dovs", [](DqnDovsConfig c) -> std::unique_ptr<Planner> { return std::make_unique<DqnDovsPlanner>(c); }},
      {"dqn_dovs_unshielded",
       [](DqnDovsConfig c) -> std::unique_ptr<Planner> {
         c.shield.enabled = false;
         return std::make_unique<DqnDovsPlanner>(c);
       }},
      {"dqn_dovs_no_escape",
       [](DqnDovsConfig c) -> std::unique_ptr<Planner> {
         c.shield.escape_enabled = false;
         return std::make_unique<DqnDovsPlanner>(c);
       }},
      {"dqn_dovs_latest_escape",
       [](DqnDovsConfig c) -> std::unique_ptr<Planner> {
         // The previous release: no static braking rule, the escape puts the first contact off longest.
         c.shield.statics.enabled = false;
         c.shield.passive_escape = false;
         return std::make_unique<DqnDovsPlanner>(c);
       }},
      {"s_dovs", [](const DqnDovsConfig&) -> std::unique_ptr<Planner> { return std::make_unique<SDovsPlanner>(); }},
      {"s_dovs_unguarded",
       [](const DqnDovsConfig&) -> std::unique_ptr<Planner> {
         SDovsConfig config;
         config.statics.enabled = false;  // the previous release, without the static braking rule
         return std::make_unique<SDovsPlanner>(config);
       }},
      {"orca_holonomic", [](const DqnDovsConfig&) { return makeOrcaHolonomicPlanner(); }},
      {"orca_diffdrive", [](const DqnDovsConfig&) { return makeOrcaDiffDrivePlanner(); }},
      {"dwa", [](const DqnDovsConfig&) { return makeDwaPlanner(); }},
  };
  return planners;
}

}  // namespace

std::unique_ptr<Planner> makePlanner(const std::string& name, const std::string& model_path,
                                     const ActionShieldConfig* shield, const StateNormalization* normalization) {
  DqnDovsConfig config;
  if (!model_path.empty()) config.model_path = model_path;
  if (shield != nullptr) config.shield = *shield;
  if (normalization != nullptr) config.normalization = *normalization;
  for (const auto& [known, factory] : registry()) {
    if (known == name) return factory(config);
  }
  std::string list;
  for (const std::string& n : plannerNames()) list += (list.empty() ? "" : ", ") + n;
  throw PlannerError("unknown planner '" + name + "' (known planners: " + list + ")");
}

const std::vector<std::string>& robotPlannerNames() {
  static const std::vector<std::string> names = {"dqn_dovs", "s_dovs", "dwa", "orca_diffdrive"};
  return names;
}

std::string robotPlannerFault(const std::string& name) {
  for (const std::string& n : robotPlannerNames())
    if (n == name) return {};
  std::string list;
  for (const std::string& n : robotPlannerNames()) list += (list.empty() ? "" : ", ") + n;
  return "planner '" + name + "' cannot run on the robot (the robot's planners: " + list + ")";
}

std::vector<std::string> plannerNames() {
  std::vector<std::string> names;
  for (const auto& entry : registry()) names.push_back(entry.first);
  return names;
}

}  // namespace dqn_dovs
