// Deterministic data-parallel loops over index ranges, on oneTBB (Debian
// libtbb-dev) when the build found it, serial otherwise.
//
// Determinism: [0, n) is cut into fixed blocks of `kBlock` indices whatever
// the thread count; a loop body may write only data owned by its indices, and
// a reduction combines the per-block results serially in block order.  So a
// floating-point sum is the same for 1, 2 or 16 threads (bit for bit), and
// so is everything computed from it.
#pragma once
#include <algorithm>
#include <cstdint>
#include <limits>
#include <thread>
#include <vector>

#ifdef TETOPT_HAVE_TBB
#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#endif

namespace tetopt::detail {

inline constexpr int64_t kBlock = 8192;

/// A thread-count option: > 0 as given, otherwise the hardware's count.
inline int resolve_threads(int t) {
  if (t > 0) return t;
  // Asked once: glibc reads /sys for it on every call, and the insertion
  // passes resolve their threads for every window of work (2% of a run).
  static const int h = [] {
    const unsigned n = std::thread::hardware_concurrency();
    return n > 0 ? static_cast<int>(n) : 1;
  }();
  return h;
}

inline int64_t block_count(int64_t n) { return n > 0 ? (n + kBlock - 1) / kBlock : 0; }

/// Calls item(i) for every i in [0, m) on up to `threads` threads (1: the
/// calling thread only, in order; 0: all cores), one task per item.
template <class Item>
void parallel_items(int64_t m, int threads, const Item& item) {
  if (m <= 0) return;
  threads = resolve_threads(threads);
#ifdef TETOPT_HAVE_TBB
  // More threads than the hardware has only adds switching (and oneTBB warns
  // about the workers it cannot grant); the result does not depend on it.
  threads = std::min(threads, tbb::info::default_concurrency());
  if (threads > 1 && m > 1) {
    tbb::task_arena arena(threads);
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<int64_t>(0, m, 1), [&](const tbb::blocked_range<int64_t>& r) {
        for (int64_t i = r.begin(); i < r.end(); ++i) item(i);
      });
    });
    return;
  }
#endif
  (void)threads;
  for (int64_t i = 0; i < m; ++i) item(i);
}

/// Calls body(begin, end) for consecutive ranges of `block` indices covering
/// [0, n).  Ranges other than kBlock's are only for loops whose body writes
/// data owned by its indices and combines nothing across ranges, so that the
/// result cannot depend on where the ranges start: finer ranges balance
/// loops over few items with much work each (vertex stars: 77k vertices are
/// 10 blocks of kBlock, and the thread that takes the last one works alone).
template <class Body>
void parallel_ranges(int64_t n, int64_t block, int threads, const Body& body) {
  if (n <= 0) return;
  block = std::max<int64_t>(1, block);
  parallel_items((n + block - 1) / block, threads, [&](int64_t b) { body(b * block, std::min(n, (b + 1) * block)); });
}

/// Calls body(begin, end) for consecutive blocks covering [0, n), on up to
/// `threads` threads (1: the calling thread only; 0: all cores).
template <class Body>
void parallel_blocks(int64_t n, int threads, const Body& body) {
  parallel_ranges(n, kBlock, threads, body);
}

/// Calls f(i) for every i in [0, n) (see parallel_blocks).
template <class F>
void parallel_for_each(int64_t n, int threads, const F& f) {
  parallel_blocks(n, threads, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) f(i);
  });
}

/// The per-block results block_fn(begin, end) -> T, in block order.
template <class BlockFn>
auto parallel_map_blocks(int64_t n, int threads, const BlockFn& block_fn) {
  std::vector<decltype(block_fn(int64_t{}, int64_t{}))> part(static_cast<size_t>(block_count(n)));
  parallel_blocks(n, threads, [&](int64_t b, int64_t e) { part[static_cast<size_t>(b / kBlock)] = block_fn(b, e); });
  return part;
}

/// Reduction with a result independent of the thread count: block_fn(begin,
/// end) -> T per block, then join(acc, block_result) in block order,
/// starting from init.
template <class T, class BlockFn, class Join>
T parallel_reduce_blocks(int64_t n, int threads, T init, const BlockFn& block_fn, const Join& join) {
  T acc = init;
  for (const T& p : parallel_map_blocks(n, threads, block_fn)) acc = join(acc, p);
  return acc;
}

/// The indices i in [0, n) with pred(i), ascending (per-block lists joined
/// in block order).
template <class Pred>
std::vector<int32_t> parallel_select(int64_t n, int threads, const Pred& pred) {
  std::vector<int32_t> out;
  for (const auto& part : parallel_map_blocks(n, threads, [&](int64_t b, int64_t e) {
         std::vector<int32_t> w;
         for (int64_t i = b; i < e; ++i)
           if (pred(i)) w.push_back(static_cast<int32_t>(i));
         return w;
       }))
    out.insert(out.end(), part.begin(), part.end());
  return out;
}

/// The number of i in [0, n) with pred(i).
template <class Pred>
int64_t parallel_count(int64_t n, int threads, const Pred& pred) {
  return parallel_reduce_blocks(
      n, threads, int64_t{0},
      [&](int64_t b, int64_t e) {
        int64_t k = 0;
        for (int64_t i = b; i < e; ++i) k += pred(i) ? 1 : 0;
        return k;
      },
      [](int64_t x, int64_t y) { return x + y; });
}

/// min over i in [0, n) of f(i) (+infinity when n == 0).
template <class F>
double parallel_min(int64_t n, int threads, const F& f) {
  return parallel_reduce_blocks(
      n, threads, std::numeric_limits<double>::infinity(),
      [&](int64_t b, int64_t e) {
        double lo = std::numeric_limits<double>::infinity();
        for (int64_t i = b; i < e; ++i) lo = std::min(lo, f(i));
        return lo;
      },
      [](double x, double y) { return std::min(x, y); });
}

}  // namespace tetopt::detail
