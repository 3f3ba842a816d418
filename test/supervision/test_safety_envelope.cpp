// Property tests of the safety envelope (include/dqn_dovs/supervision/safety_envelope.h) over many random robots,
// previous commands, commands and time steps: the output is always finite, in the feasible triangle and
// within the acceleration limits of the previous output; it is the input, bit for bit, when the input was
// admissible; otherwise it is the nearest admissible command (checked against a dense sampling of the
// admissible set), and a non-finite command brakes. The command ramp (applyAccelerationLimits) never needs
// a correction.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "dqn_dovs/supervision/safety_envelope.h"

namespace dqn_dovs {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTol = kEnvelopeTolerance;

RobotLimits randomLimits(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  RobotLimits l;
  if (u(rng) < 0.3) return l;  // the Turtlebot 2 itself, often
  l.v_max = 0.1 + 2.0 * u(rng);
  l.w_max = 0.3 + 5.0 * u(rng);
  l.a_v = 0.05 + 3.0 * u(rng);
  l.a_w = 0.2 + 8.0 * u(rng);
  return l;
}

/// A feasible velocity: uniform in the triangle, on its edges, or at its corners.
Twist2 randomFeasible(const RobotLimits& l, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double kind = u(rng);
  double a = u(rng), b = u(rng);
  if (a + b > 1.0) {
    a = 1.0 - a;
    b = 1.0 - b;
  }
  if (kind < 0.1) {  // on the slanted edges
    b = 1.0 - a;
  } else if (kind < 0.15) {  // corners
    const int c = static_cast<int>(u(rng) * 3.0);
    a = c == 0 ? 1.0 : 0.0;
    b = c == 1 ? 1.0 : 0.0;
  } else if (kind < 0.2) {  // standing still
    a = b = 0.0;
  }
  const double sign = u(rng) < 0.5 ? -1.0 : 1.0;
  return {a * l.v_max, sign * b * l.w_max};
}

double randomStep(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double k = u(rng);
  if (k < 0.05) return 0.0;
  if (k < 0.07) return -0.01 - u(rng);  // the clock went backwards
  if (k < 0.08) return kNaN;
  if (k < 0.09) return kInf;
  if (k < 0.12) return 0.1 + 5.0 * u(rng);  // a long pause
  return 0.15 * u(rng);
}

/// Commands of every kind: admissible ones, small and large overshoots, and non-numbers.
Twist2 randomCommand(const Twist2& prev, const RobotLimits& l, double dt, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double k = u(rng);
  const double step = std::isfinite(dt) && dt > 0.0 ? dt : 0.0;
  if (k < 0.03) return {kNaN, prev.w};
  if (k < 0.06) return {prev.v, u(rng) < 0.5 ? kInf : -kInf};
  if (k < 0.08) return {kNaN, kNaN};
  if (k < 0.35) {
    // Around the previous command, up to twice the acceleration step: about half of them admissible.
    return {prev.v + (2.0 * u(rng) - 1.0) * 2.0 * l.a_v * step, prev.w + (2.0 * u(rng) - 1.0) * 2.0 * l.a_w * step};
  }
  if (k < 0.6) return randomFeasible(l, rng);  // feasible, mostly too far to reach
  return {(3.0 * u(rng) - 1.0) * l.v_max, (6.0 * u(rng) - 3.0) * l.w_max};
}

double effective(double dt) { return std::isfinite(dt) && dt > 0.0 ? dt : 0.0; }

void expectAdmissible(const Twist2& prev, const Twist2& out, const RobotLimits& l, double dt, const char* what) {
  const double s = effective(dt);
  ASSERT_TRUE(std::isfinite(out.v) && std::isfinite(out.w)) << what;
  EXPECT_GE(out.v, -kTol) << what;
  EXPECT_LE(out.v, l.v_max + kTol) << what;
  EXPECT_LE(std::abs(out.w), l.w_max * (1.0 - out.v / l.v_max) + kTol) << what << ": outside the triangle";
  EXPECT_LE(std::abs(out.v - prev.v), l.a_v * s + kTol) << what << ": linear acceleration";
  EXPECT_LE(std::abs(out.w - prev.w), l.a_w * s + kTol) << what << ": angular acceleration";
}

bool admissible(const Twist2& prev, const Twist2& c, const RobotLimits& l, double dt) {
  return envelopeViolations(prev, c, l, dt) == 0;
}

TEST(SafetyEnvelope, OutputIsAlwaysFeasibleFiniteAndWithinTheAccelerationLimits) {
  std::mt19937_64 rng(20240601);
  int corrected = 0, unchanged = 0;
  for (int i = 0; i < 200000; ++i) {
    const RobotLimits l = randomLimits(rng);
    const Twist2 prev = randomFeasible(l, rng);
    const double dt = randomStep(rng);
    const Twist2 cmd = randomCommand(prev, l, dt, rng);
    const EnvelopeResult r = enforceEnvelope(prev, cmd, l, dt);
    expectAdmissible(prev, r.command, l, dt, "output");
    EXPECT_EQ(envelopeViolations(prev, r.command, l, dt), 0u);
    if (::testing::Test::HasFailure()) {
      FAIL() << "case " << i << ": prev (" << prev.v << ", " << prev.w << "), cmd (" << cmd.v << ", " << cmd.w
             << "), dt " << dt << " -> (" << r.command.v << ", " << r.command.w << ")";
    }
    r.modified() ? ++corrected : ++unchanged;
  }
  // Both branches were exercised in earnest.
  EXPECT_GT(corrected, 50000);
  EXPECT_GT(unchanged, 10000);
}

TEST(SafetyEnvelope, AdmissibleInputIsReturnedBitForBit) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int checked = 0;
  for (int i = 0; i < 200000; ++i) {
    const RobotLimits l = randomLimits(rng);
    const Twist2 prev = randomFeasible(l, rng);
    const double dt = randomStep(rng);
    const double s = effective(dt);
    // Sample inside the acceleration box; keep the ones that are also feasible.
    const Twist2 cmd{prev.v + (2.0 * u(rng) - 1.0) * l.a_v * s, prev.w + (2.0 * u(rng) - 1.0) * l.a_w * s};
    if (!admissible(prev, cmd, l, dt)) continue;
    ++checked;
    const EnvelopeResult r = enforceEnvelope(prev, cmd, l, dt);
    ASSERT_FALSE(r.modified()) << "case " << i;
    ASSERT_EQ(r.command.v, cmd.v) << "case " << i;
    ASSERT_EQ(r.command.w, cmd.w) << "case " << i;
  }
  EXPECT_GT(checked, 50000);
}

