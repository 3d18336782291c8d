// The world stage: the scenario's terrain as a MuJoCo world (generated and written as MJCF, or the
// user's MJCF as it is), its Embree ray scene and ground truth, and a picture of the terrain.
#include <algorithm>

#include "eval/figures.hpp"
#include "eval/io.hpp"
#include "eval/stages.hpp"
#include "terrains/terrain.hpp"

namespace ambler::eval::stages {

namespace {

// A picture grid over the world's horizontal extent at about the terrain's resolution.
perception::MapGrid pictureGrid(const Eigen::AlignedBox3d& b, double cell) {
  const double extent = std::max(b.max().x() - b.min().x(), b.max().y() - b.min().y());
  cell = std::max(cell, extent / 1500.0);
  return perception::MapGrid::covering(b.min().x(), b.max().x(), b.min().y(), b.max().y(), cell);
}

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  Stopwatch t;
  std::filesystem::create_directories(s.out / "world");
  if (sc.terrain.kind == terrains::TerrainKind::Mjcf) {
    s.world.emplace(sim::World::load(sc.terrain.mjcf));
    s.world->saveLastXml(s.out / "world" / "world.xml");
    s.world_xml = s.out / "world" / "world.xml";
    s.say("world     " + sc.terrain.mjcf + " (" + std::to_string(s.world->geomCount()) + " geoms)");
  } else {
    const terrains::Terrain terrain = terrains::makeTerrain(sc.terrain, sc.seed);
    const std::filesystem::path xml = sim::writeWorld(terrain, s.out / "world", sc.name);
    s.world_xml = xml;
    s.world.emplace(sim::World::load(xml));
    s.say("world     " + std::to_string(terrain.ground.rows()) + "x" + std::to_string(terrain.ground.cols()) +
          " heightfield, " + std::to_string(terrain.rocks.size()) + " rocks -> " + xml.string());
  }
  s.scene = std::make_unique<sim::RayScene>(*s.world);
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
