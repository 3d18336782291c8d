// The elevation map's layers and queries: a new map is all unseen and NaN; setKnown, setUnknown
// and setShadow keep the layers consistent (unknown is NaN *and* a state); the (x, y) queries go
// through MapGrid::cellOf (north-up, half-open cells); count tallies the states.
#include <gtest/gtest.h>

#include <cmath>

#include "perception/elevation_map.hpp"

namespace ambler::perception {
namespace {

// 3 × 4 cells of 0.5 m: x in [−1, 1), y in (0.5, 2] (row 0 is the north row, y in (1.5, 2]).
const MapGrid kGrid{-1.0, 2.0, 0.5, 3, 4};

TEST(ElevationMap, NewMapIsUnseenAndNaN) {
  const ElevationMap m(kGrid);
  EXPECT_TRUE(m.grid().sameAs(kGrid));
  ASSERT_EQ(m.elevation().rows(), 3);
  ASSERT_EQ(m.elevation().cols(), 4);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      EXPECT_EQ(m.stateAt(r, c), CellState::Unseen);
      EXPECT_TRUE(std::isnan(m.elevation()(r, c)) && std::isnan(m.sigma()(r, c)) &&
                  std::isnan(m.shadowCeiling()(r, c)));
    }
  EXPECT_EQ(m.count(CellState::Unseen), 12);
  EXPECT_EQ(m.count(CellState::Known), 0);
}

TEST(ElevationMap, SettersKeepTheLayersConsistent) {
  ElevationMap m(kGrid);
  m.setShadow(1, 2, 0.75f);
  EXPECT_EQ(m.stateAt(1, 2), CellState::Shadow);
  EXPECT_EQ(m.shadowCeiling()(1, 2), 0.75f);
  EXPECT_TRUE(std::isnan(m.elevation()(1, 2)));
  m.setKnown(1, 2, 3.5f, 0.25f);  // known: the ceiling goes
  EXPECT_EQ(m.stateAt(1, 2), CellState::Known);
  EXPECT_EQ(m.elevation()(1, 2), 3.5f);
  EXPECT_EQ(m.sigma()(1, 2), 0.25f);
  EXPECT_TRUE(std::isnan(m.shadowCeiling()(1, 2)));
  m.setUnknown(1, 2, CellState::Shadow);  // shadow without a ceiling: every layer NaN
  EXPECT_EQ(m.stateAt(1, 2), CellState::Shadow);
  EXPECT_TRUE(std::isnan(m.elevation()(1, 2)) && std::isnan(m.sigma()(1, 2)) && std::isnan(m.shadowCeiling()(1, 2)));
  m.setKnown(0, 0, 1.0f, 0.1f);
  m.setKnown(2, 3, 2.0f, 0.2f);
  m.setUnknown(0, 1, CellState::Unseen);
  EXPECT_EQ(m.count(CellState::Known), 2);
  EXPECT_EQ(m.count(CellState::Shadow), 1);
  EXPECT_EQ(m.count(CellState::Unseen), 9);
  EXPECT_EQ(m.count(CellState::Known) + m.count(CellState::Shadow) + m.count(CellState::Unseen), kGrid.cells());
}

// Cell (r, c) covers x in [x_min + c·cell, x_min + (c+1)·cell) and y in (y_max − (r+1)·cell,
// y_max − r·cell]: the queries answer for the cell containing the point, nothing outside the grid
// or for a cell that is not known (dyadic bounds: the edges are exact).
TEST(ElevationMap, QueriesByPointFindTheCellContainingIt) {
  ElevationMap m(kGrid);
  m.setKnown(0, 0, 1.0f, 0.1f);   // x in [−1, −0.5), y in (1.5, 2]
  m.setKnown(2, 3, 2.0f, 0.2f);   // x in [0.5, 1), y in (0.5, 1]
  m.setShadow(1, 1, 0.5f);        // x in [−0.5, 0), y in (1, 1.5]
  EXPECT_EQ(*m.elevationAt(-0.9, 1.9), 1.0);
  EXPECT_EQ(*m.sigmaAt(-0.9, 1.9), 0.1f);
  EXPECT_EQ(*m.elevationAt(-1.0, 2.0), 1.0);     // the north-west corner belongs to (0, 0)
  EXPECT_EQ(*m.elevationAt(-0.5 - 1e-12, 1.5 + 1e-12), 1.0);
  EXPECT_FALSE(m.elevationAt(-0.5, 1.9));        // x = −0.5 is column 1's
  EXPECT_FALSE(m.elevationAt(-0.9, 1.5));        // y = 1.5 is row 1's
  EXPECT_EQ(*m.elevationAt(0.99, 0.51), 2.0);
  EXPECT_EQ(*m.sigmaAt(0.99, 0.51), 0.2f);
  EXPECT_FALSE(m.elevationAt(1.0, 0.75));        // east of the grid
  EXPECT_FALSE(m.elevationAt(0.75, 0.5));        // south of it
  EXPECT_FALSE(m.elevationAt(-1.01, 1.9));
  EXPECT_FALSE(m.elevationAt(-0.9, 2.01));
  EXPECT_FALSE(m.elevationAt(-0.25, 1.25));      // a shadow cell has no elevation
  EXPECT_FALSE(m.sigmaAt(-0.25, 1.25));
  EXPECT_EQ(m.stateAt(-0.25, 1.25), CellState::Shadow);
  EXPECT_EQ(m.stateAt(0.25, 1.25), CellState::Unseen);
  EXPECT_EQ(m.stateAt(5.0, 5.0), CellState::Unseen);  // outside: unseen
  EXPECT_EQ(m.stateAt(-0.9, 1.9), CellState::Known);
}

}  // namespace
}  // namespace ambler::perception
