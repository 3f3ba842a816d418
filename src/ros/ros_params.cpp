#include "ros_params.h"

#include <algorithm>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <vector>

namespace dqn_dovs {

double paramInRange(const ros::NodeHandle& pnh, const std::string& name, double fallback, double lo, double hi) {
  const double value = param<double>(pnh, name, fallback);
  if (value < lo || value > hi) {
    std::ostringstream os;
    os << "parameter '" << pnh.resolveName(name) << "' = " << value << " is outside [" << lo << ", " << hi << "]";
    throw ParameterError(os.str());
  }
  return value;
}

RobotLimits loadRobotLimits(const ros::NodeHandle& pnh) {
  RobotLimits limits;
  limits.v_max = param<double>(pnh, "robot/v_max", limits.v_max);
  limits.w_max = param<double>(pnh, "robot/w_max", limits.w_max);
  limits.a_v = param<double>(pnh, "robot/a_v", limits.a_v);
  limits.a_w = param<double>(pnh, "robot/a_w", limits.a_w);
  limits.dt = param<double>(pnh, "robot/dt", limits.dt);
  limits.radius = param<double>(pnh, "robot/radius", limits.radius);
  const std::string error = limits.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("robot") + ": " + error);
  return limits;
}

}  // namespace dqn_dovs

#include "robot_description.h"

namespace dqn_dovs {

std::string robotRadiusMismatch(double configured_m, double described_m) {
  if (std::abs(described_m - configured_m) <= 1e-3) return {};
  std::ostringstream os;
  os.precision(4);
  if (described_m > configured_m) {
    os << "the robot description's footprint (radius " << described_m
       << " m) is larger than the configured robot/radius " << configured_m
       << " m: planning for a smaller robot than the real one is unsafe; set robot/radius to " << described_m
       << " (and use a model trained for it)";
  } else {
    os << "the configured robot/radius " << configured_m << " m is larger than the robot description's footprint ("
       << described_m << " m): safe, the robot keeps " << configured_m - described_m
       << " m more clearance than it needs; set robot/radius to " << described_m
       << " (with a model trained for it) to use the description's";
  }
  return os.str();
}

std::optional<RobotGeometry> loadRobotDescription(const ros::NodeHandle& nh, const RobotLimits& limits,
                                                  const std::string& base_frame, const std::string& laser_frame) {
  std::string xml;
  if (!nh.getParam("robot_description", xml)) return std::nullopt;
  RobotGeometry g;
  try {
    g = readRobotGeometry(xml, base_frame, laser_frame);
  } catch (const RobotDescriptionError& e) {
    throw ParameterError(std::string("robot_description: ") + e.what());
  }
  const std::string what = robotRadiusMismatch(limits.radius, g.radius_m);
  if (!what.empty()) {
    if (g.radius_m > limits.radius) throw ParameterError(what);
    ROS_WARN("%s: %s", nh.resolveName("robot_description").c_str(), what.c_str());
  }
  return g;
}

bool checkRobotDescription(const ros::NodeHandle& nh, const RobotLimits& limits, const std::string& base_frame,
                           const std::string& laser_frame) {
  return loadRobotDescription(nh, limits, base_frame, laser_frame).has_value();
}

namespace {

std::mutex& ledgerMutex() {
  static std::mutex m;
  return m;
}

// Resolved names of every parameter read, by the namespace of the handle that read it.
std::map<std::string, std::set<std::string>>& ledger() {
  static std::map<std::string, std::set<std::string>> read;
  return read;
}

size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace

void noteParameter(const ros::NodeHandle& pnh, const std::string& name) {
  const std::lock_guard<std::mutex> lock(ledgerMutex());
  ledger()[pnh.getNamespace()].insert(pnh.resolveName(name));
}

void refuseUnknownParameters(const ros::NodeHandle& pnh, const std::vector<std::string>& also_known) {
  const std::string ns = pnh.getNamespace();
  const std::string prefix = ns == "/" ? "/" : ns + "/";
  std::set<std::string> known;
  {
    const std::lock_guard<std::mutex> lock(ledgerMutex());
    known = ledger()[ns];
  }
  std::vector<std::string> under;  // prefixes of also_known's blocks
  for (const std::string& name : also_known) {
    if (!name.empty() && name.back() == '/') {
      under.push_back(prefix + name);
    } else {
      known.insert(pnh.resolveName(name));
    }
  }
  std::vector<std::string> all;
  if (!ros::param::getParamNames(all)) return;  // no parameter server to ask: nothing to refuse
  std::string message;
  for (const std::string& name : all) {
    if (name.rfind(prefix, 0) != 0 || known.count(name) != 0) continue;
    if (std::any_of(under.begin(), under.end(), [&](const std::string& u) { return name.rfind(u, 0) == 0; })) continue;
    std::string nearest;
    size_t best = std::numeric_limits<size_t>::max();
    for (const std::string& k : known) {
      if (const size_t d = editDistance(name, k); d < best) {
        best = d;
        nearest = k;
      }
    }
    message += (message.empty() ? "" : "; ") + std::string("'") + name + "'";
    if (!nearest.empty() && best <= std::max<size_t>(3, name.size() / 4))
      message += " (did you mean '" + nearest + "'?)";
  }
  if (!message.empty()) {
    throw ParameterError("unknown parameter(s), which this node does not read: " + message +
                         " (a misspelt key would otherwise be ignored)");
  }
}

bool paramText(const ros::NodeHandle& pnh, const std::string& name, std::string& out) {
  noteParameter(pnh, name);
  XmlRpc::XmlRpcValue v;
  if (!pnh.getParam(name, v)) return false;
  std::ostringstream os;
  os.precision(17);
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      os << (static_cast<bool>(v) ? "true" : "false");
      break;
    case XmlRpc::XmlRpcValue::TypeInt:
      os << static_cast<int>(v);
      break;
    case XmlRpc::XmlRpcValue::TypeDouble:
      os << static_cast<double>(v);
      break;
    case XmlRpc::XmlRpcValue::TypeString:
      os << static_cast<std::string>(v);
      break;
    default:
      throw ParameterError("parameter '" + pnh.resolveName(name) + "' has the wrong type (not a scalar)");
  }
  out = os.str();
  return true;
}

namespace {

// Reads the shield parameters whose names pass `wanted` into `c`; errors name the parameter.
template <typename Wanted>
void readShieldParameters(const ros::NodeHandle& pnh, ActionShieldConfig& c, Wanted&& wanted) {
  for (const std::string& name : shieldParameterNames()) {
    if (!wanted(name)) continue;
    const bool is_static = name.rfind("static_safety/", 0) == 0;
    const std::string ros_name = is_static ? name : "action_shield/" + name;
    std::string text;
    if (!paramText(pnh, ros_name, text)) continue;
    const std::string error = setShieldParameter(c, name, text);
    if (!error.empty()) throw ParameterError("parameter '" + pnh.resolveName(ros_name) + "': " + error);
  }
}

}  // namespace

StaticSafetyConfig loadStaticSafetyConfig(const ros::NodeHandle& pnh) {
  ActionShieldConfig c;
  readShieldParameters(pnh, c, [](const std::string& name) { return name.rfind("static_safety/", 0) == 0; });
  const std::string error = c.statics.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("static_safety") + ": " + error);
  return c.statics;
}

