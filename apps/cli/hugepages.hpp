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
#pragma once
#include <malloc.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

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

inline void keep_freed_memory() {
  const char* tun = std::getenv("GLIBC_TUNABLES");
  if (tun && (std::strstr(tun, "mmap_threshold") || std::strstr(tun, "trim_threshold"))) return;
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
}

}  // namespace tetopt_cli
