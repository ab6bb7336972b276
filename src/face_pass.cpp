// The face non-orthogonality pass (face_pass.hpp).
#include "tetopt/face_pass.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <optional>
#include <cmath>
#include <numbers>
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
  const size_t k = 4 * static_cast<size_t>(t);
  if (t >= m.nt() || m.tets[k] < 0 || m.adj[k + static_cast<size_t>(f)] < 0) return false;
  const int32_t* v = m.tet(t);
  int32_t s[3] = {v[kFaceVertex[f][0]], v[kFaceVertex[f][1]], v[kFaceVertex[f][2]]};
  std::sort(s, s + 3);
  return s[0] == key[0] && s[1] == key[1] && s[2] == key[2];
}

// Whether tet (a, b, c, d) passes the guard, or the alpha floor without one.
bool admitted(const FacePassOptions& o, const double* a, const double* b, const double* c, const double* d) {
  return o.guard ? o.guard->admits(a, b, c, d) : alpha(a, b, c, d) >= o.alpha_floor;
}

// A tet as it would be after a planned operation: its vertices and, for
// each face f, the vertex across it (-1 on the domain boundary).
struct LocalTet {
  int32_t v[4];
  int32_t across[4];
};

double local_faces_max(const TetMesh& m, const std::vector<LocalTet>& ts) {
  double w = 0;
  for (const LocalTet& x : ts)
    for (int f = 0; f < 4; ++f)
      if (x.across[f] >= 0)
        w = std::max(w, face_non_orthogonality(m.point(x.v[kFaceVertex[f][0]]), m.point(x.v[kFaceVertex[f][1]]),
                                               m.point(x.v[kFaceVertex[f][2]]), m.point(x.v[f]),
                                               m.point(x.across[f])));
  return w;
}

// The tets around v reached from t0 (which holds v) through faces holding
// v: v's star, read through the adjacency, which the editor keeps current
// (the vertex->tet CSR is stale inside an editor session).
void star_walk(const TetMesh& m, int32_t t0, int32_t v, std::vector<int32_t>& out) {
  out.assign(1, t0);
  for (size_t i = 0; i < out.size(); ++i) {
    const int32_t s = out[i];
    const int k = slot_in(m, s, v);
    for (int g = 0; g < 4; ++g) {
      if (g == k) continue;
      const int32_t nb = m.adj[4 * static_cast<size_t>(s) + static_cast<size_t>(g)];
      if (nb < 0) continue;
      const int32_t u = nb >> 2;
      if (std::find(out.begin(), out.end(), u) == out.end()) out.push_back(u);
    }
  }
}

