// Large pages for the heap, set up before anything else runs.
//
// tetopt's arrays are large and filled once, so a run spends much of its
// kernel time on first-touch page faults: on this project's 2-core VM,
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
#pragma once
#include <cstdlib>
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

}  // namespace tetopt_cli
