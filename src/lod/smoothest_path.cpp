// The smoothest LOD path: Liang et al., "Automatic Mesh and Shader Level of Detail", §6.1
// (Algorithm 3, eq. 5); shortest paths by Dijkstra, "A note
// on two problems in connexion with graphs", Numerische Mathematik 1 (1959).
#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

#include "duolod/lod.hpp"

namespace duolod::lod {

ShortestPath dijkstra(const WeightedGraph& graph, int source, int target) {
  const int node_count = static_cast<int>(graph.out_edges.size());
  if (source < 0 || source >= node_count || target < 0 || target >= node_count) return {};
  constexpr double kUnreached = std::numeric_limits<double>::infinity();
  std::vector<double> distance(node_count, kUnreached);
  std::vector<int> previous(node_count, -1);
  using Entry = std::pair<double, int>;  // (distance, node), smallest first
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> frontier;
  distance[source] = 0;
  frontier.push({0.0, source});
  while (!frontier.empty()) {
    auto [reached, node] = frontier.top();
    frontier.pop();
    if (reached > distance[node]) continue;  // a stale entry: the node was settled shorter
    if (node == target) break;
    for (const WeightedGraph::Edge& edge : graph.out_edges[node]) {
      // Dijkstra needs non-negative weights; an edge that is not a finite one is no edge.
      if (!(edge.weight >= 0 && edge.weight < kUnreached) || edge.to < 0 || edge.to >= node_count)
        continue;
      double through = reached + edge.weight;
      if (through < distance[edge.to]) {
        distance[edge.to] = through;
        previous[edge.to] = node;
        frontier.push({through, edge.to});
      }
    }
  }
  ShortestPath path;
  if (distance[target] == kUnreached) return path;
  path.length = distance[target];
  for (int node = target; node != -1; node = previous[node]) path.nodes.push_back(node);
  std::reverse(path.nodes.begin(), path.nodes.end());
  return path;
}

core::Result<SmoothPath> smoothestPath(std::span<const std::vector<EvaluatedPair>> level_pairs,
                                       const TransitionEvaluator& transition_error) {
  if (level_pairs.empty()) return core::Error{"SmoothestPath: no levels"};
  for (size_t level = 0; level < level_pairs.size(); ++level)
    if (level_pairs[level].empty())
      return core::Error{"SmoothestPath: level " + std::to_string(level) +
                         " has no pair within its bound"};

  // G of Algorithm 3: a source before level 0, one node per pair, a sink after the last level.
  WeightedGraph graph;
  const int source = graph.addNode();
  std::vector<std::vector<int>> node_of(level_pairs.size());
  for (size_t level = 0; level < level_pairs.size(); ++level)
    for (size_t p = 0; p < level_pairs[level].size(); ++p)
      node_of[level].push_back(graph.addNode());
  const int sink = graph.addNode();
  std::vector<int> level_of_node(graph.out_edges.size(), -1),
      pair_of_node(graph.out_edges.size(), -1);
  for (size_t level = 0; level < level_pairs.size(); ++level)
    for (size_t p = 0; p < node_of[level].size(); ++p) {
      level_of_node[node_of[level][p]] = static_cast<int>(level);
      pair_of_node[node_of[level][p]] = static_cast<int>(p);
    }

  SmoothPath result;
  for (int node : node_of.front()) graph.addEdge(source, node, 0);
  for (int node : node_of.back()) graph.addEdge(node, sink, 0);
  // Lines 4–13: every pair of level i to every pair of level i + 1, weighted by eq. (5).
  for (size_t level = 0; level + 1 < level_pairs.size(); ++level)
    for (size_t a = 0; a < level_pairs[level].size(); ++a)
      for (size_t b = 0; b < level_pairs[level + 1].size(); ++b) {
        auto weight = transition_error(static_cast<int>(level), level_pairs[level][a],
                                       level_pairs[level + 1][b]);
        ++result.evaluations;
        if (!weight)
          return core::Error{"SmoothestPath: transition " + std::to_string(level) + "." +
                             std::to_string(a) + " -> " + std::to_string(level + 1) + "." +
                             std::to_string(b) + ": " + weight.error().message};
        if (!(*weight >= 0 && std::isfinite(*weight)))
          return core::Error{
              "SmoothestPath: transition error must be a finite non-negative "
              "number, got " +
              std::to_string(*weight)};
        graph.addEdge(node_of[level][a], node_of[level + 1][b], *weight);
        result.edges.push_back({.level = static_cast<int>(level),
                                .from = static_cast<int>(a),
                                .to = static_cast<int>(b),
                                .error = *weight});
      }

  // Line 15.
  ShortestPath path = dijkstra(graph, source, sink);
  if (path.nodes.size() != level_pairs.size() + 2)  // every edge is finite: cannot happen
    return core::Error{"SmoothestPath: no path through the levels"};
  for (size_t k = 1; k + 1 < path.nodes.size(); ++k)
    result.choice.push_back(pair_of_node[path.nodes[k]]);
  for (const TransitionEdge& edge : result.edges)
    if (edge.from == result.choice[edge.level] && edge.to == result.choice[edge.level + 1])
      result.transition.push_back(edge.error);
  result.total_transition = path.length;
  return result;
}

}  // namespace duolod::lod
