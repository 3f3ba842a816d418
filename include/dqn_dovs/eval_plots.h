// Pictures of an evaluation (OpenCV): success rate against obstacle count, and one episode's paths.
#pragma once

#include <string>

#include "dqn_dovs/eval.h"

namespace dqn_dovs {

/// Success rate (y, 0..1) against obstacle count (x), one coloured line per method with a legend, written as a
/// PNG. Throws EvalError naming the file when it cannot be written or the summary is empty.
void plotSuccessVsObstacles(const EvalSummary& summary, const std::string& path);

/// One episode from above: the room and its walls, every obstacle's path (start circled, final position marked
/// with an X), the robot's path, start and goal (with the goal tolerance), axes in metres and a legend. The
/// record must carry its paths (EvalConfig::keep_paths). Throws EvalError naming the file or the missing paths.
void plotTrajectory(const EpisodeRecord& record, const sim::Scenario& scenario, double goal_tolerance_m,
                    const std::string& path);

}  // namespace dqn_dovs