// An operation whose only refused new tets share a free vertex v: a compass
// search (as improve_vertex) for a position of v after the operation at
// which every tet around v is exactly positive and admitted and the largest
// non-orthogonality over the faces that the operation and the move change
// (those of the new tets and of v's other tets) is below the largest over
// the same faces before both (those of the replaced tets and of v's star).
// The search first raises the worst alpha of the refused tets until none
// is refused, then lowers the faces' largest value.  On success *x holds the
// position and *value that largest value; m is left as it was.
bool relocate_after(TetMesh& m, const TopoEditor::Planned& p, int32_t v, const FacePassOptions& o, double* x,
                    double* value) {
  auto in_cavity = [&](int32_t s) { return std::find(p.old_tets, p.old_tets + p.n_old, s) != p.old_tets + p.n_old; };
  int32_t t0 = -1;
  for (int i = 0; i < p.n_old && t0 < 0; ++i)
    if (slot_in(m, p.old_tets[i], v) >= 0) t0 = p.old_tets[i];
  if (t0 < 0) return false;
  std::vector<int32_t> star;
  star_walk(m, t0, v, star);
  double was = 0;  // before: the replaced tets' faces and v's star's
  for (int i = 0; i < p.n_old; ++i)
    for (int f = 0; f < 4; ++f) {
      const double y = face_value(m, p.old_tets[i], f);
      if (!std::isnan(y)) was = std::max(was, y);
    }
  for (const int32_t s : star)
    for (int f = 0; f < 4; ++f) {
      const double y = face_value(m, s, f);
      if (!std::isnan(y)) was = std::max(was, y);
    }
  // After: every new tet (the faces of those without v depend on v through
  // their neighbours) and v's tets outside the cavity; `around` indexes the
  // tets holding v, `bad` those refused now.
  std::vector<LocalTet> after;
  std::vector<int> around, bad;
  for (int i = 0; i < p.n_new; ++i) {
    LocalTet lt;
    bool has_v = false;
    for (int k = 0; k < 4; ++k) {
      lt.v[k] = p.quad[i][k];
      lt.across[k] = p.across[4 * static_cast<size_t>(i) + static_cast<size_t>(k)];
      has_v = has_v || lt.v[k] == v;
    }
    if (has_v) around.push_back(static_cast<int>(after.size()));
    after.push_back(lt);
  }
  for (const int32_t s : star) {
    if (in_cavity(s)) continue;
    LocalTet lt;
    const int32_t* sv = m.tet(s);
    for (int f = 0; f < 4; ++f) {
      lt.v[f] = sv[f];
      const int32_t nb = m.adj[4 * static_cast<size_t>(s) + static_cast<size_t>(f)];
      lt.across[f] = nb < 0 ? -1 : m.tets[static_cast<size_t>(nb)];
      if (nb >= 0 && in_cavity(nb >> 2)) {  // its neighbour there is a new tet now
        int32_t key[3] = {sv[kFaceVertex[f][0]], sv[kFaceVertex[f][1]], sv[kFaceVertex[f][2]]};
        std::sort(key, key + 3);
        lt.across[f] = -1;
        for (int i = 0; i < p.n_new && lt.across[f] < 0; ++i)
          for (int g = 0; g < 4; ++g) {
            int32_t k2[3] = {p.quad[i][kFaceVertex[g][0]], p.quad[i][kFaceVertex[g][1]], p.quad[i][kFaceVertex[g][2]]};
            std::sort(k2, k2 + 3);
            if (k2[0] == key[0] && k2[1] == key[1] && k2[2] == key[2]) {
              lt.across[f] = p.quad[i][g];
              break;
            }
          }
        if (lt.across[f] < 0) return false;  // not the cavity's outer face: give up
      }
    }
    around.push_back(static_cast<int>(after.size()));
    after.push_back(lt);
  }
  // The search; refusals by the guard during it are not counted.
  Guard::Counts scratch{};
  std::optional<Guard::Deferred> quiet;
  if (o.guard) quiet.emplace(scratch);
  double* pv = m.point(v);
  const double x0[3] = {pv[0], pv[1], pv[2]};
  // key: (refused tets, -their worst alpha) while some are refused, then
  // (0, the faces' largest value); smaller is better.
  auto key_at = [&](const double* q, int& n_bad, double& k2) {
    pv[0] = q[0]; pv[1] = q[1]; pv[2] = q[2];
    n_bad = 0;
    double worst_bad = INFINITY;
    bool positive = true;
    for (const int i : around) {
      const int32_t* tv = after[static_cast<size_t>(i)].v;
      const double *a = m.point(tv[0]), *b = m.point(tv[1]), *c = m.point(tv[2]), *d = m.point(tv[3]);
      if (orient3d(a, b, c, d) != Sign::Positive) {
        positive = false;
        break;
      }
      if (!admitted(o, a, b, c, d)) {
        ++n_bad;
        worst_bad = std::min(worst_bad, alpha(a, b, c, d));
      }
    }
    k2 = n_bad > 0 ? -worst_bad : local_faces_max(m, after);
    pv[0] = x0[0]; pv[1] = x0[1]; pv[2] = x0[2];
    return positive;
  };
  double len = 0;
  int n = 0;
  for (const int i : around)
    for (int k = 0; k < 4; ++k) {
      const int32_t u = after[static_cast<size_t>(i)].v[k];
      if (u == v) continue;
      const double* q = m.point(u);
      len += std::sqrt((q[0] - x0[0]) * (q[0] - x0[0]) + (q[1] - x0[1]) * (q[1] - x0[1]) + (q[2] - x0[2]) * (q[2] - x0[2]));
      ++n;
    }
  if (n == 0) return false;
  double bp[3] = {x0[0], x0[1], x0[2]};
  int best_bad;
  double best_k2;
  if (!key_at(bp, best_bad, best_k2)) return false;  // the editor found every new tet positive
  double step = 0.1 * len / n;
  const double min_step = 1e-4 * len / n;
  int evals = 0;
  while (step > min_step && evals < 300) {
    bool moved = false;
    for (int dir = 0; dir < 6 && !moved; ++dir) {
      double q[3] = {bp[0], bp[1], bp[2]};
      q[dir / 2] += (dir & 1) ? -step : step;
      int nb;
      double k2;
      ++evals;
      if (!key_at(q, nb, k2)) continue;
      if (nb < best_bad || (nb == best_bad && k2 < best_k2 - 1e-12)) {
        best_bad = nb;
        best_k2 = k2;
        bp[0] = q[0]; bp[1] = q[1]; bp[2] = q[2];
        moved = true;
      }
    }
    if (!moved) step *= 0.5;
  }
  if (best_bad > 0 || !(best_k2 < was - kOpMargin)) return false;
  x[0] = bp[0]; x[1] = bp[1]; x[2] = bp[2];
  *value = best_k2;
  return true;
}

