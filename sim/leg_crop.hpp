// sim::Leg's crop of the world (docs/leg.md, "One leg per run"): the whole-world leg model's
// static geoms written again as MJCF, only those the foot can reach, and then made the world's to
// the bit. Internal to sim/: the model pointers are MuJoCo's.
#pragma once
#include <optional>
#include <string>
#include <vector>

struct mjModel_;

namespace ambler::sim {

// The world's static geoms as MJCF (a <mujoco> for legXml's <include>): the heightfields whole
// (MuJoCo 2.2.2 compiles one given nrow and ncol with zero data, to be filled from the world's), the
// other geoms where their bounding sphere reaches the box [x0, x1] × [y0, y1] (planes always), in
// the world's order, meshes as their compiled vertices and faces, every contact parameter copied.
// `kept` holds the world's ids of the geoms written.
struct LegCrop {
  std::string xml;
  std::vector<int> kept;
  int dropped = 0;
};

// The crop of the whole-world leg model `whole` (its world body's geoms; the leg is added by
// legXml), or nullopt when it holds more than static geoms the crop can copy: moving bodies,
// tendons, equality constraints, contact pairs, excludes, mocap bodies or a geom type it does not
// write.
std::optional<LegCrop> cropWorld(const mjModel_* whole, double x0, double x1, double y0, double y1);

// Makes the crop's compiled model `crop` hold the world's geoms to the bit: the heightfield data,
// and what compiling a mesh again rounds otherwise (re-centring its float vertices moves them and
// the geom's position by 1-4 nm on the sandbox's rocks). False if a mesh compiled again has other
// sizes than the world's (then the crop is not to be used).
bool copyWorldGeoms(const mjModel_* whole, const std::vector<int>& kept, mjModel_* crop);

}  // namespace ambler::sim
