// The non-template parts of NSGA-II (Deb et al. 2002): non-dominated sorting, crowding distance,
// elitist survival, the crowded tournament, and the search's random numbers.
#include "shader/nsga2.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numeric>

namespace duolod::shader {

bool dominates(const Objectives& a, const Objectives& b) {
  return a.cost <= b.cost && a.error <= b.error && (a.cost < b.cost || a.error < b.error);
}

std::vector<std::vector<int>> nondominatedFronts(std::span<const Objectives> points) {
  const int n = static_cast<int>(points.size());
  std::vector<std::vector<int>> dominated_by(n);  // S_p: the points p dominates
  std::vector<int> domination_count(n, 0);        // n_p: how many points dominate p
  std::vector<std::vector<int>> fronts;
  std::vector<int> current;
  for (int p = 0; p < n; ++p) {
    for (int q = 0; q < n; ++q) {
      if (dominates(points[p], points[q]))
        dominated_by[p].push_back(q);
      else if (dominates(points[q], points[p]))
        ++domination_count[p];
    }
    if (domination_count[p] == 0) current.push_back(p);
  }
  while (!current.empty()) {
    std::vector<int> next;
    for (int p : current)
      for (int q : dominated_by[p])
        if (--domination_count[q] == 0) next.push_back(q);
    std::sort(next.begin(), next.end());
    fronts.push_back(std::move(current));
    current = std::move(next);
  }
  return fronts;
}

std::vector<double> crowdingDistances(std::span<const Objectives> points,
                                      std::span<const int> front) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const size_t n = front.size();
  std::vector<double> distance(n, 0.0);
  if (n <= 2) return std::vector<double>(n, kInf);
  for (double Objectives::*objective : {&Objectives::cost, &Objectives::error}) {
    std::vector<size_t> order(n);
    std::iota(order.begin(), order.end(), size_t(0));
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return points[front[a]].*objective < points[front[b]].*objective;
    });
    double low = points[front[order.front()]].*objective;
    double high = points[front[order.back()]].*objective;
    distance[order.front()] = distance[order.back()] = kInf;
    double range = high - low;
    if (!(range > 0) || !std::isfinite(range)) continue;  // all equal (or invalid): no spread
    for (size_t i = 1; i + 1 < n; ++i)
      distance[order[i]] += (points[front[order[i + 1]]].*objective -
                             points[front[order[i - 1]]].*objective) /
                            range;
  }
  return distance;
}

Survival selectSurvivors(std::span<const Objectives> points, int count) {
  Survival survival;
  survival.rank.assign(points.size(), 0);
  survival.crowding.assign(points.size(), 0.0);
  std::vector<std::vector<int>> fronts = nondominatedFronts(points);
  for (size_t f = 0; f < fronts.size(); ++f) {
    const std::vector<int>& front = fronts[f];
    std::vector<double> distance = crowdingDistances(points, front);
    for (size_t i = 0; i < front.size(); ++i) {
      survival.rank[front[i]] = static_cast<int>(f);
      survival.crowding[front[i]] = distance[i];
    }
    int room = count - static_cast<int>(survival.survivors.size());
    if (room <= 0) continue;
    std::vector<size_t> order(front.size());
    std::iota(order.begin(), order.end(), size_t(0));
    // Most isolated first; the stable sort keeps index order among equals (determinism).
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return distance[a] > distance[b]; });
    for (size_t i = 0; i < order.size() && i < size_t(room); ++i)
      survival.survivors.push_back(front[order[i]]);
  }
  return survival;
}

uint64_t SearchRandom::next() {
  uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

double SearchRandom::uniform() { return double(next() >> 11) * 0x1.0p-53; }

size_t SearchRandom::index(size_t count) {
  assert(count > 0);
  return static_cast<size_t>(uniform() * double(count)) % count;
}

bool SearchRandom::chance(double probability) { return uniform() < probability; }

double SearchRandom::normal() {
  double u1 = 1.0 - uniform();  // (0, 1]: log is finite
  double u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
}

namespace nsga2_detail {

int tournament(std::span<const int> rank, std::span<const double> crowding, SearchRandom& random) {
  int a = static_cast<int>(random.index(rank.size()));
  int b = static_cast<int>(random.index(rank.size()));
  if (rank[a] != rank[b]) return rank[a] < rank[b] ? a : b;
  if (crowding[a] != crowding[b]) return crowding[a] > crowding[b] ? a : b;
  return random.chance(0.5) ? a : b;
}

}  // namespace nsga2_detail
}  // namespace duolod::shader
