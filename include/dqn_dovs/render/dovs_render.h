// Picture of a DOVS in the style of the paper's Figure 2: w on the x axis, v on the y axis, DOV black, free
// white, the infeasible part of the kinematic triangle shaded, the dynamic window and the goal line in green,
// the current velocity and the 8 actions marked. OpenCV is used here only.
#pragma once

#include <opencv2/core.hpp>

#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"

namespace dqn_dovs {

/// Plot area of a square image of side size_px: the (w, v) rectangle [-w_max, w_max] x [0, v_max].
struct DovsPlotFrame {
  int size_px = 0;
  int margin_px = 0;
  double w_max = 0.0;
  double v_max = 0.0;

  DovsPlotFrame(const RobotLimits& limits, int size_px);
  /// Pixel (column, row) of velocity t; v = v_max is the top row of the plot area, w = -w_max its left column.
  cv::Point2d toPixel(const Twist2& t) const;
  /// Velocity at the centre of pixel (x, y).
  Twist2 toVelocity(int x, int y) const;
  /// True when pixel (x, y) lies inside the plot area.
  bool inPlot(int x, int y) const;
};

/// Renders `dovs` with the action set, the current velocity and the chosen action (-1: none) highlighted, as a
/// BGR image of size_px x size_px. Throws DovsError when size_px is below 64 or above 4096, or chosen_action is
/// not in [-1, 7].
cv::Mat renderDovs(const VelocitySpace& dovs, const ActionSet& actions, const Twist2& current, int chosen_action,
                   int size_px);

}  // namespace dqn_dovs
