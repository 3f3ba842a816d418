// Soak of the full pipeline in simulation, in real time (soak.test): generated scenarios one after another
// (simulator ~load_scenario with seed + k and 1..12 obstacles) until soak_seconds of wall time have passed.
// Each scenario ends when the planner reports the goal reached, the simulator reports a collision, or
// scenario_time_limit of simulated time passes. Meanwhile, every 5 s, each node's process is checked (a
// vanished or zombie process is a crash) and its RSS sampled; every published command is checked against the
// safety envelope (planner/cmd_vel_stamped); the planner's deadline counters come from planner/status.
// Figures: bench/results/soak.json and soak.md. Asserted: no crash, no failed scenario load, RSS growth (linear
// fit after the warm-up) under rss_growth_limit MB/h for every node, the stream inside the envelope, at
// least one goal reached, (loosely) at most a quarter of the control periods late, and at most one collision with
// static geometry (walls, static obstacles), plus one per hundred scenarios: passive safety's target of none is not
// met with the tracker in the loop yet. Every collision, split into static / robot at rest / moving with the speed
// at contact, and the timeouts are reported.
#include <geometry_msgs/TwistStamped.h>
#include <gtest/gtest.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "dqn_dovs/LoadScenario.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/SimStatus.h"

namespace {

using dqn_dovs::PlannerStatus;
using dqn_dovs::SimStatus;

constexpr double kVMax = 0.7, kWMax = 3.14159, kAv = 0.5, kAw = 2.0, kMaxRampStep = 0.1;
const std::vector<std::string> kNodes = {"simulator", "obstacle_tracker", "dovs", "planner"};

double wallNow() { return ros::WallTime::now().toSec(); }

/// The process of node `name` as this test's own master knows it, or -1: the master's lookupNode gives the
/// node's XML-RPC URI and the node's getPid its process id. Never a search of the machine's processes, so
/// another pipeline running on the same machine (its own master, the same node names) is never mistaken for
/// this one.
int findNodePid(const std::string& name) {
  const std::string node = ros::names::resolve(name);
  XmlRpc::XmlRpcValue request, response, payload;
  request[0] = ros::this_node::getName();
  request[1] = node;
  if (!ros::master::execute("lookupNode", request, response, payload, false)) return -1;
  const std::string uri = payload;
  std::string host;
  uint32_t port = 0;
  if (!ros::network::splitURI(uri, host, port)) return -1;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue args, result;
  args[0] = ros::this_node::getName();
  if (!client.execute("getPid", args, result) || client.isFault()) return -1;
  // [code, status message, pid]; code 1 is success.
  if (result.getType() != XmlRpc::XmlRpcValue::TypeArray || result.size() != 3 || static_cast<int>(result[0]) != 1) {
    return -1;
  }
  return static_cast<int>(result[2]);
}

/// RSS in MB of a live process; -1 when it is gone or a zombie.
double rssMb(int pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  if (!f) return -1.0;
  std::string line;
  double kb = -1.0;
  bool zombie = false;
  while (std::getline(f, line)) {
    if (line.rfind("State:", 0) == 0 && line.find('Z') != std::string::npos) zombie = true;
    if (line.rfind("VmRSS:", 0) == 0) kb = std::stod(line.substr(6));
  }
  return zombie || kb < 0.0 ? -1.0 : kb / 1024.0;
}

/// Least-squares slope of y over x.
double slope(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  if (x.size() < 3) return 0.0;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    sx += x[i];
    sy += y[i];
    sxx += x[i] * x[i];
    sxy += x[i] * y[i];
  }
  const double den = n * sxx - sx * sx;
  return den > 0.0 ? (n * sxy - sx * sy) / den : 0.0;
}