// The projection is the nearest admissible command (velocities normalised by v_max, w_max): no point of a
// dense sampling of the admissible set is closer. A non-finite command goes to the admissible point nearest
// to a stop, which never speeds up.
TEST(SafetyEnvelope, CorrectionIsTheNearestAdmissibleCommandAndNaNBrakes) {
  std::mt19937_64 rng(99);
  int checked = 0;
  for (int i = 0; i < 3000; ++i) {
    const RobotLimits l = randomLimits(rng);
    const Twist2 prev = randomFeasible(l, rng);
    const double dt = 0.2 * std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    const Twist2 cmd = randomCommand(prev, l, dt, rng);
    const EnvelopeResult r = enforceEnvelope(prev, cmd, l, dt);
    if (!r.modified()) continue;
    ++checked;
    const bool nan = !std::isfinite(cmd.v) || !std::isfinite(cmd.w);
    const double qx = nan ? 0.0 : cmd.v / l.v_max, qy = nan ? 0.0 : cmd.w / l.w_max;
    auto dist = [&](const Twist2& t) { return std::hypot(t.v / l.v_max - qx, t.w / l.w_max - qy); };
    const double d_out = dist(r.command);
    const int n = 60;
    for (int a = 0; a <= n; ++a) {
      for (int b = 0; b <= n; ++b) {
        const Twist2 c{prev.v + (2.0 * a / n - 1.0) * l.a_v * dt, prev.w + (2.0 * b / n - 1.0) * l.a_w * dt};
        if (!admissible(prev, c, l, dt)) continue;
        ASSERT_GE(dist(c), d_out - 1e-9) << "case " << i << ": (" << c.v << ", " << c.w
                                         << ") is admissible and nearer to (" << cmd.v << ", " << cmd.w
                                         << ") than the output (" << r.command.v << ", " << r.command.w << ")";
      }
    }
    if (nan) {
      EXPECT_LE(r.command.v, prev.v + kTol) << "a non-finite command must brake";
      EXPECT_LE(std::abs(r.command.w), std::abs(prev.w) + kTol) << "a non-finite command must brake";
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(SafetyEnvelope, InfeasiblePreviousCommandIsClippedFirst) {
  const RobotLimits l;
  for (const Twist2 prev : {Twist2{2.0, 0.0}, Twist2{0.5, 3.0}, Twist2{-1.0, 0.0}, Twist2{kNaN, 1.0}}) {
    const EnvelopeResult r = enforceEnvelope(prev, {0.3, 0.0}, l, 0.02);
    EXPECT_TRUE(r.violations & kEnvelopeBadPrevious);
    EXPECT_TRUE(l.feasible(r.command, kTol)) << r.command.v << ", " << r.command.w;
    const Twist2 clipped = l.clipToFeasible(prev);
    EXPECT_LE(std::abs(r.command.v - clipped.v), l.a_v * 0.02 + kTol);
    EXPECT_LE(std::abs(r.command.w - clipped.w), l.a_w * 0.02 + kTol);
  }
}

// The stateful filter over long random command streams with random time steps: every output is admissible
// with respect to the previous output, and the counters count the corrections.
TEST(SafetyEnvelope, StreamsStayInsideTheEnvelopeAndCorrectionsAreCounted) {
  std::mt19937_64 rng(4242);
  for (int run = 0; run < 200; ++run) {
    const RobotLimits l = randomLimits(rng);
    SafetyEnvelope env(l, 0.1);
    Twist2 prev{};
    uint64_t corrections = 0;
    for (int k = 0; k < 1000; ++k) {
      const double dt = randomStep(rng);
      const Twist2 cmd = randomCommand(prev, l, dt, rng);
      const EnvelopeResult r = env.filter(cmd, dt);
      const double capped = std::min(effective(dt), 0.1);
      expectAdmissible(prev, r.command, l, capped, "stream");
      if (r.modified()) {
        ++corrections;
        EXPECT_FALSE(env.lastCorrection().empty());
      } else {
        EXPECT_EQ(r.command.v, cmd.v);
        EXPECT_EQ(r.command.w, cmd.w);
      }
      EXPECT_EQ(env.last().v, r.command.v);
      EXPECT_EQ(env.last().w, r.command.w);
      prev = r.command;
      if (::testing::Test::HasFailure()) FAIL() << "run " << run << " step " << k;
    }
    EXPECT_EQ(env.checked(), 1000u);
    EXPECT_EQ(env.corrected(), corrections);
  }
}

// planner_node's ramp (applyAccelerationLimits toward any target, from its last output) always stays in the
// envelope: in normal operation the envelope never has to step in.
TEST(SafetyEnvelope, TheCommandRampNeverNeedsACorrection) {
  std::mt19937_64 rng(31337);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int run = 0; run < 300; ++run) {
    const RobotLimits l = randomLimits(rng);
    SafetyEnvelope env(l, 0.1);
    Twist2 target = randomFeasible(l, rng);
    for (int k = 0; k < 2000; ++k) {
      if (u(rng) < 0.05) target = u(rng) < 0.2 ? Twist2{} : randomFeasible(l, rng);
      const double dt = std::min(effective(randomStep(rng)), 0.1);
      const Twist2 ramp = applyAccelerationLimits(env.last(), target, l, dt);
      const EnvelopeResult r = env.filter(ramp, dt);
      ASSERT_FALSE(r.modified()) << "run " << run << " step " << k << ": " << env.lastCorrection();
    }
  }
}

TEST(SafetyEnvelope, ViolationsAreNamed) {
  EXPECT_EQ(describeEnvelopeViolations(0), "");
  const std::string s = describeEnvelopeViolations(kEnvelopeNotFinite | kEnvelopeLinearAccel);
  EXPECT_NE(s.find("not finite"), std::string::npos);
  EXPECT_NE(s.find("linear acceleration"), std::string::npos);
  const RobotLimits l;
  EXPECT_EQ(envelopeViolations({0.3, 0.0}, {0.3, 0.0}, l, 0.02), 0u);
  EXPECT_EQ(envelopeViolations({0.3, 0.0}, {0.5, 0.0}, l, 0.02), static_cast<uint32_t>(kEnvelopeLinearAccel));
  EXPECT_EQ(envelopeViolations({0.0, 0.0}, {-0.001, 0.0}, l, 0.02), static_cast<uint32_t>(kEnvelopeReverse));
  EXPECT_TRUE(envelopeViolations({0.6, 0.0}, {0.6, 1.0}, l, 1.0) & kEnvelopeTriangle);
  EXPECT_TRUE(envelopeViolations({0.7, 0.0}, {0.8, 0.0}, l, 1.0) & kEnvelopeOverSpeed);
  EXPECT_EQ(envelopeViolations({0.3, 0.0}, {kNaN, 0.0}, l, 0.02), static_cast<uint32_t>(kEnvelopeNotFinite));
}

}  // namespace
}  // namespace dqn_dovs

