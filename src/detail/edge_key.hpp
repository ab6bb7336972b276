// An undirected edge (a, b) as one 64-bit key: the smaller vertex id in the
// high half, so sorting keys sorts edges lexicographically.
#pragma once
#include <cstdint>
#include <utility>

namespace tetopt::detail {

inline uint64_t edge_key(int32_t a, int32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) | static_cast<uint32_t>(b);
}

}  // namespace tetopt::detail
