// Vertex insertion pass (see insert.hpp); the local operation is
// TopoEditor::insert_vertex (topo.cpp).
#include "tetopt/insert.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "tetopt/quality.hpp"
#include "tetopt/topo.hpp"
#include "detail/edge_key.hpp"
#include "detail/vec3.hpp"

namespace tetopt {

// The most tets of a free vertex's star that a signature covers.
constexpr size_t kStarMax = 128;

// A tet with all four vertices constrained has no vertex to smooth, and
// where neither an inserted vertex (insert_vertex's cavity is the tet and
// its face neighbours) nor a removal lifts it, it can stay the mesh's worst
// for good.  Splitting one of its edges on no constrained face replaces the
// edge's shell by a cone from a free vertex that the smoothing then moves;
// the first split whose new tets' worst rises above t's alpha is taken
// (the shell holds t, so its worst rises too), at the edges' midpoints
// first, then at 0.3 and 0.7 of them (screw_graded, unguarded: a tet on
// the screw's end face took a split at 0.7 only, 0.4295 -> 0.4448 for the
// mesh; the guards refuse it there, for its mean ratio).
// forced (0 < forced < 1, with no guard): a split that lifts t first, as
// above, else one whose new tets keep forced times t's alpha.
static bool split_locked(TopoEditor& ed, int32_t t, double margin, double forced) {
  Acceptance acc;
  acc.on = true;
  acc.ratio = 0;
  const double a = ed.cached_alpha(t);
  for (const double floor : {a + margin, forced * a}) {
    if (!(floor > 0)) break;
    acc.floor = floor;
    for (const double wa : {0.5, 0.3, 0.7})
      for (int le = 0; le < 6; ++le)
        if (ed.split_edge(t, le, acc, wa) == TopoResult::Applied) return true;
  }
  return false;
}

int64_t split_locked_worst(TetMesh& m, const InsertOptions& o, double forced) {
  if (!topology_current(m) && !build_topology(m)) return 0;
  ensure_vertex_tets(m);
  const bool force = forced > 0 && forced < 1;
  TopoOptions to;
  to.margin = o.margin;
  to.objective = o.objective;
  to.guard = force ? nullptr : o.guard;
  TopoEditor ed(m, to);
  double worst = INFINITY;
  for (int32_t t = 0; t < m.nt(); ++t) worst = std::min(worst, ed.cached_alpha(t));
  std::vector<int32_t> work;
  for (int32_t t = 0; t < m.nt(); ++t)
    if (m.tet_kind[t] == 4 && ed.cached_alpha(t) <= worst + o.margin) work.push_back(t);
  int64_t n = 0;
  // A split frees its shell's slots and fills them with its new tets: a
  // slot is tried only while it still holds a locked tet at the worst.
  for (const int32_t t : work)
    if (ed.alive(t) && m.tet_kind[t] == 4 && ed.cached_alpha(t) <= worst + o.margin &&
        split_locked(ed, t, o.margin, force ? forced : 0))
      ++n;
  ed.finish();
  return n;
}

// The size of the next window of searches made ahead (insert_pass,
// refine_pass): halved while more than 1 search in 8 was made again,
// doubled while fewer than 1 in 32 were (TopoEditor::improve_tets' rule).
static size_t next_window(size_t win, int64_t redone, int64_t used, size_t lo, size_t hi) {
  if (8 * redone > redone + used) return std::max(lo, win / 2);
  if (32 * redone < redone + used) return std::min(hi, 2 * win);
  return win;
}

InsertStats insert_pass(TetMesh& m, const InsertOptions& o, const LogFn& log) {
  const auto t0 = std::chrono::steady_clock::now();
  InsertStats st;
  if (!topology_current(m)) {
    st.status = build_topology(m);
    if (!st.status) return st;
  }
  ensure_vertex_tets(m);  // absent after topology passes run without rebuild_stars
  st.vertices_before = m.nv();
  st.tets_before = m.nt();
  TopoOptions to;
  to.margin = o.margin;
  to.objective = o.objective;
  to.guard = o.guard;
  to.threads = o.threads;
  TopoEditor ed(m, to);
  st.alpha_worst_before = INFINITY;
  for (int32_t t = 0; t < m.nt(); ++t) st.alpha_worst_before = std::min(st.alpha_worst_before, ed.cached_alpha(t));
  std::vector<int32_t> work;
  // A tet refused before (in an earlier pass, or an earlier call sharing
  // o.memo) is not tried again while its signature (InsertMemo) is what it
  // was then: no commit has replaced it or its face neighbours or changed
  // what lies across their faces, no vertex of theirs has moved, and (with
  // removal on) the stars of its free vertices, which a removal replaces,
  // are the same tets at the same places.  A tet refused in this call is
  // also tried again once a commit has made a tet at a vertex of it or of
  // its face neighbours (TopoEditor::touched_since, what this pass checked
  // alone before the memo).  Not covered: a cavity grown past the face
  // neighbours, changed only there since the refusal.
  InsertMemo local;
  InsertMemo& memo = o.memo ? *o.memo : local;
  auto mixer = [](uint64_t& h, uint64_t x) {  // splitmix64's finaliser over the running hash
    uint64_t z = h ^ (x + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2));
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    h = z ^ (z >> 31);
  };
  auto key = [&](int32_t t) {
    std::array<int32_t, 4> q;
    std::copy(m.tet(t), m.tet(t) + 4, q.begin());
    std::sort(q.begin(), q.end());
    uint64_t h = 0x243F6A8885A308D3ull;
    for (const int32_t v : q) mixer(h, static_cast<uint32_t>(v));
    return h;
  };
  // What else an attempt depends on: the options (a memo shared by calls
  // with other options must not stand for them).
  uint64_t seed = 0x9E3779B97F4A7C15ull;
  {
    uint64_t mb;
    std::memcpy(&mb, &o.margin, sizeof mb);
    mixer(seed, mb);
    mixer(seed, static_cast<uint64_t>(o.insert) | static_cast<uint64_t>(o.remove) << 1 |
                    static_cast<uint64_t>(o.objective) << 8);
  }
  std::vector<int32_t> star;
  auto signature = [&](int32_t t) {
    uint64_t h = seed;
    auto tet = [&](int32_t u) {
      const int32_t* tv = m.tet(u);
      for (int k = 0; k < 4; ++k) {
        mixer(h, static_cast<uint32_t>(tv[k]));
        const double* p = m.point(tv[k]);
        for (int d = 0; d < 3; ++d) {
          uint64_t b;
          std::memcpy(&b, p + d, sizeof b);
          mixer(h, b);
        }
        // The vertex across face k (the face opposite tv[k]), -1 on none.
        const int32_t nb = m.adj[4 * static_cast<size_t>(u) + k];
        mixer(h, static_cast<uint32_t>(nb < 0 ? -1 : m.tets[nb]));
      }
      mixer(h, static_cast<uint64_t>(static_cast<uint32_t>(m.tet_ref[u])) << 8 | m.face_mask[u]);
    };
    tet(t);
    for (int f = 0; f < 4; ++f)
      if (const int32_t nb = m.adj[4 * static_cast<size_t>(t) + f]; nb >= 0) tet(nb / 4);
    if (o.remove)
      for (int k = 0; k < 4; ++k) {
        // The star of free vertex v: breadth first from t across the faces
        // that contain v (what TopoEditor::contract gathers), in an order
        // set by the tets' own vertex orders, not their slots.
        const int32_t v = m.tet(t)[k];
        if (m.vert_constrained[v]) continue;
        star.assign(1, t);
        for (size_t i = 0; i < star.size() && star.size() < kStarMax; ++i)
          for (int f = 0; f < 4; ++f) {
            if (m.tet(star[i])[f] == v) continue;  // the face opposite v does not contain it
            const int32_t nb = m.adj[4 * static_cast<size_t>(star[i]) + f];
            if (nb >= 0 && std::find(star.begin(), star.end(), nb / 4) == star.end()) star.push_back(nb / 4);
          }
        for (size_t i = 1; i < star.size(); ++i) tet(star[i]);
      }
    return h | 1;
  };
  // This call's refusals: the epoch that began after each (by slot; slots
  // keep their tets within a call) and the tet's vertices then.
  std::vector<uint32_t> failed;
  std::vector<std::array<int32_t, 4>> failed_v;
  auto refused_here = [&](int32_t t) {
    return static_cast<size_t>(t) < failed.size() && failed[t] != 0 &&
           std::equal(m.tet(t), m.tet(t) + 4, failed_v[t].begin());
  };
  auto touched = [&](int32_t t) {
    if (ed.touched_since(t, failed[t])) return true;
    for (int f = 0; f < 4; ++f) {
      const int32_t nb = m.adj[4 * static_cast<size_t>(t) + f];
      if (nb >= 0 && ed.touched_since(nb / 4, failed[t])) return true;
    }
    return false;
  };
  for (int p = 0; p < std::max(1, o.passes); ++p) {
    work.clear();
    for (int32_t t = 0; t < m.nt(); ++t)
      if (ed.alive(t) && ed.cached_alpha(t) < o.quality_threshold && (!o.all_boundary_only || m.tet_kind[t] == 4) &&
          m.tet_kind[t] >= o.min_kind)
        work.push_back(t);
    // Worst first: the worst tets get the first choice of cavity.
    std::stable_sort(work.begin(), work.end(),
                     [&](int32_t a, int32_t b) { return ed.cached_alpha(a) < ed.cached_alpha(b); });
    int64_t ins = 0, rem = 0;
    const int64_t skipped0 = st.skipped, used_p = ed.inserts_used(), redone_p = ed.inserts_redone();
    // Whether t is tried now: 2 yes; 1 no, refused in an earlier call with
    // what its signature covers unchanged (counted as skipped); 0 no (dead,
    // above the threshold, or refused in this call and not touched since:
    // those skips were never counted as tries).
    auto verdict = [&](int32_t t) {
      if (!ed.alive(t) || !(ed.cached_alpha(t) < o.quality_threshold)) return 0;
      if (const auto it = memo.refused.find(key(t)); it != memo.refused.end() && it->second == signature(t)) {
        const bool here = refused_here(t);
        if (!here || !touched(t)) return here ? 0 : 1;
      }
      return 2;
    };
    // Windows of `win` entries of work: the position searches of the tets
    // to be tried at the window's start run first, in parallel
    // (TopoEditor::plan_inserts); then the entries go in order as before,
    // each using its search when no commit has changed what it read, so
    // the pass ends where the serial one does.  The window halves while
    // more than 1 search in 8 is made again and doubles while fewer than 1
    // in 32 are (as TopoEditor::improve_tets does).
    constexpr size_t kWinMin = 8, kWinMax = 256;
    const bool ahead = o.insert && TopoEditor::plan_threads(o.threads) > 1;
    size_t win = 32;
    std::vector<int32_t> batch;
    std::vector<int> slot;       // per entry of the window: its search, or -1
    std::vector<int8_t> judged;  // per entry: its verdict at the window's start, or -1
    for (size_t w0 = 0; w0 < work.size();) {
      const size_t w1 = std::min(work.size(), w0 + win);
      batch.clear();
      slot.assign(w1 - w0, -1);
      judged.assign(w1 - w0, -1);
      if (ahead)
        for (size_t k = w0; k < w1; ++k)
          if ((judged[k - w0] = static_cast<int8_t>(verdict(work[k]))) == 2) {
            slot[k - w0] = static_cast<int>(batch.size());
            batch.push_back(work[k]);
          }
      if (ed.plan_inserts(batch.data(), static_cast<int>(batch.size())) == 0) std::fill(slot.begin(), slot.end(), -1);
      const int64_t redone0 = ed.inserts_redone(), used0 = ed.inserts_used();
      const int64_t changes0 = ins + rem;
      for (size_t k = w0; k < w1; ++k) {
        const int32_t t = work[k];
        // With no commit since the window's start nothing a verdict reads
        // has changed (this pass visits each tet once).
        if (const int v = ins + rem == changes0 && judged[k - w0] >= 0 ? judged[k - w0] : verdict(t); v < 2) {
          st.skipped += v;
          continue;
        }
        ++st.tried;
        if (o.insert && ed.insert_planned(slot[k - w0], t) == TopoResult::Applied) ++ins;
        else if (o.remove && ed.alive(t) && ed.remove_vertex(t) == TopoResult::Applied) ++rem;
        else if (ed.alive(t)) {
          memo.refused[key(t)] = signature(t);
          if (failed.size() < static_cast<size_t>(m.nt())) {
            failed.resize(m.nt(), 0);
            failed_v.resize(m.nt());
          }
          failed[t] = ed.next_stamp();
          std::copy(m.tet(t), m.tet(t) + 4, failed_v[t].begin());
        }
      }
      win = next_window(win, ed.inserts_redone() - redone0, ed.inserts_used() - used0, kWinMin, kWinMax);
      w0 = w1;
    }
    st.inserted += ins;
    st.removed += rem;
    if (log)
      log(LogLevel::Info, "insert pass " + std::to_string(p + 1) + ": " + std::to_string(work.size()) +
                              " tets visited (" + std::to_string(st.skipped - skipped0) +
                              " unchanged since refused in an earlier call), " + std::to_string(ins) + " vertices inserted, " +
                              std::to_string(rem) + " removed" +
                              (ed.inserts_used() + ed.inserts_redone() > used_p + redone_p
                                   ? " (" + std::to_string(ed.inserts_used() - used_p) + " searches made ahead used, " +
                                         std::to_string(ed.inserts_redone() - redone_p) + " made again)"
                                   : std::string()));
    if (ins + rem == 0) break;
  }
  st.alpha_worst_after = INFINITY;
  for (int32_t t = 0; t < m.nt(); ++t)
    if (ed.alive(t)) st.alpha_worst_after = std::min(st.alpha_worst_after, ed.cached_alpha(t));
  st.removed_vertices = ed.removed();
  st.planned_used = ed.inserts_used();
  st.planned_redone = ed.inserts_redone();
  ed.finish();
  st.vertices_after = m.nv() - st.removed;
  st.tets_after = m.nt();
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}


