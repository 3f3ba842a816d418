// The training reward's yardstick terms (RewardConfig): a contact the robot is at fault for costs more than being
// walked into at rest, the progress term as gamma-consistent shaping, time in a person's intimate space and blocking
// a passage priced per second; every parameter set by name and checked.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/evaluation/yardstick.h"

namespace dqn_dovs {
namespace {

sim::Scenario openRoom(const Pose2& start, const Vec2& goal) {
  sim::Scenario s;
  s.name = "reward";
  s.room_half_size_m = 6.0;
  s.robot_start = start;
  s.goal = goal;
  return s;
}

EpisodeConfig perfect(const RewardConfig& reward) {
  EpisodeConfig c;
  c.perfect_info = true;
  c.reward = reward;
  c.world.people.model = sim::PeopleModel::kConstant;
  return c;
}

TEST(Reward, ParametersAreSetByNameAndChecked) {
  RewardConfig r;
  EXPECT_EQ(setRewardParameter(r, "hit_at_rest_reward", "-5"), "");
  EXPECT_EQ(setRewardParameter(r, "shaping_gamma", "0.97"), "");
  EXPECT_EQ(setRewardParameter(r, "intimate_weight", "0.5"), "");
  EXPECT_EQ(setRewardParameter(r, "max_steps", "300"), "");
  EXPECT_EQ(r.hit_at_rest_reward, -5.0);
  EXPECT_EQ(r.shaping_gamma, 0.97);
  EXPECT_EQ(r.max_steps, 300);
  EXPECT_EQ(r.validate(), "");
  EXPECT_NE(setRewardParameter(r, "hit_reward", "1").find("unknown reward parameter 'hit_reward'"), std::string::npos);
  EXPECT_NE(setRewardParameter(r, "hit_reward", "1").find("blocking_weight"), std::string::npos);
  EXPECT_NE(setRewardParameter(r, "max_steps", "2.5").find("is not an integer"), std::string::npos);
  EXPECT_NE(setRewardParameter(r, "goal_reward", "lots").find("is not a number"), std::string::npos);
  EXPECT_EQ(rewardParameterNames().size(), 12u);
  RewardConfig bad;
  bad.hit_at_rest_reward = -20.0;  // dearer than a contact the robot caused
  EXPECT_NE(bad.validate().find("hit_at_rest_reward"), std::string::npos);
  bad = RewardConfig();
  bad.shaping_gamma = 1.2;
  EXPECT_NE(bad.validate().find("shaping_gamma"), std::string::npos);
  bad = RewardConfig();
  bad.blocking_weight = -1.0;
  EXPECT_NE(bad.validate().find("blocking_weight"), std::string::npos);
  // The paper does not tell contacts apart: without hit_at_rest_reward both cost collision_reward.
  EXPECT_EQ(RewardConfig().collisionReward(false), RewardConfig().collision_reward);
}

TEST(Reward, BeingWalkedIntoAtRestCostsLessThanAContactTheRobotCaused) {
  RewardConfig reward;
  reward.hit_at_rest_reward = -5.0;
  // A disc walks into the robot standing at rest since the start.
  sim::Scenario walked_into = openRoom({0.0, 0.0, 0.0}, {4.0, 4.0});
  MovingObstacle disc;
  disc.center = Vec2(2.0, 0.0);
  disc.heading = kPi;
  disc.speed = 1.0;
  walked_into.obstacles = {disc};
  Episode a(perfect(reward));
  a.reset(walked_into, 1);
  StepResult r;
  for (int k = 0; k < 30 && !a.done(); ++k) r = a.step(Twist2{});
  ASSERT_EQ(a.outcome(), Outcome::kCollision);
  EXPECT_FALSE(robotAtFault(a.world().collision()));
  EXPECT_EQ(r.reward, -5.0);
  // The robot drives into a static disc.
  sim::Scenario drives_in = openRoom({0.0, 0.0, 0.0}, {4.0, 0.0});
  MovingObstacle post;
  post.center = Vec2(1.5, 0.0);
  post.is_static = true;
  drives_in.obstacles = {post};
  Episode b(perfect(reward));
  b.reset(drives_in, 1);
  for (int k = 0; k < 40 && !b.done(); ++k) r = b.step(Twist2{0.5, 0.0});
  ASSERT_EQ(b.outcome(), Outcome::kCollision);
  EXPECT_TRUE(robotAtFault(b.world().collision()));
  EXPECT_EQ(r.reward, reward.collision_reward);
}

TEST(Reward, ProgressIsShapedWithTheDiscount) {
  // Standing still 3 m from the goal: the paper's progress term gives 0; gamma-consistent shaping gives
  // distance_weight * d * (1 - gamma), the same every period, so that it telescopes under the discount.
  for (const double gamma : {1.0, 0.9}) {
    RewardConfig reward;
    reward.shaping_gamma = gamma;
    Episode e(perfect(reward));
    e.reset(openRoom({0.0, 0.0, 0.0}, {3.0, 0.0}), 1);
    const StepResult r = e.step(Twist2{});
    EXPECT_NEAR(r.reward, reward.distance_weight * 3.0 * (1.0 - gamma), 1e-9) << gamma;
  }
}

TEST(Reward, TimeInAPersonsIntimateSpaceWhileMovingIsPriced) {
  // A person walking beside the robot at its pace, 0.3 m body to body: each period the moving robot spends there
  // costs intimate_weight per second.
  auto run = [](double intimate_weight) {
    RewardConfig reward;
    reward.intimate_weight = intimate_weight;
    Episode e(perfect(reward));
    sim::Scenario s = openRoom({-4.0, 0.0, 0.0}, {4.0, 3.0});
    sim::PersonSpec p;
    p.position = {-4.0, 0.2 + 0.25 + 0.3};  // robot radius 0.2, body 0.25, a 0.3 m gap
    p.heading_rad = 0.0;
    p.preferred_speed_mps = 0.3;
    s.people = {p};
    e.reset(s, 1);
    double total = 0.0;
    for (int k = 0; k < 10; ++k) total += e.step(Twist2{0.3, 0.0}).reward;
    return total;
  };
  const double free = run(0.0), priced = run(2.0);
  // The robot moves from the second period on (its first period accelerates from rest): 9 or 10 periods of 0.2 s.
  EXPECT_LT(priced, free - 2.0 * 0.2 * 8.5);
  EXPECT_GT(priced, free - 2.0 * 0.2 * 10.5);
}

TEST(Reward, BlockingADoorWhileSomeoneWaitsIsPriced) {
  // The robot stands in a 1 m door; an attentive person walking toward it through the door notices it and slows
  // down: the periods it is held up cost blocking_weight per second. Without anyone, nothing is charged.
  auto run = [](bool person) {
    RewardConfig reward;
    reward.blocking_weight = 1.0;
    reward.safe_weight = 0.0;  // standing still with gamma 1: the reward is the blocking price alone
    EpisodeConfig config = perfect(reward);
    config.world.people.model = sim::PeopleModel::kSocialForce;
    config.world.people.mix = sim::PeopleMix::allAttentive();
    config.route.enabled = false;
    Episode e(config);
    sim::Scenario s = openRoom({0.0, 0.0, kPi / 2}, {3.0, 3.0});
    s.static_segments = {{Vec2(0.0, -6.0), Vec2(0.0, -0.5)}, {Vec2(0.0, 0.5), Vec2(0.0, 6.0)}};
    if (person) {
      sim::PersonSpec p;
      p.position = {-3.0, 0.0};
      p.heading_rad = 0.0;
      p.destinations = {Vec2(3.0, 0.0)};
      s.people = {p};
    }
    e.reset(s, 1);
    double cost = 0.0;
    for (int k = 0; k < 20; ++k) {
      const StepResult r = e.step(Twist2{});
      if (e.done()) break;
      cost -= r.reward;
    }
    return cost;
  };
  EXPECT_EQ(run(false), 0.0);
  EXPECT_GT(run(true), 0.19) << "at least one period held up";
}

}  // namespace
}  // namespace dqn_dovs
