// A 4-ary min-heap: the collapse engine's greedy queue (collapse_engine.cpp, over 64-bit keys)
// and the position fast path's greedy tail (simplify_positions.cpp, over its queued candidates)
// both sift through it. Four children a node halve a binary heap's levels, and a node's children
// share a cache line or two; a full node's minimum is taken without data-dependent branches.
// Items that `before` leaves unordered pop in an unspecified order among themselves: the callers'
// orders are total, or their equal items are interchangeable. Private to src/mesh.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

namespace duolod::mesh {

template <class Item, class Before = std::less<Item>>
class QuaternaryHeap {
 public:
  void clear() { items_.clear(); }
  bool empty() const { return items_.empty(); }
  size_t size() const { return items_.size(); }
  // Adds without restoring the heap order: call heapify() before popping.
  void append(const Item& item) { items_.push_back(item); }
  void heapify() {
    if (items_.size() < 2) return;
    for (size_t i = (items_.size() - 2) / 4 + 1; i-- > 0;) siftDown(i);
  }
  void push(const Item& item) {
    items_.push_back(item);
    siftUp(items_.size() - 1);
  }
  // Removes and returns the first item (the heap must not be empty).
  Item pop() {
    const Item top = items_.front();
    items_.front() = items_.back();
    items_.pop_back();
    if (!items_.empty()) siftDown(0);
    return top;
  }

 private:
  void siftUp(size_t i) {
    const Item item = items_[i];
    while (i > 0) {
      const size_t parent = (i - 1) / 4;
      if (!before_(item, items_[parent])) break;
      items_[i] = items_[parent];
      i = parent;
    }
    items_[i] = item;
  }
  void siftDown(size_t i) {
    const size_t n = items_.size();
    const Item item = items_[i];
    for (;;) {
      const size_t first = i * 4 + 1;
      if (first >= n) break;
      size_t best = first;
      if (first + 4 <= n) {  // full node: branch-free minimum of four
        const Item* c = &items_[first];
        const size_t lo = before_(c[1], c[0]) ? 1 : 0, hi = before_(c[3], c[2]) ? 3 : 2;
        best = first + (before_(c[hi], c[lo]) ? hi : lo);
      } else {
        for (size_t c = first + 1; c < n; ++c)
          if (before_(items_[c], items_[best])) best = c;
      }
      if (!before_(items_[best], item)) break;
      items_[i] = items_[best];
      i = best;
    }
    items_[i] = item;
  }

  std::vector<Item> items_;
  [[no_unique_address]] Before before_;
};

}  // namespace duolod::mesh
