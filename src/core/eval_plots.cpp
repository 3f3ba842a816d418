#include "dqn_dovs/eval_plots.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace dqn_dovs {

namespace {

const cv::Scalar kBlack(0, 0, 0), kGrey(200, 200, 200), kDarkGrey(110, 110, 110), kWhite(255, 255, 255);

/// Distinguishable line colours (BGR), cycled through by method / obstacle index.
cv::Scalar palette(size_t i) {
  static const cv::Scalar colours[] = {{180, 119, 31},  {14, 127, 255}, {44, 160, 44},   {40, 39, 214},
                                       {189, 103, 148}, {75, 86, 140},  {194, 119, 227}, {127, 127, 127},
                                       {34, 189, 188},  {207, 190, 23}};
  return colours[i % (sizeof(colours) / sizeof(colours[0]))];
}

std::string fixed(double x, int digits) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << x;
  return os.str();
}

void text(cv::Mat& img, const std::string& s, cv::Point at, double scale = 0.5, const cv::Scalar& colour = kBlack,
          int thickness = 1) {
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv::LINE_AA);
}

void save(const cv::Mat& img, const std::string& path) {
  bool ok = false;
  try {
    ok = cv::imwrite(path, img);
  } catch (const cv::Exception& e) {
    throw EvalError("cannot write plot '" + path + "': " + e.what());
  }
  if (!ok) throw EvalError("cannot write plot '" + path + "'");
}

}  // namespace

void plotSuccessVsObstacles(const EvalSummary& summary, const std::string& path) {
  if (summary.methods.empty() || summary.obstacle_counts.empty()) {
    throw EvalError("cannot plot '" + path + "': the summary has no methods or obstacle counts");
  }
  // The legend (a line sample and "method (mean)") goes right of the plot; the canvas grows to hold the longest
  // label, so no method name or mean is cut off.
  std::vector<std::string> labels;
  int label_w = 0;
  for (size_t m = 0; m < summary.methods.size(); ++m) {
    labels.push_back(summary.methods[m] + " (" + fixed(summary.overall[m].success_rate, 2) + ")");
    int baseline = 0;
    label_w = std::max(label_w, cv::getTextSize(labels.back(), cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &baseline).width);
  }
  const int plot_w = 620, left = 80, top = 50, bottom = 70;
  const int right = std::max(200, 52 + label_w + 15);
  const int width = left + plot_w + right;
  const int height = std::max(560, top + 20 + 24 * static_cast<int>(summary.methods.size()) + bottom);
  cv::Mat img(height, width, CV_8UC3, kWhite);
  const int pw = plot_w, ph = height - top - bottom;
  const int n_lo = summary.obstacle_counts.front(), n_hi = summary.obstacle_counts.back();
  const double span = std::max(1, n_hi - n_lo);
  auto px = [&](double n) { return left + static_cast<int>(std::lround((n - n_lo) / span * pw)); };
  auto py = [&](double rate) { return top + static_cast<int>(std::lround((1.0 - rate) * ph)); };
  for (int i = 0; i <= 10; ++i) {  // horizontal grid every 0.1
    const int y = py(i / 10.0);
    cv::line(img, {left, y}, {left + pw, y}, kGrey, 1);
    text(img, fixed(i / 10.0, 1), {left - 40, y + 5}, 0.45);
  }
  for (int n : summary.obstacle_counts) {
    cv::line(img, {px(n), top + ph}, {px(n), top + ph + 5}, kBlack, 1);
    text(img, std::to_string(n), {px(n) - 6, top + ph + 22}, 0.45);
  }
  cv::rectangle(img, {left, top}, {left + pw, top + ph}, kBlack, 1);
  text(img, "obstacles", {left + pw / 2 - 40, height - 20}, 0.6);
  text(img, "success rate", {10, top - 15}, 0.6);
  text(img, "Success rate vs number of obstacles", {left + pw / 2 - 170, 25}, 0.65, kBlack, 2);
  for (size_t m = 0; m < summary.methods.size(); ++m) {
    const cv::Scalar colour = palette(m);
    cv::Point prev;
    for (size_t c = 0; c < summary.obstacle_counts.size(); ++c) {
      const cv::Point p(px(summary.obstacle_counts[c]), py(summary.cells[m][c].success_rate));
      if (c > 0) cv::line(img, prev, p, colour, 2, cv::LINE_AA);
      cv::circle(img, p, 4, colour, cv::FILLED, cv::LINE_AA);
      prev = p;
    }
    const int ly = top + 20 + static_cast<int>(m) * 24;
    cv::line(img, {left + pw + 15, ly - 5}, {left + pw + 45, ly - 5}, colour, 2, cv::LINE_AA);
    text(img, labels[m], {left + pw + 52, ly}, 0.5);
  }
  save(img, path);
}

