// QNetwork::qValues must not touch the heap once a thread has warmed up: the planner calls it every
// control period. This executable counts heap calls by wrapping glibc's allocator (all four entry points,
// as glibc requires of a replacement); it is a separate test so the wrapper touches nothing else.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstddef>
#include <random>

#include "dqn_dovs/policy/qnetwork.h"

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#define DQN_DOVS_COUNT_ALLOCATIONS 1
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void __libc_free(void* p);
}

namespace {
thread_local bool g_counting = false;
thread_local long g_allocations = 0;
}  // namespace

extern "C" {
void* malloc(std::size_t size) {
  if (g_counting) ++g_allocations;
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
  if (g_counting) ++g_allocations;
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  if (g_counting) ++g_allocations;
  return __libc_realloc(p, size);
}
void free(void* p) { __libc_free(p); }
}
#endif

namespace dqn_dovs {
namespace {

TEST(QNetworkAllocations, SteadyStateDecisionsDoNotAllocate) {
#ifndef DQN_DOVS_COUNT_ALLOCATIONS
  GTEST_SKIP() << "allocation counting needs glibc without sanitizers";
#else
  const QNetwork net = QNetwork::fromContents(makeRandomWeights(DuelingArchitecture{}, 1, {{"v_max", 0.7f}}), "<m>");
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Eigen::VectorXf state(QNetwork::kStateSize);
  for (int i = 0; i < QNetwork::kStateSize; ++i) state[i] = u(rng);
  QNetwork::ActionMask mask;
  mask.fill(true);
  net.selectAction(state, mask);  // first call on this thread sizes the scratch buffer

  // The counter itself must work, or a zero below would prove nothing.
  g_counting = true;
  g_allocations = 0;
  volatile auto* probe = new std::vector<float>(100);
  g_counting = false;
  delete probe;
  ASSERT_GT(g_allocations, 0);

  long allocations = 0;
  int checksum = 0;
  for (int n = 0; n < 100; ++n) {
    state[n % 400] = -state[n % 400];
    g_counting = true;
    g_allocations = 0;
    checksum += net.selectAction(state, mask);
    const auto q = net.qValues(state);
    g_counting = false;
    allocations += g_allocations;
    checksum += q[0] > 0.0f;
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_GE(checksum, 0);
#endif
}

}  // namespace
}  // namespace dqn_dovs
