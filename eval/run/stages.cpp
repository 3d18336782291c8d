#include "eval/run/stages.hpp"

#include <cstdio>

namespace ambler::eval {

void RunState::say(const std::string& line) const {
  if (progress) std::fprintf(stderr, "ambler: %s\n", line.c_str());
}

void RunState::addTime(const char* key, double seconds) {
  timing[key] = (timing.contains(key) ? timing[key].get<double>() : 0.0) + seconds;
}

std::string viewName(int k) { return "view_" + std::to_string(k); }

const std::vector<Stage>& runStages() {
  // One line per stage: a new stage adds its file in eval/run/stages/ and its line here.
  static const std::vector<Stage> all = {
      stages::world(),
      stages::scan(),
      stages::map(),
      stages::cartesian(),
      stages::match(),
      stages::merge(),
      stages::footfall(),
      stages::leg(),
      stages::traverse(),
  };
  return all;
}

}  // namespace ambler::eval
