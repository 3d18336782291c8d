#pragma once
// Rocks after Golombek & Rapp (1997): sizes from the cumulative fractional area model, shapes
// as irregular convex meshes, placed without overlap (docs/terrains.md, "Rocks").
#include <cstdint>
#include <vector>

#include "terrains/heightfield.hpp"
#include "base/random.hpp"
#include "terrains/terrain.hpp"

namespace ambler::terrains {

// Throws std::invalid_argument naming the field for a spec that cannot be sampled.
void checkRockSpec(const RockSpec& spec);

// q(k) = 1.79 + 0.152/k (1/m).
double rockDecay(double abundance_k);

// The model's fractional area covered by rocks with diameter in [D, max]: F(D) − F(Dmax),
// F(D) = k·exp(−q·D), with D clamped to [min, max].
double rockCumulativeFraction(const RockSpec& spec, double diameter_m);

// Expected rocks per square metre with diameter in [min, max]: ∫ k·q·exp(−qD)/(πD²/4) dD.
double rockNumberDensity(const RockSpec& spec);

// N = round(area·rockNumberDensity) diameters by stratified inverse-CDF sampling
// (D_i = G⁻¹((i + u_i)/N)), largest first. Throws std::invalid_argument past 2e6 rocks.
std::vector<double> sampleRockDiameters(const RockSpec& spec, double area_m2, base::Rng& rng);

// An irregular convex rock of plan-view diameter D, centred at the origin: the hull of 30–60
// jittered points on an ellipsoid (horizontal semi-axes a ≥ b ≥ 0.6a, height semi-axis c in
// [0.25, 0.5]·D), turned by a random yaw, then scaled in x and y to a footprint of πD²/4.
Rock makeRockShape(double diameter_m, base::Rng& rng);

// Rocks for the whole ground, largest first, each at a uniform random position with its
// footprint inside the grid and its bounding circle clear of earlier rocks, its centre sunk below
// the ground at that point by a random 0–30 % of its top's height above the centre. Throws
// std::invalid_argument for a bad spec, a rock wider than the terrain, or a rock that finds no
// free place in 5000 tries (abundance too high for the area).
std::vector<Rock> makeRocks(const RockSpec& spec, const Heightfield& ground, std::uint64_t key);

// The area of the rock's top-down silhouette (2-D convex hull of its vertices).
double planViewArea(const Rock& rock);
// The largest horizontal distance of a vertex from the centre.
double boundingRadius(const Rock& rock);
// Every vertex on or behind every face plane (within `tolerance` metres).
bool isConvex(const Rock& rock, double tolerance = 1e-9);
// Every edge shared by exactly two faces, with opposite directions.
bool isClosed(const Rock& rock);

}  // namespace ambler::terrains
