// The quadric fast path's pass order (simplify_positions.cpp) without comparisons: keys are the
// bits of non-negative float costs, selected and sorted by 11-bit digits. std::nth_element and
// std::sort on random keys mispredict about every other branch (std::sort alone took 5.6% of the
// bench's samples on bunny 10%); these are a few linear sweeps. Private to src/mesh; tested in
// tests/mesh_radix_order_test.cpp.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace duolod::mesh {

// The pass order's key of a cost: its float bits (costs are finite and >= 0, so the bits order
// as the values do; -0 is folded onto +0).
inline uint32_t orderKey(float cost) {
  uint32_t bits;
  std::memcpy(&bits, &cost, 4);
  return bits & 0x7fffffffu;
}

// Digits, most significant first: key >> 22, then bits 11-21, then bits 0-10.
constexpr uint32_t kDigitBits = 11, kDigits = 1u << kDigitBits;
// Below this many keys, comparison sorting is cheaper than three histograms of kDigits. (At 512,
// the small meshes' passes paid for std::stable_sort's buffer: 128 made Avocado's 10% and 1%
// cells ~5% faster, 32 changed nothing more; bench/RESULTS.md, issue 3, session 14.)
constexpr size_t kRadixMinimum = 128;
inline uint32_t digitOf(uint32_t key, int level) {
  return (key >> (level * kDigitBits)) & (kDigits - 1);
}

// The key of rank `rank` (0-based, < n) among keys[0, n), as std::nth_element would find it,
// narrowed one digit at a time, most significant first: a histogram of all keys' top digits finds
// the top digit, the keys that have it are gathered into `scratch` (one sweep, no branch), and the
// two lower digits are found among those alone. `histogram` has room for kDigits, `scratch` for n.
inline uint32_t selectKey(const uint32_t* keys, size_t n, size_t rank, uint32_t* histogram,
                          uint32_t* scratch) {
  if (n < kRadixMinimum) {  // clearing and scanning the histograms would cost more
    std::copy_n(keys, n, scratch);
    std::nth_element(scratch, scratch + rank, scratch + n);
    return scratch[rank];
  }
  auto narrow = [&](const uint32_t* values, size_t count, int level) {
    std::fill_n(histogram, kDigits, 0u);
    for (size_t i = 0; i < count; ++i) ++histogram[digitOf(values[i], level)];
    uint32_t digit = 0;
    for (; digit + 1 < kDigits && rank >= histogram[digit]; ++digit) rank -= histogram[digit];
    return digit;
  };
  const uint32_t top = narrow(keys, n, 2);
  size_t gathered = 0;
  for (size_t i = 0; i < n; ++i) {
    scratch[gathered] = keys[i];
    gathered += digitOf(keys[i], 2) == top;
  }
  const uint32_t middle = narrow(scratch, gathered, 1);
  size_t kept = 0;
  for (size_t i = 0; i < gathered; ++i) {
    scratch[kept] = scratch[i];
    kept += digitOf(scratch[i], 1) == middle;
  }
  const uint32_t low = narrow(scratch, kept, 0);
  return top << (2 * kDigitBits) | middle << kDigitBits | low;
}

// Stable LSD radix sort of records by orderKey(record.cost), so that equal costs keep their order
// (the pass candidates' pricing order). A digit every key shares is skipped. `scratch` has room
// for n and `histograms` for 3 * kDigits; returns where the sorted records are: `data` or
// `scratch`.
template <class Record>
Record* sortByKey(Record* data, Record* scratch, size_t n, uint32_t* histograms) {
  if (n < kRadixMinimum) {
    std::stable_sort(data, data + n, [](const Record& a, const Record& b) {
      return orderKey(a.cost) < orderKey(b.cost);
    });
    return data;
  }
  std::fill_n(histograms, 3 * kDigits, 0u);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t key = orderKey(data[i].cost);
    for (int level = 0; level < 3; ++level) ++histograms[level * kDigits + digitOf(key, level)];
  }
  for (int level = 0; level < 3; ++level) {
    uint32_t* histogram = histograms + level * kDigits;
    if (n == 0 || histogram[digitOf(orderKey(data[0].cost), level)] == n) continue;
    uint32_t sum = 0;
    for (uint32_t d = 0; d < kDigits; ++d) {
      const uint32_t count = histogram[d];
      histogram[d] = sum;
      sum += count;
    }
    for (size_t i = 0; i < n; ++i)
      scratch[histogram[digitOf(orderKey(data[i].cost), level)]++] = data[i];
    std::swap(data, scratch);
  }
  return data;  // the caller's data or scratch buffer, after an even or odd number of scatters
}

}  // namespace duolod::mesh
