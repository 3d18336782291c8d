#pragma once
// A scenario: what one `ambler run` does. Loaded from YAML (docs/scenario.md lists every key and
// default); angles are degrees in the file and radians here.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "terrains/terrain.hpp"

namespace ambler::eval {

// Bad input in a scenario file: the message names the file and the key.
class ScenarioError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SensorSpec {
  int rows = 64;
  int cols = 256;
  double fov_v_rad = 30.0 * 3.14159265358979323846 / 180.0;
  double fov_h_rad = 80.0 * 3.14159265358979323846 / 180.0;
  double noise_k = 0.0003;          // σ_ρ = noise_k · ρ² (ρ in m); 0 = off
  double quantization_m = 0.0762;   // 0 = off
  double ambiguity_m = 19.5;        // 0 = off
  bool mixed_pixels = true;
  double max_range_m = 40.0;
  double beam_divergence_rad = 0.0; // full angle of the beam footprint; 0 = one pixel's spacing
  double dropout = 0.0;             // probability that a pixel returns nothing
};

struct ViewSpec {
  Eigen::Vector3d xyz_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d rpy_rad = Eigen::Vector3d::Zero();  // roll, pitch, yaw
};

struct MapSpec {
  double cell_m = 0.10;
  Eigen::Vector2d x_m{-5.0, 5.0};
  Eigen::Vector2d y_m{-3.0, 8.0};
  double epsilon_rad = 1.0e-5;
  std::string shadows = "gnc";      // gnc | none
  std::string baseline = "cartesian";  // cartesian | none
};

struct Scenario {
  std::filesystem::path file;       // where it was loaded from (for messages and relative paths)
  std::string name;
  std::string description;          // free text; "" when absent
  std::uint64_t seed = 0;
  terrains::TerrainSpec terrain;
  SensorSpec sensor;
  std::vector<ViewSpec> views;
  std::optional<MapSpec> map;       // absent: no maps
};

// Loads and validates a scenario. Throws ScenarioError naming the file and the key for a missing
// file, bad YAML, an unknown key, a wrong type or an out-of-range value.
Scenario loadScenario(const std::filesystem::path& file);

// The same from YAML text; `file` is only used in messages and to resolve relative paths.
Scenario parseScenario(const std::string& yaml_text, const std::filesystem::path& file);

// The scenario with every default filled in, as YAML (degrees, as in the input).
// parseScenario(resolvedYaml(s), s.file) gives back s bit for bit when s came from parseScenario;
// an angle set in code as radians may read back one ulp off (no degree double maps onto it).
std::string resolvedYaml(const Scenario& scenario);

// `text` as a double-quoted YAML scalar (backslash escapes for quotes, backslashes and control
// characters), so strings read back exactly.
std::string yamlQuoted(std::string_view text);

}  // namespace ambler::eval
