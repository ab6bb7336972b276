// Memory set-up of the programs, done before anything else runs.
//
// Large pages for the heap (reexec_with_huge_pages): tetopt's arrays are
// large and filled once, so a run spends much of its kernel time on
// first-touch page faults: on this project's 2-core VM,
// `tetopt improve` on the 2.0M-tet flange_large took 113k minor faults and
// 9.0 s; with glibc's malloc asking for transparent huge pages, 7.5k faults
// and 7.6 s (impeller: 1.85 -> 1.63 s at 1 thread; docs/benchmarks.md).
//
// The switch is the glibc tunable glibc.malloc.hugetlb=1 (glibc >= 2.35;
// glibc manual, "Memory Allocation Tunables": malloc then madvises its
// arenas and mmap'd chunks with MADV_HUGEPAGE).  Tunables are read only at
// process start, so the program re-executes itself once with it set.  It
// does so only where it helps and the user has not decided otherwise:
// transparent huge pages in "madvise" mode (in "always" mode the kernel
// does it anyway; in "never" mode nothing would change), GLIBC_TUNABLES not
// set, and TETOPT_NO_HUGEPAGES not set.  If the re-execution fails the
// program carries on as it is.  Results do not depend on it.
//
// Freed memory kept in the heap (keep_freed_memory, called after the
// re-execution): a run allocates and frees the same large arrays many times
// (an alpha cache and stamps per topology pass, vertex stars after every
// pass, buffers of the smoothing passes).  glibc serves a request above its
// mmap threshold (128 KiB, raised dynamically up to 32 MiB) with a fresh
// mapping and returns it to the kernel when freed, and trims the heap's top
// above 128 KiB; each new use then pays its page faults again, and with huge
// pages each fault is a 2 MiB clear, serial on the allocating thread.  A
// perf profile of the demo impeller at 2 threads put 1,086 of its samples
// (about 0.2 s of 1.1 s) in page faults.  With the mmap threshold at its
// maximum (32 MiB, glibc's DEFAULT_MMAP_THRESHOLD_MAX on 64-bit) and trimming
// above 1 GiB (glibc manual, "Memory Allocation Tunables" and mallopt(3)),
// a freed array is reused from the heap: the impeller ran about 10% faster
// at 1 and 2 threads with the same peak memory (docs/benchmarks.md).  A user
// who sets either value in GLIBC_TUNABLES keeps it.
//
// Heap touched on every thread (prefault_heap): the first write to a page
// the process has never used makes the kernel clear it, on the writing
// thread; with huge pages that is 2 MiB at a time.  On this project's VM the
// host also backs the page at that moment, unless a recent process freed it:
// a first touch measured 1.7-1.9 ms per MB after a few idle seconds
// (0.06-0.08 ms per MB right after another process), and two threads
// touching 64 MB took 58-73 ms against 104-126 ms for one (ninth session,
// docs/benchmarks.md).  tetopt's big arrays are mostly allocated by the main
// thread (the reader's, the topology's, the passes' caches), so those faults
// were serial: a perf profile of the demo impeller at 2 threads put about
// 0.08 s of main-thread-only samples in page faults.  With more than one
// thread, the programs allocate an estimate of what the next phase needs in
// pieces below the mmap threshold, touch one byte per 4 KiB page of them on
// all threads, and free them: with keep_freed_memory's trim threshold the
// pages stay in the heap, and the next allocations take them.  Results do
// not depend on it; TETOPT_NO_PREFAULT turns it off.
#pragma once
#include <malloc.h>

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

namespace tetopt_cli {

inline void reexec_with_huge_pages(char** argv) {
  if (std::getenv("GLIBC_TUNABLES") || std::getenv("TETOPT_NO_HUGEPAGES")) return;
  std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  if (!thp || !std::getline(thp, mode) || mode.find("[madvise]") == std::string::npos) return;
  if (setenv("GLIBC_TUNABLES", "glibc.malloc.hugetlb=1", 1) != 0) return;
  execv("/proc/self/exe", argv);
  unsetenv("GLIBC_TUNABLES");  // exec failed: go on without
}

// Whether keep_freed_memory set the thresholds (prefault_heap relies on them).
inline bool g_keeps_freed_memory = false;
inline constexpr size_t kMmapThreshold = size_t{32} << 20;

inline void keep_freed_memory() {
  const char* tun = std::getenv("GLIBC_TUNABLES");
  if (tun && (std::strstr(tun, "mmap_threshold") || std::strstr(tun, "trim_threshold"))) return;
  g_keeps_freed_memory = mallopt(M_MMAP_THRESHOLD, static_cast<int>(kMmapThreshold)) == 1 &&
                         mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024) == 1;
}

/// Whether an array of `bytes` is below the mmap threshold, so that glibc
/// always serves it from the heap (a larger one gets a mapping of its own
/// unless a free chunk happens to be large enough).  The programs prefault
/// only while the per-tet arrays of 16 bytes stay below it: on the 3.07M-tet
/// generated box (49 MB each), prefaulting raised the peak memory from 362
/// to 425 MB and saved nothing.
inline bool heap_serves(size_t bytes) { return g_keeps_freed_memory && bytes < kMmapThreshold; }

/// Touches about `bytes` of fresh heap on `threads` threads (0: all cores)
/// and frees it again (see above).  Nothing with one thread: the faults it
/// would take are the ones the run takes anyway, on the same thread.
inline void prefault_heap(size_t bytes, int threads) {
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  if (threads <= 0 || (cores > 0 && threads > cores)) threads = cores;  // no more helpers than cores
  if (threads <= 1 || !g_keeps_freed_memory || bytes < (size_t{4} << 20) || std::getenv("TETOPT_NO_PREFAULT")) return;
  // Pieces well below the 32 MiB mmap threshold (keep_freed_memory), so
  // that they come from the heap's top, one after the other, and coalesce
  // into one free chunk when freed.  Nothing else is allocated between them
  // (both vectors are reserved first): a vector growing between two pieces
  // left them apart, and a 24 MiB request then grew the heap.
  constexpr size_t kPiece = size_t{8} << 20, kPage = 4096;
  std::vector<char*> piece;
  std::vector<std::thread> helper;
  piece.reserve((bytes + kPiece - 1) / kPiece);
  helper.reserve(static_cast<size_t>(threads - 1));
  for (size_t b = 0; b < bytes; b += kPiece) {
    char* p = static_cast<char*>(std::malloc(kPiece));
    if (!p) break;
    piece.push_back(p);
  }
  // Pieces taken in turn by whichever thread is free (the helpers start
  // later than the main thread).
  std::atomic<size_t> next{0};
  auto touch = [&] {
    for (size_t i; (i = next.fetch_add(1, std::memory_order_relaxed)) < piece.size();)
      for (size_t o = 0; o < kPiece; o += kPage) reinterpret_cast<volatile char*>(piece[i])[o] = 0;
  };
  try {
    for (int t = 1; t < threads; ++t) helper.emplace_back(touch);
  } catch (...) {  // fewer helpers: the others take their share
  }
  touch();
  for (std::thread& h : helper) h.join();
  for (size_t i = piece.size(); i-- > 0;) std::free(piece[i]);
}

}  // namespace tetopt_cli
