#include "odometry/search_answer.hpp"

#include <algorithm>
#include <iterator>
#include <tuple>

namespace liloc {

size_t pick_search_answer(const std::vector<SearchCandidate>& candidates, double tie_fraction,
                          double tie_odds) {
  const auto most_by = [&](auto key) {
    return std::max_element(
        candidates.begin(), candidates.end(),
        [&](const SearchCandidate& a, const SearchCandidate& b) { return key(a) < key(b); });
  };
  const auto most_inliers =
      most_by([](const SearchCandidate& c) { return std::make_tuple(c.inliers, c.prior_density); });
  const auto most_likely_alike = most_by([&](const SearchCandidate& c) {
    return std::make_tuple(c.inliers >= tie_fraction * most_inliers->inliers, c.prior_density,
                           c.inliers);
  });
  const auto best = most_likely_alike->prior_density >= tie_odds * most_inliers->prior_density
                        ? most_likely_alike
                        : most_inliers;
  return static_cast<size_t>(std::distance(candidates.begin(), best));
}

}  // namespace liloc
