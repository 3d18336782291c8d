#pragma once
// Footfall evaluation (paper §5): every candidate foot centre of a region R scored by the five
// measures of "best" of §5 and one that uses the map's uncertainty (docs/footfall.md).
// The foot is a flat disk (§5: 30 cm); its disk on a map is the cells whose centres lie within
// foot_diameter/2 of the candidate's centre, and candidates are cell centres.
// Convention: LOWER SCORE = BETTER for every method; NaN = not a candidate. Onboard code.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string_view>
#include <vector>

#include "perception/elevation_map.hpp"

namespace ambler::perception {

enum class FootfallMethod {
  MaxMin,                // z_max − z_min over the disk [m]
  PlanarFit,             // RMS residual of the disk's least-squares plane [m]; NaN if its normal
                         // is more than max_normal_deviation_deg from the leg's axis (vertical)
  SupportArea,           // d_opt [m]: the least sinkage from the disk's highest point at which
                         // the cells within d_opt of it cover min_support_fraction of the disk
  FreeVolume,            // V = cell²·(N·z_max − Σz_i) [m³]
  Equilibrium,           // V + moment_weight·E/(foot_diameter/2) [m³], E = √(m_x² + m_y²) [m⁴]
  EquilibriumUncertain,  // Equilibrium on pessimistic surfaces from σ_z and shadow ceilings
  EquilibriumSoil,       // Equilibrium on the surface after the soil yields (the ground lowered by
                         // sinkage_m, cells standing above it, rocks, not), over the cells within
                         // one cell of the foot's rim [m³]
};
// The methods a scenario runs unless it lists its own: §5's five and the uncertainty-aware one.
inline constexpr std::array<FootfallMethod, 6> kFootfallMethods = {
    FootfallMethod::MaxMin,     FootfallMethod::PlanarFit,   FootfallMethod::SupportArea,
    FootfallMethod::FreeVolume, FootfallMethod::Equilibrium, FootfallMethod::EquilibriumUncertain};
// Every method, the soil-aware one too.
inline constexpr std::array<FootfallMethod, 7> kAllFootfallMethods = {
    FootfallMethod::MaxMin,      FootfallMethod::PlanarFit,          FootfallMethod::SupportArea,
    FootfallMethod::FreeVolume,  FootfallMethod::Equilibrium,        FootfallMethod::EquilibriumUncertain,
    FootfallMethod::EquilibriumSoil};

// "max_min", "planar_fit", "support_area", "free_volume", "equilibrium", "equilibrium_uncertain",
// "equilibrium_soil".
std::string_view footfallMethodName(FootfallMethod m);
// The method of that name; throws std::invalid_argument naming it if there is none.
FootfallMethod footfallMethodFromName(std::string_view name);

struct FootfallConfig {
  // The Ambler's foot: a flat disk 30 cm across (§5).
  double foot_diameter_m = 0.30;
  // Support area: A_min as a fraction of the disk's cells. §5 gives no value. Half the sole:
  // the scenario's 4000 N leg load over half the 0.0707 m² sole is 113 kPa, the order of the
  // allowable bearing pressure of medium sand; a full sole (1.0) would make d_opt the max-min.
  double min_support_fraction = 0.5;
  // Planar fit: §5's "plane normal approximately parallel to the leg" as a hard limit on the
  // angle between the fitted normal and vertical (the Ambler's legs are vertical). §5 gives no
  // number; 15° is our reading of "approximately" — a sole tilted more than that rests on its rim.
  double max_normal_deviation_deg = 15.0;
  // Equilibrium: §5 minimises V and E together; we add them as V + w·E/R (R the foot radius):
  // E/R is the free volume which, at the rim, has moment E, so w = 1 weighs imbalance as much as
  // volume (a hole at the rim counts twice, one at the centre once).
  double moment_weight = 1.0;
  // The five methods of §5: the largest share of a disk's cells that may be unknown (Shadow or
  // Unseen). 0 (default): a disk with any unknown cell is no candidate — the rover does not put
  // its foot where it has not seen. Above 0, unknown cells are filled with the least-squares plane
  // of the disk's Known cells (needs ≥ 3 non-collinear Known cells) before scoring.
  double max_unknown_fraction = 0.0;
  // EquilibriumUncertain: the surfaces z ± k·σ_z; k = 2 is a one-sided 97.7 % bound per cell.
  double sigma_k = 2.0;
  // EquilibriumSoil (docs/footfall.md, "Soil"): how far the ground sinks under the foot's load
  // (Bekker's law for the soil and the load; 0 on rigid ground).
  double sinkage_m = 0.0;
  // EquilibriumSoil: a cell is rigid (a rock: it does not sink) where it stands more than
  // rigid_height_m above the ground, the map's grey opening by a disk rigid_width_m across (what
  // is left when everything narrower than that is taken off).
  double rigid_height_m = 0.03;
  double rigid_width_m = 0.6;
};

// Candidate centres: a rectangle of cells of the map grid (row-major: row 0 is the largest y).
struct CellRegion {
  int row0 = 0, col0 = 0, rows = 0, cols = 0;
};
// The cells of `grid` whose centres lie in [x0, x1] × [y0, y1] of the map frame (may be empty).
CellRegion regionOfBox(const MapGrid& grid, double x0, double x1, double y0, double y1);

struct FootfallScores {
  FootfallMethod method{};
  // Map-sized (grid rows × cols): the score of every candidate centre, lower is better; NaN
  // outside the region, where the disk leaves the map, and where the method rejects the disk.
  Raster<float> score;
  // PlanarFit only (empty otherwise): the fitted normal's angle from vertical [deg], for every
  // disk that was fitted (also those rejected by max_normal_deviation_deg); NaN elsewhere.
  Raster<float> tilt_deg;
  // The lowest score's cell (row, col); ties go to the first in row-major order. nullopt: no
  // candidate.
  std::optional<Eigen::Vector2i> best;
  double best_score = std::numeric_limits<double>::quiet_NaN();
};

// Unknown cells. The five methods of §5 see a disk's Known cells only (max_unknown_fraction
// above). EquilibriumUncertain: a Known cell spans [z − kσ, z + kσ] (a non-finite σ rejects the
// disk); a Shadow cell with a ceiling is taken at its ceiling (its terrain lies below, so may
// reach it); a Shadow cell without a ceiling or an Unseen cell rejects the disk. The contact
// height is the highest upper bound, the free volume and moments are taken down to the lower
// bounds: V = cell²·(N·max u − Σ l_i), m_x = cell²·Σ x_i(max u − l_i).
//
// Scores each candidate centre of `region` (clipped to the map) whose whole disk lies on the map,
// by each method of `methods` (one result per method, in that order). The same bits on any
// number of threads. Throws std::invalid_argument if the configuration is out of range, the
// disk holds fewer than 3 cells, the region has no cell on the map, or the foot is wider than
// the region (§5: the foot B is a subregion of R).
std::vector<FootfallScores> evaluateFootfalls(const ElevationMap& map, const CellRegion& region,
                                              const FootfallConfig& config = {},
                                              const std::vector<FootfallMethod>& methods =
                                                  {kFootfallMethods.begin(), kFootfallMethods.end()});

// A raster held elsewhere, read in place: row-major, its cells contiguous, any stride between rows.
template <class T>
using RasterView = Eigen::Map<const Raster<T>, 0, Eigen::OuterStride<>>;
template <class T>
RasterView<T> rasterView(const Raster<T>& r) {
  return RasterView<T>(r.data(), r.rows(), r.cols(), Eigen::OuterStride<>(r.cols()));
}

// A map's layers where someone else holds them (the Python module's numpy arrays), read without a
// copy; each should be grid.rows × grid.cols.
struct ElevationLayers {
  MapGrid grid;
  RasterView<float> elevation, sigma, ceiling;  // ceiling: the shadow ceiling
  RasterView<std::uint8_t> state;               // CellState values
  explicit ElevationLayers(const ElevationMap& map)
      : grid(map.grid()), elevation(rasterView(map.elevation())), sigma(rasterView(map.sigma())),
        ceiling(rasterView(map.shadowCeiling())), state(rasterView(map.state())) {}
  ElevationLayers(const MapGrid& g, const RasterView<float>& z, const RasterView<float>& s,
                  const RasterView<float>& c, const RasterView<std::uint8_t>& st)
      : grid(g), elevation(z), sigma(s), ceiling(c), state(st) {}
};

// The same on layers held elsewhere: the same bits as on an ElevationMap holding those values (the
// function above calls this one). Also throws std::invalid_argument naming a layer whose size is
// not the grid's.
std::vector<FootfallScores> evaluateFootfalls(const ElevationLayers& map, const CellRegion& region,
                                              const FootfallConfig& config = {},
                                              const std::vector<FootfallMethod>& methods =
                                                  {kFootfallMethods.begin(), kFootfallMethods.end()});

}  // namespace ambler::perception
