#include "dqn_dovs/render/dovs_render.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace dqn_dovs {

namespace {

const cv::Vec3b kFree(255, 255, 255);
const cv::Vec3b kUnsafe(0, 0, 0);
const cv::Vec3b kInfeasible(150, 150, 150);
const cv::Vec3b kBackground(225, 225, 225);
const cv::Scalar kGreen(0, 170, 0);
const cv::Scalar kCurrent(0, 0, 220);
const cv::Scalar kAction(200, 90, 0);
const cv::Scalar kInvalid(120, 120, 120);
const cv::Scalar kChosen(0, 140, 255);

}  // namespace

DovsPlotFrame::DovsPlotFrame(const RobotLimits& limits, int size)
    : size_px(size), margin_px(std::max(4, size / 20)), w_max(limits.w_max), v_max(limits.v_max) {}

cv::Point2d DovsPlotFrame::toPixel(const Twist2& t) const {
  const double span = size_px - 2 * margin_px;
  return {margin_px + (t.w + w_max) / (2.0 * w_max) * span, margin_px + (1.0 - t.v / v_max) * span};
}

Twist2 DovsPlotFrame::toVelocity(int x, int y) const {
  const double span = size_px - 2 * margin_px;
  return {v_max * (1.0 - (y + 0.5 - margin_px) / span), w_max * (2.0 * (x + 0.5 - margin_px) / span - 1.0)};
}

bool DovsPlotFrame::inPlot(int x, int y) const {
  return x >= margin_px && y >= margin_px && x < size_px - margin_px && y < size_px - margin_px;
}

cv::Mat renderDovs(const VelocitySpace& dovs, const ActionSet& actions, const Twist2& current, int chosen_action,
                   int size_px) {
  if (size_px < 64 || size_px > 4096) {
    std::ostringstream os;
    os << "renderDovs: size_px = " << size_px << " must be in [64, 4096]";
    throw DovsError(os.str());
  }
  if (chosen_action < -1 || chosen_action >= kNumActions) {
    std::ostringstream os;
    os << "renderDovs: chosen_action = " << chosen_action << " must be -1 (none) or an action index in [0, 7]";
    throw DovsError(os.str());
  }
  const DovsPlotFrame frame(dovs.limits(), size_px);
  cv::Mat img(size_px, size_px, CV_8UC3, cv::Scalar(kBackground[0], kBackground[1], kBackground[2]));
  for (int y = 0; y < size_px; ++y) {
    cv::Vec3b* row = img.ptr<cv::Vec3b>(y);
    for (int x = 0; x < size_px; ++x) {
      if (!frame.inPlot(x, y)) continue;
      const Twist2 t = frame.toVelocity(x, y);
      row[x] = !dovs.isFeasible(t) ? kInfeasible : dovs.isFree(t) ? kFree : kUnsafe;
    }
  }
  const int thick = std::max(1, size_px / 200);
  const int shift = 4;  // sub-pixel drawing
  auto P = [&](const Twist2& t) {
    const cv::Point2d p = frame.toPixel(t);
    return cv::Point(static_cast<int>(std::lround(p.x * (1 << shift))),
                     static_cast<int>(std::lround(p.y * (1 << shift))));
  };
  cv::rectangle(img, cv::Point(frame.margin_px - 1, frame.margin_px - 1),
                cv::Point(size_px - frame.margin_px, size_px - frame.margin_px), cv::Scalar(60, 60, 60), 1);

  // Dynamic window rhombus.
  const std::array<Twist2, 4> c = actions.window.corners();
  const std::array<Twist2, 4> ring{c[0], c[3], c[1], c[2]};  // top, right, bottom, left
  for (size_t i = 0; i < 4; ++i) cv::line(img, P(ring[i]), P(ring[(i + 1) % 4]), kGreen, thick, cv::LINE_AA, shift);

  // Goal line, from the origin to the edge of the feasible triangle.
  const RobotLimits& l = dovs.limits();
  if (actions.goal_line.kind == GoalLine::Kind::kArc) {
    const double k = actions.goal_line.curvature_1pm;
    const double v_end = l.v_max / (1.0 + std::abs(k) * l.v_max / l.w_max);
    cv::line(img, P({0.0, 0.0}), P({v_end, k * v_end}), kGreen, thick, cv::LINE_AA, shift);
  } else if (actions.goal_line.kind == GoalLine::Kind::kTurnInPlace) {
    cv::line(img, P({0.0, 0.0}), P({0.0, actions.goal_line.turn_sign * l.w_max}), kGreen, 2 * thick, cv::LINE_AA,
             shift);
  }

  const int mark = std::max(2, size_px / 100);
  for (int i = 0; i < kNumActions; ++i) {
    const cv::Point p = P(actions.velocities[static_cast<size_t>(i)]);
    if (actions.valid[static_cast<size_t>(i)]) {
      cv::circle(img, p, mark << shift, kAction, cv::FILLED, cv::LINE_AA, shift);
    } else {
      cv::circle(img, p, mark << shift, kInvalid, 1, cv::LINE_AA, shift);
    }
  }
  if (chosen_action >= 0) {
    cv::circle(img, P(actions.velocities[static_cast<size_t>(chosen_action)]), (2 * mark + thick) << shift, kChosen,
               2 * thick, cv::LINE_AA, shift);
  }
  const cv::Point cur = P(l.clipToFeasible(current));
  const int arm = (2 * mark) << shift;
  cv::line(img, cur - cv::Point(arm, 0), cur + cv::Point(arm, 0), kCurrent, thick, cv::LINE_AA, shift);
  cv::line(img, cur - cv::Point(0, arm), cur + cv::Point(0, arm), kCurrent, thick, cv::LINE_AA, shift);
  return img;
}

}  // namespace dqn_dovs