namespace dqn_dovs {
namespace {

TEST(SafetyEnvelopeReverse, StraightReverseOnlyWhenAdmittedAndWithinItsLimit) {
  const RobotLimits l;
  // Without a reverse allowance any reverse speed is a violation (the default everywhere).
  EXPECT_EQ(envelopeViolations({0.0, 0.0}, {-0.05, 0.0}, l, 0.1), static_cast<uint32_t>(kEnvelopeReverse));
  // With 0.1 m/s: straight reverse within it is admissible, turning while reversing or faster is not.
  EXPECT_EQ(envelopeViolations({0.0, 0.0}, {-0.05, 0.0}, l, 0.1, kEnvelopeTolerance, 0.1), 0u);
  EXPECT_TRUE(envelopeViolations({0.0, 0.0}, {-0.05, 0.2}, l, 0.1, kEnvelopeTolerance, 0.1) & kEnvelopeReverse);
  EXPECT_TRUE(envelopeViolations({-0.1, 0.0}, {-0.15, 0.0}, l, 0.1, kEnvelopeTolerance, 0.1) & kEnvelopeReverse);
  // A previous reverse command is not a bad previous one.
  EXPECT_EQ(envelopeViolations({-0.1, 0.0}, {-0.1, 0.0}, l, 0.02, kEnvelopeTolerance, 0.1), 0u);
  // Projection: a reverse command far off is brought within the acceleration box, straight.
  EnvelopeResult r = enforceEnvelope({0.0, 0.0}, {-0.3, 0.5}, l, 0.02, 0.1);
  EXPECT_NEAR(r.command.v, -l.a_v * 0.02, 1e-12);
  EXPECT_EQ(r.command.w, 0.0);
  EXPECT_EQ(envelopeViolations({0.0, 0.0}, r.command, l, 0.02, kEnvelopeTolerance, 0.1), 0u);
  // From fast forward, a reverse command brakes first (no reverse reachable this step).
  r = enforceEnvelope({0.5, 0.0}, {-0.1, 0.0}, l, 0.02, 0.1);
  EXPECT_NEAR(r.command.v, 0.5 - l.a_v * 0.02, 1e-12);
  // Out of a reverse that cannot end this step, a forward command stays straight reverse, slowing down.
  r = enforceEnvelope({-0.1, 0.0}, {0.3, 0.0}, l, 0.02, 0.1);
  EXPECT_NEAR(r.command.v, -0.1 + l.a_v * 0.02, 1e-12);
  EXPECT_EQ(r.command.w, 0.0);
  EXPECT_EQ(envelopeViolations({-0.1, 0.0}, r.command, l, 0.02, kEnvelopeTolerance, 0.1), 0u);
}

}  // namespace
}  // namespace dqn_dovs
