#include "source_paths.h"

namespace dqn_dovs::test {
const char* sourceDir() { return DQN_DOVS_PATH_SOURCE; }
const char* testDataDir() { return DQN_DOVS_PATH_SOURCE "/test/data"; }
const char* scenariosDir() { return DQN_DOVS_PATH_SOURCE "/data/scenarios"; }
}  // namespace dqn_dovs::test
