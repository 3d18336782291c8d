#pragma once
// The composite the merge stage builds (docs/composite.md), scored against ground truth: the
// map's figures, and where the rover put each view and by which registrations.
#include <nlohmann/json.hpp>
#include <vector>

#include "eval/score/map_metrics.hpp"
#include "perception/placement.hpp"

namespace ambler::eval {

// metrics.json's "composite": the composite's figures and the placements it was built on.
struct CompositeScore {
  MapMetrics map;          // the composite against the truth
  int views = 0;           // the scenario's views
  int views_used = 0;      // those placed (not left out)
  const char* poses = "";  // merge.poses: "matched" or "true"
  // One per view, and the links their chains point into; neither null, both outlive the score.
  const std::vector<perception::ViewPlacement>* placements = nullptr;
  const std::vector<perception::PlacementLink>* links = nullptr;
};

// compositeJson's figures, then views_used, "placement" (per view: view, how, and links, the
// [i, j] of its chain's links from the reference out) and "rejected_links" (the [i, j] of the
// links the rover rejected, in the links' order).
nlohmann::ordered_json toJson(const CompositeScore& c);

}  // namespace ambler::eval
