// eval/score/composite_score: metrics.json's composite entry, its placements against hand-made
// ones: each view's chain of links in chain order, and the links the rover rejected.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "eval/score/composite_score.hpp"

namespace ambler::eval {
namespace {

perception::PlacementLink link(int i, int j, bool accepted) {
  perception::PlacementLink l;
  l.i = i, l.j = j, l.accepted = accepted;
  return l;
}

std::vector<std::string> keysOf(const nlohmann::ordered_json& j) {
  std::vector<std::string> keys;
  for (const auto& [k, v] : j.items()) keys.push_back(k);
  return keys;
}

// Five views: 0 the reference; 1 through (0, 1); 2 through (0, 1) then (1, 2), listed after it;
// 4 through those and (4, 2) used in reverse; 3 reached only by the rejected (2, 3), left out.
struct Placed {
  std::vector<perception::PlacementLink> links{link(1, 2, true), link(2, 3, false), link(0, 1, true),
                                               link(4, 2, true), link(0, 4, false)};
  std::vector<perception::ViewPlacement> placements;
  Placed() {
    using perception::PlacementHow;
    const perception::ChainStep l01{&links[2]}, l12{&links[0]}, l42{&links[3], true};
    placements = {{PlacementHow::Reference, {}, {}},
                  {PlacementHow::Matched, {}, {l01}},
                  {PlacementHow::Matched, {}, {l01, l12}},
                  {PlacementHow::LeftOut, {}, {}},
                  {PlacementHow::Matched, {}, {l01, l12, l42}}};
  }
  Placed(const Placed&) = delete;
  CompositeScore score() const {
    CompositeScore c;
    c.views = 5, c.views_used = 4, c.poses = "matched";
    c.map.cells = 400, c.map.coverage = 0.75;
    c.placements = &placements, c.links = &links;
    return c;
  }
};

TEST(CompositeScore, EntryHoldsTheFiguresThenThePlacements) {
  const Placed p;
  const nlohmann::ordered_json j = toJson(p.score());
  EXPECT_EQ(keysOf(j), (std::vector<std::string>{"views", "poses", "cells", "coverage", "rms_error_m",
                                                 "median_abs_error_m", "within_1sigma", "within_2sigma", "known",
                                                 "shadow", "compared", "p95_abs_error_m", "max_abs_error_m",
                                                 "views_used", "placement", "rejected_links"}));
  EXPECT_EQ(j["views"], 5);
  EXPECT_EQ(j["poses"], "matched");
  EXPECT_EQ(j["cells"], 400);
  EXPECT_EQ(j["coverage"], 0.75);
  EXPECT_EQ(j["views_used"], 4);
}

TEST(CompositeScore, EachViewListsItsChainsLinksInChainOrder) {
  const Placed p;
  const nlohmann::ordered_json placement = toJson(p.score())["placement"];
  ASSERT_EQ(placement.size(), 5u);
  EXPECT_EQ(keysOf(placement[0]), (std::vector<std::string>{"view", "how", "links"}));
  EXPECT_EQ(placement[0], nlohmann::ordered_json::parse(R"({"view": 0, "how": "reference", "links": []})"));
  EXPECT_EQ(placement[1], nlohmann::ordered_json::parse(R"({"view": 1, "how": "matched", "links": [[0, 1]]})"));
  EXPECT_EQ(placement[2], nlohmann::ordered_json::parse(R"({"view": 2, "how": "matched", "links": [[0, 1], [1, 2]]})"));
  EXPECT_EQ(placement[3], nlohmann::ordered_json::parse(R"({"view": 3, "how": "left_out", "links": []})"));
  // A link used in reverse is still named (i, j).
  EXPECT_EQ(placement[4]["links"], nlohmann::json::parse("[[0, 1], [1, 2], [4, 2]]"));
}

TEST(CompositeScore, RejectedLinksAreThoseTheRoverRefusedInTheLinksOrder) {
  const Placed p;
  EXPECT_EQ(toJson(p.score())["rejected_links"], nlohmann::json::parse("[[2, 3], [0, 4]]"));
  std::vector<perception::PlacementLink> accepted{link(0, 1, true)};
  CompositeScore c = p.score();
  c.links = &accepted;
  EXPECT_EQ(toJson(c)["rejected_links"], nlohmann::json::array());
}

// The true poses (merge.poses: true): no chains.
TEST(CompositeScore, TruePosesHaveNoLinks) {
  const std::vector<perception::PlacementLink> links;
  const std::vector<perception::ViewPlacement> placements{{perception::PlacementHow::Reference, {}, {}},
                                                          {perception::PlacementHow::True, {}, {}}};
  CompositeScore c;
  c.views = 2, c.views_used = 2, c.poses = "true";
  c.placements = &placements, c.links = &links;
  const nlohmann::ordered_json j = toJson(c);
  EXPECT_EQ(j["placement"], nlohmann::ordered_json::parse(R"([{"view": 0, "how": "reference", "links": []},
                                                      {"view": 1, "how": "true", "links": []}])"));
  EXPECT_EQ(j["rejected_links"], nlohmann::json::array());
}

}  // namespace
}  // namespace ambler::eval