DovsConfig loadDovsConfig(const ros::NodeHandle& pnh) {
  // Every DovsConfig field by its config/dovs.yaml name (dovsParameterNames, the table the evaluation and the
  // trainer set them by); a key under dovs/ that names none is refused by refuseUnknownParameters.
  DovsConfig c;
  for (const std::string& name : dovsParameterNames()) {
    std::string text;
    if (!paramText(pnh, "dovs/" + name, text)) continue;
    const std::string why = setDovsParameter(c, name, text);
    if (!why.empty()) throw ParameterError("parameter '" + pnh.resolveName("dovs/" + name) + "': " + why);
  }
  const std::string error = c.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("dovs") + ": " + error);
  if (c.grid_channels == 2) {
    throw ParameterError(pnh.resolveName("dovs/grid_channels") +
                         " = 2 (the previous decision's grid) exists in training and evaluation only: the nodes "
                         "build 1 or 3");
  }
  if (c.previous_action != 0) {
    throw ParameterError(pnh.resolveName("dovs/previous_action") +
                         " = 1 (the previous choice in the state) exists in training and evaluation only: the nodes "
                         "build states without it");
  }
  return c;
}

ActionShieldConfig loadActionShieldConfig(const ros::NodeHandle& pnh) {
  ActionShieldConfig c;
  readShieldParameters(pnh, c, [](const std::string&) { return true; });
  const std::string error = c.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("action_shield") + ": " + error);
  return c;
}

}  // namespace dqn_dovs
