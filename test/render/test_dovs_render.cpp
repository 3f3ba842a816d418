// The DOVS picture: size, and the colours of pixels known to be in the DOV, free and infeasible.
#include <gtest/gtest.h>

#include "dqn_dovs/render/dovs_render.h"

namespace dqn_dovs {
namespace {

TEST(DovsRender, ColoursFollowTheDovs) {
  Observation obs;
  MovingObstacle o;
  o.center = {1.0, 0.0};
  o.radius = 0.2;
  o.is_static = true;
  obs.obstacles.push_back(o);
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  const Twist2 current{0.1, 0.0};
  const ActionSet actions = computeActions(current, {-2.0, 1.0}, RobotLimits{});
  const cv::Mat img = renderDovs(d, actions, current, kActionDwLeft, 400);
  ASSERT_EQ(img.rows, 400);
  ASSERT_EQ(img.cols, 400);
  ASSERT_EQ(img.type(), CV_8UC3);
  const DovsPlotFrame frame(RobotLimits{}, 400);
  auto pixelAt = [&](const Twist2& t) {
    const cv::Point2d p = frame.toPixel(t);
    return img.at<cv::Vec3b>(static_cast<int>(p.y), static_cast<int>(p.x));
  };
  ASSERT_FALSE(d.isFree({0.67, 0.05}));
  EXPECT_EQ(pixelAt({0.67, 0.05}), cv::Vec3b(0, 0, 0));  // in the DOV: black
  ASSERT_TRUE(d.isFree({0.35, 1.2}));
  EXPECT_EQ(pixelAt({0.35, 1.2}), cv::Vec3b(255, 255, 255));  // free: white
  const cv::Vec3b infeasible = pixelAt({0.6, -2.5});
  EXPECT_NE(infeasible, cv::Vec3b(0, 0, 0));
  EXPECT_NE(infeasible, cv::Vec3b(255, 255, 255));
  // The pixel maths round-trips.
  const cv::Point2d p = frame.toPixel({0.35, 1.2});
  const Twist2 back = frame.toVelocity(static_cast<int>(p.x), static_cast<int>(p.y));
  EXPECT_NEAR(back.v, 0.35, 0.7 / 360);
  EXPECT_NEAR(back.w, 1.2, 2 * kPi / 360);
}

TEST(DovsRender, BadArgumentsAreErrors) {
  const VelocitySpace d = buildDovs(Observation{}, RobotLimits{}, DovsConfig{});
  const ActionSet a = computeActions({0.0, 0.0}, {1.0, 0.0}, RobotLimits{});
  EXPECT_THROW(renderDovs(d, a, {0.0, 0.0}, -1, 10), DovsError);
  EXPECT_THROW(renderDovs(d, a, {0.0, 0.0}, 8, 200), DovsError);
  EXPECT_NO_THROW(renderDovs(d, a, {0.0, 0.0}, -1, 64));
}

}  // namespace
}  // namespace dqn_dovs
