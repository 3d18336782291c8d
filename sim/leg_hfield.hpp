#pragma once
// The leg's heightfield × foot-tile collision (docs/leg.md, "The foot's heightfield contacts";
// sim/leg_hfield.cpp): MuJoCo 2.2.2's heightfield × mesh collision, the same contacts, without MPR
// on the prisms a separating plane keeps from the tile. Installed in MuJoCo's collision table and
// active only on a thread inside a Scope (a leg step); everywhere else MuJoCo's function runs.
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
