// plan_edge's alpha from memoised pieces (see ShellAlpha).
#pragma once
#include <algorithm>
#include <cstdint>
#include <limits>

#include "detail/tet_kernels.hpp"
#include "detail/vec3.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/topo.hpp"

namespace tetopt::detail {

// plan_edge's tets from memoised pieces: alpha(r_i, r_k, r_j, b) ("top")
// and alpha(r_i, r_j, r_k, a) ("bottom") for ring indices i < k < j, the
// same bits as alpha() (quality.cpp, detail/tet_kernels.hpp): each face's
// area is 0.5 |u x v| with u, v the differences alpha() takes, up to the
// order of u and v (|v x u| = |u x v| exactly: each component only changes
// sign), summed in alpha()'s face order; the longest edge is a max (order-
// free); the volume is per tet.  A ring pair's lengths and side areas are
// computed once for the polygon, a triangle's own area once for its two
// tets (NaN: not yet).  In the edge-removal DP these pieces were most of
// alpha's work, and alpha was a fifth of an insertion run on hinge_raw.
struct ShellAlpha {
  static constexpr int kN = kMaxShell + 2;  // plan_edge's ring
  int n = 0;
  const double* r[kN];
  const double *a = nullptr, *b = nullptr;
  double bb[kN][kN], ba[kN][kN], bah[kN][kN], l2[kN][kN];  // [s][t], s < t
  double la[kN], lb[kN];
  double tri = 0;  // top()'s triangle, for bottom() on the same i, k, j
  void reset(int nr, const int32_t* ring, const double* pa, const double* pb, const TetMesh& m) {  // nr <= kN
    n = nr;
    a = pa;
    b = pb;
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    for (int s = 0; s < n; ++s) {
      r[s] = m.point(ring[s]);
      la[s] = lb[s] = kNaN;
      for (int t = s + 1; t < n; ++t) bb[s][t] = ba[s][t] = bah[s][t] = l2[s][t] = kNaN;
    }
  }
  static double half_area(const double* o, const double* p, const double* q) {  // 0.5 |(p - o) x (q - o)|
    double u[3], v[3], x[3];
    detail::sub(p, o, u);
    detail::sub(q, o, v);
    detail::cross(u, v, x);
    return 0.5 * detail::norm(x);
  }
  static double dist2(const double* p, const double* q) {
    double u[3];
    detail::sub(p, q, u);
    return detail::dot(u, u);
  }
  double side_b(int s, int t) { return bb[s][t] == bb[s][t] ? bb[s][t] : (bb[s][t] = half_area(r[s], r[t], b)); }
  double side_a(int s, int t) { return ba[s][t] == ba[s][t] ? ba[s][t] : (ba[s][t] = half_area(r[s], r[t], a)); }
  double side_a_hi(int s, int t) {
    return bah[s][t] == bah[s][t] ? bah[s][t] : (bah[s][t] = half_area(r[t], r[s], a));
  }
  double edge2(int s, int t) { return l2[s][t] == l2[s][t] ? l2[s][t] : (l2[s][t] = dist2(r[t], r[s])); }
  double apex_a2(int s) { return la[s] == la[s] ? la[s] : (la[s] = dist2(a, r[s])); }
  double apex_b2(int s) { return lb[s] == lb[s] ? lb[s] : (lb[s] = dist2(b, r[s])); }
  static double max6(double x0, double x1, double x2, double x3, double x4, double x5) {
    double mx = 0;  // edge_lengths2's running max
    for (const double x : {x0, x1, x2, x3, x4, x5}) mx = std::max(mx, x);
    return mx;
  }
  // (r_i, r_k, r_j, b): faces (r_k, r_j, b), (r_i, b, r_j), (r_i, r_k, b), (r_i, r_j, r_k).
  double top(int i, int k, int j) {
    tri = half_area(r[i], r[j], r[k]);
    double area = 0;
    area += side_b(k, j);
    area += side_b(i, j);
    area += side_b(i, k);
    area += tri;
    const double mx = max6(edge2(i, k), edge2(i, j), apex_b2(i), edge2(k, j), apex_b2(k), apex_b2(j));
    return alpha_from(tet_signed_volume(r[i], r[k], r[j], b), area, mx);
  }
  // (r_i, r_j, r_k, a): faces (r_j, r_k, a), (r_i, a, r_k), (r_i, r_j, a), (r_i, r_k, r_j); after top(i, k, j).
  double bottom(int i, int k, int j) {
    double area = 0;
    area += side_a_hi(k, j);
    area += side_a(i, k);
    area += side_a(i, j);
    area += tri;
    const double mx = max6(edge2(i, j), edge2(i, k), apex_a2(i), edge2(k, j), apex_a2(j), apex_a2(k));
    return alpha_from(tet_signed_volume(r[i], r[j], r[k], a), area, mx);
  }
};

}  // namespace tetopt::detail
