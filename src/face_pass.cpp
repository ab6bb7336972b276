// The face non-orthogonality pass (face_pass.hpp).
#include "tetopt/face_pass.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <vector>

#include "tetopt/conventions.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/topo.hpp"

namespace tetopt {

namespace {

constexpr double kBand = 5.0;   // faces within this many degrees of the largest are worked on
constexpr size_t kTop = 64;     // ... and at least this many of the worst
constexpr double kGain = 0.01;  // a sweep must lower the largest by this many degrees to go on
constexpr double kOpMargin = 1e-9;  // a topological change must lower its faces' largest by this many degrees

// Non-orthogonality of face f of tet t (NaN for a boundary face).
double face_value(const TetMesh& m, int32_t t, int f) {
  const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)];
  if (nb < 0) return NAN;
  const int32_t* v = m.tet(t);
  const int32_t q = m.tet(nb >> 2)[nb & 3];
  return face_non_orthogonality(m.point(v[kFaceVertex[f][0]]), m.point(v[kFaceVertex[f][1]]),
                                m.point(v[kFaceVertex[f][2]]), m.point(v[f]), m.point(q));
}

int slot_in(const TetMesh& m, int32_t t, int32_t v) {
  const int32_t* tv = m.tet(t);
  for (int k = 0; k < 4; ++k)
    if (tv[k] == v) return k;
  return -1;
}

// The largest non-orthogonality over the faces of v's star tets, with v's
// coordinates as they are in m.
double star_faces_max(const TetMesh& m, int32_t v) {
  double w = 0;
  for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it)
    for (int f = 0; f < 4; ++f) {
      const double x = face_value(m, *it, f);
      if (!std::isnan(x)) w = std::max(w, x);
    }
  return w;
}

// Whether every star tet of v is positive with v at p (v's coordinates in m
// untouched).
bool star_positive(const TetMesh& m, int32_t v, const double* p) {
  for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
    const int32_t* tv = m.tet(*it);
    const int s = slot_in(m, *it, v);
    if (orient3d(p, m.point(tv[kFaceVertex[s][0]]), m.point(tv[kFaceVertex[s][1]]),
                 m.point(tv[kFaceVertex[s][2]])) != Sign::Positive)
      return false;
  }
  return true;
}

// Whether the star of v at its current coordinates passes the guard, or
// the alpha floor without one.
bool star_admitted(const TetMesh& m, int32_t v, const FacePassOptions& o) {
  for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
    const int32_t* tv = m.tet(*it);
    const double *a = m.point(tv[0]), *b = m.point(tv[1]), *c = m.point(tv[2]), *d = m.point(tv[3]);
    if (o.guard ? !o.guard->admits(a, b, c, d) : !(alpha(a, b, c, d) >= o.alpha_floor)) return false;
  }
  return true;
}

// Compass search on v's position minimising star_faces_max; commits the
// best position found when it lowers the value and the star is admitted.
bool improve_vertex(TetMesh& m, int32_t v, const FacePassOptions& o) {
  double* x = m.point(v);
  const double x0[3] = {x[0], x[1], x[2]};
  double len = 0;
  int n = 0;
  for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it)
    for (int k = 0; k < 4; ++k) {
      const int32_t u = m.tet(*it)[k];
      if (u == v) continue;
      const double* q = m.point(u);
      len += std::sqrt((q[0] - x0[0]) * (q[0] - x0[0]) + (q[1] - x0[1]) * (q[1] - x0[1]) + (q[2] - x0[2]) * (q[2] - x0[2]));
      ++n;
    }
  if (n == 0) return false;
  const double start = star_faces_max(m, v);
  double best = start;
  double bp[3] = {x0[0], x0[1], x0[2]};
  double step = 0.1 * len / n;
  const double min_step = 1e-4 * len / n;
  int evals = 0;
  while (step > min_step && evals < 400) {
    bool moved = false;
    for (int dir = 0; dir < 6 && !moved; ++dir) {
      double p[3] = {bp[0], bp[1], bp[2]};
      p[dir / 2] += (dir & 1) ? -step : step;
      if (!star_positive(m, v, p)) continue;
      x[0] = p[0]; x[1] = p[1]; x[2] = p[2];
      const double w = star_faces_max(m, v);
      ++evals;
      x[0] = bp[0]; x[1] = bp[1]; x[2] = bp[2];
      if (w < best - 1e-12) {
        best = w;
        bp[0] = p[0]; bp[1] = p[1]; bp[2] = p[2];
        moved = true;
      }
    }
    if (!moved) step *= 0.5;
  }
  if (!(best < start - 1e-9)) {
    x[0] = x0[0]; x[1] = x0[1]; x[2] = x0[2];
    return false;
  }
  x[0] = bp[0]; x[1] = bp[1]; x[2] = bp[2];
  if (!star_admitted(m, v, o)) {
    x[0] = x0[0]; x[1] = x0[1]; x[2] = x0[2];
    return false;
  }
  return true;
}

