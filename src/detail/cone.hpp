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

// The fan as a structure of arrays, for cone_alpha4: four faces a call,
// lane by lane the operations of cone_alpha in its order (so each lane is
// its bits: no operation is fused or reordered, and the selects at the end
// give what its early returns give), in a form the compiler keeps in vector
// registers.  The search's fan evaluations were a fifth of an insertion run
// on tw_A (twenty-sixth session).  Lanes from n up to the next multiple of
// 4 are copies of face 0 (pad), which change no minimum.
template <int N>
struct ConeFan {
  static_assert(N % 4 == 0, "whole blocks of four");
  alignas(32) double ax[N], ay[N], az[N], bx[N], by[N], bz[N], cx[N], cy[N], cz[N], base_area[N], l2fix[N];
  void set(int i, const double* A, const double* B, const double* C) {
    ConeFace f;
    make_cone_face(A, B, C, f);
    ax[i] = f.a[0]; ay[i] = f.a[1]; az[i] = f.a[2];
    bx[i] = f.b[0]; by[i] = f.b[1]; bz[i] = f.b[2];
    cx[i] = f.c[0]; cy[i] = f.c[1]; cz[i] = f.c[2];
    base_area[i] = f.base_area;
    l2fix[i] = f.l2fix;
  }
  void pad(int n) {
    for (int i = n; i % 4 != 0; ++i) {
      ax[i] = ax[0]; ay[i] = ay[0]; az[i] = az[0];
      bx[i] = bx[0]; by[i] = by[0]; bz[i] = bz[0];
      cx[i] = cx[0]; cy[i] = cy[0]; cz[i] = cz[0];
      base_area[i] = base_area[0];
      l2fix[i] = l2fix[0];
    }
  }
};

// cone_alpha of faces i0 .. i0 + 3 at apex p, into out[0..4).
template <int N>
inline void cone_alpha4(const ConeFan<N>& f, int i0, const double* p, double* out) {
  const double px = p[0], py = p[1], pz = p[2];
  for (int l = 0; l < 4; ++l) {
    const int i = i0 + l;
    const double Ax = f.ax[i], Ay = f.ay[i], Az = f.az[i];
    const double Bx = f.bx[i], By = f.by[i], Bz = f.bz[i];
    const double Cx = f.cx[i], Cy = f.cy[i], Cz = f.cz[i];
    // cross(u, v) . w and |cross(u, v)| as vec3.hpp computes them.
    auto crs = [](double u0, double u1, double u2, double v0, double v1, double v2, double& r0, double& r1,
                  double& r2) {
      r0 = u1 * v2 - u2 * v1;
      r1 = u2 * v0 - u0 * v2;
      r2 = u0 * v1 - u1 * v0;
    };
    // Volume: dot(C - A, (B - A) x (p - A)) / 6.
    const double bax = Cx - Ax, bay = Cy - Ay, baz = Cz - Az;
    const double cax = Bx - Ax, cay = By - Ay, caz = Bz - Az;
    const double dax = px - Ax, day = py - Ay, daz = pz - Az;
    double x0, x1, x2;
    crs(cax, cay, caz, dax, day, daz, x0, x1, x2);
    const double vol = (bax * x0 + bay * x1 + baz * x2) / 6.0;
    double area = 0, n0, n1, n2;
    // Face 0 (C, B, p).
    crs(Bx - Cx, By - Cy, Bz - Cz, px - Cx, py - Cy, pz - Cz, n0, n1, n2);
    area += 0.5 * std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
    // Face 1 (A, p, B).
    crs(px - Ax, py - Ay, pz - Az, Bx - Ax, By - Ay, Bz - Az, n0, n1, n2);
    area += 0.5 * std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
    // Face 2 (A, C, p).
    crs(Cx - Ax, Cy - Ay, Cz - Az, px - Ax, py - Ay, pz - Az, n0, n1, n2);
    area += 0.5 * std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
    area += f.base_area[i];
    // std::max({l2fix, |p - A|^2, |p - C|^2, |p - B|^2}), its comparisons.
    const double ecx = px - Cx, ecy = py - Cy, ecz = pz - Cz;
    const double ebx = px - Bx, eby = py - By, ebz = pz - Bz;
    const double d1 = dax * dax + day * day + daz * daz, d2 = ecx * ecx + ecy * ecy + ecz * ecz,
                 d3 = ebx * ebx + eby * eby + ebz * ebz;
    double l2 = f.l2fix[i];
    l2 = l2 < d1 ? d1 : l2;
    l2 = l2 < d2 ? d2 : l2;
    l2 = l2 < d3 ? d3 : l2;
    const double den = area * std::sqrt(l2);
    const double q = kConeSixSqrt6 * vol / den;
    out[l] = ((den > 0) & (std::fabs(q) <= 1.7976931348623157e308)) ? q : 0.0;
  }
}

}  // namespace tetopt::detail
