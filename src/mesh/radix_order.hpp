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

// Keys have 31 bits. Digits, most significant first: 11-bit digits (three levels) for many
// keys; 8-bit digits (four levels) below kWideDigitsMinimum keys, where clearing and scanning
// the wide digits' histograms (2048 counters a level) cost more than the extra sweep (Avocado's
// passes: 5-9% of its time). Above a few thousand keys the extra sweep costs more: float costs
// share their top 8 bits, so the 8-bit select gathers nearly all keys twice.
constexpr uint32_t kDigitBits = 11, kDigits = 1u << kDigitBits;
constexpr size_t kWideDigitsMinimum = 2048;
// Below this many keys, comparison sorting is cheaper than the histograms. (At 512, the small
// meshes' passes paid for std::stable_sort's buffer: 128 made Avocado's 10% and 1% cells ~5%
// faster, 32 changed nothing more; bench/RESULTS.md, issue 3, session 14.)
constexpr size_t kRadixMinimum = 128;

namespace radix_detail {

template <uint32_t kBits>
struct Digits {
  static constexpr uint32_t kCount = 1u << kBits;
  static constexpr int kLevels = int((31 + kBits - 1) / kBits);
  static uint32_t of(uint32_t key, int level) { return (key >> (level * kBits)) & (kCount - 1); }
};

// selectKey with digits of kBits, most significant first: a histogram of the keys' top digits
// finds the top digit of the ranked key, the keys that have it are gathered into `scratch` (one
// sweep, no branch), and the lower digits are found among those alone.
template <uint32_t kBits>
uint32_t selectKeyWith(const uint32_t* keys, size_t n, size_t rank, uint32_t* histogram,
                       uint32_t* scratch) {
  using D = Digits<kBits>;
  const uint32_t* values = keys;
  size_t count = n;
  uint32_t key = 0;
  for (int level = D::kLevels - 1; level >= 0; --level) {
    std::fill_n(histogram, D::kCount, 0u);
    for (size_t i = 0; i < count; ++i) ++histogram[D::of(values[i], level)];
    uint32_t digit = 0;
    for (; digit + 1 < D::kCount && rank >= histogram[digit]; ++digit) rank -= histogram[digit];
    key |= digit << (level * kBits);
    if (level == 0) break;
    size_t kept = 0;
    for (size_t i = 0; i < count; ++i) {  // in place once values is scratch: kept <= i
      const uint32_t value = values[i];
      scratch[kept] = value;
      kept += D::of(value, level) == digit;
    }
    values = scratch;
    count = kept;
  }
  return key;
}

// sortByKey with digits of kBits: a stable LSD radix sort, one histogram sweep for all levels.
template <uint32_t kBits, class Record>
Record* sortByKeyWith(Record* data, Record* scratch, size_t n, uint32_t* histograms) {
  using D = Digits<kBits>;
  std::fill_n(histograms, D::kLevels * D::kCount, 0u);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t key = orderKey(data[i].cost);
    for (int level = 0; level < D::kLevels; ++level)
      ++histograms[level * D::kCount + D::of(key, level)];
  }
  for (int level = 0; level < D::kLevels; ++level) {
    uint32_t* histogram = histograms + level * D::kCount;
    if (n == 0 || histogram[D::of(orderKey(data[0].cost), level)] == n) continue;
    uint32_t sum = 0;
    for (uint32_t d = 0; d < D::kCount; ++d) {
      const uint32_t count = histogram[d];
      histogram[d] = sum;
      sum += count;
    }
    for (size_t i = 0; i < n; ++i)
      scratch[histogram[D::of(orderKey(data[i].cost), level)]++] = data[i];
    std::swap(data, scratch);
  }
  return data;  // the caller's data or scratch buffer, after an even or odd number of scatters
}

}  // namespace radix_detail

// The key of rank `rank` (0-based, < n) among keys[0, n), as std::nth_element would find it,
// narrowed one digit at a time. `histogram` has room for kDigits, `scratch` for n.
inline uint32_t selectKey(const uint32_t* keys, size_t n, size_t rank, uint32_t* histogram,
                          uint32_t* scratch) {
  if (n < kRadixMinimum) {  // clearing and scanning the histograms would cost more
    std::copy_n(keys, n, scratch);
    std::nth_element(scratch, scratch + rank, scratch + n);
    return scratch[rank];
  }
  return n < kWideDigitsMinimum
             ? radix_detail::selectKeyWith<8>(keys, n, rank, histogram, scratch)
             : radix_detail::selectKeyWith<kDigitBits>(keys, n, rank, histogram, scratch);
}

// Stable radix sort of records by orderKey(record.cost), so that equal costs keep their order
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
  return n < kWideDigitsMinimum
             ? radix_detail::sortByKeyWith<8>(data, scratch, n, histograms)
             : radix_detail::sortByKeyWith<kDigitBits>(data, scratch, n, histograms);
}

}  // namespace duolod::mesh
