#include "sim/session_planner.hpp"

#include <set>
#include <stdexcept>

#include "sim/random.hpp"

namespace liloc::sim {
namespace {

class RouteBuilder {
 public:
  RouteBuilder(const RoadNetwork& roads, Random& rng) : roads_(roads), rng_(rng) {}

  void start_at(int node) { nodes_ = {node}; }
  void start_mid_edge(const Eigen::Vector2d& point, int from, int to) {
    start_point_ = point;
    has_start_point_ = true;
    length_ += (roads_.nodes()[to] - point).norm();
    previous_ = from;
    nodes_ = {to};
    visited_.insert(key(from, to));
  }

  // Random walk preferring roads not yet driven, never turning back unless it must,
  // restricted to nodes where allowed(node); stops after `meters`.
  template <class Allowed>
  void wander(double meters, Allowed allowed) {
    const double goal = length_ + meters;
    while (length_ < goal) {
      const int here = nodes_.back();
      std::vector<int> fresh, other;
      for (const int n : roads_.neighbors(here)) {
        if (!allowed(n) || n == previous_) {
          continue;
        }
        (visited_.count(key(here, n)) ? other : fresh).push_back(n);
      }
      std::vector<int>& pool = fresh.empty() ? other : fresh;
      if (pool.empty()) {
        if (previous_ < 0) {
          throw std::invalid_argument("route cannot continue: isolated road node");
        }
        pool.push_back(previous_);
      }
      step_to(pool[rng_.uniform_int(0, static_cast<int>(pool.size()) - 1)]);
    }
  }

  template <class Allowed>
  void go_to(int target, Allowed allowed) {
    const std::vector<int> path = roads_.shortest_path(nodes_.back(), target, allowed);
    if (path.empty()) {
      throw std::invalid_argument("route target unreachable");
    }
    for (size_t i = 1; i < path.size(); ++i) {
      step_to(path[i]);
    }
  }

  int last() const { return nodes_.back(); }
  double length_m() const { return length_; }

  std::vector<Eigen::Vector2d> waypoints() const {
    std::vector<Eigen::Vector2d> w;
    if (has_start_point_) {
      w.push_back(start_point_);
    }
    for (const int n : nodes_) {
      w.push_back(roads_.nodes()[n]);
    }
    return w;
  }

 private:
  static std::pair<int, int> key(int a, int b) { return {std::min(a, b), std::max(a, b)}; }
  void step_to(int n) {
    const int here = nodes_.back();
    visited_.insert(key(here, n));
    length_ += roads_.distance(here, n);
    previous_ = here;
    nodes_.push_back(n);
  }

  const RoadNetwork& roads_;
  Random& rng_;
  std::vector<int> nodes_;
  std::set<std::pair<int, int>> visited_;
  int previous_ = -1;
  double length_ = 0.0;
  Eigen::Vector2d start_point_ = Eigen::Vector2d::Zero();
  bool has_start_point_ = false;
};

}  // namespace

void SessionPlanConfig::validate() const {
  for (const double length : {a_length_m, b_inside_m, b_excursion_m, c_length_m, d_length_m}) {
    if (!(length > 0.0 && length <= 1e6)) {
      throw std::invalid_argument("session lengths must be in (0, 1e6] m");
    }
  }
}

SessionPlan plan_session(const std::string& name, const World& world, double mapped_max_x_m,
                         const SessionPlanConfig& config, uint64_t seed) {
  const RoadNetwork& roads = world.roads();
  Random rng(mix64(seed ^ static_cast<uint64_t>(name.empty() ? 0 : name[0])));
  const auto mapped = [&](int n) { return roads.nodes()[n].x() < mapped_max_x_m; };
  const auto anywhere = [](int) { return true; };
  std::vector<int> mapped_nodes, unmapped_nodes;
  for (int n = 0; n < static_cast<int>(roads.nodes().size()); ++n) {
    (mapped(n) ? mapped_nodes : unmapped_nodes).push_back(n);
  }
  if (mapped_nodes.empty()) {
    throw std::invalid_argument("the world has no road inside the mapped region");
  }
  const auto random_node = [&](const std::vector<int>& pool) {
    return pool[rng.uniform_int(0, static_cast<int>(pool.size()) - 1)];
  };
  RouteBuilder route(roads, rng);
  SessionPlan plan;
  plan.name = name;
  if (name == "A" || name == "C") {
    const int start = random_node(mapped_nodes);
    route.start_at(start);
    route.wander(name == "A" ? config.a_length_m : config.c_length_m, mapped);
    route.go_to(start, mapped);
    plan.day = name == "A" ? 0 : 1;
    plan.description = name == "A" ? "central session: loops through the mapped region"
                                   : "another day: changed cars, structures and foliage";
  } else if (name == "B") {
    if (unmapped_nodes.empty()) {
      throw std::invalid_argument("session B needs roads outside the mapped region");
    }
    route.start_at(random_node(mapped_nodes));
    route.wander(config.b_inside_m, mapped);
    // Out into the unmapped region, around it, and back.
    int exit_node = unmapped_nodes.front();
    double best = 1e18;
    for (const int n : unmapped_nodes) {
      const double d = roads.distance(route.last(), n);
      if (d < best) {
        best = d;
        exit_node = n;
      }
    }
    route.go_to(exit_node, anywhere);
    const auto unmapped = [&](int n) { return !mapped(n); };
    route.wander(config.b_excursion_m, unmapped);
    int return_node = mapped_nodes.front();
    best = 1e18;
    for (const int n : mapped_nodes) {
      const double d = roads.distance(route.last(), n);
      if (d < best) {
        best = d;
        return_node = n;
      }
    }
    route.go_to(return_node, anywhere);
    route.wander(config.b_inside_m, mapped);
    plan.description = "leaves the mapped region and comes back (RLM -> ILM -> RLM)";
  } else if (name == "D") {
    std::vector<std::pair<int, int>> edges;
    for (const auto& e : roads.edges()) {
      if (mapped(e.first) && mapped(e.second)) {
        edges.push_back(e);
      }
    }
    const auto [a, b] = edges[rng.uniform_int(0, static_cast<int>(edges.size()) - 1)];
    const bool forward = rng.bernoulli(0.5);
    const int from = forward ? a : b;
    const int to = forward ? b : a;
    const Eigen::Vector2d start =
        roads.nodes()[from] + rng.uniform(0.3, 0.7) * (roads.nodes()[to] - roads.nodes()[from]);
    route.start_mid_edge(start, from, to);
    route.wander(config.d_length_m, mapped);
    plan.initial_pose_known = false;
    plan.description = "unknown start: global initialization needed";
  } else {
    throw std::invalid_argument("unknown session '" + name + "' (A, B, C or D)");
  }
  plan.waypoints = route.waypoints();
  return plan;
}

}  // namespace liloc::sim