struct Watch {
  std::mutex mutex;
  SimStatus sim;
  bool have_sim = false;
  PlannerStatus planner;
  bool have_planner = false;
  ros::Time reached_stamp;  // stamp of the latest REACHED status
  // Wall-clock view of the control periods: planner/status comes once per period; an interval longer than
  // 1.5 periods is a period that published late by more than half a period.
  double last_status_wall = 0.0, max_status_interval = 0.0;
  uint64_t status_intervals = 0, late_status_intervals = 0;
  // The command stream against the envelope.
  bool have_prev = false;
  geometry_msgs::TwistStamped prev;
  uint64_t stream = 0, stream_pairs = 0, stream_gaps = 0, stream_outside = 0;
  std::string first_outside;

  void onSim(const SimStatus::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    sim = *m;
    have_sim = true;
  }
  void onPlanner(const PlannerStatus::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    planner = *m;
    have_planner = true;
    const double now = wallNow();
    if (last_status_wall > 0.0) {
      const double dt = now - last_status_wall;
      ++status_intervals;
      max_status_interval = std::max(max_status_interval, dt);
      if (dt > 1.5 * 0.2) ++late_status_intervals;
    }
    last_status_wall = now;
    if (m->state == PlannerStatus::REACHED) reached_stamp = m->header.stamp;
  }
  void onStamped(const geometry_msgs::TwistStamped::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    ++stream;
    const double v = m->twist.linear.x, w = m->twist.angular.z;
    bool ok = std::isfinite(v) && std::isfinite(w) && v >= -1e-9 && v <= kVMax + 1e-9 &&
              std::abs(w) <= kWMax * (1.0 - v / kVMax) + 1e-9;
    if (have_prev) {
      if (m->header.seq != prev.header.seq + 1) {
        ++stream_gaps;
      } else {
        ++stream_pairs;
        const double dt = std::clamp((m->header.stamp - prev.header.stamp).toSec(), 0.0, kMaxRampStep);
        ok = ok && std::abs(v - prev.twist.linear.x) <= kAv * dt + 1e-9 &&
             std::abs(w - prev.twist.angular.z) <= kAw * dt + 1e-9;
      }
    }
    if (!ok) {
      ++stream_outside;
      if (first_outside.empty()) {
        std::ostringstream os;
        os << "(" << prev.twist.linear.x << ", " << prev.twist.angular.z << ") -> (" << v << ", " << w << ")";
        first_outside = os.str();
      }
    }
    prev = *m;
    have_prev = true;
  }
};

struct NodeSamples {
  int pid = -1;
  bool crashed = false;
  double crashed_at_s = -1.0;
  std::vector<double> t_h, mb;
};

