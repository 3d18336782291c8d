#pragma once
// The stages of a run, in order (docs/architecture.md, "Adding a stage"). Each is a small unit in
// eval/run/stages/ that calls the library for its work, scores it against ground truth and writes its
// files; the runner only calls them in turn.
#include <vector>

#include "eval/run/run_state.hpp"
#include "sim/leg.hpp"

namespace ambler::eval {

struct Stage {
  const char* name;
  bool (*wanted)(const Scenario&);  // whether the scenario asks for this stage
  void (*run)(RunState&);
};

// The registered stages, in the order a run calls them.
const std::vector<Stage>& runStages();

// The stages (eval/run/stages/<name>.cpp).
namespace stages {
Stage world();      // the MuJoCo world, its ray scene and ground truth; terrain.png
Stage scan();       // one ERIM scan per view; scans/
Stage map();        // the locus map of each scan, scored; maps/
Stage cartesian();  // the Cartesian baseline of each scan, scored; maps/
Stage match();      // each pair of views registered by each method, scored; matching/
Stage merge();      // the composite map of every view, scored; maps/composite_*
Stage footfall();   // each method's footfall on a map, scored on the true surface; footfall/
Stage leg();        // the MuJoCo leg steps on each choice; leg/, world/leg.xml
Stage traverse();   // the rover walks the path: each stop scanned, registered, merged; traverse/
}  // namespace stages

// The leg stage's leg for a scenario with footfall and leg sections: the scenario's foot, load and
// soil, no hold after settling; and the footfall region it steps in.
sim::LegConfig legConfig(const Scenario& sc);
sim::LegRegion legRegion(const Scenario& sc);
// equilibrium_soil's sinkage (perception::FootfallConfig::sinkage_m): Bekker's law for the leg
// section's load on sand (docs/leg.md); 0 on rock or without a leg or footfall section.
double soilSinkage(const Scenario& sc);

}  // namespace ambler::eval
