#pragma once
// Internal to eval/scenario*.cpp: what the reader (scenario.cpp, scenario_reader.cpp) and the
// writer (scenario_writer.cpp) share. Not part of the eval library's interface.
#include <array>
#include <limits>
#include <string>
#include <string_view>
#include <utility>

#include "terrains/terrain.hpp"

namespace ambler::eval::scenario_detail {

using terrains::TerrainKind;

constexpr double kInf = std::numeric_limits<double>::infinity();

constexpr std::array<std::pair<std::string_view, TerrainKind>, 7> kKinds{{
    {"plane", TerrainKind::Plane},
    {"fractal", TerrainKind::Fractal},
    {"sinusoid", TerrainKind::Sinusoid},
    {"steps", TerrainKind::Steps},
    {"mars", TerrainKind::Mars},
    {"mjcf", TerrainKind::Mjcf},
    {"dem", TerrainKind::Dem},
}};

// Number text, defined in scenario_writer.cpp: degToRad is how the reader turns degrees into
// radians, and shortest (base::plainText) and degreesText write them back so that they read back
// bit for bit.
double degToRad(double deg);
std::string shortest(double v);
std::string degreesText(double rad);

}  // namespace ambler::eval::scenario_detail
