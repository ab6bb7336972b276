// Vertex insertion pass (see insert.hpp); the local operation is
// TopoEditor::insert_vertex (topo.cpp).
#include "tetopt/insert.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "tetopt/quality.hpp"
#include "tetopt/topo.hpp"

namespace tetopt {

InsertStats insert_pass(TetMesh& m, const InsertOptions& o, const LogFn& log) {
  const auto t0 = std::chrono::steady_clock::now();
  InsertStats st;
  if (m.adj.size() != m.tets.size() || m.tet_kind.size() != m.tets.size() / 4 ||
      m.vert_constrained.size() != static_cast<size_t>(m.nv())) {
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
  TopoEditor ed(m, to);
  st.alpha_worst_before = INFINITY;
  for (int32_t t = 0; t < m.nt(); ++t) st.alpha_worst_before = std::min(st.alpha_worst_before, ed.cached_alpha(t));
  std::vector<int32_t> work;
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
    for (int32_t t : work) {
      if (!ed.alive(t) || !(ed.cached_alpha(t) < o.quality_threshold)) continue;
      ++st.tried;
      if (o.insert && ed.insert_vertex(t) == TopoResult::Applied) ++ins;
      else if (o.remove && ed.alive(t) && ed.remove_vertex(t) == TopoResult::Applied) ++rem;
    }
    st.inserted += ins;
    st.removed += rem;
    if (log)
      log(LogLevel::Info, "insert pass " + std::to_string(p + 1) + ": " + std::to_string(work.size()) +
                              " tets visited, " + std::to_string(ins) + " vertices inserted, " + std::to_string(rem) +
                              " removed");
    if (ins + rem == 0) break;
  }
  st.alpha_worst_after = INFINITY;
  for (int32_t t = 0; t < m.nt(); ++t)
    if (ed.alive(t)) st.alpha_worst_after = std::min(st.alpha_worst_after, ed.cached_alpha(t));
  st.removed_vertices = ed.removed();
  ed.finish();
  st.vertices_after = m.nv() - st.removed;
  st.tets_after = m.nt();
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace tetopt