// The topological step of a sweep: for each face of `work` (packed 4t+f,
// worst first) that is still there, the options that remove it (the 2-3
// flip, the best multi-face removal through it, the removal of each of its
// three edges) are planned by the editor (valid, guarded) and judged by
// the face measure; the option whose new faces' largest value is lowest is
// committed when that is below the largest over the faces of the tets it
// replaces.  Returns the number committed; counts go to st.
// With `diag`: plans the options of work's first face only, commits none,
// and tallies them in *diag (FacePassStats::worst_*).
struct Tally {
  int lowering = 0, constrained_refused = 0;
};
int64_t remove_faces(TetMesh& m, const std::vector<int64_t>& work, const FacePassOptions& o, FacePassStats& st,
                     Tally* diag = nullptr) {
  // The editor checks validity (exact orientation, constrained faces,
  // listed edges, the cavity's boundary) and chooses the new tets by their
  // worst alpha (its dynamic programs); the guard or the alpha floor is
  // applied here, so that an operation whose refused tets share a free
  // vertex can be taken together with a move of that vertex.
  TopoOptions to;
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
    int32_t best_v = -1;  // >= 0: the option needs v moved to best_x
    double best_x[3] = {0, 0, 0};
    for (int k = 0; k < n_opts; ++k) {
      plan(opts[k], [&](const TopoEditor::Planned& p) {
        const double was = old_faces_max(m, p), now = new_faces_max(m, p);
        if (!(now < was - kOpMargin)) return false;
        if (diag) ++diag->lowering;
        bool constrained_refused = false;  // a refused new tet has four constrained vertices
        // The free vertices common to every refused new tet (all of them
        // when none is refused).
        int32_t common[4];
        int n_common = -1;
        {
          std::optional<Guard::Deferred> quiet;  // a refusal here is not yet an operation refused
          Guard::Counts scratch{};
          if (o.guard) quiet.emplace(scratch);
          for (int ni = 0; ni < p.n_new; ++ni) {
            const int32_t* q = p.quad[ni];
            if (admitted(o, m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3]))) continue;
            constrained_refused = constrained_refused || (m.vert_constrained[q[0]] && m.vert_constrained[q[1]] &&
                                                          m.vert_constrained[q[2]] && m.vert_constrained[q[3]]);
            if (n_common < 0) {
              n_common = 0;
              for (int j = 0; j < 4; ++j)
                if (!m.vert_constrained[q[j]]) common[n_common++] = q[j];
            } else {
              int kept = 0;
              for (int j = 0; j < n_common; ++j)
                if (std::find(q, q + 4, common[j]) != q + 4) common[kept++] = common[j];
              n_common = kept;
            }
          }
        }
        if (diag && constrained_refused) ++diag->constrained_refused;
        if (n_common < 0) {  // every new tet admitted
          if (now < best) {
            best = now;
            best_opt = k;
            best_v = -1;
          }
          return false;
        }
        // In ascending id order (at most four: an insertion sort).
        for (int j = 1; j < n_common && j < 4; ++j)
          for (int l = j; l > 0 && common[l - 1] > common[l]; --l) std::swap(common[l - 1], common[l]);
        for (int j = 0; j < n_common && j < 4; ++j) {
          double x[3], value;
          if (relocate_after(m, p, common[j], o, x, &value) && value < best) {
            best = value;
            best_opt = k;
            best_v = common[j];
            std::copy(x, x + 3, best_x);
          }
        }
        return false;
      });
    }
    if (diag) break;
    if (best_opt < 0) continue;
    // Planning is deterministic: the same option again, committed.
    if (plan(opts[best_opt], [](const TopoEditor::Planned&) { return true; }) == TopoResult::Applied) {
      ++applied;
      if (opts[best_opt].kind < 2) ++st.face_removals;
      else ++st.edge_removals;
      if (best_v >= 0) {
        std::copy(best_x, best_x + 3, m.point(best_v));
        ++st.moves;
        ++st.combined;
      }
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
        const double x = std::max(face_value(m, t, f), face_value(m, nb >> 2, nb & 3));
        faces.push_back({x, 4 * static_cast<int64_t>(t) + f});
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
    for (size_t i = 0; i < faces.size() && (i < kTop || faces[i].first >= w - kBand); ++i)
      ids.push_back(faces[i].second);
    return ids;
  };
  // Two phases: vertex moves alone until a sweep no longer lowers the
  // largest value by kGain, then sweeps of topology on the faces near the
  // largest followed by vertex moves, until the same.  (Topology from the
  // first sweep was tried: on jittered boxes its early changes left the
  // moves worse places to go, e.g. 50.8 degrees instead of 39.9; after the
  // moves have converged the largest value can only fall further.)
  bool topo_phase = false;
  int sweeps_in_phase = 0;
  while (!faces.empty() && sweeps_in_phase < o.sweeps) {
    if (topo_phase) {
      remove_faces(m, worked(worst), o, st);
      scan();
    }
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
    ++st.sweeps;
    ++sweeps_in_phase;
    const double now = scan();
    const bool gained = now < worst - kGain;
    worst = now;
    if (gained) continue;
    if (topo_phase || !o.topology) break;
    topo_phase = true;
    sweeps_in_phase = 0;
  }
  st.worst_after = worst;
  // Why the largest face stays (FacePassStats::worst_*).
  if (!faces.empty()) {
    const int32_t t = static_cast<int32_t>(faces[0].second >> 2);
    const int f = static_cast<int>(faces[0].second & 3);
    const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)];
    const int32_t* v = m.tet(t);
    const int32_t p = v[f], q = m.tets[static_cast<size_t>(nb)];
    int n_free = 0, fr = -1;
    for (int k = 0; k < 3; ++k)
      if (!m.vert_constrained[v[kFaceVertex[f][k]]]) ++n_free, fr = k;
    if (m.vert_constrained[p] && m.vert_constrained[q] && n_free <= 1) {
      st.worst_move_floor = worst;
      if (n_free == 1) {  // asin(|d.e| / (|d||e|)), e the constrained edge, d parallel to q - p
        const double* a = m.point(v[kFaceVertex[f][(fr + 1) % 3]]);
        const double* b = m.point(v[kFaceVertex[f][(fr + 2) % 3]]);
        const double *pp = m.point(p), *pq = m.point(q);
        const double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double d[3] = {pq[0] - pp[0], pq[1] - pp[1], pq[2] - pp[2]};
        const double c = std::fabs(e[0] * d[0] + e[1] * d[1] + e[2] * d[2]) /
                         (std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) * std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
        st.worst_move_floor = std::asin(std::min(1.0, c)) * 180.0 / std::numbers::pi;
      }
    }
    if (o.topology) {
      Tally d;
      remove_faces(m, {faces[0].second}, o, st, &d);
      st.worst_lowering_options = d.lowering;
      st.worst_constrained_refused = d.constrained_refused;
    }
  }
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace tetopt
