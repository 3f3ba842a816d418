#include "planner_decision.h"

#include <std_msgs/Float64.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <sstream>

#include "dqn_dovs/dovs/state.h"
#include "pipeline_steps.h"
#include "ros_params.h"

namespace dqn_dovs {

PlannerDecisionAdapter::PlannerDecisionAdapter(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& fixed_frame,
                                               const RobotLimits& limits, Supervisor& supervisor)
    : fixed_frame_(fixed_frame), limits_(limits), nh_(nh), supervisor_(supervisor) {
  planner_ = param<std::string>(pnh, "planner", "dqn_dovs");
  if (const std::string why = robotPlannerFault(planner_); !why.empty()) {
    throw ParameterError("parameter '" + pnh.resolveName("planner") + "': " + why);
  }
  statics_ = loadStaticSafetyConfig(pnh);
  const DovsConfig dovs = loadDovsConfig(pnh);
  const std::string model_path = param<std::string>(pnh, "model_path", "");
  if (planner_ == "dqn_dovs") loadModel(pnh, model_path, dovs);
  // dovs.yaml's action shield is dovs_node's; read here too, so that a bad value is refused by both nodes alike.
  (void)loadActionShieldConfig(pnh);
  latency_pub_ = nh_.advertise<std_msgs::Float64>("planner/latency", 20);
}

void PlannerDecisionAdapter::loadModel(const ros::NodeHandle& pnh, const std::string& model_path,
                                       const DovsConfig& dovs) {
  if (model_path.empty()) throw ParameterError("parameter '" + pnh.resolveName("model_path") + "' is not set");
  {
    // The loader names the field that is wrong inside a weight file; what is wrong with the path itself is
    // said here (a directory, for one, would otherwise surface as a bare stream error).
    std::error_code ec;
    const auto status = std::filesystem::status(model_path, ec);
    const std::string culprit = "model file '" + model_path + "' (parameter '" + pnh.resolveName("model_path") + "')";
    if (!std::filesystem::exists(status)) throw ParameterError(culprit + " does not exist");
    if (std::filesystem::is_directory(status)) throw ParameterError(culprit + " is a directory, not a weight file");
    if (!std::filesystem::is_regular_file(status)) throw ParameterError(culprit + " is not a regular file");
    if (access(model_path.c_str(), R_OK) != 0) throw ParameterError(culprit + " is not readable");
  }
  network_ = std::make_unique<QNetwork>(QNetwork::load(model_path));  // throws WeightFileError naming the field
  // At start, against the robot's limits (and any dovs/* given to the planner); each Dovs message carries the
  // normalisation dovs_node really used, checked again before the network runs (chooseAction).
  const StateNormalization expected = stateNormalization(limits_, dovs);
  std::string mismatch = network_->normalizationMismatch(expected.fields(), 1e-4f);
  if (mismatch.empty()) mismatch = network_->gridChannelsMismatch(expected.grid_channels);
  if (mismatch.empty()) mismatch = network_->previousActionMismatch(expected.previous_action != 0);
  if (mismatch.empty())
    mismatch = network_->tokenLayoutMismatch(expected.wall_rays, expected.person_tokens, expected.route_points);
  if (!mismatch.empty()) {
    throw ParameterError("model '" + model_path +
                         "' was trained with another state normalisation or layout: " + mismatch);
  }
  // Everything else the state depends on (the DOVS model, the dynamic window, the radius), when the model names it.
  if (const std::string other = stateParametersMismatch(network_->metadata(), limits_, dovs); !other.empty()) {
    throw ParameterError("model '" + model_path + "' was trained with other state parameters (its metadata's '" +
                         kStateParametersKey + "'): " + other);
  }
}

void PlannerDecisionAdapter::start(const PlannerNavigation& navigation) {
  navigation_ = &navigation;
  dovs_sub_ = nh_.subscribe("dovs", 2, &PlannerDecisionAdapter::onDovs, this, ros::TransportHints().tcpNoDelay());
}

std::string PlannerDecisionAdapter::spaceFault() const {
  if (navigation_ == nullptr) return "the planner is starting";
  if (!navigation_->goalFault().empty()) return navigation_->goalFault();
  if (!last_dovs_) return "dovs is stale or missing";
  if (const std::string other = navigation_->localGoalFault(*last_dovs_); !other.empty()) return other;
  if (network_ && last_dovs_->state.size() != static_cast<size_t>(network_->stateSize()))
    return "dovs state has the wrong size";
  return {};
}

void PlannerDecisionAdapter::forget() {
  last_dovs_.reset();
  chosen_for_.reset();
}

void PlannerDecisionAdapter::onDovs(const Dovs::ConstPtr& msg) {
  last_dovs_ = msg;
  // Choose the action as soon as the velocity space arrives: the control timer then applies it without
  // running the network, and planner/latency reports how old the scan behind the choice is.
  supervisor_.space(msg->header.stamp.toSec());
  if (supervisor_.hasGoal() && supervisor_.state() != GoalState::kReached &&
      navigation_->localGoalFault(*msg).empty()) {
    std::string why;
    if (network_) actionForLastDovs(why);
    if (latency_pub_.getNumSubscribers() > 0) {
      std_msgs::Float64 latency;
      latency.data = (ros::Time::now() - msg->header.stamp).toSec();
      latency_pub_.publish(latency);
    }
  }
}

int PlannerDecisionAdapter::actionForLastDovs(std::string& why) {
  if (chosen_for_ != last_dovs_) {
    // The message's decision fields, copied once per message; every control period until the next one reads them.
    chosen_decision_ = dovsDecisionFromMessage(*last_dovs_);
    chosen_action_ = chooseAction(*network_, chosen_decision_, chosen_why_);
    chosen_for_ = last_dovs_;
  }
  why = chosen_why_;
  return chosen_action_;
}

Choice PlannerDecisionAdapter::choose(const Pose2& pose) {
  Choice c;
  int a = -1;
  if (network_) {
    a = actionForLastDovs(c.why);
    if (a < 0) return c;
    c.action = a;
    c.target = limits_.clipToFeasible(choiceVelocity(chosen_decision_, a));
  } else {
    // Another planner decided in dovs_node (the registry's, on the observation there): its command, then the same
    // static last line.
    const Dovs& d = *last_dovs_;
    if (d.planner != planner_) {
      c.why = "dovs was decided by '" + d.planner + "' (dovs_node's planner), this planner runs '" + planner_ + "'";
      return c;
    }
    if (!std::isfinite(d.planner_v) || !std::isfinite(d.planner_w)) {
      c.why = planner_ + ": " + (d.planner_note.empty() ? std::string("no finite command") : d.planner_note);
      return c;
    }
    if (chosen_for_ != last_dovs_) {
      chosen_decision_ = dovsDecisionFromMessage(d);  // the static geometry for the last line
      chosen_for_ = last_dovs_;
    }
    a = d.planner_action;
    c.action = d.planner_action >= 0 && d.planner_action < kNumActions ? d.planner_action : -1;
    c.target = limits_.clipToFeasible({d.planner_v, d.planner_w});
  }
  if (statics_.enabled) {
    // The last line (the core's, as the evaluation runs it): the target's braking trajectory, from where the robot
    // is now at the speed last sent, must keep clear of the static geometry the Dovs carries; otherwise the nearest
    // velocity whose does.
    if (const std::string bad = staticFrameFault(*last_dovs_, fixed_frame_); !bad.empty()) {
      c.why = bad;
      return c;
    }
    const LastLine last = staticLastLine(chosen_decision_, c.target, pose, supervisor_.command(), limits_, statics_);
    if (!last.fault.empty()) {
      c.why = last.fault;
      return c;
    }
    if (last.corrected) {
      ++static_corrections_;
      std::ostringstream os;
      os.precision(3);
      os << "choice " << a << " (" << c.target.v << " m/s, " << c.target.w
         << " rad/s) would brake into static geometry; sent (" << last.command.v << ", " << last.command.w << ")";
      static_last_ = os.str();
      ROS_WARN_THROTTLE(1.0, "planner: static safety: %s (%u so far)", static_last_.c_str(), static_corrections_);
      c.target = last.command;
    }
  }
  return c;
}

}  // namespace dqn_dovs
