#pragma once
/// @file union_find.h
/// The one disjoint-set forest of the library (components, vertex fans).
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

namespace qjulia::detail {

/// Disjoint sets over 0..n-1 with path halving. The root of a set is its smallest element, so
/// the result of a sequence of unite() calls does not depend on the order of their arguments.
class UnionFind {
 public:
  explicit UnionFind(std::size_t n = 0) { reset(n); }

  /// n singleton sets (reuses the storage).
  void reset(std::size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), uint32_t{0});
    sets_ = n;
  }

  /// The root (smallest element) of x's set.
  uint32_t find(uint32_t x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }

  /// Joins the sets of a and b; true when they were apart.
  bool unite(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    if (a < b)
      parent_[b] = a;
    else
      parent_[a] = b;
    --sets_;
    return true;
  }

  /// The number of sets.
  std::size_t sets() const { return sets_; }

  /// Each element's set numbered 0, 1, ... in the order of the sets' smallest elements, into
  /// `label` (n entries); returns the number of sets. One pass without a search: an element's
  /// parent is never larger than it (a root is its set's smallest element, and halving a path
  /// only moves an element to an ancestor), so its label is known when the element is reached.
  std::uint32_t labels(std::vector<uint32_t>& label) const {
    label.resize(parent_.size());
    std::uint32_t next = 0;
    for (std::size_t x = 0; x < parent_.size(); ++x)
      label[x] = parent_[x] == x ? next++ : label[parent_[x]];
    return next;
  }

 private:
  std::vector<uint32_t> parent_;
  std::size_t sets_ = 0;
};

}  // namespace qjulia::detail
