// Where the tests find the package's files (the source tree, test/data, data/scenarios). The folders are compiled
// into one small library (source_paths.cpp), not into every test's command line, so that a test compiles the same
// in any checkout and a compiler cache shares it between checkouts.
#pragma once

namespace dqn_dovs::test {
/// The package's source folder (absolute, no trailing slash).
const char* sourceDir();
/// test/data of the source folder.
const char* testDataDir();
/// data/scenarios of the source folder (data/scenarios/README.md).
const char* scenariosDir();
}  // namespace dqn_dovs::test

#define DQN_DOVS_SOURCE_DIR (::dqn_dovs::test::sourceDir())
#define DQN_DOVS_TEST_DATA_DIR (::dqn_dovs::test::testDataDir())
#define DQN_DOVS_SCENARIOS_DIR (::dqn_dovs::test::scenariosDir())
