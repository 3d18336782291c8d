// The world stage: the scenario's terrain as a MuJoCo world (generated and written as MJCF, or the
// user's MJCF as it is), its Embree ray scene and ground truth, and a picture of the terrain.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include "eval/geo/dem.hpp"
#include "eval/pictures/figures.hpp"
#include "eval/scenario/io.hpp"
#include "base/text.hpp"
#include "eval/run/stages.hpp"
#include "terrains/terrain.hpp"

namespace ambler::eval::stages {

namespace {

// A picture grid over the world's horizontal extent at about the terrain's resolution.
perception::MapGrid pictureGrid(const Eigen::AlignedBox3d& b, double cell) {
  const double extent = std::max(b.max().x() - b.min().x(), b.max().y() - b.min().y());
  cell = std::max(cell, extent / 1500.0);
  return perception::MapGrid::covering(b.min().x(), b.max().x(), b.min().y(), b.max().y(), cell);
}

std::string metres(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f", v);
  return text;
}

// A view the terrain would swallow or that has no terrain under it: refused before the run writes
// anything (docs/errors.md, "Views: over the terrain and above it"). `surface` is the terrain's
// top at (x, y) or nullopt outside it; `free_below` says whether the sensor sees ground straight
// below it.
void checkView(const Scenario& sc, std::size_t k, const std::optional<double>& surface, bool free_below) {
  const Eigen::Vector3d& p = sc.views[k].xyz_m;
  const std::string where = (sc.file.empty() ? std::string("<string>") : sc.file.string()) + ": views[" +
                            std::to_string(k) + "].xyz_m: ";
  std::string got = "[";  // (appended, not "[" + ...: GCC 12 warns a false -Wrestrict on that)
  got += base::plainText(p.x()) + ", " + base::plainText(p.y()) + ", " +
         base::plainText(p.z()) + "]";
  if (!surface)
    throw ScenarioError(where + "expected a sensor over the terrain, got " + got + ", where there is no ground");
  if (!free_below || !(p.z() > *surface))
    throw ScenarioError(where + "expected the sensor above the terrain, whose surface is at z = " + metres(*surface) +
                        " there, got z = " + base::plainText(p.z()));
}

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  base::Stopwatch t;
  // Everything that can refuse the scenario comes before the first file: the run directory is
  // made here, once the views are known to stand over the terrain.
  if (sc.terrain.kind == terrains::TerrainKind::Mjcf) {
    s.world.emplace(sim::World::load(sc.terrain.mjcf));
    s.scene = std::make_unique<sim::RayScene>(*s.world);
    const sim::GroundTruth truth(*s.scene);
    for (std::size_t k = 0; k < sc.views.size(); ++k) {
      // A world may overhang (a table): the sensor must see something straight below it.
      const Eigen::Vector3d& p = sc.views[k].xyz_m;
      checkView(sc, k, truth.elevation(p.x(), p.y()), s.scene->intersect(p, -Eigen::Vector3d::UnitZ()).has_value());
    }
    createOutDir(s.out);
    createOutDir(s.out / "world");
    s.world->saveLastXml(s.out / "world" / "world.xml");
    s.world_xml = s.out / "world" / "world.xml";
    s.say("world     " + sc.terrain.mjcf + " (" + std::to_string(s.world->geomCount()) + " geoms)");
  } else {
    std::optional<DemSurface> dem;
    const terrains::Terrain terrain = scenarioTerrain(sc, &dem);  // a DEM may refuse: before any file
    for (std::size_t k = 0; k < sc.views.size(); ++k)
      checkView(sc, k, terrains::surfaceAt(terrain, sc.views[k].xyz_m.x(), sc.views[k].xyz_m.y()), true);
    createOutDir(s.out);
    createOutDir(s.out / "world");
    const std::filesystem::path xml = sim::writeWorld(terrain, s.out / "world", sc.name);
    s.world_xml = xml;
    s.world.emplace(sim::World::load(xml));
    s.say("world     " + std::to_string(terrain.ground.rows()) + "x" + std::to_string(terrain.ground.cols()) +
          " heightfield, " + std::to_string(terrain.rocks.size()) + " rocks -> " + xml.string());
    s.scene = std::make_unique<sim::RayScene>(*s.world);
    if (sc.traverse) s.terrain = terrain;  // the body's poses stand on it
    if (dem) {
      // Map rasters sit on the DEM: its CRS, the world origin at the window centre.
      s.geo = dem->frame;
      s.terrain_resolved = sc.terrain;  // scenario.resolved.yaml writes the centre and offset used
      s.terrain_resolved->dem_centre_m = Eigen::Vector2d(dem->frame.origin_x_m, dem->frame.origin_y_m);
      s.terrain_resolved->dem_vertical_offset_m = dem->vertical_offset_m;
      s.metrics["terrain"] = {{"dem_crs", dem->crs_name},
                              {"dem_pixel_m", {dem->pixel_m[0], dem->pixel_m[1]}},
                              {"origin_en_m", {dem->frame.origin_x_m, dem->frame.origin_y_m}},
                              {"vertical_offset_m", dem->vertical_offset_m}};
      const double off = dem->vertical_offset_m;
      s.say("world     DEM " + sc.terrain.dem + " (" + dem->crs_name + "): world origin at E " +
            base::plainText(dem->frame.origin_x_m) + ", N " + base::plainText(dem->frame.origin_y_m) +
            ", z = DEM height " + (off < 0 ? "+ " : "- ") + metres(std::abs(off)) + " m");
    }
  }
  s.truth = std::make_unique<sim::GroundTruth>(*s.scene);
  s.addTime("world", t.seconds());

  const auto grid = pictureGrid(s.scene->bounds(), sc.terrain.cell_m);
  writePng(s.out / "terrain.png",
           shadedRelief(s.truth->elevation(grid).elevation(), grid.cell, sc.name + ": terrain (ground truth)"));
}

}  // namespace

Stage world() {
  return {"world", [](const Scenario&) { return true; }, run};
}

}  // namespace ambler::eval::stages
