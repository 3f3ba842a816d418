// The planner factory and the shared fallback command.
#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>

#include "dqn_dovs/planner.h"
#include "dqn_dovs/planners/dqn_dovs_planner.h"
#include "dqn_dovs/planners/dwa.h"
#include "dqn_dovs/planners/orca.h"
#include "dqn_dovs/planners/s_dovs.h"

namespace dqn_dovs {

namespace {

using PlannerFactory = std::function<std::unique_ptr<Planner>(const std::string& model_path)>;

/// Every planner the project builds by name, in the order plannerNames() lists them. A new planner is added
/// here with one line: its name and a factory taking the model path (ignored by planners without a model).
const std::vector<std::pair<std::string, PlannerFactory>>& registry() {
  static const std::vector<std::pair<std::string, PlannerFactory>> planners = {
      {"dqn_dovs",
       [](const std::string& model_path) -> std::unique_ptr<Planner> {
         DqnDovsConfig config;
         if (!model_path.empty()) config.model_path = model_path;
         return std::make_unique<DqnDovsPlanner>(config);
       }},
      {"dqn_dovs_unshielded",
       [](const std::string& model_path) -> std::unique_ptr<Planner> {
         DqnDovsConfig config;
         if (!model_path.empty()) config.model_path = model_path;
         config.shield.enabled = false;
         return std::make_unique<DqnDovsPlanner>(config);
       }},
      {"dqn_dovs_no_escape",
       [](const std::string& model_path) -> std::unique_ptr<Planner> {
         DqnDovsConfig config;
         if (!model_path.empty()) config.model_path = model_path;
         config.shield.escape_enabled = false;
         return std::make_unique<DqnDovsPlanner>(config);
       }},
      {"dqn_dovs_latest_escape",
       [](const std::string& model_path) -> std::unique_ptr<Planner> {
         // The previous release: no static braking rule, the escape puts the first contact off longest.
         DqnDovsConfig config;
         if (!model_path.empty()) config.model_path = model_path;
         config.shield.statics.enabled = false;
         config.shield.passive_escape = false;
         return std::make_unique<DqnDovsPlanner>(config);
       }},
      {"s_dovs", [](const std::string&) -> std::unique_ptr<Planner> { return std::make_unique<SDovsPlanner>(); }},
      {"s_dovs_unguarded",
       [](const std::string&) -> std::unique_ptr<Planner> {
         SDovsConfig config;
         config.statics.enabled = false;  // the previous release, without the static braking rule
         return std::make_unique<SDovsPlanner>(config);
       }},
      {"orca_holonomic", [](const std::string&) { return makeOrcaHolonomicPlanner(); }},
      {"orca_diffdrive", [](const std::string&) { return makeOrcaDiffDrivePlanner(); }},
      {"dwa", [](const std::string&) { return makeDwaPlanner(); }},
  };
  return planners;
}

}  // namespace

std::unique_ptr<Planner> makePlanner(const std::string& name, const std::string& model_path) {
  for (const auto& [known, factory] : registry()) {
    if (known == name) return factory(model_path);
  }
  std::string list;
  for (const std::string& n : plannerNames()) list += (list.empty() ? "" : ", ") + n;
  throw PlannerError("unknown planner '" + name + "' (known planners: " + list + ")");
}

std::vector<std::string> plannerNames() {
  std::vector<std::string> names;
  for (const auto& entry : registry()) names.push_back(entry.first);
  return names;
}

Twist2 decelerationCommand(const Twist2& current, const RobotLimits& limits) {
  Twist2 c = current;
  if (!std::isfinite(c.v) || !std::isfinite(c.w)) return Twist2{0.0, 0.0};
  c = limits.clipToFeasible(c);
  // Speed first: it is what carries the robot into things. The bottom corner of the window lowers v by dv;
  // when less than dv of speed is left, the rest of the window's budget stops the turning (toward w = 0).
  // The result stays inside the rhombus, so a caller that clips to the window keeps it as it is.
  Twist2 out;
  const double dv = limits.dv(), dw = limits.dw();
  const double dv_used = std::min(c.v, dv);
  out.v = c.v - dv_used;
  const double dw_budget = dw * (1.0 - dv_used / dv);
  out.w = std::abs(c.w) <= dw_budget ? 0.0 : c.w - std::copysign(dw_budget, c.w);
  return limits.clipToFeasible(out);
}

}  // namespace dqn_dovs
