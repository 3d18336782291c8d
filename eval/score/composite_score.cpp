#include "eval/score/composite_score.hpp"

namespace ambler::eval {

nlohmann::ordered_json toJson(const CompositeScore& c) {
  nlohmann::ordered_json j = compositeJson(c.map, c.views, c.poses);
  j["views_used"] = c.views_used;
  nlohmann::ordered_json placement = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < c.placements->size(); ++k) {
    const perception::ViewPlacement& p = (*c.placements)[k];
    nlohmann::ordered_json e{{"view", k}, {"how", perception::placementHowName(p.how)}};
    nlohmann::ordered_json chain = nlohmann::ordered_json::array();
    for (const perception::ChainStep& step : p.chain) chain.push_back({step.link->i, step.link->j});
    e["links"] = chain;
    placement.push_back(e);
  }
  j["placement"] = placement;
  nlohmann::ordered_json rejected = nlohmann::ordered_json::array();
  for (const perception::PlacementLink& l : *c.links)
    if (!l.accepted) rejected.push_back({l.i, l.j});
  j["rejected_links"] = rejected;
  return j;
}

}  // namespace ambler::eval