TEST(Soak, PipelineRunsScenarioAfterScenario) {
  ros::NodeHandle nh, pnh("~");
  const double soak_s = pnh.param("soak_seconds", 300.0);
  const double scenario_limit_s = pnh.param("scenario_time_limit", 60.0);
  const int seed0 = pnh.param("seed", 1);
  const double rss_limit = pnh.param("rss_growth_limit", 100.0);
  const std::string results_dir = pnh.param<std::string>("results_dir", "");
  Watch w;
  auto s1 = nh.subscribe("sim/status", 20, &Watch::onSim, &w);
  auto s2 = nh.subscribe("planner/status", 20, &Watch::onPlanner, &w);
  auto s3 = nh.subscribe("planner/cmd_vel_stamped", 500, &Watch::onStamped, &w);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ros::ServiceClient load = nh.serviceClient<dqn_dovs::LoadScenario>("simulator/load_scenario");
  ASSERT_TRUE(load.waitForExistence(ros::Duration(60.0))) << "no simulator/load_scenario service";
  ASSERT_TRUE(ros::Time::waitForValid(ros::WallDuration(30.0))) << "no /clock";
  ASSERT_TRUE([&] {
    const double until = wallNow() + 60.0;
    while (wallNow() < until) {
      {
        std::lock_guard<std::mutex> l(w.mutex);
        if (w.have_planner && w.have_sim) return true;
      }
      ros::WallDuration(0.1).sleep();
    }
    return false;
  }()) << "no planner/status or sim/status";

  std::map<std::string, NodeSamples> nodes;
  for (const std::string& n : kNodes) {
    nodes[n].pid = findNodePid(n);
    ASSERT_GT(nodes[n].pid, 0) << "no process for node '" << n << "'";
  }

  const double wall0 = wallNow();
  const double sim0 = ros::Time::now().toSec();
  double next_sample = wall0;
  int scenarios = 0, reached = 0, collisions = 0, timeouts = 0, unfinished = 0, load_failures = 0;
  std::map<std::string, int> collision_kinds{{"static", 0}, {"rest", 0}, {"moving", 0}};
  std::vector<double> contact_speeds;
  std::ostringstream outcomes;
  auto sample = [&] {
    const double now = wallNow();
    if (now < next_sample) return;
    next_sample = now + 5.0;
    for (auto& [name, s] : nodes) {
      if (s.crashed) continue;
      const double mb = rssMb(s.pid);
      if (mb < 0.0) {
        s.crashed = true;
        s.crashed_at_s = now - wall0;
        ADD_FAILURE() << "node '" << name << "' (pid " << s.pid << ") is gone at t = " << now - wall0 << " s";
        continue;
      }
      s.t_h.push_back((now - wall0) / 3600.0);
      s.mb.push_back(mb);
    }
  };

  for (int k = 0; ros::ok() && wallNow() - wall0 < soak_s; ++k) {
    dqn_dovs::LoadScenario srv;
    srv.request.seed = seed0 + k;
    srv.request.obstacle_count = 1 + static_cast<int>((static_cast<uint64_t>(seed0 + k) * 2654435761u) % 12u);
    srv.request.dynamic_fraction = -1.0;
    if (!load.call(srv) || !srv.response.success) {
      ++load_failures;
      ADD_FAILURE() << "load_scenario seed " << srv.request.seed << " failed: " << srv.response.message;
      ros::WallDuration(1.0).sleep();
      sample();
      if (load_failures > 3) break;
      continue;
    }
    ++scenarios;
    // The new world's clock at its start: every status stamped after it belongs to this scenario.
    const ros::Time load_stamp = srv.response.goal.header.stamp;
    std::string outcome = "unfinished", kind;
    double contact_speed = 0.0;
    ros::Time active_at;  // the planner's first ACTIVE status for this scenario's goal
    while (ros::ok()) {
      sample();
      if (wallNow() - wall0 >= soak_s) break;
      {
        std::lock_guard<std::mutex> l(w.mutex);
        const bool this_scenario = w.sim.header.stamp > load_stamp && w.sim.episode_time < scenario_limit_s + 5.0;
        if (active_at.isZero() && w.planner.header.stamp > load_stamp && w.planner.state == PlannerStatus::ACTIVE) {
          active_at = w.planner.header.stamp;
        }
        if (this_scenario && w.sim.collided) {
          outcome = "collision";
          kind = w.sim.collision_kind;
          contact_speed = w.sim.contact_speed;
        } else if (!active_at.isZero() && w.reached_stamp > active_at) {
          outcome = "reached";
        } else if (this_scenario && w.sim.episode_time > scenario_limit_s) {
          outcome = "timeout";
        }
      }
      if (outcome != "unfinished") break;
      ros::WallDuration(0.05).sleep();
    }
    if (outcome == "reached") ++reached;
    if (outcome == "collision") ++collisions;
    if (outcome == "timeout") ++timeouts;
    if (outcome == "unfinished") ++unfinished;
    outcomes << (k ? ", " : "") << srv.request.seed << ":" << srv.request.obstacle_count << ":" << outcome;
    if (outcome == "collision") {
      ++collision_kinds[kind];
      contact_speeds.push_back(contact_speed);
      outcomes << "/" << kind;
    }
    std::cout << "[soak] t = " << std::fixed << std::setprecision(0) << wallNow() - wall0 << " s, scenario seed "
              << srv.request.seed << " (" << srv.request.obstacle_count << " obstacles): " << outcome << std::endl;
    bool any_crash = false;
    for (auto& [name, s] : nodes) any_crash = any_crash || s.crashed;
    if (any_crash) break;
  }
  next_sample = 0.0;
  sample();
  const double wall_s = wallNow() - wall0;
  const double sim_s = ros::Time::now().toSec() - sim0;
  spinner.stop();

  // Figures.
  std::lock_guard<std::mutex> l(w.mutex);
  const double warmup_h = std::min(60.0, 0.2 * wall_s) / 3600.0;
  int crashes = 0;
  std::ostringstream rss_json, rss_md;
  std::map<std::string, double> growth;
  for (const auto& [name, s] : nodes) {
    if (s.crashed) ++crashes;
    std::vector<double> x, y;
    for (size_t i = 0; i < s.t_h.size(); ++i) {
      if (s.t_h[i] >= warmup_h) {
        x.push_back(s.t_h[i]);
        y.push_back(s.mb[i]);
      }
    }
    growth[name] = slope(x, y);
    const double start = s.mb.empty() ? 0.0 : s.mb.front(), end = s.mb.empty() ? 0.0 : s.mb.back();
    const double peak = s.mb.empty() ? 0.0 : *std::max_element(s.mb.begin(), s.mb.end());
    rss_json << (rss_json.tellp() > 0 ? ",\n" : "") << "    \"" << name << "\": {\"start_mb\": " << start
             << ", \"end_mb\": " << end << ", \"max_mb\": " << peak << ", \"growth_mb_per_h\": " << growth[name]
             << ", \"samples\": " << s.mb.size() << ", \"crashed\": " << (s.crashed ? "true" : "false") << "}";
    rss_md << "| " << name << " | " << start << " | " << end << " | " << peak << " | " << growth[name] << " |\n";
  }
  const PlannerStatus& p = w.planner;
  double speed_mean = 0.0, speed_p95 = 0.0;
  if (!contact_speeds.empty()) {
    std::sort(contact_speeds.begin(), contact_speeds.end());
    for (double v : contact_speeds) speed_mean += v / contact_speeds.size();
    speed_p95 = contact_speeds[static_cast<size_t>(std::ceil(0.95 * contact_speeds.size())) - 1];
  }
  const double miss_fraction = p.control_periods > 0 ? double(p.deadline_misses) / p.control_periods : 0.0;
  std::ostringstream summary;
  summary << std::fixed << std::setprecision(2) << "soak " << wall_s << " s wall (" << sim_s
          << " s simulated): " << scenarios << " scenarios, " << reached << " goals reached, " << collisions
          << " collisions (static " << collision_kinds["static"] << ", robot at rest " << collision_kinds["rest"]
          << ", robot moving " << collision_kinds["moving"] << "; speed at contact mean " << speed_mean << " m/s, p95 "
          << speed_p95 << " m/s), " << timeouts << " timeouts, " << unfinished << " unfinished; " << crashes
          << " crashes; deadline misses " << p.deadline_misses << " of " << p.control_periods
          << " control periods (worst lateness " << p.max_period_lateness << " s simulated; on the wall clock "
          << w.late_status_intervals << " of " << w.status_intervals << " periods over 0.3 s, longest "
          << w.max_status_interval << " s); envelope: " << w.stream_outside << " of " << w.stream
          << " published commands outside, planner corrected " << p.envelope_corrections << "; RSS growth MB/h:";
  for (const auto& [name, g] : growth) summary << " " << name << " " << g;
  std::cout << "[soak] " << summary.str() << std::endl;

  if (!results_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(results_dir, ec);
    std::ofstream json(results_dir + "/soak.json");
    json << std::setprecision(6) << "{\n  \"duration_s\": " << wall_s << ",\n  \"simulated_s\": " << sim_s
         << ",\n  \"realtime_factor_achieved\": " << (wall_s > 0 ? sim_s / wall_s : 0.0)
         << ",\n  \"scenarios\": " << scenarios << ",\n  \"goals_reached\": " << reached
         << ",\n  \"collisions\": " << collisions << ",\n  \"collisions_static\": " << collision_kinds["static"]
         << ",\n  \"collisions_rest\": " << collision_kinds["rest"]
         << ",\n  \"collisions_moving\": " << collision_kinds["moving"] << ",\n  \"contact_speed_mean\": " << speed_mean
         << ",\n  \"contact_speed_p95\": " << speed_p95 << ",\n  \"static_corrections\": " << p.static_corrections
         << ",\n  \"timeouts\": " << timeouts << ",\n  \"unfinished\": " << unfinished
         << ",\n  \"load_failures\": " << load_failures << ",\n  \"crashes\": " << crashes
         << ",\n  \"deadline\": {\"control_periods\": " << p.control_periods << ", \"misses\": " << p.deadline_misses
         << ", \"miss_fraction\": " << miss_fraction << ", \"max_lateness_s\": " << p.max_period_lateness
         << ", \"threshold\": \"50% of the 0.2 s period\""
         << ", \"wall_periods\": " << w.status_intervals << ", \"wall_late_periods\": " << w.late_status_intervals
         << ", \"wall_max_period_s\": " << w.max_status_interval << "}"
         << ",\n  \"envelope\": {\"stream_commands\": " << w.stream << ", \"stream_pairs_checked\": " << w.stream_pairs
         << ", \"stream_gaps\": " << w.stream_gaps << ", \"stream_outside\": " << w.stream_outside
         << ", \"planner_checks\": " << p.envelope_checks << ", \"planner_corrections\": " << p.envelope_corrections
         << "},\n  \"rss_warmup_s\": " << warmup_h * 3600.0 << ",\n  \"rss\": {\n"
         << rss_json.str() << "\n  },\n  \"outcomes\": \"" << outcomes.str() << "\"\n}\n";
    std::ofstream md(results_dir + "/soak.md");
    md << "# Soak\n\n"
       << summary.str() << "\n\n| node | RSS start MB | end MB | max MB | growth MB/h |\n|---|---|---|---|---|\n"
       << rss_md.str();
  }

  EXPECT_EQ(crashes, 0) << "a node crashed";
  EXPECT_EQ(load_failures, 0);
  // Passive safety's target is no collision with static geometry at all. With the tracker in the loop it is not met
  // yet: a static disc the tracker reports as moving escapes the static braking rule (about one collision in
  // 1,000-1,500 evaluated episodes, docs/results.md "Passive safety"), so a soak may meet one. More than one, or
  // more than one in a hundred scenarios, is a regression.
  const int static_allowed = 1 + scenarios / 100;
  EXPECT_LE(collision_kinds["static"], static_allowed) << "the robot hit static geometry " << collision_kinds["static"]
                                                       << " times in " << scenarios << " scenarios: " << outcomes.str();
  EXPECT_GE(scenarios, 2) << "the soak ran too few scenarios to mean anything";
  EXPECT_GE(reached, 1) << "no goal reached in " << scenarios << " scenarios: the pipeline does not work";
  for (const auto& [name, g] : growth) {
    EXPECT_LT(g, rss_limit) << "RSS of '" << name << "' grows by " << g << " MB/h";
  }
  EXPECT_GT(w.stream_pairs, 1000u);
  EXPECT_EQ(w.stream_outside, 0u) << "published commands outside the envelope, first " << w.first_outside;
  EXPECT_LE(miss_fraction, 0.25) << p.deadline_misses << " of " << p.control_periods << " control periods late";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_soak");
  return RUN_ALL_TESTS();
}
