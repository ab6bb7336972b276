// A generated test mesh shared by test_topo, test_objective and test_poor_polish.
#pragma once
#include <cmath>
#include <cstdint>

#include "tetopt/generate.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"

namespace tetopt_test {

// A jittered nx x nx x nz box whose bottom face (z = 0) has needle
// triangles: every third vertex strictly inside it, moved within the face
// almost onto its neighbour in +x (x = i + 0.999).  A move that would make a
// tet non-positive is undone; *moved (when given) counts the others.  The
// tets on the needles cannot reach a good alpha whatever their apex (a thin
// vessel wall meshed coarsely: aorta_vessel).  Topology not built.  With
// `rest` below 0.999 the needles are of two strengths: the first vertex
// moved goes to x = i + 0.999 (the mesh's worst), the others to x = i + rest
// (test_poor_polish).
inline tetopt::TetMesh needle_box(int nx, int nz, uint64_t seed, int* moved = nullptr, double rest = 0.999) {
  using namespace tetopt;
  TetMesh m = make_box_mesh({.nx = nx, .ny = nx, .nz = nz, .jitter = 0.3, .seed = seed});
  int n = 0;
  for (int32_t v = 0; v < m.nv(); ++v) {
    double* p = m.point(v);
    if (p[2] != 0.0 || p[0] <= 0.5 || p[0] >= nx - 0.5 || p[1] <= 0.5 || p[1] >= nx - 0.5) continue;
    const long i = std::lround(p[0]), j = std::lround(p[1]);
    if ((i + j) % 3 != 0) continue;
    const double old_x = p[0];
    p[0] = static_cast<double>(i) + (n == 0 ? 0.999 : rest);
    bool ok = true;
    for (int32_t t = 0; t < m.nt() && ok; ++t) {
      const int32_t* q = m.tet(t);
      if (q[0] == v || q[1] == v || q[2] == v || q[3] == v)
        ok = orient3d(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3])) == Sign::Positive;
    }
    if (ok) ++n;
    else p[0] = old_x;
  }
  if (moved) *moved = n;
  return m;
}

}  // namespace tetopt_test
