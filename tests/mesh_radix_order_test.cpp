// The quadric fast path's pass order (src/mesh/radix_order.hpp): the radix select must find the
// same key as std::nth_element and the radix sort must give std::stable_sort's order, for every
// size (both sides of the comparison-sort cutoff and of the 8-bit/11-bit digit cutoff), rank and
// pattern of ties. Also the greedy queues' 4-ary heap (src/mesh/quaternary_heap.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <vector>

#include "mesh/quaternary_heap.hpp"
#include "mesh/radix_order.hpp"

namespace duolod {
namespace {

struct Record {
  float cost;
  uint32_t id;  // input position, to check stability
};

std::vector<uint32_t> keysOf(const std::vector<float>& costs) {
  std::vector<uint32_t> keys;
  for (float c : costs) keys.push_back(mesh::orderKey(c));
  return keys;
}

uint32_t select(const std::vector<uint32_t>& keys, size_t rank) {
  std::vector<uint32_t> histogram(mesh::kDigits), scratch(keys.size());
  return mesh::selectKey(keys.data(), keys.size(), rank, histogram.data(), scratch.data());
}

std::vector<Record> radixSorted(std::vector<Record> records) {
  std::vector<Record> scratch(records.size());
  std::vector<uint32_t> histograms(3 * mesh::kDigits);
  const Record* sorted =
      mesh::sortByKey(records.data(), scratch.data(), records.size(), histograms.data());
  return {sorted, sorted + records.size()};
}

std::vector<Record> stableSorted(std::vector<Record> records) {
  std::stable_sort(records.begin(), records.end(),
                   [](const Record& a, const Record& b) { return a.cost < b.cost; });
  return records;
}

// Costs of the kinds pass pricing produces: a spread of magnitudes, many exact zeros (flat
// regions) and repeated values.
std::vector<float> costs(size_t n, uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> exponent(-30.0f, 2.0f);
  std::vector<float> out(n);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t kind = random() % 8;
    out[i] = kind == 0 ? 0.0f : kind == 1 ? 1.5f : std::pow(10.0f, exponent(random));
  }
  return out;
}

TEST(RadixOrder, OrderKeysOrderAsTheCostsAndFoldNegativeZero) {
  EXPECT_LT(mesh::orderKey(0.0f), mesh::orderKey(1e-38f));
  EXPECT_LT(mesh::orderKey(1e-38f), mesh::orderKey(1.0f));
  EXPECT_LT(mesh::orderKey(1.0f), mesh::orderKey(1.0000001f));
  EXPECT_EQ(mesh::orderKey(-0.0f), mesh::orderKey(0.0f));
}

TEST(RadixOrder, SelectsTheRankedKeyOfAHandCheckableList) {
  const std::vector<uint32_t> keys = keysOf({5, 1, 4, 1, 3});
  EXPECT_EQ(select(keys, 0), mesh::orderKey(1));
  EXPECT_EQ(select(keys, 1), mesh::orderKey(1));
  EXPECT_EQ(select(keys, 2), mesh::orderKey(3));
  EXPECT_EQ(select(keys, 4), mesh::orderKey(5));
}

TEST(RadixOrder, SelectAgreesWithNthElementOnBothSidesOfTheCutoff) {
  for (size_t n : {size_t(1), size_t(7), mesh::kRadixMinimum - 1, mesh::kRadixMinimum, size_t(5000),
                   mesh::kWideDigitsMinimum - 1, mesh::kWideDigitsMinimum, size_t(100000)}) {
    const std::vector<uint32_t> keys = keysOf(costs(n, uint32_t(n)));
    for (size_t rank : {size_t(0), n / 3, n / 2, n - 1}) {
      std::vector<uint32_t> expected = keys;
      std::nth_element(expected.begin(), expected.begin() + rank, expected.end());
      EXPECT_EQ(select(keys, rank), expected[rank]) << "n " << n << " rank " << rank;
    }
  }
}

TEST(RadixOrder, SelectHandlesKeysThatShareTheirTopDigits) {
  // All within one top digit (and one middle digit): the lower digits decide. With 8-bit
  // digits (1500 keys) and 11-bit ones (12000).
  for (size_t n : {size_t(1500), size_t(12000)}) {
    ASSERT_EQ(n < mesh::kWideDigitsMinimum, n == 1500);
    std::vector<uint32_t> keys(n);
    for (size_t i = 0; i < n; ++i) keys[i] = mesh::orderKey(1.0f) + uint32_t(i * 7 % 2000);
    for (size_t rank : {size_t(0), size_t(1234), n - 1}) {
      std::vector<uint32_t> expected = keys;
      std::nth_element(expected.begin(), expected.begin() + rank, expected.end());
      EXPECT_EQ(select(keys, rank), expected[rank]) << "n " << n;
    }
  }
  EXPECT_EQ(select(std::vector<uint32_t>(1000, 42), 999), 42u);  // all equal
}

TEST(RadixOrder, SortIsStableSortOnBothSidesOfTheCutoff) {
  for (size_t n :
       {size_t(0), size_t(1), size_t(100), mesh::kRadixMinimum, size_t(4097),
        mesh::kWideDigitsMinimum - 1, mesh::kWideDigitsMinimum, size_t(60000)}) {
    const std::vector<float> c = costs(n, uint32_t(n) + 1);
    std::vector<Record> records(n);
    for (size_t i = 0; i < n; ++i) records[i] = {c[i], uint32_t(i)};
    const std::vector<Record> got = radixSorted(records), expected = stableSorted(records);
    ASSERT_EQ(got.size(), expected.size());
    for (size_t i = 0; i < n; ++i) {
      ASSERT_EQ(got[i].id, expected[i].id) << "n " << n << " at " << i;
      ASSERT_EQ(got[i].cost, expected[i].cost);
    }
  }
}

TEST(RadixOrder, SortSkipsSharedDigitsAndReturnsWhereTheResultIs) {
  // Costs that differ only in the lowest digit: one scatter, so the result is in the scratch
  // buffer; equal costs keep their input order.
  const size_t n = 2000;
  std::vector<Record> records(n);
  for (size_t i = 0; i < n; ++i) {
    uint32_t bits = mesh::orderKey(2.0f) + uint32_t((n - i) % 5);
    float cost;
    std::memcpy(&cost, &bits, 4);
    records[i] = {cost, uint32_t(i)};
  }
  std::vector<Record> scratch(n);
  std::vector<uint32_t> histograms(3 * mesh::kDigits);
  const Record* sorted = mesh::sortByKey(records.data(), scratch.data(), n, histograms.data());
  EXPECT_EQ(sorted, scratch.data());
  const std::vector<Record> expected = stableSorted(records);
  for (size_t i = 0; i < n; ++i) ASSERT_EQ(sorted[i].id, expected[i].id) << i;
}

// The heap against std::multiset under a random mix of pushes and pops after a heapify, with
// many ties and sizes that leave the last node part full: the top is always the least item left.
TEST(QuaternaryHeap, PopsTheLeastUnderPushesAndPops) {
  std::mt19937 random(7);
  for (int round = 0; round < 50; ++round) {
    mesh::QuaternaryHeap<int> heap;
    std::multiset<int> reference;
    const int initial = int(random() % 40);
    for (int i = 0; i < initial; ++i) {
      const int item = int(random() % 16);
      heap.append(item);
      reference.insert(item);
    }
    heap.heapify();
    for (int step = 0; step < 400; ++step) {
      ASSERT_EQ(heap.size(), reference.size());
      if (random() % 2 == 0) {
        const int item = int(random() % 16);
        heap.push(item);
        reference.insert(item);
      } else if (!reference.empty()) {
        ASSERT_EQ(heap.pop(), *reference.begin()) << round << " " << step;
        reference.erase(reference.begin());
      }
    }
    while (!reference.empty()) {
      ASSERT_EQ(heap.pop(), *reference.begin()) << round;
      reference.erase(reference.begin());
    }
    EXPECT_TRUE(heap.empty());
  }
}

}  // namespace
}  // namespace duolod