// The largest non-orthogonality over the faces of the tets an operation
// replaces (with their neighbours outside the cavity as they are now).
double old_faces_max(const TetMesh& m, const TopoEditor::Planned& p) {
  double w = 0;
  for (int i = 0; i < p.n_old; ++i)
    for (int f = 0; f < 4; ++f) {
      const double x = face_value(m, p.old_tets[i], f);
      if (!std::isnan(x)) w = std::max(w, x);
    }
  return w;
}

// The same over the faces of the tets it would create: the faces between
// two new tets and those shared with the unchanged tets around the cavity.
// (Faces outside the cavity keep their two tets, hence their values.)
double new_faces_max(const TetMesh& m, const TopoEditor::Planned& p) {
  double w = 0;
  for (int i = 0; i < p.n_new; ++i) {
    const int32_t* q = p.quad[i];
    for (int f = 0; f < 4; ++f) {
      const int32_t o = p.across[4 * static_cast<size_t>(i) + static_cast<size_t>(f)];
      if (o < 0) continue;
      w = std::max(w, face_non_orthogonality(m.point(q[kFaceVertex[f][0]]), m.point(q[kFaceVertex[f][1]]),
                                             m.point(q[kFaceVertex[f][2]]), m.point(q[f]), m.point(o)));
    }
  }
  return w;
}

// Whether face f of live tet t still joins the vertices key (sorted) and
// lies between two tets.
bool same_face(const TetMesh& m, int32_t t, int f, const int32_t key[3]) {
  if (t >= m.nt() || m.tets[4 * static_cast<size_t>(t)] < 0 || m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)] < 0)
    return false;
  const int32_t* v = m.tet(t);
  int32_t s[3] = {v[kFaceVertex[f][0]], v[kFaceVertex[f][1]], v[kFaceVertex[f][2]]};
  std::sort(s, s + 3);
  return s[0] == key[0] && s[1] == key[1] && s[2] == key[2];
}

// The topological step of a sweep: for each face of `work` (packed 4t+f,
// worst first) that is still there, the options that remove it (the 2-3
// flip, the best multi-face removal through it, the removal of each of its
// three edges) are planned by the editor (valid, guarded) and judged by
// the face measure; the option whose new faces' largest value is lowest is
// committed when that is below the largest over the faces of the tets it
// replaces.  Returns the number committed; counts go to st.
int64_t remove_faces(TetMesh& m, const std::vector<int64_t>& work, const FacePassOptions& o, FacePassStats& st) {
  TopoOptions to;
  to.guard = o.guard;
  // The new tets are chosen by the worst alpha (the editor's dynamic
  // programs); a floor at the mesh's worst alpha steers them away from
  // triangulations the guard or the floor would refuse.
  to.alpha_floor = o.guard ? (o.guard->on() ? o.guard->extreme(Measure::Alpha) : -1e300) : o.alpha_floor;
  to.threads = 1;
  to.rebuild_stars = true;
  std::vector<std::array<int32_t, 3>> keys(work.size());
  for (size_t i = 0; i < work.size(); ++i) {
    const int32_t* v = m.tet(static_cast<int32_t>(work[i] >> 2));
    const int f = static_cast<int>(work[i] & 3);
    keys[i] = {v[kFaceVertex[f][0]], v[kFaceVertex[f][1]], v[kFaceVertex[f][2]]};
    std::sort(keys[i].begin(), keys[i].end());
  }
  int64_t applied = 0;
  TopoEditor ed(m, to);
  for (size_t i = 0; i < work.size(); ++i) {
    const int32_t t = static_cast<int32_t>(work[i] >> 2);
    const int f = static_cast<int>(work[i] & 3);
    if (!same_face(m, t, f, keys[i].data())) continue;  // a commit of this step changed it
    // The options, on t and on its neighbour u across f: a 2-3 flip and a
    // multi-face removal across each face, the removal of each edge.  Those
    // through f remove it; the others give f a new tet on one side (a new
    // apex, perhaps a free one that the vertex moves can then place), or
    // change its neighbours' faces.  (The shared face and its edges are
    // planned from t only.)
    struct Option {
      int32_t tet;
      int kind;  // 0: 2-3 flip, 1: multi-face removal, 2: edge removal
      int local;
    };
    Option opts[2 * 4 * 2 + 6 + 3];
    int n_opts = 0;
    const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)];
    const int32_t u = nb >> 2;
    const int fu = nb & 3;
    for (const int32_t x : {t, u}) {
      for (int lf = 0; lf < 4; ++lf) {
        if (x == u && lf == fu) continue;
        opts[n_opts++] = {x, 0, lf};
        opts[n_opts++] = {x, 1, lf};
      }
      for (int le = 0; le < 6; ++le) {
        if (x == u && kEdgeVertex[le][0] != fu && kEdgeVertex[le][1] != fu) continue;  // an edge of f
        opts[n_opts++] = {x, 2, le};
      }
    }
    auto plan = [&](const Option& op, const TopoEditor::Judge& judge) {
      if (op.kind == 0) return ed.remove_face_judged(op.tet, op.local, 1, judge);
      if (op.kind == 1) return ed.remove_face_judged(op.tet, op.local, kMaxShell, judge);
      return ed.remove_edge_judged(op.tet, op.local, judge);
    };
    double best = INFINITY;
    int best_opt = -1;
    for (int k = 0; k < n_opts; ++k) {
      plan(opts[k], [&](const TopoEditor::Planned& p) {
        const double was = old_faces_max(m, p), now = new_faces_max(m, p);
        if (now < was - kOpMargin && now < best) {
          best = now;
          best_opt = k;
        }
        return false;
      });
    }
    if (best_opt < 0) continue;
    // Planning is deterministic: the same option again, committed.
    if (plan(opts[best_opt], [](const TopoEditor::Planned&) { return true; }) == TopoResult::Applied) {
      ++applied;
      if (opts[best_opt].kind < 2) ++st.face_removals;
      else ++st.edge_removals;
    }
  }
  ed.finish();
  return applied;
}

}  // namespace

