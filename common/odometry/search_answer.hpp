#pragma once
// Which of a correlative search's refined starts a sweep is placed at.

#include <cstddef>
#include <vector>

namespace liloc {

// One refined start: how many points it fits, and how likely its guess's prior makes it.
struct SearchCandidate {
  int inliers = 0;             // points within search_inlier_m of the map
  double prior_density = 0.0;  // exp(-d^2 / 2), d: the Mahalanobis distance from its guess
};

// The index of the answer taken (candidates must not be empty): the one that fits the most
// points (of equal counts, the likelier), unless another that fits at least tie_fraction of
// them (they fit alike) is at least tie_odds times as likely by its prior; then the most
// likely of those. Between answers that fit alike the count is noise (a warped sweep fitted
// 34.8 % 2.2 m from the prediction, 33.6-34.4 % near it), but a prior only somewhat
// stronger is no reason either: after a sweep was placed off, the next search's prior is off
// too.
size_t pick_search_answer(const std::vector<SearchCandidate>& candidates, double tie_fraction,
                          double tie_odds);

}  // namespace liloc
