// Runs a people predictor file (.dqnp) on scenes of people with the oracle's own inference code.
//
//   dqn_dovs_people_predict PREDICTOR.dqnp SCENES.txt OUT.txt
//     scenes: one scene per line: "N W AX AY BX BY ... X0 Y0 X1 Y1 ..." (N people, W walls and their end points,
//             then each person's historySteps() + 1 positions, oldest first)
//     out:    one line per person of every scene: its futureSteps() predicted positions "X Y ..."
//
// Used by the PyTorch parity test (test/python/test_people_predictor.py).
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "dqn_dovs/perception/people_predictor.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: dqn_dovs_people_predict PREDICTOR.dqnp SCENES.txt OUT.txt\n";
    return 2;
  }
  try {
    const dqn_dovs::PeoplePredictor predictor = dqn_dovs::PeoplePredictor::load(argv[1]);
    std::ifstream in(argv[2]);
    if (!in) {
      std::cerr << "dqn_dovs_people_predict: cannot open scenes file '" << argv[2] << "'\n";
      return 1;
    }
    std::ofstream out(argv[3]);
    if (!out) {
      std::cerr << "dqn_dovs_people_predict: cannot write '" << argv[3] << "'\n";
      return 1;
    }
    out << std::setprecision(9);
    const size_t steps = static_cast<size_t>(predictor.historySteps()) + 1;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      std::istringstream row(line);
      size_t people = 0, wall_count = 0;
      row >> people >> wall_count;
      if (!row || people > 1000 || wall_count > 100000) {
        std::cerr << "dqn_dovs_people_predict: scenes line " << number << ": N or W missing or out of range\n";
        return 1;
      }
      std::vector<dqn_dovs::Segment> walls(wall_count);
      for (dqn_dovs::Segment& w : walls) row >> w.a.x() >> w.a.y() >> w.b.x() >> w.b.y();
      std::vector<std::vector<dqn_dovs::Vec2>> tracks(people);
      for (auto& track : tracks) {
        for (size_t s = 0; s < steps; ++s) {
          double x = 0.0, y = 0.0;
          row >> x >> y;
          track.emplace_back(x, y);
        }
      }
      std::string extra;
      if (!row || people == 0 || (row >> extra)) {
        std::cerr << "dqn_dovs_people_predict: scenes line " << number << ": not N, W, W walls and N x " << steps
                  << " positions\n";
        return 1;
      }
      for (size_t i = 0; i < people; ++i) {
        for (const dqn_dovs::Vec2& p : predictor.predict(tracks, i, walls)) out << p.x() << " " << p.y() << " ";
        out << "\n";
      }
    }
  } catch (const dqn_dovs::PeoplePredictorError& e) {
    std::cerr << "dqn_dovs_people_predict: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
