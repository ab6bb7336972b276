// The fan of an insertion cavity (TopoEditor::insert_vertex): each outer
// face's part of alpha computed once, the apex's part per position.
#pragma once
#include <algorithm>
#include <cmath>

#include "detail/vec3.hpp"

namespace tetopt::detail {

// One outer face (A, B, C) of an insertion cavity with what alpha(A, C, B, p)
// computes from the face alone, so that the position search pays only for
// the apex p's part.  cone_alpha returns alpha(A, C, B, p) bit for bit: the
// same operations in the same order (quality.cpp: the area sum adds the
// faces opposite vertices 0, 1, 2, 3 in turn, the last being (A, B, C); the
// longest edge is a max, which is order-free).
struct ConeFace {
  double a[3], b[3], c[3];
  double base_area;  // 0.5 |(B - A) x (C - A)|
  double l2fix;      // longest squared edge of (A, B, C)
};

inline void make_cone_face(const double* A, const double* B, const double* C, ConeFace& f) {
  using detail::cross;
  using detail::dot;
  using detail::norm;
  using detail::sub;
  for (int k = 0; k < 3; ++k) { f.a[k] = A[k]; f.b[k] = B[k]; f.c[k] = C[k]; }
  double u[3], v[3], w[3], n[3];
  sub(B, A, u);
  sub(C, A, v);
  cross(u, v, n);
  f.base_area = 0.5 * norm(n);
  sub(B, C, w);
  f.l2fix = std::max({dot(v, v), dot(u, u), dot(w, w)});
}

inline const double kConeSixSqrt6 = 6.0 * std::sqrt(6.0);

inline double cone_alpha(const ConeFace& f, const double* p) {
  using detail::cross;
  using detail::dot;
  using detail::norm;
  using detail::sub;
  // Tet (A, C, B, p) as quality.cpp sees it: a = A, b = C, c = B, d = p.
  double u[3], v[3], n[3];
  // Volume: dot(b - a, (c - a) x (d - a)) / 6.
  double ba[3], ca[3], da[3], x[3];
  sub(f.c, f.a, ba);
  sub(f.b, f.a, ca);
  sub(p, f.a, da);
  cross(ca, da, x);
  const double vol = dot(ba, x) / 6.0;
  double area = 0;
  // Face 0 (b, c, d) = (C, B, p).
  sub(f.b, f.c, u);
  sub(p, f.c, v);
  cross(u, v, n);
  area += 0.5 * norm(n);
  // Face 1 (a, d, c) = (A, p, B).
  sub(p, f.a, u);
  sub(f.b, f.a, v);
  cross(u, v, n);
  area += 0.5 * norm(n);
  // Face 2 (a, b, d) = (A, C, p).
  sub(f.c, f.a, u);
  sub(p, f.a, v);
  cross(u, v, n);
  area += 0.5 * norm(n);
  area += f.base_area;  // face 3 (a, c, b) = (A, B, C)
  const double l2 = std::max({f.l2fix, dot(da, da), [&] { double e[3]; sub(p, f.c, e); return dot(e, e); }(),
                              [&] { double e[3]; sub(p, f.b, e); return dot(e, e); }()});
  const double den = area * std::sqrt(l2);
  if (!(den > 0)) return 0.0;
  const double q = kConeSixSqrt6 * vol / den;
  return std::isfinite(q) ? q : 0.0;
}

}  // namespace tetopt::detail
