// The machine's own 1 -> 2 thread ceiling, for reading tetopt's thread ratio
// in the same run (bench/run_bench.sh builds and runs it; nothing of tetopt
// in it).  Two workloads, each run with one thread and then with two threads
// doing the same work each (one per core), REPS times alternated:
//   compute: eight independent multiply-add chains per thread (bound by the
//            core's arithmetic throughput, no memory traffic);
//   random:  a walk through a private 32 MiB array per thread in which each
//            read gives the position of the next (a random cycle), so every
//            read waits for a cache miss (like the topology passes' walks
//            from tet to neighbour to vertex coordinates).
// Prints one JSON object: per workload the median seconds at 1 and 2 threads
// and the speed-up 2 * t1 / t2 (2.0 = the second core does as much again).
// usage: ceiling [REPS]   (default 5)
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

namespace {

volatile double g_sink_d = 0;
volatile uint64_t g_sink_u = 0;

void compute_work() {
  double x[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  for (long i = 0; i < 60000000; ++i)
    for (double& v : x) v = v * 1.0000001 + 1e-9;
  double s = 0;
  for (double v : x) s += v;
  g_sink_d = s;
}

void random_work(const std::vector<uint64_t>& next) {
  uint64_t at = 0;
  for (long i = 0; i < 4000000; ++i) at = next[at];
  g_sink_u = at;
}

// One cycle through all n positions in random order (Sattolo's algorithm,
// with a 64-bit LCG, Knuth's MMIX constants, for the random numbers).
std::vector<uint64_t> random_cycle(size_t n, uint64_t seed) {
  std::vector<uint64_t> perm(n);
  for (size_t i = 0; i < n; ++i) perm[i] = i;
  uint64_t x = seed;
  for (size_t i = n - 1; i > 0; --i) {
    x = x * 6364136223846793005ull + 1442695040888963407ull;
    std::swap(perm[i], perm[(x >> 33) % i]);
  }
  std::vector<uint64_t> next(n);
  for (size_t i = 0; i < n; ++i) next[perm[i]] = perm[(i + 1) % n];
  return next;
}

template <class Work>
double timed(int threads, const Work& work) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back([&work, t] { work(t); });
  work(0);
  for (std::thread& th : pool) th.join();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  const std::vector<std::vector<uint64_t>> arrays = {random_cycle(size_t{1} << 22, 1),
                                                      random_cycle(size_t{1} << 22, 2)};  // 32 MiB each
  auto compute = [](int) { compute_work(); };
  auto random = [&arrays](int t) { random_work(arrays[static_cast<size_t>(t)]); };
  std::vector<double> c1, c2, r1, r2;
  for (int i = 0; i < reps; ++i) {
    c1.push_back(timed(1, compute));
    c2.push_back(timed(2, compute));
    r1.push_back(timed(1, random));
    r2.push_back(timed(2, random));
  }
  const double mc1 = median(c1), mc2 = median(c2), mr1 = median(r1), mr2 = median(r2);
  std::printf(
      "{\"reps\": %d, \"compute\": {\"t1_s\": %.4f, \"t2_s\": %.4f, \"speedup\": %.3f}, "
      "\"random_walk\": {\"t1_s\": %.4f, \"t2_s\": %.4f, \"speedup\": %.3f}}\n",
      reps, mc1, mc2, 2 * mc1 / mc2, mr1, mr2, 2 * mr1 / mr2);
  return 0;
}
