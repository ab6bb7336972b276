// The face non-orthogonality pass (face_pass.hpp).
#include "tetopt/face_pass.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "tetopt/conventions.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"

namespace tetopt {

namespace {

constexpr double kBand = 5.0;   // faces within this many degrees of the largest are worked on
constexpr size_t kTop = 64;     // ... and at least this many of the worst
constexpr double kGain = 0.01;  // a sweep must lower the largest by this many degrees to go on

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
  const int32_t nt = m.nt();
  std::vector<std::pair<double, int64_t>> faces;  // (value, 4t+f) of interior faces, each once
  auto scan = [&] {
    faces.clear();
    for (int32_t t = 0; t < nt; ++t)
      for (int f = 0; f < 4; ++f) {
        const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)];
        if (nb < 0 || (nb >> 2) < t) continue;
        faces.push_back({face_value(m, t, f), 4 * static_cast<int64_t>(t) + f});
      }
    std::sort(faces.begin(), faces.end(), [](const auto& a, const auto& b) {
      return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
    return faces.empty() ? 0.0 : faces[0].first;
  };
  double worst = scan();
  st.worst_before = worst;
  for (int sweep = 0; sweep < o.sweeps && !faces.empty(); ++sweep) {
    std::vector<int32_t> verts;
    for (size_t i = 0; i < faces.size() && (i < kTop || faces[i].first >= worst - kBand); ++i) {
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