void plotTrajectory(const EpisodeRecord& record, const sim::Scenario& scenario, double goal_tolerance_m,
                    const std::string& path) {
  if (record.robot_path.empty()) {
    throw EvalError("cannot plot '" + path + "': the record of " + record.method + " on " + record.scenario +
                    " has no robot path (not listed in keep_paths)");
  }
  const double half = scenario.room_half_size_m;
  const int room_px = 640, left = 60, top = 60, legend_w = 290, bottom = 50;
  const double scale = room_px / (2.0 * half);
  cv::Mat img(top + room_px + bottom, left + room_px + legend_w, CV_8UC3, kWhite);
  auto px = [&](const Vec2& p) {
    return cv::Point(left + static_cast<int>(std::lround((p.x() + half) * scale)),
                     top + static_cast<int>(std::lround((half - p.y()) * scale)));
  };
  auto radiusPx = [&](double r) { return std::max(1, static_cast<int>(std::lround(r * scale))); };
  // Axes: a tick every metre.
  for (int m = static_cast<int>(std::ceil(-half)); m <= static_cast<int>(std::floor(half)); ++m) {
    const cv::Point bx = px(Vec2(m, -half)), ly = px(Vec2(-half, m));
    cv::line(img, bx, bx + cv::Point(0, 5), kBlack, 1);
    text(img, std::to_string(m), bx + cv::Point(-5, 20), 0.4);
    cv::line(img, ly, ly - cv::Point(5, 0), kBlack, 1);
    text(img, std::to_string(m), ly + cv::Point(-30, 4), 0.4);
  }
  text(img, "x (m)", px(Vec2(0.0, -half)) + cv::Point(-15, 40), 0.5);
  text(img, "y (m)", {5, top - 10}, 0.5);
  cv::rectangle(img, px(Vec2(-half, half)), px(Vec2(half, -half)), kBlack, 3);  // the room's walls
  for (const Segment& s : scenario.static_segments) cv::line(img, px(s.a), px(s.b), kBlack, 3);

  // Obstacles: path, start circled, final position marked with an X.
  for (size_t i = 0; i < record.obstacle_paths.size(); ++i) {
    const auto& trail = record.obstacle_paths[i];
    if (trail.empty()) continue;
    const double r = i < scenario.obstacles.size() ? scenario.obstacles[i].radius : 0.2;
    const bool is_static = i < scenario.obstacles.size() && scenario.obstacles[i].is_static;
    const cv::Scalar colour = is_static ? kDarkGrey : cv::Scalar(60, 60, 220);
    for (size_t k = 1; k < trail.size(); ++k) cv::line(img, px(trail[k - 1]), px(trail[k]), colour, 1, cv::LINE_AA);
    cv::circle(img, px(trail.front()), radiusPx(r), colour, 1, cv::LINE_AA);
    const cv::Point e = px(trail.back());
    const int d = radiusPx(r * 0.8);
    cv::line(img, e + cv::Point(-d, -d), e + cv::Point(d, d), colour, 2, cv::LINE_AA);
    cv::line(img, e + cv::Point(-d, d), e + cv::Point(d, -d), colour, 2, cv::LINE_AA);
  }
  // Goal with its tolerance, robot path, start and end.
  const cv::Scalar goal_colour(40, 160, 40), robot_colour(180, 100, 20);
  cv::circle(img, px(scenario.goal), radiusPx(goal_tolerance_m), goal_colour, cv::FILLED, cv::LINE_AA);
  cv::circle(img, px(scenario.goal), radiusPx(0.25), goal_colour, 1, cv::LINE_AA);
  for (size_t k = 1; k < record.robot_path.size(); ++k) {
    cv::line(img, px(record.robot_path[k - 1].position()), px(record.robot_path[k].position()), robot_colour, 2,
             cv::LINE_AA);
  }
  const Pose2& start = record.robot_path.front();
  cv::circle(img, px(start.position()), radiusPx(0.2), robot_colour, 1, cv::LINE_AA);
  const Pose2& end = record.robot_path.back();
  cv::circle(img, px(end.position()), radiusPx(0.2), robot_colour, 2, cv::LINE_AA);
  cv::line(img, px(end.position()), px(end.position() + 0.3 * Vec2(std::cos(end.theta), std::sin(end.theta))),
           robot_colour, 2, cv::LINE_AA);

  text(img,
       record.method + "  scenario " + record.scenario + "  " + outcomeName(record.outcome) + " after " +
           fixed(record.time_s, 1) + " s",
       {left, 30}, 0.6, kBlack, 2);
  const int lx = left + room_px + 20;
  int ly = top + 20;
  auto legend = [&](const std::string& label, const cv::Scalar& colour, int kind) {
    if (kind == 0) cv::line(img, {lx, ly - 5}, {lx + 30, ly - 5}, colour, 2, cv::LINE_AA);
    if (kind == 1) {
      cv::line(img, {lx + 8, ly - 12}, {lx + 20, ly}, colour, 2, cv::LINE_AA);
      cv::line(img, {lx + 8, ly}, {lx + 20, ly - 12}, colour, 2, cv::LINE_AA);
    }
    if (kind == 2) cv::circle(img, {lx + 15, ly - 5}, 7, colour, cv::FILLED, cv::LINE_AA);
    text(img, label, {lx + 40, ly}, 0.5);
    ly += 26;
  };
  legend("robot path", robot_colour, 0);
  legend("goal", goal_colour, 2);
  legend("moving obstacle path", cv::Scalar(60, 60, 220), 0);
  legend("static obstacle", kDarkGrey, 0);
  legend("final obstacle position", kBlack, 1);
  text(img, "path " + fixed(record.path_length_m, 2) + " m", {lx, ly + 10}, 0.5);
  text(img, "min clearance " + fixed(record.min_clearance_m, 2) + " m", {lx, ly + 36}, 0.5);
  save(img, path);
}

}  // namespace dqn_dovs
