// Google Benchmark micro-benchmarks of the kernels and single operations
// (STYLE.md §10): alpha and dihedral kernels, exact orient3d, one local
// smoothing solve, one edge removal, adjacency / topology build, and one
// smoothing pass at 1 and 2 threads.  Inputs are generated here (box meshes,
// seeded random tets), so the numbers need no files.
//
//   build-x/tetopt_bench --benchmark_format=json > micro.json
//
// Release builds only; compare ratios within one run on a shared machine.
#include <benchmark/benchmark.h>

#include <cstring>
#include <random>
#include <vector>

#include "tetopt/generate.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/smooth.hpp"
#include "tetopt/topo.hpp"

using namespace tetopt;

namespace {

TetMesh jittered_box(int n, double jitter = 0.38, uint64_t seed = 7) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = n;
  bo.jitter = jitter;
  bo.seed = seed;
  TetMesh m = make_box_mesh(bo);
  build_topology(m);
  return m;
}

// 1024 random positive tets, 12 doubles each.
const std::vector<double>& random_tets() {
  static const std::vector<double> pts = [] {
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<double> p;
    while (p.size() < 1024 * 12) {
      double q[12];
      for (double& x : q) x = u(rng);
      if (tet_signed_volume(q, q + 3, q + 6, q + 9) < 0) std::swap_ranges(q, q + 3, q + 3);
      p.insert(p.end(), q, q + 12);
    }
    return p;
  }();
  return pts;
}

