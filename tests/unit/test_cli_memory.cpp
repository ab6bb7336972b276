// The programs' memory set-up (apps/cli/hugepages.hpp): the heap touched on
// every thread must stay in the heap for the run's own arrays.  Each case runs
// in a forked child, since mallopt changes the whole process.
#include <gtest/gtest.h>
#include <malloc.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <thread>

#include "../../apps/cli/hugepages.hpp"

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kOwnMalloc = false;  // the sanitizer's allocator: no glibc arena to look at
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kOwnMalloc = false;
#else
constexpr bool kOwnMalloc = true;
#endif
#else
constexpr bool kOwnMalloc = true;
#endif

size_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  size_t size = 0, resident = 0;
  f >> size >> resident;
  return resident * static_cast<size_t>(sysconf(_SC_PAGESIZE));
}

// Runs body in a child; returns its exit code (the line of the first failed
// check, 0 when all held).
template <class Body>
int in_child(const Body& body) {
  const pid_t pid = fork();
  if (pid == 0) _exit(body());
  int st = 0;
  waitpid(pid, &st, 0);
  return WIFEXITED(st) ? WEXITSTATUS(st) : 255;
}

#define CHILD_CHECK(c) \
  if (!(c)) return __LINE__ % 250 + 1

constexpr size_t kMiB = size_t{1} << 20;

}  // namespace

TEST(CliMemory, PrefaultedHeapIsTouchedAndKeptForTheNextAllocations) {
  if (!kOwnMalloc) GTEST_SKIP() << "not glibc's allocator";
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "one core: prefault_heap does nothing";
  EXPECT_EQ(0, in_child([] {
    unsetenv("TETOPT_NO_PREFAULT");
    tetopt_cli::keep_freed_memory();
    const size_t arena0 = mallinfo2().arena, res0 = resident_bytes();
    tetopt_cli::prefault_heap(64 * kMiB, 2);
    const struct mallinfo2 mi = mallinfo2();
    // From the heap (not mmap'd pieces), touched, freed and not trimmed.
    CHILD_CHECK(mi.arena >= arena0 + 64 * kMiB);
    CHILD_CHECK(mi.fordblks >= 64 * kMiB);
    CHILD_CHECK(resident_bytes() >= res0 + 60 * kMiB);
    // A 24 MiB array and a 30 MiB one then come out of it: the heap does not grow.
    void* a = std::malloc(24 * kMiB);
    void* b = std::malloc(30 * kMiB);
    CHILD_CHECK(a && b);
    CHILD_CHECK(mallinfo2().arena == mi.arena);
    CHILD_CHECK(mallinfo2().hblkhd == mi.hblkhd);
    std::free(b);
    std::free(a);
    CHILD_CHECK(tetopt_cli::heap_serves(30 * kMiB) && !tetopt_cli::heap_serves(32 * kMiB));
    return 0;
  }));
}

TEST(CliMemory, NoPrefaultWithOneThreadOrWhenSwitchedOff) {
  if (!kOwnMalloc) GTEST_SKIP() << "not glibc's allocator";
  EXPECT_EQ(0, in_child([] {
    tetopt_cli::keep_freed_memory();
    const size_t arena0 = mallinfo2().arena;
    unsetenv("TETOPT_NO_PREFAULT");
    tetopt_cli::prefault_heap(64 * kMiB, 1);
    CHILD_CHECK(mallinfo2().arena < arena0 + 8 * kMiB);
    setenv("TETOPT_NO_PREFAULT", "1", 1);
    tetopt_cli::prefault_heap(64 * kMiB, 2);
    CHILD_CHECK(mallinfo2().arena < arena0 + 8 * kMiB);
    return 0;
  }));
}
