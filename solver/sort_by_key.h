#pragma once

#include <algorithm>
#include <utility>
#include <vector>

namespace shadowsg {

// Sorts `items` by key(item), ascending, ties in input order. Each key is
// computed once: a comparator that recomputes a floating-point key may round
// one element two ways (FMA contraction differs between inlined copies), which
// breaks std::sort's strict weak ordering (the sphere-tree build crashed in
// std::sort when built with -march=native).
template <typename T, typename KeyFn>
void SortByKey(std::vector<T>* items, KeyFn key) {
  using Key = decltype(key(items->front()));
  std::vector<std::pair<Key, size_t>> keyed;
  keyed.reserve(items->size());
  for (size_t i = 0; i < items->size(); ++i) keyed.emplace_back(key((*items)[i]), i);
  std::sort(keyed.begin(), keyed.end());
  std::vector<T> sorted;
  sorted.reserve(items->size());
  for (const auto& entry : keyed) sorted.push_back(std::move((*items)[entry.second]));
  *items = std::move(sorted);
}

}  // namespace shadowsg