namespace {

double dist(const double* a, const double* b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

// Largest growth of the size field along an edge where it is graded (a
// vertex of a raw mesh): h_v <= h_w + kSizeGradation * |vw|.  MMG's gradation
// (Dapogny, Dobrzynski & Frey 2014, §4: h grows by at most log(hgrad) times
// the distance, hgrad 1.3 by default, i.e. 0.26) gave on bib_0p25 (docs/
// benchmarks.md, nineteenth session) 42k tets with mean alpha 0.648; 0.2:
// 53k, 0.680; 0.15: 74k, 0.704 (MMG: 113k, 0.700); 0.1: 146k, 0.721 (the
// first and last with an earlier variant: the graded size at every vertex).
constexpr double kSizeGradation = 0.15;

// How fast the size of a circumcentre that refine_pass inserts into a raw
// mesh may grow with its distance from the tet's vertices: the circumcentre
// of a Delaunay tet is equally far (its circumradius r) from its four
// vertices and no vertex is nearer, so min_i h_i + g r is the size graded
// from the nearest ones, capped by the interior's graded size above.  g =
// log 1.3, MMG's default hgrad (Dapogny, Dobrzynski & Frey 2014, §4).
// Before, a raw vertex and so the first layer of new vertices took the
// graded size itself, on cylinder_hole's raw mesh 1.7 times its surface
// triangles' edges: the tets on its boundary triangles averaged alpha 0.66
// where MMG's averaged 0.71 (the interior 0.71 against 0.68), and the mesh
// 0.679 against MMG's 0.686.  Graded from the wall: 26k tets instead of
// 17k, mean 0.735-0.741 over three seeds (0.3: 0.732-0.738; 0.2: 29k tets,
// 0.743; docs/benchmarks.md, twenty-fourth session).
constexpr double kWallGradation = 0.2624;

// The size field of RemeshOptions (see insert.hpp); with cap, that of
// refine_pass on a raw mesh: h the surface size at a raw vertex, cap the
// graded size.
void size_field(const TetMesh& m, double size, double gradation, std::vector<double>& h,
                std::vector<double>* cap = nullptr) {
  const double grade = gradation > 0 ? gradation : kSizeGradation;
  const int32_t nv = m.nv();
  h.assign(nv, 0.0);
  if (cap) cap->clear();
  if (size > 0) {
    std::fill(h.begin(), h.end(), size);
    return;
  }
  for (const auto& pf : m.point_fields)
    if ((pf.name == "size" || pf.name == "h") && pf.components == 1 &&
        pf.values.size() == static_cast<size_t>(nv)) {
      bool all = true;
      for (int32_t v = 0; v < nv && all; ++v) all = pf.values[v] > 0 && std::isfinite(pf.values[v]);
      if (all) {
        h = pf.values;
        return;
      }
    }
  std::vector<double> sum_c(nv, 0.0), sum_all(nv, 0.0);
  std::vector<int32_t> n_c(nv, 0), n_all(nv, 0);
  // raw[v]: v is constrained and no tet at v has a free vertex (a raw
  // constrained Delaunay mesh, tetgen -p: nothing inside tells the size).
  std::vector<uint8_t> raw(nv, 0);
  for (int32_t v = 0; v < nv; ++v) raw[v] = m.vert_constrained[v] ? 1 : 0;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* tv = m.tet(t);
    if (tv[0] < 0) continue;
    if (!m.vert_constrained[tv[0]] || !m.vert_constrained[tv[1]] || !m.vert_constrained[tv[2]] ||
        !m.vert_constrained[tv[3]])
      for (int i = 0; i < 4; ++i) raw[tv[i]] = 0;
    for (int le = 0; le < 6; ++le) {
      const int32_t a = tv[kEdgeVertex[le][0]], b = tv[kEdgeVertex[le][1]];
      const double l = dist(m.point(a), m.point(b));
      sum_all[a] += l; sum_all[b] += l; ++n_all[a]; ++n_all[b];
    }
    const uint8_t mask = m.face_mask[t];
    for (int f = 0; f < 4; ++f) {
      if (!((mask >> f) & 1u)) continue;
      for (int k = 0; k < 3; ++k) {
        const int32_t a = tv[kFaceVertex[f][k]], b = tv[kFaceVertex[f][(k + 1) % 3]];
        const double l = dist(m.point(a), m.point(b));
        sum_c[a] += l; sum_c[b] += l; ++n_c[a]; ++n_c[b];
      }
    }
  }
  double mean = 0;
  int64_t cnt = 0;
  bool any_raw = false;
  for (int32_t v = 0; v < nv; ++v) {
    if (n_c[v]) h[v] = sum_c[v] / n_c[v];
    else if (n_all[v]) h[v] = sum_all[v] / n_all[v];
    if (h[v] > 0) { mean += h[v]; ++cnt; }
    any_raw = any_raw || (raw[v] && n_all[v]);
  }
  for (int32_t v = 0; v < nv; ++v)
    if (!(h[v] > 0)) h[v] = cnt ? mean / cnt : 1.0;
  if (!any_raw || m.vt_offsets.size() != static_cast<size_t>(nv) + 1) return;
  // A raw vertex takes the larger of its surface size and MMG -optim's size
  // (MMG3D_doSol: the mean length of every edge at the vertex, which on a
  // raw mesh includes the long edges across the volume) graded so that it
  // grows by at most kSizeGradation per unit length from any vertex (a
  // shortest-path problem: Dijkstra from every vertex at once, exact, so
  // independent of the visiting order).  The surface size alone makes the
  // interior as fine as the finest surface near it: bib_0p25 went from 25k
  // to 360k tets that way, 74k so.
  std::vector<double> g(nv);
  for (int32_t v = 0; v < nv; ++v) g[v] = n_all[v] ? sum_all[v] / n_all[v] : h[v];
  using Item = std::pair<double, int32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
  for (int32_t v = 0; v < nv; ++v) heap.push({g[v], v});
  while (!heap.empty()) {
    const auto [gv, v] = heap.top();
    heap.pop();
    if (gv > g[v]) continue;  // a stale entry
    for (const int32_t* s = m.star_begin(v); s != m.star_end(v); ++s) {
      const int32_t* tv = m.tet(*s);
      for (int i = 0; i < 4; ++i) {
        const int32_t w = tv[i];
        const double c = gv + grade * dist(m.point(v), m.point(w));
        if (c < g[w]) {
          g[w] = c;
          heap.push({c, w});
        }
      }
    }
  }
  // With cap (refine_pass), a raw vertex keeps its surface size in h and
  // the graded size goes to cap, the most a vertex refinement makes may take
  // (see kWallGradation).
  std::vector<double>& out = cap ? *cap : h;
  if (cap) cap->assign(h.begin(), h.end());
  for (int32_t v = 0; v < nv; ++v)
    if (raw[v] && n_all[v]) out[v] = std::max(h[v], g[v]);
}

// What remesh_pass and refine_pass set up alike: the topology and the
// vertex stars, the size field when h does not cover every vertex, an
// editor's options, and the split's acceptance (floor: the worst at the
// start, so the worst alpha never falls).
Status prepare_sized(TetMesh& m, std::vector<double>& h, double size, double gradation,
                     std::vector<double>* cap = nullptr) {
  if (!topology_current(m))
    if (Status s = build_topology(m); !s) return s;
  ensure_vertex_tets(m);
  if (h.size() != static_cast<size_t>(m.nv())) size_field(m, size, gradation, h, cap);
  return Status::success();
}

TopoOptions editor_options(Objective objective, const Guard* guard, const std::atomic<bool>* stop) {
  TopoOptions to;
  to.objective = objective;
  to.guard = guard;
  to.stop = stop;
  return to;
}

Acceptance acceptance(const TopoEditor& ed, double cap, double ratio) {
  Acceptance acc;
  acc.on = true;
  acc.floor = ed.min_cached();
  acc.cap = cap;
  acc.ratio = ratio;
  return acc;
}

struct EdgeRef {
  double l;      // length over the size
  uint64_t key;  // edge_key(a, b)
  int32_t t;
  int8_t le;
};

}  // namespace

