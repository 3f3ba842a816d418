// Evaluates a .dqnw Q-network on a batch of states with the planner's own inference code.
//
//   dqn_dovs_qnet_eval WEIGHTS.dqnw STATES.f32 OUT.f32   states: N x stateSize float32 (408 for one grid channel)
//   (little-endian, row-major)
//                                                         out:    N x 8 float32 Q-values
//   dqn_dovs_qnet_eval --values action|quantiles WEIGHTS.dqnw STATES.f32 OUT.f32
//                                                         the action values the choice maximises (N x 8: CVaR of a
//                                                         quantile network, Q otherwise), or every quantile
//                                                         (N x 8 x quantile count, action-major)
//   dqn_dovs_qnet_eval --info WEIGHTS.dqnw                prints layers, normalisation and metadata
//
// Used by the PyTorch parity test (test/python/test_qnet_parity.py) and to inspect exported files.
#include <Eigen/Core>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "dqn_dovs/policy/qnetwork.h"

namespace {

int usage() {
  std::cerr << "usage: dqn_dovs_qnet_eval WEIGHTS.dqnw STATES.f32 OUT.f32\n"
               "       dqn_dovs_qnet_eval --values q|action|quantiles WEIGHTS.dqnw STATES.f32 OUT.f32\n"
               "       dqn_dovs_qnet_eval --info WEIGHTS.dqnw\n";
  return 2;
}

int info(const std::string& path) {
  const dqn_dovs::QNetwork net = dqn_dovs::QNetwork::load(path);
  std::cout << net.describe() << "normalization:\n";
  for (const auto& [name, value] : net.normalization()) std::cout << "  " << name << " = " << value << "\n";
  std::cout << "metadata:\n" << net.metadata() << "\n";
  return 0;
}

int evaluate(const std::string& weights_path, const std::string& states_path, const std::string& out_path,
             const std::string& values = "q") {
  const dqn_dovs::QNetwork net = dqn_dovs::QNetwork::load(weights_path);
  std::ifstream in(states_path, std::ios::binary);
  if (!in) {
    std::cerr << "dqn_dovs_qnet_eval: cannot open states file '" << states_path << "'\n";
    return 1;
  }
  std::vector<char> raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t state_size = static_cast<std::size_t>(net.stateSize());
  const std::size_t kRowBytes = state_size * sizeof(float);
  if (raw.size() % kRowBytes != 0) {
    std::cerr << "dqn_dovs_qnet_eval: states file '" << states_path << "' has " << raw.size()
              << " bytes, not a multiple of one state (" << kRowBytes << " bytes = " << state_size
              << " float32 for this model)\n";
    return 1;
  }
  const std::size_t n = raw.size() / kRowBytes;
  std::vector<float> states(n * state_size);
  std::copy(raw.begin(), raw.end(), reinterpret_cast<char*>(states.data()));
  std::vector<float> q_all;
  q_all.reserve(n * dqn_dovs::QNetwork::kActionCount);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Map<const Eigen::VectorXf> state(states.data() + i * state_size,
                                                  static_cast<Eigen::Index>(state_size));
    try {
      if (values == "quantiles") {
        const std::vector<float> z = net.quantileValues(state);
        q_all.insert(q_all.end(), z.begin(), z.end());
      } else {
        const auto q = values == "action" ? net.actionValues(state) : net.qValues(state);
        q_all.insert(q_all.end(), q.begin(), q.end());
      }
    } catch (const dqn_dovs::QNetworkInputError& e) {
      std::cerr << "dqn_dovs_qnet_eval: state " << i << ": " << e.what() << "\n";
      return 1;
    }
  }
  std::ofstream out(out_path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(q_all.data()), static_cast<std::streamsize>(q_all.size() * sizeof(float)));
  out.close();
  if (!out) {
    std::cerr << "dqn_dovs_qnet_eval: cannot write '" << out_path << "'\n";
    return 1;
  }
  std::cerr << "evaluated " << n << " states\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 3 && std::string(argv[1]) == "--info") return info(argv[2]);
    if (argc == 6 && std::string(argv[1]) == "--values") {
      const std::string values = argv[2];
      if (values != "q" && values != "action" && values != "quantiles") return usage();
      return evaluate(argv[3], argv[4], argv[5], values);
    }
    if (argc != 4) return usage();
    return evaluate(argv[1], argv[2], argv[3]);
  } catch (const std::exception& e) {
    std::cerr << "dqn_dovs_qnet_eval: " << e.what() << "\n";
    return 1;
  }
}