double max_non_orthogonality(const TetMesh& m) {
  double w = 0;
  for (int32_t t = 0; t < m.nt(); ++t)
    for (int f = 0; f < 4; ++f) {
      const double x = face_value(m, t, f);
      if (!std::isnan(x)) w = std::max(w, x);
    }
  return w;
}

FacePassStats face_pass(TetMesh& m, const FacePassOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  FacePassStats st;
  std::vector<std::pair<double, int64_t>> faces;  // (value, 4t+f) of interior faces, each once
  auto scan = [&] {
    faces.clear();
    const int32_t nt = m.nt();  // topology changes it
    for (int32_t t = 0; t < nt; ++t)
      for (int f = 0; f < 4; ++f) {
        const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)];
        if (nb < 0 || (nb >> 2) < t) continue;
        // The larger of the values seen from either side (they differ by
        // rounding), as max_non_orthogonality and the measures table take.
        faces.push_back({std::max(face_value(m, t, f), face_value(m, nb >> 2, nb & 3)), 4 * static_cast<int64_t>(t) + f});
      }
    std::sort(faces.begin(), faces.end(), [](const auto& a, const auto& b) {
      return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
    return faces.empty() ? 0.0 : faces[0].first;
  };
  double worst = scan();
  st.worst_before = worst;
  // The faces worked on: within kBand of the largest, at least the kTop worst.
  auto worked = [&](double w) {
    std::vector<int64_t> ids;
    for (size_t i = 0; i < faces.size() && (i < kTop || faces[i].first >= w - kBand); ++i) ids.push_back(faces[i].second);
    return ids;
  };
  for (int sweep = 0; sweep < o.sweeps && !faces.empty(); ++sweep) {
    // Vertex moves first, then topology on the faces worst after them
    // (those the moves could not help).  (Topology first was tried: its
    // changes near a worst face can give it constrained apexes that lock it.)
    std::vector<int32_t> verts;
    for (size_t i = 0; i < faces.size() && (i < kTop || faces[i].first >= faces[0].first - kBand); ++i) {
      const int32_t t = static_cast<int32_t>(faces[i].second >> 2);
      const int f = static_cast<int>(faces[i].second & 3);
      const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)];
      if (nb < 0) continue;
      for (const int32_t u : {t, nb >> 2})
        for (int k = 0; k < 4; ++k) {
          const int32_t v = m.tet(u)[k];
          if (!m.vert_constrained[v]) verts.push_back(v);
        }
    }
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    for (const int32_t v : verts) {
      ++st.vertices_tried;
      if (improve_vertex(m, v, o)) ++st.moves;
    }
    if (o.topology) {
      scan();
      remove_faces(m, worked(faces[0].first), o, st);
    }
    ++st.sweeps;
    const double now = scan();
    const bool go_on = now < worst - kGain;
    worst = now;
    if (!go_on) break;
  }
  st.worst_after = worst;
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace tetopt
