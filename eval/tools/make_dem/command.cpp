// `ambler make-dem` (docs/terrains.md, "DEM terrains"): the sample Mars DTM as a GeoTIFF.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "eval/geo/dem.hpp"
#include "eval/tools/command.hpp"

namespace ambler::eval {

void addMakeDemCommand(CLI::App& app, Commands& out) {
  struct Options {
    std::string out;
    std::uint64_t seed = 1;
  };
  auto o = std::make_shared<Options>();
  CLI::App* make_dem = app.add_subcommand("make-dem", "Write the sample DEM (a HiRISE-like 1 m Mars DTM of the "
                                                      "documented procedural model, docs/terrains.md) as a GeoTIFF.");
  make_dem->add_option("--out,-o", o->out, "GeoTIFF to write (scenarios/dem/sample_dtm.tif is seed 1)")->required();
  make_dem->add_option("--seed", o->seed, "Seed of the fBm and the craters")->capture_default_str();
  out.push_back({make_dem, [o] {
                   writeSampleDem(o->out, o->seed);
                   std::fprintf(stderr, "ambler: wrote %s\n", o->out.c_str());
                 }});
}

}  // namespace ambler::eval