void BM_Alpha(benchmark::State& state) {
  const std::vector<double>& p = random_tets();
  size_t i = 0;
  for (auto _ : state) {
    const double* q = &p[12 * i];
    benchmark::DoNotOptimize(alpha(q, q + 3, q + 6, q + 9));
    i = (i + 1) & 1023;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Alpha);

void BM_DihedralAngles(benchmark::State& state) {
  const std::vector<double>& p = random_tets();
  size_t i = 0;
  double out[6];
  for (auto _ : state) {
    const double* q = &p[12 * i];
    dihedral_angles(q, q + 3, q + 6, q + 9, out);
    benchmark::DoNotOptimize(out);
    i = (i + 1) & 1023;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DihedralAngles);

// Generic (filtered, decided in floating point) orient3d.
void BM_Orient3dGeneric(benchmark::State& state) {
  const std::vector<double>& p = random_tets();
  size_t i = 0;
  for (auto _ : state) {
    const double* q = &p[12 * i];
    benchmark::DoNotOptimize(orient3d(q, q + 3, q + 6, q + 9));
    i = (i + 1) & 1023;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Orient3dGeneric);

// Exactly coplanar points (a lattice plane): the filter fails and the exact
// path decides Zero.
void BM_Orient3dCoplanar(benchmark::State& state) {
  const double a[3] = {0.1, 0.2, 0.3}, b[3] = {1.1, 0.7, 0.3}, c[3] = {0.3, 1.9, 0.3}, d[3] = {0.7, 0.7, 0.3};
  for (auto _ : state) benchmark::DoNotOptimize(orient3d(a, b, c, d));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Orient3dCoplanar);

// One local solve (gather, optimise, exact check, commit) on a fixed free
// vertex of a jittered box; the vertex is put back after every solve.
void BM_SmoothVertex(benchmark::State& state) {
  static TetMesh m = jittered_box(10);
  const Optimizer opt = state.range(0) ? Optimizer::MaxMin : Optimizer::Paper;
  std::vector<int32_t> free;
  for (int32_t v = 0; v < m.nv(); ++v)
    if (!m.vert_constrained[v]) free.push_back(v);
  SmoothOptions o;
  o.optimizer = opt;
  size_t i = 0;
  int64_t applied = 0;
  for (auto _ : state) {
    const int32_t v = free[i];
    double keep[3];
    std::memcpy(keep, m.point(v), sizeof keep);
    applied += smooth_vertex(m, v, o) == SmoothResult::Applied;
    std::memcpy(m.point(v), keep, sizeof keep);
    i = (i + 1) % free.size();
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["applied_fraction"] = static_cast<double>(applied) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_SmoothVertex)->Arg(0)->Arg(1)->ArgName("maxmin");

// One edge removal through a TopoEditor: plan (shell, DP, exact checks) and
// commit.  Each iteration works on a fresh copy of a small box (copy and
// editor construction are not timed); edges are those the editor accepts.
void BM_RemoveEdge(benchmark::State& state) {
  static const TetMesh base = jittered_box(5, 0.42, 3);
  TopoOptions to;
  to.quality_threshold = 2.0;
  std::vector<std::pair<int32_t, int>> ok;
  {
    for (int32_t t = 0; t < base.nt() && ok.size() < 64; ++t)
      for (int le = 0; le < 6; ++le) {
        TetMesh m = base;
        TopoEditor ed(m, to);
        if (ed.remove_edge(t, le) == TopoResult::Applied) ok.emplace_back(t, le);
      }
  }
  if (ok.empty()) {
    state.SkipWithError("no removable edge in the box");
    return;
  }
  size_t i = 0;
  for (auto _ : state) {
    state.PauseTiming();
    TetMesh m = base;
    {
      TopoEditor ed(m, to);
      state.ResumeTiming();
      benchmark::DoNotOptimize(ed.remove_edge(ok[i].first, ok[i].second));
      state.PauseTiming();
    }
    state.ResumeTiming();
    i = (i + 1) % ok.size();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RemoveEdge);

// Face adjacency alone and the whole topology (CSR, adjacency, classify).
void BM_BuildAdjacency(benchmark::State& state) {
  TetMesh m = jittered_box(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    benchmark::DoNotOptimize(build_adjacency(m).ok());
  }
  state.SetItemsProcessed(state.iterations() * m.nt());
  state.counters["tets"] = m.nt();
}
BENCHMARK(BM_BuildAdjacency)->Arg(16)->Arg(40)->Unit(benchmark::kMillisecond);

void BM_BuildTopology(benchmark::State& state) {
  TetMesh m = jittered_box(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    benchmark::DoNotOptimize(build_topology(m).ok());
  }
  state.SetItemsProcessed(state.iterations() * m.nt());
  state.counters["tets"] = m.nt();
}
BENCHMARK(BM_BuildTopology)->Arg(16)->Arg(40)->Unit(benchmark::kMillisecond);

// One smoothing pass (both phases, 3 sweeps each) on a 24^3-cell box
// (82,944 tets) at 1 and 2 threads: the same bytes, wall-clock ratio = the
// parallel speed-up.  The mesh is copied outside the timed region.
void BM_SmoothPass(benchmark::State& state) {
  static const TetMesh base = jittered_box(24, 0.38, 11);
  SmoothOptions o;
  o.all_vertices = true;
  o.iterations = 3;
  o.threads = static_cast<int>(state.range(0));
  int64_t moves = 0;
  for (auto _ : state) {
    state.PauseTiming();
    TetMesh m = base;
    state.ResumeTiming();
    moves = smooth_pass(m, o).moves_tried;
  }
  state.counters["moves_tried"] = static_cast<double>(moves);
  state.SetItemsProcessed(state.iterations() * base.nt());
}
BENCHMARK(BM_SmoothPass)->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond)->UseRealTime();

// The O(nt) quality scan a pass starts with, per tet.
void BM_AlphaScan(benchmark::State& state) {
  static const TetMesh m = jittered_box(24);
  std::vector<double> qa(m.nt());
  for (auto _ : state) {
    for (int32_t t = 0; t < m.nt(); ++t) qa[t] = tet_alpha(m, t);
    benchmark::DoNotOptimize(qa.data());
  }
  state.SetItemsProcessed(state.iterations() * m.nt());
}
BENCHMARK(BM_AlphaScan)->Unit(benchmark::kMillisecond);

}  // namespace