RemeshStats remesh_pass(TetMesh& m, std::vector<double>& h, const RemeshOptions& o, const LogFn& log) {
  const auto t0 = std::chrono::steady_clock::now();
  RemeshStats st;
  st.status = prepare_sized(m, h, o.size, o.gradation);
  if (!st.status) return st;
  TopoEditor ed(m, editor_options(o.objective, o.guard, o.stop));
  const Acceptance acc = acceptance(ed, o.cap, o.ratio);
  std::vector<EdgeRef> edges;
  auto collect = [&](bool longer) {
    edges.clear();
    for (int32_t t = 0; t < m.nt(); ++t) {
      if (!ed.alive(t)) continue;
      const int32_t* tv = m.tet(t);
      for (int le = 0; le < 6; ++le) {
        const int32_t a = tv[kEdgeVertex[le][0]], b = tv[kEdgeVertex[le][1]];
        const double l = dist(m.point(a), m.point(b)) * 2 / (h[a] + h[b]);
        const double above =
            m.vert_constrained[a] && m.vert_constrained[b] ? std::min(o.split_above, o.split_spanning) : o.split_above;
        if (longer ? l > above : l < o.collapse_below) {
          if (!longer && (m.vert_constrained[a] || a < o.removable_from) &&
              (m.vert_constrained[b] || b < o.removable_from))
            continue;
          edges.push_back({l, detail::edge_key(a, b), t, static_cast<int8_t>(le)});
        }
      }
    }
    std::sort(edges.begin(), edges.end(), [](const EdgeRef& x, const EdgeRef& y) {
      return x.key != y.key ? x.key < y.key : x.t < y.t;
    });
    edges.erase(std::unique(edges.begin(), edges.end(), [](const EdgeRef& x, const EdgeRef& y) { return x.key == y.key; }),
                edges.end());
    // Longest first for splits, shortest first for collapses; ties by key.
    std::sort(edges.begin(), edges.end(), [&](const EdgeRef& x, const EdgeRef& y) {
      if (x.l != y.l) return longer ? x.l > y.l : x.l < y.l;
      return x.key < y.key;
    });
  };
  auto still = [&](const EdgeRef& e) {
    if (!ed.alive(e.t)) return false;
    const int32_t* tv = m.tet(e.t);
    return detail::edge_key(tv[kEdgeVertex[e.le][0]], tv[kEdgeVertex[e.le][1]]) == e.key;
  };
  // A split destroys its shell, so the other long edges of those tets wait
  // for the next collection: splits repeat (collect, split) until a
  // collection finds little left to do, then collapses do the same.
  auto stopped = [&] { return o.stop && o.stop->load(std::memory_order_relaxed); };
  for (int sweep = 0; sweep < std::max(1, o.sweeps) && !stopped(); ++sweep) {
    int64_t splits = 0, collapses = 0;
    for (int loop = 0; loop < o.max_loops && !stopped(); ++loop) {
      collect(true);
      if (loop == 0) st.long_edges = static_cast<int64_t>(edges.size());
      int64_t n = 0;
      for (const EdgeRef& e : edges) {
        if (!still(e)) continue;
        const int32_t a = m.tet(e.t)[kEdgeVertex[e.le][0]], b = m.tet(e.t)[kEdgeVertex[e.le][1]];
        const double hn = 0.5 * (h[a] + h[b]);
        if (ed.split_edge(e.t, e.le, acc) == TopoResult::Applied) {
          h.push_back(hn);
          ++n;
        }
      }
      splits += n;
      if (n <= static_cast<int64_t>(0.02 * static_cast<double>(edges.size()))) break;
    }
    for (int loop = 0; loop < o.max_loops && !stopped(); ++loop) {
      collect(false);
      if (loop == 0) st.short_edges = static_cast<int64_t>(edges.size());
      int64_t n = 0;
      for (const EdgeRef& e : edges) {
        if (!still(e)) continue;
        if (ed.collapse_edge(e.t, e.le, acc, o.removable_from) == TopoResult::Applied) ++n;
      }
      collapses += n;
      if (n <= static_cast<int64_t>(0.02 * static_cast<double>(edges.size()))) break;
    }
    st.splits += splits;
    st.collapses += collapses;
    if (log)
      log(LogLevel::Info, "remesh sweep " + std::to_string(sweep + 1) + ": " + std::to_string(st.long_edges) +
                              " long edges, " + std::to_string(splits) + " split; " + std::to_string(st.short_edges) +
                              " short, " + std::to_string(collapses) + " collapsed");
    if (splits + collapses == 0) break;
  }
  st.removed_vertices = ed.removed();
  ed.finish();
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

namespace {

// The mesh as a pass found it (a copy of its points, tets and neighbours),
// to read a per-vertex field of it at any point inside: a walk to the tet
// that holds the point, then linear interpolation there.  The field is the
// pass's own array, which only grows: the values at these tets' vertices
// are those it had when the copy was made.
struct Background {
  std::vector<double> pts;
  std::vector<int32_t> tets, adj;
  explicit Background(const TetMesh& m) : pts(m.xyz), tets(m.tets), adj(m.adj) {}
  const double* point(int32_t v) const { return &pts[3 * static_cast<size_t>(v)]; }
  // The tet holding x, walking from `start` across the face x lies farthest
  // beyond (floating point; inside every face within rounding ends it):
  // region interfaces are crossed, the outer boundary is not.  -1 where the
  // walk leaves the mesh or takes more than kSteps steps.
  int32_t locate(int32_t start, const double* x) const {
    constexpr int kSteps = 1000;
    int32_t cur = start;
    for (int step = 0; cur >= 0 && step < kSteps; ++step) {
      const int32_t* tv = &tets[4 * static_cast<size_t>(cur)];
      if (tv[0] < 0) return -1;
      int bf = -1;
      double bo = 0;
      for (int f = 0; f < 4; ++f) {
        const double o = tet_signed_volume(point(tv[kFaceVertex[f][0]]), point(tv[kFaceVertex[f][1]]),
                                           point(tv[kFaceVertex[f][2]]), x);
        if (o > bo) { bo = o; bf = f; }
      }
      if (bf < 0) return cur;
      const int32_t nb = adj[4 * static_cast<size_t>(cur) + bf];
      cur = nb < 0 ? -1 : nb / 4;
    }
    return -1;
  }
  // x's barycentric weights in tet t (negative ones, from rounding, as 0);
  // false when they do not sum above 0.
  bool weights(int32_t t, const double* x, double* w) const {
    const int32_t* tv = &tets[4 * static_cast<size_t>(t)];
    double sw = 0;
    for (int i = 0; i < 4; ++i) {
      const double* p[4] = {point(tv[0]), point(tv[1]), point(tv[2]), point(tv[3])};
      p[i] = x;
      w[i] = std::max(0.0, tet_signed_volume(p[0], p[1], p[2], p[3]));
      sw += w[i];
    }
    if (!(sw > 0)) return false;
    for (int i = 0; i < 4; ++i) w[i] /= sw;
    return true;
  }
  double at(const std::vector<double>& f, int32_t t, const double* w) const {
    const int32_t* tv = &tets[4 * static_cast<size_t>(t)];
    return w[0] * f[tv[0]] + w[1] * f[tv[1]] + w[2] * f[tv[2]] + w[3] * f[tv[3]];
  }
};

}  // namespace

RefineStats refine_pass(TetMesh& m, std::vector<double>& h, const RefineOptions& o, const LogFn& log) {
  const auto t0 = std::chrono::steady_clock::now();
  RefineStats st;
  std::vector<double> cap;  // empty unless the mesh is raw (size_field)
  st.status = prepare_sized(m, h, o.size, o.gradation, &cap);
  // A gradation asked for above the wall's (RefineOptions::gradation) is the
  // wall's too: the layer on the boundary grows as fast as the interior may.
  const double wall_grade = std::max(kWallGradation, o.gradation);
  if (!st.status) return st;
  TopoOptions to = editor_options(o.objective, o.guard, o.stop);
  to.threads = o.threads;
  TopoEditor ed(m, to);
  const Acceptance acc = acceptance(ed, o.cap, o.ratio);
  struct Item {
    double ratio;
    int32_t t;
    int32_t v[4];
    double cc[3];  // the circumcentre (the same while the tet is current)
    bool operator<(const Item& y) const { return ratio != y.ratio ? ratio < y.ratio : t > y.t; }
  };
  std::priority_queue<Item> heap;
  // Circumradius over the tet's mean size, and the circumcentre.
  auto ratio_of = [&](int32_t t, double* cc) {
    const int32_t* tv = m.tet(t);
    double r2 = 0;
    if (!detail::circumsphere(m.point(tv[0]), m.point(tv[1]), m.point(tv[2]), m.point(tv[3]), cc, r2)) return 0.0;
    return std::sqrt(r2) * 4 / (h[tv[0]] + h[tv[1]] + h[tv[2]] + h[tv[3]]);
  };
  auto consider = [&](int32_t t) {
    double cc[3];
    const double r = ratio_of(t, cc);
    if (r > o.radius_above) {
      const int32_t* tv = m.tet(t);
      heap.push({r, t, {tv[0], tv[1], tv[2], tv[3]}, {cc[0], cc[1], cc[2]}});
    }
  };
  for (int32_t t = 0; t < m.nt(); ++t)
    if (ed.alive(t)) consider(t);
  st.large = static_cast<int64_t>(heap.size());
  // A runaway guard only: refinement ends when no tet is too large.
  const int64_t max_inserts = 8 * static_cast<int64_t>(m.nt()) + 10000;
  std::vector<int32_t> made;
  int64_t why[8] = {};
  auto stopped = [&] { return o.stop && o.stop->load(std::memory_order_relaxed); };
  // The serial order is the heap's: the tet with the largest ratio first,
  // the new tets of each insertion pushed as they come.  It is kept
  // exactly while the cavity searches of a window of the top entries run
  // ahead, in parallel (TopoEditor::plan_points): the entries are taken in
  // their order, each using its search where no commit since wrote a tet
  // it read, and the window ends early, its rest pushed back (their
  // searches kept for when they come again), when a new tet comes before
  // its next entry.  The window halves while more than 1 search in 8 is
  // made again and doubles while fewer than 1 in 32 are.
  auto current = [&](const Item& it) {
    if (!ed.alive(it.t)) return false;
    const int32_t* tv = m.tet(it.t);
    return tv[0] == it.v[0] && tv[1] == it.v[1] && tv[2] == it.v[2] && tv[3] == it.v[3];
  };
  // The size of the vertex it.cc would make, and its cap (see
  // kWallGradation; 0 where the mesh is not raw): h, or cap, as it was when
  // the pass began, read at the point (Background: linear in the tet of the
  // frozen mesh that holds it); the mean over the tet where the walk finds
  // none (a point outside the mesh, which the cavity search refuses, or a
  // walk stopped by the boundary on its way).  The mean over the tet everywhere
  // passed sizes from vertex to new vertex, averaging them and never
  // letting them grow: in a box with a spherical hole of radius 1e-4 (gmsh,
  // surface edges 7e-5, the next vertices 1.6e-3 away) the surface's size
  // spread into the volume, 80,816 insertions (the runaway guard's limit)
  // in 4.2 s, then 515,143 edge splits in the remesher's first sweep, and
  // the run did not end in 300 s; now 2,844 insertions and 0.7 s.  On the
  // bench meshes the frozen field reads 0.93-1.22 times the mean (median
  // 1.035, larger for the first insertions), so a raw mesh gets fewer tets
  // (bib_0p5 27,718 instead of 50,830; docs/benchmarks.md, thirty-third
  // session).
  const Background bg(m);
  std::vector<int32_t> hint;  // a tet of bg near each vertex, where a walk starts
  hint.reserve(static_cast<size_t>(m.nv()));
  for (int32_t v = 0; v < m.nv(); ++v) hint.push_back(m.star_begin(v) != m.star_end(v) ? *m.star_begin(v) : -1);
  struct NewSize {
    double h, cap;
    int32_t at;  // the tet of bg holding the point, -1 if none was found
  };
  auto new_size = [&](const Item& it) -> NewSize {
    const int32_t* tv = m.tet(it.t);
    int32_t start = -1;
    for (int i = 0; i < 4 && start < 0; ++i) start = hint[static_cast<size_t>(tv[i])];
    const int32_t at = bg.locate(start, it.cc);
    double w[4];
    const bool inside = at >= 0 && bg.weights(at, it.cc, w);
    auto read = [&](const std::vector<double>& f) {
      return inside ? bg.at(f, at, w) : 0.25 * (f[tv[0]] + f[tv[1]] + f[tv[2]] + f[tv[3]]);
    };
    if (cap.empty()) return {read(h), 0, at};
    const double capn = read(cap);
    const double hmin = std::min(std::min(h[tv[0]], h[tv[1]]), std::min(h[tv[2]], h[tv[3]]));
    return {std::min(capn, hmin + wall_grade * dist(it.cc, m.point(tv[0]))), capn, at};
  };
  constexpr size_t kWinMin = 4, kWinMax = 128;
  const bool ahead = TopoEditor::plan_threads(o.threads) > 1;
  size_t win = ahead ? 16 : 1;
  std::vector<Item> items;
  std::vector<int32_t> bt;
  std::vector<double> bx;  // the points, three coordinates each
  std::vector<double> bd;
  while (!heap.empty() && st.inserted < max_inserts && !stopped()) {
    items.clear();
    while (!heap.empty() && items.size() < win) {
      items.push_back(heap.top());
      heap.pop();
    }
    if (ahead && items.size() > 1) {
      bt.clear();
      bx.clear();
      bd.clear();
      for (const Item& it : items)
        if (current(it) && !ed.point_planned(it.t)) {
          bt.push_back(it.t);
          bx.insert(bx.end(), it.cc, it.cc + 3);
          bd.push_back(o.min_dist * new_size(it).h);
        }
      ed.plan_points(bt.data(), bx.data(), bd.data(), static_cast<int>(bt.size()), acc);
    }
    const int64_t redone0 = ed.points_redone(), used0 = ed.points_used();
    size_t taken = items.size();
    for (size_t j = 0; j < items.size(); ++j) {
      if (j > 0 && ((!heap.empty() && items[j] < heap.top()) || st.inserted >= max_inserts || stopped())) {
        for (size_t k = j; k < items.size(); ++k) heap.push(items[k]);
        st.pushed_back += static_cast<int64_t>(items.size() - j);
        taken = j;
        break;
      }
      const Item& it = items[j];
      if (!current(it)) continue;
      const auto [hn, capn, at] = new_size(it);
      ++st.tried;
      const TopoResult rr = ed.insert_point_planned(it.t, it.cc, acc, o.min_dist * hn, &made);
      ++why[static_cast<int>(rr)];
      if (rr != TopoResult::Applied) continue;
      h.push_back(hn);
      if (!cap.empty()) cap.push_back(capn);
      hint.push_back(at);
      ++st.inserted;
      for (int32_t n : made) consider(n);
    }
    ++st.windows;
    if (ahead) {
      win = next_window(win, ed.points_redone() - redone0, ed.points_used() - used0, kWinMin, kWinMax);
      // No larger than twice what this window took before a new tet came first.
      win = std::clamp(std::min(win, 2 * taken), kWinMin, kWinMax);
    }
  }
  st.planned_used = ed.points_used();
  st.planned_redone = ed.points_redone();
  ed.finish();
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (log) {
    std::string w;
    for (int k = 0; k < 7; ++k) w += std::string(" ") + to_string(static_cast<TopoResult>(k)) + " " + std::to_string(why[k]);
    log(LogLevel::Debug, "refine: the tries ended" + w + "; cavity searches made ahead: " +
                             std::to_string(st.planned_used) + " used, " + std::to_string(st.planned_redone) +
                             " made again; windows " + std::to_string(st.windows) + " pushed back " + std::to_string(st.pushed_back));
  }
  if (log)
    log(LogLevel::Info, "refine: " + std::to_string(st.large) + " tets too large for the size field, " +
                            std::to_string(st.inserted) + " circumcentres inserted of " + std::to_string(st.tried) +
                            " tried, " + std::to_string(m.nt()) + " tets, " + std::to_string(st.seconds) + " s");
  return st;
}

}  // namespace tetopt
