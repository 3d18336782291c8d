#pragma once
// The leg's heightfield × foot-tile collision (docs/leg.md, "The foot's heightfield contacts"), included by
// sim/leg_step.cpp only. MuJoCo 2.2.2 collides a convex mesh with a heightfield by running MPR
// (libccd's ccdMPRPenetration) on every prism of the heightfield's cells under the mesh's bounding
// box whose top reaches the mesh's lowest point. Under the foot's 6 cm tiles on the sandbox's 2 cm
// sand that is ~210 MPR calls a collision pass, of which ~11 find a contact: a tile tilted by a few
// degrees, or a crater that keeps the sand's relief, puts most prisms of its box below the tile or
// beside it. This is the same computation in the same order — the same sub-grid, the same prisms,
// the same MPR on the same support functions and numbers, the same contacts — except that a prism
// that a separating plane shows to be more than kCullGap away from the tile is skipped instead of
// handed to MPR, which would have found no contact there. Installed in mjCOLLISIONFUNC for
// (heightfield, mesh) and active only on a thread inside a leg step that asks for it (a
// thread_local switch); everywhere else the table's original function runs.
#include <mujoco/mujoco.h>

#include <memory>

namespace ambler::sim::hfield {

struct Context;

// Puts the culling collision into MuJoCo's table for (heightfield, mesh), once per process; false
// when the table has no function there, and the leg then runs MuJoCo's own. Call it before any
// step runs (the table is process-wide; the function acts only inside a Scope).
bool install();

// Culls on this thread while it lives (a leg step on `m`), if `on`.
class Scope {
 public:
  Scope(const mjModel* m, bool on);
  ~Scope();
  Scope(const Scope&) = delete;
  Scope& operator=(const Scope&) = delete;

 private:
  const void* was_;
  std::unique_ptr<Context> context_;
};

}  // namespace ambler::sim::hfield
