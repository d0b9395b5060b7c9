// Median and Spearman's rank correlation (Spearman 1904), with ties given their mean rank.
#include <algorithm>
#include <cmath>
#include <numeric>

#include "duolod/core.hpp"

namespace duolod::core {

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  size_t n = values.size();
  std::sort(values.begin(), values.end());
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

std::vector<double> fractionalRanks(std::span<const double> values) {
  std::vector<size_t> order(values.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return values[a] < values[b]; });
  std::vector<double> ranks(values.size());
  for (size_t first = 0; first < order.size();) {
    size_t last = first;  // [first, last] share one value
    while (last + 1 < order.size() && values[order[last + 1]] == values[order[first]]) ++last;
    double mean_rank = 0.5 * double(first + last) + 1.0;
    for (size_t i = first; i <= last; ++i) ranks[order[i]] = mean_rank;
    first = last + 1;
  }
  return ranks;
}

double spearmanCorrelation(std::span<const double> a, std::span<const double> b) {
  if (a.size() != b.size() || a.size() < 2) return 0;
  std::vector<double> ra = fractionalRanks(a), rb = fractionalRanks(b);
  double mean = 0.5 * double(a.size() + 1);  // mean rank, ties included
  double covariance = 0, variance_a = 0, variance_b = 0;
  for (size_t i = 0; i < ra.size(); ++i) {
    double da = ra[i] - mean, db = rb[i] - mean;
    covariance += da * db;
    variance_a += da * da;
    variance_b += db * db;
  }
  if (variance_a == 0 || variance_b == 0) return 0;
  return covariance / std::sqrt(variance_a * variance_b);
}

}  // namespace duolod::core
