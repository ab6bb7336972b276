// Best-apex bounds and the classification of tets left below the threshold
// (see diagnose.hpp for the definitions and the search).
#include "tetopt/diagnose.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "detail/cone.hpp"
#include "detail/parallel.hpp"
#include "detail/vec3.hpp"

#include "tetopt/conventions.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"

namespace tetopt {

namespace {

using Vec3 = std::array<double, 3>;

// The triangle in its own frame: a = 0, b on +x, c in the upper half plane,
// scaled so the longest edge is 1.  `to_world` maps a local apex back.
struct Frame {
  bool degenerate = true;
  double bx = 0, cx = 0, cy = 0;  // local b = (bx,0,0), c = (cx,cy,0)
  Vec3 origin{}, e1{}, e2{}, n{};
  double scale = 0;

  Frame(const double* a0, const double* b0, const double* c0) {
    // Rotate the labels cyclically (keeps the orientation) so that the
    // longest edge is a-b: then bx = 1 and similar triangles share a frame.
    const double* a = a0; const double* b = b0; const double* c = c0;
    {
      auto d2 = [](const double* p, const double* q) {
        return (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]);
      };
      const double ab = d2(a0, b0), bc = d2(b0, c0), ca = d2(c0, a0);
      if (bc > ab && bc >= ca) { a = b0; b = c0; c = a0; }
      else if (ca > ab && ca > bc) { a = c0; b = a0; c = b0; }
    }
    Vec3 u{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    Vec3 w{c[0] - b[0], c[1] - b[1], c[2] - b[2]};
    auto len = [](const Vec3& x) { return std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]); };
    const double lu = len(u), lv = len(v), lw = len(w);
    scale = std::max({lu, lv, lw});
    Vec3 nn{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    const double ln = len(nn);
    if (!(scale > 0) || !(lu > 0) || !(ln > 1e-14 * scale * scale) || !std::isfinite(ln)) return;
    origin = {a[0], a[1], a[2]};
    for (int k = 0; k < 3; ++k) { e1[k] = u[k] / lu; n[k] = nn[k] / ln; }
    e2 = {n[1] * e1[2] - n[2] * e1[1], n[2] * e1[0] - n[0] * e1[2], n[0] * e1[1] - n[1] * e1[0]};
    bx = lu / scale;
    cx = (v[0] * e1[0] + v[1] * e1[1] + v[2] * e1[2]) / scale;
    cy = (v[0] * e2[0] + v[1] * e2[1] + v[2] * e2[2]) / scale;
    degenerate = !(cy > 0);
  }
  Vec3 to_world(const Vec3& p) const {
    Vec3 r;
    const double z = std::fabs(p[2]);
    for (int k = 0; k < 3; ++k) r[k] = origin[k] + scale * (p[0] * e1[k] + p[1] * e2[k] + z * n[k]);
    return r;
  }
};

// Key of a triangle's shape up to similarity and reflection (the best-apex
// values depend on nothing else), or false when degenerate.
bool shape_key(const Frame& f, std::pair<int64_t, int64_t>& key) {
  if (f.degenerate) return false;
  const double x = std::min(f.cx, f.bx - f.cx);
  key = {std::llround(x * 1e10), std::llround(f.cy * 1e10)};
  return true;
}

struct PairHash {
  size_t operator()(const std::pair<int64_t, int64_t>& p) const {
    return std::hash<int64_t>()(p.first) * 1000003u ^ std::hash<int64_t>()(p.second);
  }
};

// The search box: apexes farther than kReach longest edges never matter for
// alpha, and for the dihedral objectives, whose supremum can lie at infinity
// (a right triangle's max dihedral tends to 90 degrees as the apex rises), it
// keeps every search finite.
constexpr double kReach = 4.0;

bool in_reach(const Vec3& p) {
  return std::fabs(p[0]) <= kReach && std::fabs(p[1]) <= kReach && std::fabs(p[2]) <= kReach;
}

// The cosines of the extreme dihedral angles of the tet (frame triangle, d):
// dihedral at edge (i,j) = pi - angle between the outward normals of the two
// faces holding it.  False for a flat tet (d on the plane or a zero normal).
bool dihedral_cosines(const Frame& f, const double d[3], double& cmin, double& cmax) {
  if (d[2] == 0) return false;
  const double a[3] = {0, 0, 0}, b[3] = {f.bx, 0, 0}, c[3] = {f.cx, f.cy, 0};
  const double* corner[4] = {a, b, c, d};
  double nrm[4][3], len[4];
  detail::face_normals(corner, nrm, len);
  for (int k = 0; k < 4; ++k) {
    const double l = len[k];
    if (!(l > 0)) return false;
    double* n = nrm[k];
    n[0] /= l; n[1] /= l; n[2] /= l;
  }
  cmin = 2;
  cmax = -2;
  for (int e = 0; e < 6; ++e) {
    const int o = kEdgeOpposite[e];
    const double* n1 = nrm[kEdgeVertex[o][0]];
    const double* n2 = nrm[kEdgeVertex[o][1]];
    const double cs = -(n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2]);
    cmin = std::min(cmin, cs);
    cmax = std::max(cmax, cs);
  }
  return true;
}

constexpr double kDeg = 180.0 / M_PI;

// The objective to maximise at local apex p (z folded to the positive side).
// Alpha runs on the triangle's cone face (detail::cone_alpha: alpha(a, b, c,
// d) bit for bit, the face's own part computed once): the searches evaluate
// it thousands of times per triangle, and it was 43% of a diagnosis.
struct ApexMeasure {
  const Frame& f;
  ApexObjective obj;
  detail::ConeFace cone;
  ApexMeasure(const Frame& frame, ApexObjective o) : f(frame), obj(o) {
    // cone_alpha(face (A, B, C), d) is alpha(A, C, B, d): A = a, B = c, C = b.
    const double a[3] = {0, 0, 0}, b[3] = {f.bx, 0, 0}, c[3] = {f.cx, f.cy, 0};
    detail::make_cone_face(a, c, b, cone);
  }
  double operator()(const Vec3& p) const {
    if (!in_reach(p)) return -std::numeric_limits<double>::infinity();
    const double d[3] = {p[0], p[1], std::fabs(p[2])};
    if (obj == ApexObjective::Alpha) return detail::cone_alpha(cone, d);
    if (static_cast<int>(obj) >= static_cast<int>(ApexObjective::SineMin)) {
      const double a[3] = {0, 0, 0}, b[3] = {f.bx, 0, 0}, c[3] = {f.cx, f.cy, 0};
      switch (obj) {
        case ApexObjective::SineMin: return sine_min(a, b, c, d);
        case ApexObjective::ScaledJacobian: return scaled_jacobian(a, b, c, d);
        case ApexObjective::RadiusRatio: return radius_ratio(a, b, c, d);
        case ApexObjective::MeanRatio: return mean_ratio(a, b, c, d);
        default: {
          const double s = equivolume_skewness(a, b, c, d);
          return std::isnan(s) ? -1.0 : -s;
        }
      }
    }
    double cmin, cmax;
    if (!dihedral_cosines(f, d, cmin, cmax)) return obj == ApexObjective::MinDihedral ? 0.0 : -180.0;
    if (obj == ApexObjective::MinDihedral) return std::acos(std::clamp(cmax, -1.0, 1.0)) * kDeg;
    return -std::acos(std::clamp(cmin, -1.0, 1.0)) * kDeg;
  }
};

// All three objectives at p, in the order Alpha, MinDihedral, MaxDihedral:
// the values of ApexMeasure{f, obj}(p), from one set of face normals.
void objectives_at(const Frame& f, const Vec3& p, double out[3]) {
  if (!in_reach(p)) {
    out[0] = out[1] = out[2] = -std::numeric_limits<double>::infinity();
    return;
  }
  const double d[3] = {p[0], p[1], std::fabs(p[2])};
  const double a[3] = {0, 0, 0}, b[3] = {f.bx, 0, 0}, c[3] = {f.cx, f.cy, 0};
  out[0] = alpha(a, b, c, d);
  double cmin, cmax;
  if (!dihedral_cosines(f, d, cmin, cmax)) {
    out[1] = 0.0;
    out[2] = -180.0;
    return;
  }
  out[1] = std::acos(std::clamp(cmax, -1.0, 1.0)) * kDeg;
  out[2] = -std::acos(std::clamp(cmin, -1.0, 1.0)) * kDeg;
}

// Closed-form candidate apexes: above the centroid, the incentre and (when
// inside the triangle) the circumcentre, at a few heights.
struct Candidates {
  std::array<Vec3, 9> p;
  int n = 0;
  const Vec3* begin() const { return p.data(); }
  const Vec3* end() const { return p.data() + n; }
};
Candidates candidates(const Frame& f) {
  Candidates pts;
  const double la = std::hypot(f.bx - f.cx, f.cy), lb = std::hypot(f.cx, f.cy), lc = f.bx;  // opposite a, b, c
  const double per = la + lb + lc;
  const double gx = (f.bx + f.cx) / 3, gy = f.cy / 3;
  const double ix = (lb * f.bx + lc * f.cx) / per, iy = (lc * f.cy) / per;
  std::array<std::array<double, 2>, 3> base = {{{gx, gy}, {ix, iy}, {0, 0}}};
  int nb = 2;
  // circumcentre of (0,0), (bx,0), (cx,cy), kept when inside (acute triangle)
  const double ox = f.bx / 2;
  const double oy = (f.cx * f.cx + f.cy * f.cy - f.bx * f.cx) / (2 * f.cy);
  const double lam_c = oy / f.cy, lam_b = (ox - lam_c * f.cx) / f.bx;
  if (lam_c > 0 && lam_b > 0 && lam_b + lam_c < 1) base[nb++] = {ox, oy};
  const double mean = per / 3;
  for (int i = 0; i < nb; ++i)
    for (double h : {0.35, 0.6, 0.8165})
      pts.p[pts.n++] = {base[i][0], base[i][1], h * mean};
  return pts;
}

// Nelder–Mead simplex search (Nelder and Mead 1965; standard coefficients
// 1, 2, 0.5, 0.5) maximising g from x0 with initial step `step`.
template <class G>
double nelder_mead(const G& g, Vec3& x0, double step, int max_evals) {
  std::array<Vec3, 4> s;
  std::array<double, 4> fv;
  s[0] = x0;
  for (int i = 0; i < 3; ++i) { s[i + 1] = x0; s[i + 1][i] += step; }
  for (int i = 0; i < 4; ++i) fv[i] = g(s[i]);
  int evals = 4;
  std::array<int, 4> idx{0, 1, 2, 3};
  while (evals < max_evals) {
    std::sort(idx.begin(), idx.end(), [&](int p, int q) { return fv[p] > fv[q]; });  // best first
    const int best = idx[0], worst = idx[3], second_worst = idx[2];
    double size = 0;
    for (int i = 1; i < 4; ++i)
      for (int k = 0; k < 3; ++k) size = std::max(size, std::fabs(s[idx[i]][k] - s[best][k]));
    if (size < 1e-11 || (fv[best] - fv[worst] <= 1e-15 * std::max(1.0, std::fabs(fv[best])) && size < 1e-7)) break;
    Vec3 cen{0, 0, 0};
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) cen[k] += s[idx[i]][k] / 3;
    auto along = [&](double t) {
      Vec3 r;
      for (int k = 0; k < 3; ++k) r[k] = cen[k] + t * (s[worst][k] - cen[k]);
      return r;
    };
    const Vec3 xr = along(-1.0);
    const double fr = g(xr);
    ++evals;
    if (fr > fv[best]) {
      const Vec3 xe = along(-2.0);
      const double fe = g(xe);
      ++evals;
      if (fe > fr) { s[worst] = xe; fv[worst] = fe; } else { s[worst] = xr; fv[worst] = fr; }
    } else if (fr > fv[second_worst]) {
      s[worst] = xr; fv[worst] = fr;
    } else {
      const bool outside = fr > fv[worst];
      const Vec3 xc = along(outside ? -0.5 : 0.5);
      const double fc = g(xc);
      ++evals;
      if (fc > (outside ? fr : fv[worst])) {
        s[worst] = xc; fv[worst] = fc;
      } else {
        for (int i = 1; i < 4; ++i) {
          const int j = idx[i];
          for (int k = 0; k < 3; ++k) s[j][k] = s[best][k] + 0.5 * (s[j][k] - s[best][k]);
          fv[j] = g(s[j]);
          ++evals;
        }
      }
    }
  }
  int b = 0;
  for (int i = 1; i < 4; ++i) if (fv[i] > fv[b]) b = i;
  x0 = s[b];
  return fv[b];
}

// Compass search (Kolda, Lewis and Torczon 2003): poll +-step along each
// axis, move on improvement, halve the step otherwise.
template <class G>
double compass(const G& g, Vec3& x, double fx, double step, double min_step, int max_evals = 3000) {
  int evals = 0;
  while (step > min_step && evals < max_evals) {
    bool moved = false;
    for (int k = 0; k < 3 && !moved; ++k)
      for (double sgn : {1.0, -1.0}) {
        Vec3 y = x;
        y[k] += sgn * step;
        const double fy = g(y);
        ++evals;
        if (fy > fx) { x = y; fx = fy; moved = true; break; }
      }
    if (!moved) step *= 0.5;
  }
  return fx;
}

// Measures whose public value is minimised (the search maximises minus it).
bool lower_is_better(ApexObjective obj) {
  return obj == ApexObjective::MaxDihedral || obj == ApexObjective::Skewness;
}

double degenerate_value(ApexObjective obj) {
  return obj == ApexObjective::MaxDihedral ? 180.0 : (obj == ApexObjective::Skewness ? 1.0 : 0.0);
}

double to_public(ApexObjective obj, double score) { return lower_is_better(obj) ? -score : score; }

// The measure each apex objective bounds.
Measure measure_of(ApexObjective obj) {
  switch (obj) {
    case ApexObjective::Alpha: return Measure::Alpha;
    case ApexObjective::MinDihedral: return Measure::DihedralMin;
    case ApexObjective::MaxDihedral: return Measure::DihedralMax;
    case ApexObjective::SineMin: return Measure::SineMin;
    case ApexObjective::ScaledJacobian: return Measure::ScaledJacobian;
    case ApexObjective::RadiusRatio: return Measure::RadiusRatio;
    case ApexObjective::MeanRatio: return Measure::MeanRatio;
    case ApexObjective::Skewness: return Measure::EquivolumeSkewness;
  }
  return Measure::Alpha;
}

}  // namespace

namespace {
// cheap_apex_value for the three objectives (indexed by ApexObjective),
// sharing the frame and the normals at each candidate.
void cheap_apex_values(const double* a, const double* b, const double* c, double out[3]) {
  const Frame f(a, b, c);
  const ApexObjective objs[3] = {ApexObjective::Alpha, ApexObjective::MinDihedral, ApexObjective::MaxDihedral};
  if (f.degenerate) {
    for (int k = 0; k < 3; ++k) out[k] = degenerate_value(objs[k]);
    return;
  }
  for (int k = 0; k < 3; ++k) out[k] = -std::numeric_limits<double>::infinity();
  for (const Vec3& p : candidates(f)) {
    double v[3];
    objectives_at(f, p, v);
    for (int k = 0; k < 3; ++k) out[k] = std::max(out[k], v[k]);
  }
  for (int k = 0; k < 3; ++k) out[k] = to_public(objs[k], out[k]);
}
}  // namespace

namespace {
// cheap_apex_value for the other measures (ApexObjective 3 .. 7, out[o - 3])
// from one frame and one candidate set.
void cheap_other_values(const double* a, const double* b, const double* c, double out[kApexObjectives - 3]) {
  const Frame f(a, b, c);
  for (int o = 3; o < kApexObjectives; ++o) {
    const ApexObjective obj = static_cast<ApexObjective>(o);
    double best = -std::numeric_limits<double>::infinity();
    if (f.degenerate) {
      best = to_public(obj, degenerate_value(obj));
    } else {
      const ApexMeasure g{f, obj};
      for (const Vec3& p : candidates(f)) best = std::max(best, g(p));
    }
    out[o - 3] = to_public(obj, best);
  }
}
}  // namespace

double cheap_apex_value(const double* a, const double* b, const double* c, ApexObjective obj) {
  const int o = static_cast<int>(obj);
  if (o < 3) {
    double v[3];
    cheap_apex_values(a, b, c, v);
    return v[o];
  }
  double v[kApexObjectives - 3];
  cheap_other_values(a, b, c, v);
  return v[o - 3];
}

namespace {
// Between cheap and full: the best candidate polished by a short compass
// search (about 100 evaluations).  Achieved, like both.
double quick_score(const double* a, const double* b, const double* c, ApexObjective obj) {
  const Frame f(a, b, c);
  if (f.degenerate) return to_public(obj, degenerate_value(obj));
  const ApexMeasure g{f, obj};
  double best = -std::numeric_limits<double>::infinity();
  Vec3 bp{0, 0, 0};
  for (const Vec3& p : candidates(f)) {
    const double v = g(p);
    if (v > best) { best = v; bp = p; }
  }
  return compass(g, bp, best, 0.05, 2e-4, 300);
}
}  // namespace

ApexResult best_apex(const double* a, const double* b, const double* c, ApexObjective obj) {
  ApexResult r;
  const Frame f(a, b, c);
  if (f.degenerate) {
    r.value = degenerate_value(obj);
    for (int k = 0; k < 3; ++k) r.apex[k] = (a[k] + b[k] + c[k]) / 3;
    return r;
  }
  const ApexMeasure g{f, obj};
  // Starts: the candidates and a coarse grid around the triangle.
  std::vector<std::pair<double, Vec3>> starts;
  for (const Vec3& p : candidates(f)) starts.push_back({g(p), p});
  const double x0 = std::min(0.0, f.cx) - 0.3, x1 = std::max(f.bx, f.cx) + 0.3;
  const double y0 = -0.5, y1 = f.cy + 0.6;
  constexpr int kNx = 9, kNy = 9, kNz = 6;
  for (int i = 0; i < kNx; ++i)
    for (int j = 0; j < kNy; ++j)
      for (int k = 0; k < kNz; ++k) {
        const Vec3 p{x0 + (x1 - x0) * i / (kNx - 1), y0 + (y1 - y0) * j / (kNy - 1), 0.06 + 1.14 * k / (kNz - 1)};
        starts.push_back({g(p), p});
      }
  std::partial_sort(starts.begin(), starts.begin() + 4, starts.end(),
                    [](const auto& p, const auto& q) { return p.first > q.first; });
  double best = starts[0].first;
  Vec3 best_p = starts[0].second;
  for (int s = 0; s < 4; ++s) {
    Vec3 x = starts[s].second;
    double fx = nelder_mead(g, x, 0.08, 600);
    fx = std::max(fx, nelder_mead(g, x, 0.01, 400));  // restart: cures stalls at kinks
    if (fx > best) { best = fx; best_p = x; }
  }
  if (obj == ApexObjective::SineMin) {
    // The minimum sine has spikes at the scale of a short edge: an apex
    // within about that edge's length of it makes a needle tet, whose
    // dihedral angles are all near 60 or 90 degrees.  Starts at each edge's
    // own scale (above its midpoint, inward and outward), searched with steps
    // of that scale.
    const double px[3] = {0, f.bx, f.cx}, py[3] = {0, 0, f.cy};
    for (int e = 0; e < 3; ++e) {
      const int i = e, j = (e + 1) % 3;
      const double ex = px[j] - px[i], ey = py[j] - py[i], l = std::hypot(ex, ey);
      if (!(l > 0)) continue;
      const double mx = (px[i] + px[j]) / 2, my = (py[i] + py[j]) / 2, nx = -ey / l, ny = ex / l;
      for (double side : {-0.3, 0.0, 0.3})
        for (double h : {0.5, 0.87}) {
          Vec3 x{mx + side * l * nx, my + side * l * ny, h * l};
          double fx = nelder_mead(g, x, 0.1 * l, 300);
          fx = compass(g, x, fx, 0.05 * l, 1e-6 * l, 300);
          if (fx > best) { best = fx; best_p = x; }
        }
    }
  }
  best = compass(g, best_p, best, 1e-3, 1e-10);
  r.value = to_public(obj, best);
  best_p[2] = std::fabs(best_p[2]);
  const Vec3 w = f.to_world(best_p);
  for (int k = 0; k < 3; ++k) r.apex[k] = w[k];
  return r;
}

double alpha_ceiling(const double* a, const double* b, const double* c) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double w[3] = {c[0] - b[0], c[1] - b[1], c[2] - b[2]};
  const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  const double area = 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  const double lu = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  const double lv = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  const double lw = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  const double l = std::max({lu, lv, lw}), per = lu + lv + lw;
  if (!(l > 0)) return 0;
  return 2 * std::sqrt(6.0) * area / (area + l * per / 2);
}

namespace {
// The dihedral angle (degrees) at edge pq between triangles (p, q, r) and
// (p, q, s): the angle between r - p and s - p projected across the edge.
double edge_dihedral_deg(const double* p, const double* q, const double* r, const double* s) {
  double e[3], a[3], b[3];
  for (int k = 0; k < 3; ++k) { e[k] = q[k] - p[k]; a[k] = r[k] - p[k]; b[k] = s[k] - p[k]; }
  const double ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  if (!(ee > 0)) return 0;
  const double ka = (a[0] * e[0] + a[1] * e[1] + a[2] * e[2]) / ee, kb = (b[0] * e[0] + b[1] * e[1] + b[2] * e[2]) / ee;
  for (int k = 0; k < 3; ++k) { a[k] -= ka * e[k]; b[k] -= kb * e[k]; }
  const double la = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), lb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
  if (!(la > 0 && lb > 0)) return 0;
  const double c = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (la * lb);
  return std::acos(std::clamp(c, -1.0, 1.0)) * 57.29577951308232;
}
}  // namespace

double wedge_best_alpha(const double* p, const double* q, const double* r, const double* s) {
  const double* w[3] = {s, nullptr, nullptr};
  return wedges_best_alpha(p, q, r, w);
}

namespace {

// Kept triangles facing one side of a kept face ("walls", issue 27): any
// kept triangle K that the open segment from T's centroid g to an apex D
// meets forbids D (that segment lies inside the tet (T, D), and no tet of a
// conforming mesh has a point of a kept triangle inside it).  World
// coordinates, 9 doubles each.
using WallTri = std::array<double, 9>;

// The apex constraints of one side of a triangle in its Frame (local
// coordinates, the side mirrored onto z > 0): the wedge planes of
// face_wedges and the walls.  ok(x) is false where x is forbidden (margins
// of 1e-9 longest edges against rounding: see hits), so a search over the
// allowed set bounds every mesh.
struct SideConstraint {
  struct Plane {
    Vec3 o, n;
    double sign;
    Vec3 ls, u;
    int e;
    Vec3 c3;  // T's vertex off edge e
  };
  struct Wall {
    Vec3 v[3], n;
    double zmin, nn;
    double lo[2], hi[2];  // bounding rectangle in x, y
  };
  std::vector<Plane> planes;
  std::vector<Wall> walls;
  Vec3 g{};            // T's centroid, local
  double wall_h = 0;   // local height of the lowest wall point above g's normal (0: none)
  bool bad = false;    // a wedge vertex on T's plane: no bound (wedges_best_alpha returns 0)

  static Vec3 loc(const Frame& f, const double* w) {
    Vec3 d{w[0] - f.origin[0], w[1] - f.origin[1], w[2] - f.origin[2]};
    return Vec3{(d[0] * f.e1[0] + d[1] * f.e1[1] + d[2] * f.e1[2]) / f.scale,
                (d[0] * f.e2[0] + d[1] * f.e2[1] + d[2] * f.e2[2]) / f.scale,
                (d[0] * f.n[0] + d[1] * f.n[1] + d[2] * f.n[2]) / f.scale};
  }

  // side: a point strictly on the side (for the walls' mirroring); walls may be null.
  SideConstraint(const Frame& f, const double* p, const double* q, const double* r, const double* const s[3],
                 const std::vector<WallTri>* wl, const double* side) {
    const Vec3 lv[3] = {loc(f, p), loc(f, q), loc(f, r)};
    for (int k = 0; k < 3; ++k) g[k] = (lv[0][k] + lv[1][k] + lv[2][k]) / 3;
    g[2] = 0;
    // Edge e = (v[e], v[e+1]) with s[e]: the apex must stay on the third
    // vertex's side of the plane (v[e], v[e+1], s[e]).  alpha is symmetric
    // under the reflection through (p, q, r)'s plane, which ApexMeasure folds
    // onto z > 0: each s is mirrored there too (they all lie on the domain's
    // side of (p, q, r), so mirroring keeps them on one side).
    for (int e = 0; e < 3; ++e) {
      if (!s || !s[e]) continue;
      Vec3 ls = loc(f, s[e]);
      if (ls[2] < 0) ls[2] = -ls[2];
      const Vec3& a = lv[e];
      const Vec3& b = lv[(e + 1) % 3];
      const Vec3& c = lv[(e + 2) % 3];
      const Vec3 u{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v{ls[0] - a[0], ls[1] - a[1], ls[2] - a[2]};
      const Vec3 n{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
      const double sc = (c[0] - a[0]) * n[0] + (c[1] - a[1]) * n[1] + (c[2] - a[2]) * n[2];
      if (!(sc != 0)) { bad = true; return; }
      planes.push_back({a, n, sc > 0 ? 1.0 : -1.0, ls, u, e, c});
    }
    if (!wl || !side) return;
    const double sgn = loc(f, side)[2] < 0 ? -1.0 : 1.0;
    for (const WallTri& w : *wl) {
      Wall k;
      for (int i = 0; i < 3; ++i) {
        k.v[i] = loc(f, &w[3 * i]);
        k.v[i][2] *= sgn;
      }
      const Vec3 u{k.v[1][0] - k.v[0][0], k.v[1][1] - k.v[0][1], k.v[1][2] - k.v[0][2]};
      const Vec3 v{k.v[2][0] - k.v[0][0], k.v[2][1] - k.v[0][1], k.v[2][2] - k.v[0][2]};
      k.n = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
      k.nn = std::sqrt(k.n[0] * k.n[0] + k.n[1] * k.n[1] + k.n[2] * k.n[2]);
      if (!(k.nn > 1e-12)) continue;
      k.zmin = std::min({k.v[0][2], k.v[1][2], k.v[2][2]});
      // A wall with no point above T's plane meets no open segment from g
      // upward (its points are at z > 0): leaving it out changes nothing.
      if (!(std::max({k.v[0][2], k.v[1][2], k.v[2][2]}) > 1e-9)) continue;
      for (int a = 0; a < 2; ++a) {
        k.lo[a] = std::min({k.v[0][a], k.v[1][a], k.v[2][a]});
        k.hi[a] = std::max({k.v[0][a], k.v[1][a], k.v[2][a]});
      }
      walls.push_back(k);
    }
    // Lowest first: a forbidden apex is usually found at the first wall.
    std::sort(walls.begin(), walls.end(), [](const Wall& a, const Wall& b) { return a.zmin < b.zmin; });
  }

  // Whether the open segment (g, x) meets wall k: it crosses the wall's
  // plane clear by 1e-9 longest edges at both ends, at a point of the wall
  // closed and grown by 1e-9 across its edges.  Closed, because a kept
  // edge or vertex is in the mesh's skeleton too (no tet holds one inside),
  // and grown, so that a segment through the edge two walls share is not
  // let through by rounding (a search finds such cracks); what the growth
  // forbids beyond a wall's free edge is a sliver whose apexes have
  // neighbours as good outside it (alpha is continuous).
  // (Former test: strictly inside by 1e-9, which let those cracks through.)
  bool hits(const Wall& k, const Vec3& x) const {
    constexpr double eps = 1e-9;
    auto dot = [](const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    const Vec3 ga{g[0] - k.v[0][0], g[1] - k.v[0][1], g[2] - k.v[0][2]};
    const Vec3 xa{x[0] - k.v[0][0], x[1] - k.v[0][1], x[2] - k.v[0][2]};
    const double sa = dot(k.n, ga) / k.nn, sb = dot(k.n, xa) / k.nn;
    if (!((sa > eps && sb < -eps) || (sa < -eps && sb > eps))) return false;
    const double t = sa / (sa - sb);
    const Vec3 y{g[0] + t * (x[0] - g[0]), g[1] + t * (x[1] - g[1]), g[2] + t * (x[2] - g[2])};
    for (int i = 0; i < 3; ++i) {
      const Vec3& a = k.v[i];
      const Vec3& b = k.v[(i + 1) % 3];
      const Vec3 ab{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ay{y[0] - a[0], y[1] - a[1], y[2] - a[2]};
      const Vec3 c{ab[1] * ay[2] - ab[2] * ay[1], ab[2] * ay[0] - ab[0] * ay[2], ab[0] * ay[1] - ab[1] * ay[0]};
      if (!(dot(c, k.n) > -eps * k.nn * std::sqrt(dot(ab, ab)))) return false;
    }
    return true;
  }

  // The point where the segment from g toward x first leaves the allowed
  // set (x itself when it is allowed): g + t (x - g) for the smallest t at
  // which it crosses a wall or a wedge plane, pulled back by 1e-9 so the
  // segment to it crosses nothing.  The set is star-shaped from g (a prefix
  // of an allowed segment is allowed; g lies inside every wedge), so this
  // is a point of it: maximising alpha at proj(x) over x maximises over
  // the set, on a continuous objective the searches handle better than a
  // cliff.  False when x is below T's plane.
  bool proj(Vec3& x) const {
    if (!(x[2] >= 0)) return false;
    double t = 1;
    for (const Plane& pl : planes) {
      const double vx = ((x[0] - pl.o[0]) * pl.n[0] + (x[1] - pl.o[1]) * pl.n[1] + (x[2] - pl.o[2]) * pl.n[2]) * pl.sign;
      if (vx >= 0) continue;
      const double vg = ((g[0] - pl.o[0]) * pl.n[0] + (g[1] - pl.o[1]) * pl.n[1] + (g[2] - pl.o[2]) * pl.n[2]) * pl.sign;
      if (!(vg > 0)) return false;
      t = std::min(t, vg / (vg - vx));
    }
    Vec3 y{g[0] + t * (x[0] - g[0]), g[1] + t * (x[1] - g[1]), g[2] + t * (x[2] - g[2])};
    for (const Wall& k : walls) {
      if (k.zmin >= y[2]) break;
      const double lo0 = std::min(g[0], y[0]), hi0 = std::max(g[0], y[0]);
      const double lo1 = std::min(g[1], y[1]), hi1 = std::max(g[1], y[1]);
      if (k.hi[0] < lo0 || k.lo[0] > hi0 || k.hi[1] < lo1 || k.lo[1] > hi1) continue;
      if (!hits(k, y)) continue;
      const Vec3 ga{g[0] - k.v[0][0], g[1] - k.v[0][1], g[2] - k.v[0][2]};
      const Vec3 ya{y[0] - k.v[0][0], y[1] - k.v[0][1], y[2] - k.v[0][2]};
      const double sa = k.n[0] * ga[0] + k.n[1] * ga[1] + k.n[2] * ga[2];
      const double sb = k.n[0] * ya[0] + k.n[1] * ya[1] + k.n[2] * ya[2];
      const double u = std::max(0.0, sa / (sa - sb) - 1e-9);
      for (int i = 0; i < 3; ++i) y[i] = g[i] + u * (y[i] - g[i]);
    }
    x = y;
    return x[2] > 0;
  }

  bool ok(const Vec3& x) const {
    const double tol = 1e-12;
    if (!(x[2] >= 0)) return false;
    for (const Plane& pl : planes)
      if (((x[0] - pl.o[0]) * pl.n[0] + (x[1] - pl.o[1]) * pl.n[1] + (x[2] - pl.o[2]) * pl.n[2]) * pl.sign < -tol)
        return false;
    const double lo0 = std::min(g[0], x[0]), hi0 = std::max(g[0], x[0]);
    const double lo1 = std::min(g[1], x[1]), hi1 = std::max(g[1], x[1]);
    for (const Wall& k : walls) {
      if (k.zmin >= x[2]) break;  // the segment stays below this wall and every later one
      if (k.hi[0] < lo0 || k.lo[0] > hi0 || k.hi[1] < lo1 || k.lo[1] > hi1) continue;  // apart in x or y
      if (hits(k, x)) return false;
    }
    return true;
  }
};

// The highest alpha of a tet on (p, q, r) with its apex allowed by c (see
// SideConstraint), searched like best_apex: starts from the grid, the
// closed-form candidates, points of each wedge, layers below the walls and
// `start` (an allowed apex, world, or null), then Nelder–Mead and compass.
// light: a lighter search (a 7^3 grid, three starts, shorter runs) for the
// walled sides, which are many in raw meshes of thin parts.
// best_at: the apex reaching the value (local; null: not wanted); start_local:
// another start, local.
double constrained_best_alpha(const Frame& f, const SideConstraint& c, const double* start, bool light = false,
                              Vec3* best_at = nullptr, const Vec3* start_local = nullptr) {
  const ApexMeasure g0{f, ApexObjective::Alpha};
  // With walls the objective is alpha at the point proj gives (a point of
  // the allowed set); with wedges only, a cliff outside them (as before).
  const bool walled = !c.walls.empty();
  auto g = [&](const Vec3& x) {
    if (walled) {
      Vec3 y = x;
      if (!c.proj(y)) return -std::numeric_limits<double>::infinity();
      return g0(y);
    }
    if (!c.ok(x)) return -std::numeric_limits<double>::infinity();
    return g0(x);
  };
  std::vector<std::pair<double, Vec3>> starts;
  for (const SideConstraint::Plane& pl : c.planes) starts.push_back({g(pl.ls), pl.ls});
  for (const Vec3& p : candidates(f)) starts.push_back({g(p), p});
  if (start) {
    Vec3 x = SideConstraint::loc(f, start);
    x[2] = std::fabs(x[2]);
    starts.push_back({g(x), x});
  }
  if (start_local) starts.push_back({g(*start_local), *start_local});
  const double x0 = std::min(0.0, f.cx) - 0.3, x1 = std::max(f.bx, f.cx) + 0.3;
  const double y0 = -0.5, y1 = f.cy + 0.6;
  const int kN = light ? 7 : 11;
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j)
      for (int k = 0; k < kN; ++k) {
        const Vec3 x{x0 + (x1 - x0) * i / (kN - 1), y0 + (y1 - y0) * j / (kN - 1), 0.01 + 1.19 * k / (kN - 1)};
        starts.push_back({g(x), x});
      }
  if (c.wall_h > 0) {
    // Layers at the walls' scale: a thin slab holds few grid points, and
    // where the facing wall curves or tilts away the best apexes lie beside
    // the triangle, up to a few times higher than above its centroid.
    constexpr int kW = 15;
    for (double fr : {0.25, 0.5, 0.75, 0.95, 1.25, 1.5, 2.0, 2.5, 3.0})
      for (int i = 0; i < kW; ++i)
        for (int j = 0; j < kW; ++j) {
          const Vec3 x{x0 + (x1 - x0) * i / (kW - 1), y0 + (y1 - y0) * j / (kW - 1), fr * c.wall_h};
          starts.push_back({g(x), x});
        }
  }
  // Points of each wedge near its edge at every depth: the search box of a
  // thin wedge holds few grid points.
  for (const SideConstraint::Plane& pl : c.planes) {
    const Vec3& a = pl.o;
    const Vec3& cc = pl.c3;
    for (int i = 1; i < kN; ++i)
      for (int j = 1; j < kN; ++j) {
        const double ta = static_cast<double>(i) / kN, tb = static_cast<double>(j) / kN;
        Vec3 x;
        for (int k = 0; k < 3; ++k) x[k] = a[k] + ta * pl.u[k] + tb * (cc[k] - a[k] + pl.ls[k] - a[k]) / 2;
        starts.push_back({g(x), x});
      }
  }
  const size_t k = std::min<size_t>(light ? 3 : 6, starts.size());
  std::partial_sort(starts.begin(), starts.begin() + static_cast<std::ptrdiff_t>(k), starts.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  double best = starts[0].first;
  Vec3 bx = starts[0].second;
  for (size_t i = 0; i < k; ++i) {
    if (!(starts[i].first > -std::numeric_limits<double>::infinity())) continue;
    Vec3 x = starts[i].second;
    double fx = nelder_mead(g, x, 0.05, light ? 300 : 600);
    fx = std::max(fx, nelder_mead(g, x, 0.005, light ? 200 : 400));
    fx = compass(g, x, fx, 1e-3, 1e-10, light ? 600 : 3000);
    if (fx > best) { best = fx; bx = x; }
  }
  if (walled) c.proj(bx);  // the point reaching the value
  if (best_at) *best_at = bx;
  return std::max(best, 0.0);
}

}  // namespace

double wedges_best_alpha(const double* p, const double* q, const double* r, const double* const s[3]) {
  const Frame f(p, q, r);
  if (f.degenerate) return 0;
  const SideConstraint c(f, p, q, r, s, nullptr, nullptr);
  if (c.bad) return 0;
  return constrained_best_alpha(f, c, nullptr);
}

namespace {

// Constrained triangles, each once: packed face 4t+f of its first tet.
std::vector<int32_t> constrained_faces(const TetMesh& m, int threads) {
  std::vector<int32_t> out;
  // Per-block lists joined in block order: the serial list.
  for (const auto& part : detail::parallel_map_blocks(m.nt(), threads, [&](int64_t b, int64_t e) {
         std::vector<int32_t> o;
         for (int64_t i = b; i < e; ++i) {
           const auto t = static_cast<int32_t>(i);
           const uint8_t mask = m.face_mask[t];
           if (!mask) continue;
           for (int f = 0; f < 4; ++f) {
             if (!(mask & (1u << f))) continue;
             const int32_t nb = m.adj[4 * static_cast<size_t>(t) + f];
             if (nb >= 0 && (nb >> 2) < t) continue;  // counted from the other tet
             o.push_back(4 * t + f);
           }
         }
         return o;
       }))
    out.insert(out.end(), part.begin(), part.end());
  return out;
}

void face_points(const TetMesh& m, int32_t packed, const double* p[3]) {
  const int32_t t = packed >> 2, f = packed & 3;
  const int32_t* v = m.tet(t);
  for (int k = 0; k < 3; ++k) p[k] = m.point(v[kFaceVertex[f][k]]);
}

// Quality of the tets standing on a face (achieved values, so lower bounds on
// the best apex): the larger over the face's one or two tets.
void achieved_on_face(const TetMesh& m, int32_t packed, double& a_best, double& dmin_best, double& dmax_best) {
  a_best = -1;
  dmin_best = 0;
  dmax_best = 180;
  const int32_t nb = m.adj[static_cast<size_t>(packed)];
  for (int32_t t : {packed >> 2, nb >= 0 ? nb >> 2 : -1}) {
    if (t < 0) continue;
    const int32_t* v = m.tet(t);
    const double *a = m.point(v[0]), *b = m.point(v[1]), *c = m.point(v[2]), *d = m.point(v[3]);
    const double q = alpha(a, b, c, d);
    if (q <= 0) continue;
    double lo_deg, hi_deg;
    dihedral_extremes(a, b, c, d, lo_deg, hi_deg);
    a_best = std::max(a_best, q);
    dmin_best = std::max(dmin_best, lo_deg);
    dmax_best = std::min(dmax_best, hi_deg);
  }
}

// Wedges at the edges of a constrained face, on the side of the tet of
// `packed` (4t+f; issue 27, item 2).  Around each edge of the face, on that
// side, the tets reach the next constrained face (domain boundary, region
// interface or listed triangle), found by walking through them.  No tet of
// any mesh keeping both faces crosses either, so the tet on this side of
// the face lies inside the wedge between them: where that wedge is convex
// (the next face's far vertex s lies on this side of the face) and narrower
// than kWedgeDeg, its apex is on this face's side of the next face's plane.
// s[e] is that far vertex for edge e of face_points' order ((p0, p1),
// (p1, p2), (p2, p0)), nullptr elsewhere; the count is returned.
// Non-manifold walks and reflex edges get none (the bound stays the
// triangle's own there).  kWedgeDeg: wedges wider
// than this never bind an apex good enough to matter (a regular tet's
// dihedral angle is 70.5 degrees), and leaving them out only loosens the
// bound.
constexpr double kWedgeDeg = 150.0;

int face_wedges(const TetMesh& m, int32_t packed, const double* s[3], int32_t* other = nullptr) {
  s[0] = s[1] = s[2] = nullptr;
  if (other) other[0] = other[1] = other[2] = -1;
  const int32_t t0 = packed >> 2;
  const int f = packed & 3;
  const int32_t* tv = m.tet(t0);
  int32_t fv[3];
  for (int k = 0; k < 3; ++k) fv[k] = tv[kFaceVertex[f][k]];
  const double* apex = m.point(tv[f]);
  const Sign inside = orient3d(m.point(fv[0]), m.point(fv[1]), m.point(fv[2]), apex);
  if (inside == Sign::Zero) return 0;
  int n = 0;
  for (int e = 0; e < 3; ++e) {
    const int32_t x = fv[e], y = fv[(e + 1) % 3], z = fv[(e + 2) % 3];
    // Walk around edge (x, y) from t0: cross the face opposite `opp`, whose
    // third vertex is `far`, until a face with no tet beyond.
    int32_t cur = t0, opp = z, far = tv[f];
    int32_t found = -1, found_side = -1;
    for (int step = 0; step < 256; ++step) {
      const int32_t* cv = m.tet(cur);
      int k = 0;
      while (k < 4 && cv[k] != opp) ++k;
      if (k == 4) break;
      const int32_t nb = m.adj[4 * static_cast<size_t>(cur) + static_cast<size_t>(k)];
      if (nb < 0 || (!m.face_mask.empty() && (m.face_mask[cur] & (1u << k)))) {
        found = far;  // the next constrained face around the edge
        found_side = 4 * cur + k;
        break;
      }
      const int32_t next = nb >> 2;
      if (next == t0) break;  // closed ring: not a boundary edge after all
      const int32_t u = m.tet(next)[nb & 3];
      opp = far;
      far = u;
      cur = next;
    }
    if (found < 0) continue;
    const double* sp = m.point(found);
    if (orient3d(m.point(fv[0]), m.point(fv[1]), m.point(fv[2]), sp) != inside) continue;  // reflex or flat
    if (!(edge_dihedral_deg(m.point(x), m.point(y), m.point(z), sp) < kWedgeDeg)) continue;
    s[e] = sp;
    if (other) other[e] = found_side;
    ++n;
  }
  return n;
}

// Two kept triangles T and S that share an edge, consecutive around it on
// one side (S is the next kept face met walking around the edge from T's
// tet; face_wedges), at an angle phi (degrees) there.  The tet on T and the
// tet on S are either one tet (T plus S's far vertex: its alpha is fixed) or
// two tets of the edge's shell whose dihedral angles at the edge add up to
// at most phi: T's apex lies within theta of T's plane and S's within
// phi - theta of S's (issue 27: "the bound should get tighter where a pair
// of constrained faces provably forces something").  So any mesh keeping
// both has min(alpha on T, alpha on S) <= max(alpha of the one tet,
// max over theta of min(f_T(theta), f_S(phi - theta))), f_X(theta) the best
// alpha of X's apex in X's wedges with the one at the shared edge narrowed
// to theta (wedges_best_alpha).  f_T rises with theta and f_S(phi - theta)
// falls: the maximum of their minimum is found by bisection on theta.
// t[3], u[3]: T's and S's points; et, eu: the shared edge's index in each
// ((t[et], t[et + 1]), likewise for u); tw, uw: their wedges (the far points
// of face_wedges, nullptr for none); the entries at et and eu are replaced.
// Returns early (the value then is only a lower estimate) once a value at
// or above `enough` is found: the caller needs the pair only below it.
constexpr int kPairSteps = 12;
double pair_best_alpha(const double* const t[3], int et, const double* const tw[3], const double* const u[3], int eu,
                       const double* const uw[3], double enough) {
  const double* x = t[et];
  const double* y = t[(et + 1) % 3];
  const double* r = t[(et + 2) % 3];
  const double* far = u[(eu + 2) % 3];
  const double phi = edge_dihedral_deg(x, y, r, far);
  if (!(phi > 0 && phi < 179.0)) return INFINITY;  // flat or reflex: no pair limit taken
  // The point at angle theta from the plane of (x, y, a) toward b, around
  // the edge, at the edge's length from its midpoint.
  auto rotated = [&](const double* a, const double* b, double theta, double* out) {
    double e[3], pa[3], pb[3];
    for (int k = 0; k < 3; ++k) { e[k] = y[k] - x[k]; pa[k] = a[k] - x[k]; pb[k] = b[k] - x[k]; }
    const double ee = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    for (double& c : e) c /= ee;
    const double ka = pa[0] * e[0] + pa[1] * e[1] + pa[2] * e[2], kb = pb[0] * e[0] + pb[1] * e[1] + pb[2] * e[2];
    for (int k = 0; k < 3; ++k) { pa[k] -= ka * e[k]; pb[k] -= kb * e[k]; }
    const double la = std::sqrt(pa[0] * pa[0] + pa[1] * pa[1] + pa[2] * pa[2]);
    for (double& c : pa) c /= la;
    const double c0 = pb[0] * pa[0] + pb[1] * pa[1] + pb[2] * pa[2];
    double nb[3];
    for (int k = 0; k < 3; ++k) nb[k] = pb[k] - c0 * pa[k];
    const double ln = std::sqrt(nb[0] * nb[0] + nb[1] * nb[1] + nb[2] * nb[2]);
    for (double& c : nb) c /= ln;
    const double th = theta * 0.017453292519943295;
    for (int k = 0; k < 3; ++k) out[k] = x[k] + 0.5 * ee * e[k] + ee * (std::cos(th) * pa[k] + std::sin(th) * nb[k]);
  };
  auto f = [&](const double* const p[3], int ep, const double* const w[3], const double* a, const double* b,
               double theta) {
    double q[3];
    rotated(a, b, theta, q);
    const double* ws[3] = {w[0], w[1], w[2]};
    ws[ep] = q;
    return wedges_best_alpha(p[0], p[1], p[2], ws);
  };
  // The one tet on both faces (either orientation: alpha of the positive one).
  const double one = std::max({alpha(t[0], t[1], t[2], far), alpha(t[0], t[2], t[1], far), 0.0});
  double best = one;
  double lo = 0, hi = phi;
  for (int step = 0; step < kPairSteps; ++step) {
    const double th = step == 0 ? phi / 2 : (lo + hi) / 2;
    const double a = f(t, et, tw, r, far, th);
    const double b = f(u, eu, uw, far, r, phi - th);
    best = std::max(best, std::min(a, b));
    if (best >= enough) break;
    if (a < b) lo = th; else hi = th;
  }
  return best;
}

// The bound's searches made ahead in parallel (lower_by_pairs, and the
// wedged and walled sides in mesh_bound_impl) go in batches of this many
// per thread: larger batches search more that the running bound would have
// cut short.
constexpr size_t kAheadPerThread = 4;

// The pairs of side `side` with the kept face beside it at each of its
// sharp edges (face_wedges), for lower_by_pairs: a pair's bound is at least
// its two tets' alpha now (the mesh itself keeps both faces), so a pair
// whose tets are at `above` or better is left out.
struct PairTask {
  const double* tp[3];
  const double* tw[3];
  const double* up[3];
  const double* uw[3];
  int e = 0, eu = 0;
  double now = 0;    // the two tets' alpha now
  double value = 0;  // max(now, pair_best_alpha), once searched
  size_t face = 0;   // the index of the wedged face it came from
};
void pair_tasks(const TetMesh& m, int32_t side, size_t face, double above, std::vector<PairTask>& out) {
  const double* tw[3];
  int32_t other[3];
  if (face_wedges(m, side, tw, other) == 0) return;
  const double* tp[3];
  face_points(m, side, tp);
  for (int e = 0; e < 3; ++e) {
    if (other[e] < 0) continue;
    PairTask task;
    face_points(m, other[e], task.up);
    face_wedges(m, other[e], task.uw);
    int eu = -1;  // the shared edge in the other face
    for (int k = 0; k < 3; ++k)
      if ((task.up[k] == tp[e] && task.up[(k + 1) % 3] == tp[(e + 1) % 3]) ||
          (task.up[k] == tp[(e + 1) % 3] && task.up[(k + 1) % 3] == tp[e]))
        eu = k;
    if (eu < 0) continue;
    task.now = std::min(tet_alpha(m, side >> 2), tet_alpha(m, other[e] >> 2));
    if (task.now >= above) continue;
    for (int k = 0; k < 3; ++k) { task.tp[k] = tp[k]; task.tw[k] = tw[k]; }
    task.e = e;
    task.eu = eu;
    task.face = face;
    out.push_back(task);
  }
}

// Lowers `cur` to the pair bounds (pair_best_alpha) of the given wedged
// faces' sides, each where it is below cur - tol; returns the index of the
// face whose pair set it last (or SIZE_MAX).  The searches run in parallel
// batches, each stopping once it reaches the bound at its batch's start:
// pair_best_alpha's steps do not depend on where it stops, so a search that
// the running bound (lower) would have stopped earlier still ends at or
// above that bound, and one that runs to the end returns the same value at
// either stop.  The tasks are then taken in order as one loop would take
// them: the bound is the same, bit for bit, for every thread count
// (plate_stack.geo, thin plates with many sharp edges, spent 0.6 s of a
// 2.9 s insertion run in these searches on one busy thread).
size_t lower_by_pairs(const TetMesh& m, const std::vector<int32_t>& faces, const std::vector<size_t>& paired,
                      double tol, int threads, double& cur) {
  std::vector<PairTask> tasks;
  for (const size_t i : paired)
    for (const int32_t side : {faces[i], m.adj[static_cast<size_t>(faces[i])]})
      if (side >= 0) pair_tasks(m, side, i, cur - tol, tasks);
  // In batches of a few per thread: the bound falls fast over the first
  // pairs, and a search stops sooner the lower it is (one batch of all
  // of them, each stopping only at the bound from before, took 5.1 s of
  // `tetopt quality` on plate_stack where the loop took 1.4 s).
  const int nth = detail::resolve_threads(threads);
  const size_t batch = nth > 1 ? kAheadPerThread * static_cast<size_t>(nth) : 1;
  size_t arg = SIZE_MAX;
  for (size_t b = 0; b < tasks.size(); b += batch) {
    const size_t e = std::min(tasks.size(), b + batch);
    const double enough = cur - tol;
    detail::parallel_items(static_cast<int64_t>(e - b), nth, [&](int64_t k) {  // one task each
      PairTask& t = tasks[b + static_cast<size_t>(k)];
      t.value = t.now < enough ? std::max(t.now, pair_best_alpha(t.tp, t.e, t.tw, t.up, t.eu, t.uw, enough)) : t.now;
    });
    for (size_t k = b; k < e; ++k) {
      const PairTask& t = tasks[k];
      if (t.now >= cur - tol) continue;
      if (t.value < cur - tol) {
        cur = t.value;
        arg = t.face;
      }
    }
  }
  return arg;
}

// Walls facing one side of a kept face (issue 27: a wall one tet thick).
// First a straight walk from T's centroid along its normal into the side,
// through the tets, to the first kept face (or the domain's boundary): its
// distance h.  Only when h < kThinRatio longest edges of T may a wall cap
// the apex (the best apex of a fair triangle is about 0.8 longest edges
// high), and only then are the kept faces around collected: a walk through
// the tets of that side (never across a kept face) within kWallReach
// longest edges of the centroid, every kept face met on the way a wall.
// Both walks are only a choice of which kept triangles to test: any subset
// of them gives a valid bound (fewer walls: a looser one), so rounding in
// the walks cannot make the bound wrong.
constexpr double kThinRatio = 1.0;
constexpr double kWallReach = 3.5;
constexpr int kWallTets = 4000;

double side_centroid_normal(const TetMesh& m, int32_t side, double g[3], double dir[3], double& scale) {
  const double* p[3];
  face_points(m, side, p);
  double u[3], v[3], n[3];
  for (int k = 0; k < 3; ++k) { u[k] = p[1][k] - p[0][k]; v[k] = p[2][k] - p[0][k]; g[k] = (p[0][k] + p[1][k] + p[2][k]) / 3; }
  n[0] = u[1] * v[2] - u[2] * v[1];
  n[1] = u[2] * v[0] - u[0] * v[2];
  n[2] = u[0] * v[1] - u[1] * v[0];
  const double ln = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  auto d2 = [](const double* a, const double* b) {
    return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
  };
  scale = std::sqrt(std::max({d2(p[0], p[1]), d2(p[1], p[2]), d2(p[2], p[0])}));
  if (!(ln > 0)) return 0;
  const double* apex = m.point(m.tet(side >> 2)[side & 3]);
  double dn = 0;
  for (int k = 0; k < 3; ++k) dn += (apex[k] - p[0][k]) * n[k];
  const double sg = dn < 0 ? -1.0 : 1.0;
  for (int k = 0; k < 3; ++k) dir[k] = sg * n[k] / ln;
  return ln;
}

// The straight walk: distance from the centroid along the normal to the
// first kept face, +inf when beyond `limit` or the walk fails.
double normal_wall_height(const TetMesh& m, int32_t side, double limit) {
  double g[3], dir[3], scale;
  if (!(side_centroid_normal(m, side, g, dir, scale) > 0)) return INFINITY;
  int32_t cur = side >> 2, entry = side & 3;
  for (int step = 0; step < 64; ++step) {
    const int32_t* cv = m.tet(cur);
    int exit = -1;
    double te = INFINITY;
    for (int k = 0; k < 4; ++k) {
      if (k == entry) continue;
      const double *a = m.point(cv[kFaceVertex[k][0]]), *b = m.point(cv[kFaceVertex[k][1]]),
                   *c = m.point(cv[kFaceVertex[k][2]]), *o = m.point(cv[k]);
      double u[3], v[3];
      for (int i = 0; i < 3; ++i) { u[i] = b[i] - a[i]; v[i] = c[i] - a[i]; }
      double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
      if ((o[0] - a[0]) * n[0] + (o[1] - a[1]) * n[1] + (o[2] - a[2]) * n[2] > 0)
        for (double& x : n) x = -x;
      const double den = n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2];
      if (!(den > 0)) continue;
      const double t = ((a[0] - g[0]) * n[0] + (a[1] - g[1]) * n[1] + (a[2] - g[2]) * n[2]) / den;
      if (t < te) { te = t; exit = k; }
    }
    if (exit < 0 || !(te < limit)) return INFINITY;
    const int32_t nb = m.adj[4 * static_cast<size_t>(cur) + static_cast<size_t>(exit)];
    if (nb < 0 || (!m.face_mask.empty() && (m.face_mask[cur] & (1u << exit)))) return std::max(te, 0.0);
    cur = nb >> 2;
    entry = nb & 3;
  }
  return INFINITY;
}

// The walls of side `side` (empty when the side is not thin); h: the
// normal walk's distance (+inf when not thin).
// verts (may be null): the vertices of the tets the walk visited (the
// apexes a mesh without new vertices can put on this side within reach).
void side_walls(const TetMesh& m, int32_t side, std::vector<WallTri>& walls, double& h, bool on = true,
                std::vector<int32_t>* verts = nullptr) {
  walls.clear();
  if (verts) verts->clear();
  double g[3], dir[3], scale;
  h = INFINITY;
  if (!on) return;
  if (m.adj.empty() || !(side_centroid_normal(m, side, g, dir, scale) > 0)) return;
  h = normal_wall_height(m, side, kThinRatio * scale);
  if (!std::isfinite(h)) return;
  const double reach2 = (kWallReach * scale) * (kWallReach * scale);
  auto near = [&](int32_t t) {
    const int32_t* v = m.tet(t);
    for (int k = 0; k < 4; ++k) {
      const double* x = m.point(v[k]);
      if ((x[0] - g[0]) * (x[0] - g[0]) + (x[1] - g[1]) * (x[1] - g[1]) + (x[2] - g[2]) * (x[2] - g[2]) <= reach2)
        return true;
    }
    return false;
  };
  std::vector<int32_t> stack{side >> 2};
  std::unordered_set<int32_t> seen{side >> 2};
  auto visited = [&](int32_t t) { return seen.count(t) > 0; };
  while (!stack.empty() && static_cast<int>(seen.size()) < kWallTets) {
    const int32_t t = stack.back();
    stack.pop_back();
    const int32_t* v = m.tet(t);
    for (int k = 0; k < 4; ++k) {
      if (4 * t + k == side) continue;
      const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(k)];
      if (nb < 0 || (!m.face_mask.empty() && (m.face_mask[t] & (1u << k)))) {
        WallTri w;
        for (int i = 0; i < 3; ++i) {
          const double* x = m.point(v[kFaceVertex[k][i]]);
          for (int c = 0; c < 3; ++c) w[3 * i + c] = x[c];
        }
        walls.push_back(w);
        continue;
      }
      const int32_t u = nb >> 2;
      if (visited(u) || !near(u)) continue;
      seen.insert(u);
      stack.push_back(u);
    }
  }
  if (verts) {
    for (const int32_t t : seen) verts->insert(verts->end(), m.tet(t), m.tet(t) + 4);
    std::sort(verts->begin(), verts->end());
    verts->erase(std::unique(verts->begin(), verts->end()), verts->end());
  }
}

// Whether the open segment (a, b) crosses the open triangle (p, q, r)
// (exact predicates; touching does not count).  Segments and triangles
// that share a point are never asked (the callers skip them).
bool segment_crosses_triangle(const double* a, const double* b, const double* p, const double* q, const double* r) {
  const Sign sa = orient3d(p, q, r, a), sb = orient3d(p, q, r, b);
  if (sa == Sign::Zero || sb == Sign::Zero || sa == sb) return false;
  const Sign s0 = orient3d(a, b, p, q), s1 = orient3d(a, b, q, r), s2 = orient3d(a, b, r, p);
  return s0 != Sign::Zero && s0 == s1 && s1 == s2;
}

bool same_point(const double* a, const double* b) { return a[0] == b[0] && a[1] == b[1] && a[2] == b[2]; }

// Whether tet (v[0..3]) and kept triangle w cross: an edge of one through
// the other's open face (exact).  A conforming mesh keeping w has no such
// tet (its edges and faces meet w only in w's edges and vertices), so a
// candidate apex that makes one is impossible; missing other contacts only
// loosens the bound.
bool tet_crosses_wall(const double* const v[4], const WallTri& w) {
  const double* wv[3] = {&w[0], &w[3], &w[6]};
  auto shares = [&](const double* x) { return same_point(x, wv[0]) || same_point(x, wv[1]) || same_point(x, wv[2]); };
  static constexpr int kE[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (const auto& e : kE)
    if (!shares(v[e[0]]) && !shares(v[e[1]]) && segment_crosses_triangle(v[e[0]], v[e[1]], wv[0], wv[1], wv[2]))
      return true;
  for (int i = 0; i < 3; ++i) {
    const double *a = wv[i], *b = wv[(i + 1) % 3];
    for (int f = 0; f < 4; ++f) {
      const double* fv[3] = {v[kFaceVertex[f][0]], v[kFaceVertex[f][1]], v[kFaceVertex[f][2]]};
      bool sh = false;
      for (const double* x : fv) sh = sh || same_point(x, a) || same_point(x, b);
      if (!sh && segment_crosses_triangle(a, b, fv[0], fv[1], fv[2])) return true;
    }
  }
  return false;
}

// SideBound::vertex_alpha: the best alpha of the tet on side `side` with its
// apex at one of `verts` (side_walls' visited vertices) allowed by the same
// constraint as walled_side_best's apexes (inside the wedges s, the open
// segment from the centroid clear of the walls), at least the side's own
// tet; *apex: that vertex.  NaN when a free vertex is among them (the wall
// already has vertices inside it, which can move).
double walled_side_vertex_best(const TetMesh& m, int32_t side, const double* const s[3],
                               const std::vector<WallTri>& walls, const std::vector<int32_t>& verts, int32_t* apex_out) {
  *apex_out = -1;
  if (m.vert_constrained.size() != static_cast<size_t>(m.nv())) return NAN;
  const double* p[3];
  face_points(m, side, p);
  const Frame f(p[0], p[1], p[2]);
  if (f.degenerate) return NAN;
  const int32_t* tv = m.tet(side >> 2);
  const int32_t own = tv[side & 3];
  const double* apex = m.point(own);
  const SideConstraint c(f, p[0], p[1], p[2], s, &walls, apex);
  if (c.bad) return NAN;
  const double sgn = SideConstraint::loc(f, apex)[2] < 0 ? -1.0 : 1.0;
  for (const int32_t v : verts)
    if (!m.vert_constrained[v]) return NAN;
  double best = std::max(0.0, tet_alpha(m, side >> 2));
  *apex_out = own;
  // Candidates above the side's own tet, best first; the first one whose
  // tet passes both tests (the centroid segment clear of the walls, no
  // crossing with a wall) is the value.
  std::vector<std::pair<double, int32_t>> cand;
  for (const int32_t v : verts) {
    bool on_face = false;
    for (int k = 0; k < 4; ++k)
      if (k != (side & 3) && tv[k] == v) on_face = true;
    if (on_face || v == own) continue;
    Vec3 x = SideConstraint::loc(f, m.point(v));
    x[2] *= sgn;
    if (!(x[2] > 0)) continue;
    const double a = std::fabs(alpha(p[0], p[1], p[2], m.point(v)));
    if (a > best) cand.push_back({a, v});
  }
  std::sort(cand.begin(), cand.end(), [](const auto& a, const auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); });
  for (const auto& [a, v] : cand) {
    Vec3 x = SideConstraint::loc(f, m.point(v));
    x[2] *= sgn;
    if (!c.ok(x)) continue;
    const double* tv4[4] = {p[0], p[1], p[2], m.point(v)};
    bool crosses = false;
    for (const WallTri& w : walls)
      if ((crosses = tet_crosses_wall(tv4, w))) break;
    if (crosses) continue;
    *apex_out = v;
    return a;
  }
  return best;
}

// The best alpha of side `side` with its apex inside the wedges s (may be
// all null) and clear of the walls.  The side's bound without the walls
// (the wedges' search, or best_apex) is found first: when its apex is clear
// of the walls the walls do not bind and that value stands (walled = false);
// otherwise the search with the walls, from the side's own tet and that
// apex.
double walled_side_best(const TetMesh& m, int32_t side, const double* const s[3], const std::vector<WallTri>& walls,
                        double h, bool& walled) {
  walled = false;
  const double* p[3];
  face_points(m, side, p);
  const Frame f(p[0], p[1], p[2]);
  if (f.degenerate) return 0;
  const double* apex = m.point(m.tet(side >> 2)[side & 3]);
  const SideConstraint free_c(f, p[0], p[1], p[2], s, nullptr, nullptr);
  SideConstraint c(f, p[0], p[1], p[2], s, &walls, apex);
  if (c.bad || free_c.bad) return 0;
  c.wall_h = h / f.scale;
  Vec3 at{};
  double open;
  if (!free_c.planes.empty()) {
    open = constrained_best_alpha(f, free_c, nullptr, false, &at);
  } else {
    const ApexResult r = best_apex(p[0], p[1], p[2], ApexObjective::Alpha);
    open = r.value;
    at = SideConstraint::loc(f, r.apex);
    at[2] = std::fabs(at[2]);
  }
  if (c.ok(at)) return open;
  const double v = std::max(constrained_best_alpha(f, c, apex, false, nullptr, &at), std::max(0.0, tet_alpha(m, side >> 2)));
  // Within the searches' exactness (1e-4, diagnose.hpp) of the side's own
  // bound the walls are not said to bind, and that bound stands.
  walled = v < open - 1e-4;
  return walled ? v : open;
}

// A cheap achieved value for a walled side: its tet, and the closed-form
// candidates (also at 0.9 h above their base points) that the constraint
// allows.
double walled_side_cheap(const TetMesh& m, int32_t side, const double* const s[3], const std::vector<WallTri>& walls,
                         double h) {
  double best = std::max(0.0, tet_alpha(m, side >> 2));
  const double* p[3];
  face_points(m, side, p);
  const Frame f(p[0], p[1], p[2]);
  if (f.degenerate) return best;
  const double* apex = m.point(m.tet(side >> 2)[side & 3]);
  const SideConstraint c(f, p[0], p[1], p[2], s, &walls, apex);
  if (c.bad) return best;
  const ApexMeasure g0{f, ApexObjective::Alpha};
  for (const Vec3& x : candidates(f)) {
    if (c.ok(x)) best = std::max(best, g0(x));
    const Vec3 y{x[0], x[1], 0.9 * h / f.scale};
    if (c.ok(y)) best = std::max(best, g0(y));
  }
  return best;
}

// A cheap achieved alpha of the tet on side `packed` of a constrained face:
// the largest over that side's tet and the closed-form candidate apexes
// that lie inside the side's wedges s (face_wedges; every candidate when it
// has none).  At most the side's best, so it may prune the full search.
double side_cheap_alpha(const TetMesh& m, int32_t packed, const double* const s[3]) {
  const double* p[3];
  face_points(m, packed, p);
  double best = std::max(0.0, tet_alpha(m, packed >> 2));
  const Frame f(p[0], p[1], p[2]);
  if (f.degenerate) return best;
  const bool nw = s[0] || s[1] || s[2];
  // The side of the tet's apex, in the frame's normal direction.
  const double* apex = m.point(m.tet(packed >> 2)[packed & 3]);
  double dn = 0;
  for (int k = 0; k < 3; ++k) dn += (apex[k] - f.origin[k]) * f.n[k];
  const double sgn = dn < 0 ? -1.0 : 1.0;
  double nrm[3][3], third[3];
  for (int e = 0; e < 3; ++e) {
    if (!s[e]) continue;
    const double *a = p[e], *b = p[(e + 1) % 3], *c = p[(e + 2) % 3];
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {s[e][0] - a[0], s[e][1] - a[1], s[e][2] - a[2]};
    nrm[e][0] = u[1] * v[2] - u[2] * v[1];
    nrm[e][1] = u[2] * v[0] - u[0] * v[2];
    nrm[e][2] = u[0] * v[1] - u[1] * v[0];
    third[e] = (c[0] - a[0]) * nrm[e][0] + (c[1] - a[1]) * nrm[e][1] + (c[2] - a[2]) * nrm[e][2];
  }
  for (const Vec3& c : candidates(f)) {
    double w[3];
    for (int k = 0; k < 3; ++k) w[k] = f.origin[k] + f.scale * (c[0] * f.e1[k] + c[1] * f.e2[k] + sgn * c[2] * f.n[k]);
    bool inside = true;
    for (int e = 0; e < 3 && inside && nw; ++e) {
      if (!s[e]) continue;
      const double* a = p[e];
      const double val = (w[0] - a[0]) * nrm[e][0] + (w[1] - a[1]) * nrm[e][1] + (w[2] - a[2]) * nrm[e][2];
      // Strictly inside, with a margin for rounding: the value is achieved.
      inside = val * third[e] > 0 && std::fabs(val) > 1e-9 * std::fabs(third[e]);
    }
    if (inside) best = std::max(best, std::fabs(alpha(p[0], p[1], p[2], w)));
  }
  return best;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

namespace {

// The best alpha of the tet on one side of a constrained face: `side` is
// the packed face (4t+f) of that side's tet t.  Inside the wedges of its
// sharp edges on that side (face_wedges), else the triangle's own (cached
// by shape when cache is given; no cache: thread-safe).
// `by_shape` (when given) says whether the value came from the plain
// triangle's best apex, which `cache` memoises by shape.
double side_best(const TetMesh& m, int32_t side,
                 std::unordered_map<std::pair<int64_t, int64_t>, double, PairHash>* cache, SideBound* info = nullptr,
                 bool walls_on = true, bool* by_shape = nullptr) {
  if (by_shape) *by_shape = false;
  const double* p[3];
  face_points(m, side, p);
  const double* s[3];
  const bool wedged = face_wedges(m, side, s) > 0;
  std::vector<WallTri> walls;
  std::vector<int32_t> verts;
  double h;
  side_walls(m, side, walls, h, walls_on, info ? &verts : nullptr);
  if (info) {
    info->wedged = wedged;
    info->walled = false;
    info->wall_distance = NAN;
    info->vertex_alpha = NAN;
    info->vertex_apex = -1;
  }
  if (!walls.empty()) {
    bool walled;
    const double v = walled_side_best(m, side, wedged ? s : nullptr, walls, h, walled);
    if (info && walled) {
      info->walled = true;
      info->wall_distance = h;
      const double va = walled_side_vertex_best(m, side, wedged ? s : nullptr, walls, verts, &info->vertex_apex);
      if (!std::isnan(va)) info->vertex_alpha = std::min(v, va);
    }
    return v;
  }
  if (wedged) return wedges_best_alpha(p[0], p[1], p[2], s);
  if (by_shape) *by_shape = true;
  std::pair<int64_t, int64_t> key;
  if (!shape_key(Frame(p[0], p[1], p[2]), key)) return 0;  // degenerate
  if (cache)
    if (const auto it = cache->find(key); it != cache->end()) return it->second;
  const double v = best_apex(p[0], p[1], p[2], ApexObjective::Alpha).value;
  if (cache) cache->emplace(key, v);
  return v;
}

// Whether side `side` is thin (its normal walk meets a kept face within
// kThinRatio longest edges): then side_walls collects walls for it.
bool side_thin(const TetMesh& m, int32_t side, bool on = true) {
  if (!on) return false;
  double g[3], dir[3], scale;
  if (m.adj.empty() || !(side_centroid_normal(m, side, g, dir, scale) > 0)) return false;
  return std::isfinite(normal_wall_height(m, side, kThinRatio * scale));
}

// MeshBound::below_at_least.  cheap: each face's achieved alpha, at most
// the best of each of its sides; cache: best alpha by triangle shape, as the
// bound's own search filled it.
// Sides already searched (side_best's value by packed side), shared by the
// diagnosis, the bound's search and the count floor: walled sides are
// searched once (not cached by shape, and each costs milliseconds).
using SideCache = std::unordered_map<int32_t, SideBound>;

std::array<int64_t, 3> count_bound(const TetMesh& m, const std::vector<int32_t>& faces, const SideCache& known,
                                   const std::vector<double>& cheap,
                                   std::unordered_map<std::pair<int64_t, int64_t>, double, PairHash>& cache,
                                   int threads, bool walls_on) {
  constexpr double kTol = 1e-4;  // the alpha search's exactness (diagnose.hpp)
  const double top = kCountThresholds.back();
  // The sides of the faces whose cheap value leaves them in doubt, each
  // searched in full: a side is the packed face of the tet on it.
  std::vector<int32_t> sides;
  std::vector<double> lo;  // each side's face's cheap value: at most its best
  for (size_t i = 0; i < faces.size(); ++i) {
    if (!(cheap[i] < top - kTol)) continue;
    const int32_t nb = m.adj[static_cast<size_t>(faces[i])];
    for (const int32_t side : {faces[i], nb})
      if (side >= 0) {
        sides.push_back(side);
        lo.push_back(cheap[i]);
      }
  }
  // A closed-form ceiling on each side's best (alpha_ceiling): a side whose
  // ceiling and cheap value fall on the same side of every threshold needs
  // no search (raw meshes have thousands of needles, each certainly bad).
  std::vector<double> best(sides.size(), -1), hi(sides.size());
  for (size_t j = 0; j < sides.size(); ++j) {
    const double* p[3];
    face_points(m, sides[j], p);
    hi[j] = alpha_ceiling(p[0], p[1], p[2]);
  }
  auto decided = [&](size_t j) {
    for (const double tau : kCountThresholds)
      if (lo[j] < tau - kTol && !(hi[j] < tau - kTol)) return false;
    return true;
  };
  for (size_t j = 0; j < sides.size(); ++j) {  // shapes already searched, serially
    if (decided(j)) {
      best[j] = hi[j];  // below every threshold it is below; lo decides the rest
      continue;
    }
    const double* s[3];
    if (face_wedges(m, sides[j], s) > 0 || side_thin(m, sides[j], walls_on)) continue;
    const double* p[3];
    face_points(m, sides[j], p);
    std::pair<int64_t, int64_t> key;
    if (!shape_key(Frame(p[0], p[1], p[2]), key)) best[j] = 0;
    else if (const auto it = cache.find(key); it != cache.end()) best[j] = it->second;
  }
  for (size_t j = 0; j < sides.size(); ++j)
    if (best[j] < 0)
      if (const auto it = known.find(sides[j]); it != known.end()) best[j] = it->second.alpha;
  detail::parallel_for_each(static_cast<int64_t>(sides.size()), threads, [&](int64_t j) {
    if (best[j] < 0) best[j] = side_best(m, sides[j], nullptr, nullptr, walls_on);
  });
  // Whether x lies strictly on side b's side of its triangle.
  auto on_side = [&](int32_t b, const double* x) {
    const int32_t* v = m.tet(b >> 2);
    const int f = b & 3;
    const double *a = m.point(v[kFaceVertex[f][0]]), *q = m.point(v[kFaceVertex[f][1]]),
                 *r = m.point(v[kFaceVertex[f][2]]);
    const Sign o = orient3d(a, q, r, x);
    return o != Sign::Zero && o == orient3d(a, q, r, m.point(v[f]));
  };
  auto other_vertex = [&](int32_t b, int32_t x, int32_t y) {
    const int32_t* v = m.tet(b >> 2);
    for (int e = 0; e < 3; ++e) {
      const int32_t w = v[kFaceVertex[b & 3][e]];
      if (w != x && w != y) return w;
    }
    return int32_t{-1};
  };
  std::array<int64_t, 3> out{};
  for (size_t k = 0; k < kCountThresholds.size(); ++k) {
    const double tau = kCountThresholds[k];
    std::vector<int32_t> bad;  // the bad sides
    for (size_t j = 0; j < sides.size(); ++j)
      if (lo[j] < tau - kTol && best[j] < tau - kTol) bad.push_back(sides[j]);
    // Their edges (sorted vertex pairs).
    std::vector<std::pair<std::pair<int32_t, int32_t>, size_t>> edges;
    edges.reserve(3 * bad.size());
    for (size_t b = 0; b < bad.size(); ++b) {
      const int32_t* v = m.tet(bad[b] >> 2);
      const int f = bad[b] & 3;
      for (int e = 0; e < 3; ++e) {
        const int32_t x = v[kFaceVertex[f][e]], y = v[kFaceVertex[f][(e + 1) % 3]];
        edges.push_back({{std::min(x, y), std::max(x, y)}, b});
      }
    }
    std::sort(edges.begin(), edges.end());
    // Two bad sides sharing an edge can be faces of one tet only when each
    // one's far vertex lies on the other's side.
    std::vector<uint8_t> partnered(bad.size(), 0);
    for (size_t i = 0; i < edges.size();) {
      size_t j = i;
      while (j < edges.size() && edges[j].first == edges[i].first) ++j;
      const auto [x, y] = edges[i].first;
      for (size_t p = i; p < j; ++p)
        for (size_t q = p + 1; q < j; ++q) {
          const size_t b1 = edges[p].second, b2 = edges[q].second;
          if (on_side(bad[b1], m.point(other_vertex(bad[b2], x, y))) &&
              on_side(bad[b2], m.point(other_vertex(bad[b1], x, y))))
            partnered[b1] = partnered[b2] = 1;
        }
      i = j;
    }
    int64_t isolated = 0, shared = 0;
    for (size_t b = 0; b < bad.size(); ++b) (partnered[b] ? shared : isolated) += 1;
    out[k] = isolated + (shared + 3) / 4;
  }
  return out;
}

}  // namespace

namespace {
MeshBound mesh_bound_impl(const TetMesh& m, int threads, bool all_measures, SideCache& known, bool walls_on) {
  const auto t0 = std::chrono::steady_clock::now();
  MeshBound mb;
  const std::vector<int32_t> faces = constrained_faces(m, threads);
  mb.triangles = static_cast<int64_t>(faces.size());
  if (faces.empty()) return mb;
  const size_t nf = faces.size();
  // Cheap achieved scores (maximised), per objective.
  const int nobj = all_measures ? kApexObjectives : 3;
  std::vector<double> cheap[kApexObjectives];
  for (int o = 0; o < nobj; ++o) cheap[o].resize(nf);
  // Faces with a sharp boundary edge (face_wedges): their alpha is bounded
  // with the apex inside the wedges, and only the achieved value (the tet
  // there now, which lies inside them) is a cheap value that respects them.
  std::vector<uint8_t> wedged(nf, 0), walled(nf, 0);
  detail::parallel_for_each(static_cast<int64_t>(nf), threads, [&](int64_t i) {
    const double* p[3];
    face_points(m, faces[i], p);
    double qa, qmin, qmax;
    achieved_on_face(m, faces[i], qa, qmin, qmax);
    double best[3];
    cheap_apex_values(p[0], p[1], p[2], best);
    // Each side of the face (the tet on it): its wedges, its achieved alpha.
    const int32_t side[2] = {faces[i], m.adj[static_cast<size_t>(faces[i])]};
    const double* s[2][3] = {{nullptr, nullptr, nullptr}, {nullptr, nullptr, nullptr}};
    for (int k = 0; k < 2; ++k)
      if (side[k] >= 0 && face_wedges(m, side[k], s[k]) > 0) wedged[i] = 1;
    // Thin sides (side_walls): walls facing them may cap the apex, and the
    // cheap value respects them.
    std::vector<WallTri> walls[2];
    double h[2] = {INFINITY, INFINITY};
    for (int k = 0; k < 2; ++k)
      if (side[k] >= 0) {
        side_walls(m, side[k], walls[k], h[k], walls_on);
        if (!walls[k].empty()) walled[i] = 1;
      }
    if (walled[i]) {
      cheap[0][i] = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 2; ++k)
        if (side[k] >= 0)
          cheap[0][i] = std::min(cheap[0][i], walls[k].empty() ? side_cheap_alpha(m, side[k], s[k])
                                                               : walled_side_cheap(m, side[k], s[k], walls[k], h[k]));
    } else if (wedged[i]) {
      cheap[0][i] = side_cheap_alpha(m, side[0], s[0]);
      if (side[1] >= 0) cheap[0][i] = std::min(cheap[0][i], side_cheap_alpha(m, side[1], s[1]));
    } else {
      cheap[0][i] = std::max(qa, best[0]);
    }
    cheap[1][i] = std::max(qmin, best[1]);
    cheap[2][i] = -std::min(qmax, best[2]);
    if (nobj > 3) {  // the other measures: the best candidate apex (achieved)
      double other[kApexObjectives - 3];
      cheap_other_values(p[0], p[1], p[2], other);
      for (int o = 3; o < nobj; ++o) {
        const ApexObjective obj = static_cast<ApexObjective>(o);
        cheap[o][i] = to_public(obj, other[o - 3]);
      }
    }
  });
  std::vector<uint8_t> refined(nf, 0);
  double result[kApexObjectives];
  size_t arg[kApexObjectives] = {};
  std::vector<size_t> heap(nf);
  std::unordered_map<std::pair<int64_t, int64_t>, double, PairHash> cache[kApexObjectives];  // shape -> best value
  double wall_d = NAN;  // the alpha bound's side is capped by a wall this far (NaN: not)
  bool pair_arg = false;  // the alpha bound is a pair's (pair_best_alpha)
  std::vector<size_t> paired;  // wedged faces searched for alpha: their pairs then
  for (int o = 0; o < nobj; ++o) {
    const ApexObjective obj = static_cast<ApexObjective>(o);
    // The triangles by increasing cheap score (ties by index), taken from a
    // heap: the loop below stops after the first few, so sorting all of them
    // would be wasted.
    auto after = [&](size_t p, size_t q) {  // p comes after q
      return cheap[o][p] > cheap[o][q] || (cheap[o][p] == cheap[o][q] && p > q);
    };
    std::iota(heap.begin(), heap.end(), size_t{0});
    std::make_heap(heap.begin(), heap.end(), after);
    auto heap_end = heap.end();
    // Scores within `tol` of the current minimum are not refined: the bound
    // is exact to tol (1e-4 in alpha and the other measures scaled to 1 for
    // the regular tet, 0.01 degree), which keeps meshes with many congruent
    // triangles (generated boxes) from refining them all.
    const bool angle = obj == ApexObjective::MinDihedral || obj == ApexObjective::MaxDihedral;
    const double tol = angle ? 1e-2 : 1e-4;
    // The angle-like bounds cluster (any triangle with a small angle allows a
    // min dihedral near 60 degrees and a max near 90; the minimum sine and
    // the equivolume skewness follow the dihedral angles), so pruning cannot
    // separate them: only the kDihedralExamined lowest are examined, which
    // makes those figures estimates (as bound.py's are); alpha, the radius
    // ratio, the mean ratio and the scaled Jacobian are exact to tol.
    const bool capped = angle || obj == ApexObjective::SineMin || obj == ApexObjective::Skewness;
    constexpr size_t kDihedralExamined = 64;
    double cur = std::numeric_limits<double>::infinity();
    size_t examined = 0;
    // For alpha, the sides of wedged or walled faces (side_best: a search in
    // the wedges, or under the walls) are searched ahead in parallel, a
    // batch of the next faces in the heap's order at a time, into `known`;
    // the loop then takes them in that order as before.  side_best uses its
    // shape cache only for a side neither wedged nor walled: those values
    // are dropped and left to the loop, so every value is the loop's own,
    // bit for bit, for every thread count.
    const int nth = detail::resolve_threads(threads);
    const size_t batch = o == 0 && nth > 1 ? kAheadPerThread * static_cast<size_t>(nth) : 0;
    std::vector<size_t> ahead;  // faces popped and searched ahead, in order
    size_t next_ahead = 0;
    std::vector<int32_t> todo;
    while (next_ahead < ahead.size() || heap_end != heap.begin()) {
      if (batch > 0 && next_ahead == ahead.size()) {
        ahead.clear();
        next_ahead = 0;
        todo.clear();
        while (ahead.size() < batch && heap_end != heap.begin()) {
          std::pop_heap(heap.begin(), heap_end, after);
          const size_t f = *--heap_end;
          ahead.push_back(f);
          if (cheap[o][f] >= cur - tol) break;  // the loop stops there
          if (!(wedged[f] || walled[f])) continue;
          for (const int32_t side : {faces[f], m.adj[static_cast<size_t>(faces[f])]})
            if (side >= 0 && !known.count(side)) todo.push_back(side);
        }
        std::sort(todo.begin(), todo.end());
        todo.erase(std::unique(todo.begin(), todo.end()), todo.end());
        std::vector<SideBound> found(todo.size());
        std::vector<uint8_t> by_shape(todo.size(), 0);
        detail::parallel_items(static_cast<int64_t>(todo.size()), nth, [&](int64_t k) {  // one task each
          SideBound& sb = found[static_cast<size_t>(k)];
          bool shape = false;
          sb.alpha = side_best(m, todo[static_cast<size_t>(k)], nullptr, &sb, walls_on, &shape);
          by_shape[static_cast<size_t>(k)] = shape;
        });
        // A value by shape is left to the loop, which memoises it (its
        // cache may hold a congruent triangle's value).
        for (size_t k = 0; k < todo.size(); ++k)
          if (!by_shape[k]) known.emplace(todo[k], found[k]);
      }
      size_t i;
      if (batch > 0) {
        i = ahead[next_ahead++];
      } else {
        std::pop_heap(heap.begin(), heap_end, after);
        i = *--heap_end;
      }
      if (cheap[o][i] >= cur - tol) break;  // achieved >= current minimum: cannot hold it
      if (capped && examined++ >= kDihedralExamined) break;
      const double* p[3];
      face_points(m, faces[i], p);
      if (o == 0 && (wedged[i] || walled[i])) {
        auto side_value = [&](int32_t side) {
          if (const auto it = known.find(side); it != known.end()) return it->second;
          SideBound sb;
          sb.alpha = side_best(m, side, &cache[o], &sb, walls_on);
          known.emplace(side, sb);
          return sb;
        };
        const SideBound first = side_value(faces[i]);
        double found = first.alpha;
        double d = first.wall_distance;
        if (const int32_t nb = m.adj[static_cast<size_t>(faces[i])]; nb >= 0) {
          const SideBound other = side_value(nb);
          if (other.alpha < found) { found = other.alpha; d = other.wall_distance; }
        }
        if (wedged[i]) paired.push_back(i);
        const double v = std::max(cheap[o][i], found);
        refined[i] = 1;
        if (v < cur) { cur = v; arg[o] = i; wall_d = d; pair_arg = false; }
        continue;
      }
      if (quick_score(p[0], p[1], p[2], obj) >= cur - tol) continue;
      std::pair<int64_t, int64_t> key;
      const bool keyed = shape_key(Frame(p[0], p[1], p[2]), key);
      double found;
      auto it = keyed ? cache[o].find(key) : cache[o].end();
      if (it != cache[o].end()) {
        found = it->second;
      } else {
        found = best_apex(p[0], p[1], p[2], obj).value;
        if (keyed) cache[o].emplace(key, found);
        refined[i] = 1;
      }
      const double v = std::max(cheap[o][i], to_public(obj, found));
      if (v < cur) {
        cur = v;
        arg[o] = i;
        if (o == 0) {
          wall_d = NAN;
          pair_arg = false;
        }
      }
    }
    // Then the pairs at the sharp edges of the wedged faces searched above
    // (pair_best_alpha): a bound on the worse of two tets, so on the mesh's
    // worst too.  After the triangles, so that each pair's search stops as
    // soon as it reaches the bound they set (most stop at their first
    // split, at half the angle).  Only the pairs of those faces (whose
    // cheap value was below the bound when they were searched): a pair of
    // two faces that each allow a better apex alone may still bind, and is
    // not looked for, so this part makes the bound tighter where it finds a
    // pair and never wrong, but not exact to tol.  An extra 0.01-0.09 s of
    // `tetopt quality` on the bench meshes (docs/benchmarks.md,
    // twenty-eighth session).
    if (o == 0)
      if (const size_t i = lower_by_pairs(m, faces, paired, tol, threads, cur); i != SIZE_MAX) {
        arg[o] = i;
        wall_d = NAN;
        pair_arg = true;
      }
    result[o] = cur;
    mb.measure[static_cast<size_t>(measure_of(obj))] = to_public(obj, cur);
  }
  mb.alpha = result[0];
  mb.alpha_wall_d = wall_d;
  mb.alpha_pair = pair_arg;
  mb.dihedral_min = result[1];
  mb.dihedral_max = -result[2];
  mb.alpha_tet = faces[arg[0]] >> 2;
  mb.alpha_face = faces[arg[0]] & 3;
  const double* p[3];
  face_points(m, faces[arg[0]], p);
  for (int k = 0; k < 3; ++k) mb.alpha_location[k] = (p[0][k] + p[1][k] + p[2][k]) / 3;
  for (uint8_t r : refined) mb.refined += r;
  mb.below_at_least = count_bound(m, faces, known, cheap[0], cache[0], threads, walls_on);
  mb.seconds = seconds_since(t0);
  return mb;
}
}  // namespace

MeshBound mesh_bound(const TetMesh& m, int threads, bool all_measures, bool walls) {
  SideCache known;
  return mesh_bound_impl(m, threads, all_measures, known, walls);
}

SideBound side_bound(const TetMesh& m, int32_t packed) {
  SideBound sb;
  sb.alpha = side_best(m, packed, nullptr, &sb);
  return sb;
}

const char* tet_class_name(TetClass c) {
  switch (c) {
    case TetClass::Good: return "good";
    case TetClass::LockedByTriangle: return "locked by its boundary triangle";
    case TetClass::LockedByNeighbours: return "locked by its constrained neighbours";
    case TetClass::Improvable: return "improvable (not reached)";
  }
  return "?";
}

Diagnosis diagnose(const TetMesh& m, const DiagnoseOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  Diagnosis d;
  d.threshold = opt.threshold;
  const int32_t nt = m.nt();
  d.tets = nt;
  d.tet_class.assign(static_cast<size_t>(nt), static_cast<uint8_t>(TetClass::Good));
  std::unordered_map<std::pair<int64_t, int64_t>, int32_t, PairHash> shape_best;  // similar triangles: their job
  // The poor tets, found over parallel blocks (in index order).
  const std::vector<int32_t> poor = detail::parallel_select(
      nt, opt.threads, [&](int64_t t) { return tet_alpha(m, static_cast<int32_t>(t)) < opt.threshold; });
  // Their measures, their constrained faces' keys and the two-face wedge
  // bounds in parallel (each a function of the mesh alone).
  std::vector<PoorTet> info(poor.size());
  struct FaceKey {
    int32_t key = -1;       // the side's key, then its job (below); -1: face not constrained
    bool searched = false;  // wedged or thin: side_best on this side
  };
  std::vector<std::array<FaceKey, 4>> keys(poor.size());
  auto examine = [&](int64_t i) {
    const int32_t t = poor[i];
    const int32_t* v = m.tet(t);
    const double *a = m.point(v[0]), *b = m.point(v[1]), *c = m.point(v[2]), *e = m.point(v[3]);
    PoorTet& p = info[i];
    p.tet = t;
    p.alpha = alpha(a, b, c, e);
    p.kind = m.tet_kind.empty() ? 0 : m.tet_kind[t];
    dihedral_extremes(a, b, c, e, p.dihedral_min, p.dihedral_max);
    for (int k = 0; k < 3; ++k) p.centroid[k] = (a[k] + b[k] + c[k] + e[k]) / 4;
    const uint8_t mask = m.face_mask.empty() ? 0 : m.face_mask[t];
    for (int f = 0; f < 4; ++f) {
      if (!(mask & (1u << f))) continue;
      const int32_t packed = 4 * t + f;
      const int32_t nb = m.adj[static_cast<size_t>(packed)];
      const double* ws[3];
      const bool wedge = face_wedges(m, packed, ws) > 0;
      const bool thin = side_thin(m, packed, opt.walls);
      // The face's own bound is the same on both sides; a side's wedges and
      // walls are its own, so a wedged or thin face is keyed by this side.
      keys[i][f] = {nb >= 0 && !wedge && !thin ? std::min(packed, nb) : packed, wedge || thin};
    }
    // Two faces of t on the domain boundary (no tet beyond either): t is the
    // only tet at their common edge, so near it the domain is t's wedge and
    // the tet any mesh puts on either face has its apex inside that wedge
    // (issue 27: a pair of constrained faces provably forces this).
    if (!m.adj.empty())
      for (int f1 = 0; f1 < 4; ++f1)
        for (int f2 = 0; f2 < 4; ++f2) {
          if (f1 == f2 || !(mask & (1u << f1)) || !(mask & (1u << f2))) continue;
          if (m.adj[4 * static_cast<size_t>(t) + f1] >= 0 || m.adj[4 * static_cast<size_t>(t) + f2] >= 0) continue;
          // Face f1 = (p, q, r) where r = vertex f2 is off the shared edge
          // and s = vertex f1 is face f2's own.
          int pq[2], n = 0;
          for (int k = 0; k < 4; ++k)
            if (k != f1 && k != f2) pq[n++] = k;
          const double w = wedge_best_alpha(m.point(v[pq[0]]), m.point(v[pq[1]]), m.point(v[f2]), m.point(v[f1]));
          if (std::isnan(p.wedge_alpha) || w < p.wedge_alpha) {
            p.wedge_alpha = w;
            p.wedge_face = f1;
            p.wedge_deg = edge_dihedral_deg(m.point(v[pq[0]]), m.point(v[pq[1]]), m.point(v[f2]), m.point(v[f1]));
          }
        }
  };
  // Ranges of 16 tets, not kBlock: a wedge search costs milliseconds, and
  // a few thousand poor tets would otherwise be one block on one thread.
  detail::parallel_ranges(static_cast<int64_t>(poor.size()), 16, opt.threads, [&](int64_t i0, int64_t i1) {
    for (int64_t i = i0; i < i1; ++i) examine(i);
  });
  // Each key's bound, searched once: the keys in the order the poor tets
  // first meet them (so faces_searched and the order are as a serial
  // pass over the tets makes them), the searches in parallel.  A face that
  // is neither wedged nor thin gets the triangle's own bound, searched once
  // per shape (shape_best) unless its closed-form apexes already reach the
  // threshold (then NaN: not a lock).  The searches were 47% of an insertion
  // run on hinge_raw with the summary (and 9 tenths of a default one) when
  // they ran one after the other.
  struct Job {
    int32_t packed;  // the side first met
    bool searched;
    SideBound sb;
    double cheap = 0;
    bool keyed = false;
    std::pair<int64_t, int64_t> shape{0, 0};
  };
  std::vector<Job> jobs;
  {
    std::unordered_map<int32_t, int32_t> job_of;  // key -> job
    for (size_t i = 0; i < poor.size(); ++i)
      for (int f = 0; f < 4; ++f) {
        FaceKey& k = keys[i][f];
        if (k.key < 0) continue;
        const auto [it, fresh] = job_of.emplace(k.key, static_cast<int32_t>(jobs.size()));
        if (fresh) jobs.push_back({4 * poor[i] + f, k.searched, {}});
        k.key = it->second;
      }
  }
  detail::parallel_items(static_cast<int64_t>(jobs.size()), opt.threads, [&](int64_t j) {  // one task each
    Job& jb = jobs[j];
    if (jb.searched) {  // inside the wedges of its sharp edges (face_wedges), clear of the walls (side_walls)
      jb.sb.alpha = side_best(m, jb.packed, nullptr, &jb.sb, opt.walls);
      return;
    }
    const double* fp[3];
    face_points(m, jb.packed, fp);
    jb.cheap = cheap_apex_value(fp[0], fp[1], fp[2]);
    if (jb.cheap >= opt.threshold) {
      jb.sb.alpha = NAN;  // an apex reaching the threshold exists: not a lock
      return;
    }
    jb.keyed = shape_key(Frame(fp[0], fp[1], fp[2]), jb.shape);
  });
  // One search per shape (the first job of each), the others take its value.
  std::vector<int32_t> shape_job(jobs.size(), -1);  // job whose search a job takes
  std::vector<int32_t> to_search;
  for (size_t j = 0; j < jobs.size(); ++j) {
    const Job& jb = jobs[j];
    if (jb.searched) {
      d.faces_searched++;
      continue;
    }
    if (jb.cheap >= opt.threshold) continue;
    if (jb.keyed) {
      const auto [it, fresh] = shape_best.emplace(jb.shape, static_cast<int32_t>(j));
      shape_job[j] = it->second;
      if (!fresh) continue;
    } else {
      shape_job[j] = static_cast<int32_t>(j);
    }
    d.faces_searched++;
    to_search.push_back(static_cast<int32_t>(j));
  }
  detail::parallel_items(static_cast<int64_t>(to_search.size()), opt.threads, [&](int64_t k) {
    Job& jb = jobs[to_search[k]];
    const double* fp[3];
    face_points(m, jb.packed, fp);
    jb.sb.alpha = best_apex(fp[0], fp[1], fp[2]).value;
  });
  for (size_t j = 0; j < jobs.size(); ++j)
    if (shape_job[j] >= 0) jobs[j].sb.alpha = jobs[shape_job[j]].sb.alpha;
  d.poor.reserve(poor.size());
  for (size_t i = 0; i < poor.size(); ++i) {
    PoorTet& p = info[i];
    const int32_t t = p.tet;
    for (int f = 0; f < 4; ++f) {
      if (keys[i][f].key < 0) continue;
      p.constrained_faces++;
      const SideBound& sb = jobs[keys[i][f].key].sb;
      const double best = sb.alpha;
      if (!std::isnan(best) && (std::isnan(p.best_alpha) || best < p.best_alpha)) {
        p.best_alpha = best;
        p.face = f;
        p.wedged = sb.wedged;
        p.walled = sb.walled;
        p.wall_d = sb.wall_distance;
        p.vertex_alpha = sb.vertex_alpha;
      }
    }
    if (!m.adj.empty()) {
      if (!std::isnan(p.wedge_alpha) && (std::isnan(p.best_alpha) || p.wedge_alpha <= p.best_alpha + 1e-9)) {
        p.best_alpha = std::min(p.best_alpha, p.wedge_alpha);
        p.face = p.wedge_face;
        p.wedged = p.walled = false;  // said with the angle instead
        p.wall_d = p.vertex_alpha = NAN;
      } else {
        p.wedge_alpha = p.wedge_deg = NAN;  // no tighter than the triangle's own bound
        p.wedge_face = -1;
      }
    }
    if (!std::isnan(p.best_alpha) && p.best_alpha < opt.threshold) p.cls = TetClass::LockedByTriangle;
    else if (p.kind == 4) p.cls = TetClass::LockedByNeighbours;
    else p.cls = TetClass::Improvable;
    d.tet_class[t] = static_cast<uint8_t>(p.cls);
    d.count[static_cast<int>(p.cls)]++;
    d.poor.push_back(std::move(p));
  }
  d.count[0] = nt - d.count[1] - d.count[2] - d.count[3];
  for (const PoorTet& p : d.poor)
    if (!std::isnan(p.vertex_alpha) && !(p.vertex_alpha >= d.vertex_bound)) {
      d.vertex_bound = p.vertex_alpha;
      d.vertex_bound_tet = p.tet;
    }
  std::sort(d.poor.begin(), d.poor.end(), [](const PoorTet& x, const PoorTet& y) {
    return x.alpha < y.alpha || (x.alpha == y.alpha && x.tet < y.tet);
  });
  if (opt.mesh_bound) {
    SideCache known;  // the wedged and thin sides searched above
    for (const Job& jb : jobs)
      if (jb.searched) known.emplace(jb.packed, jb.sb);
    d.bound = mesh_bound_impl(m, opt.threads, opt.all_measures, known, opt.walls);
    // A poor tet's wedge bound holds for the whole mesh too.
    for (const PoorTet& p : d.poor)
      if (!std::isnan(p.wedge_alpha) && !(p.wedge_alpha >= d.bound.alpha)) {
        d.bound.alpha = p.wedge_alpha;
        d.bound.measure[static_cast<size_t>(Measure::Alpha)] = p.wedge_alpha;
        d.bound.alpha_tet = p.tet;
        d.bound.alpha_face = p.wedge_face;
        d.bound.alpha_wedge_deg = p.wedge_deg;
        d.bound.alpha_wall_d = NAN;
        d.bound.alpha_pair = false;
        const double* fp[3];
        face_points(m, 4 * p.tet + p.wedge_face, fp);
        for (int k = 0; k < 3; ++k) d.bound.alpha_location[k] = (fp[0][k] + fp[1][k] + fp[2][k]) / 3;
      }
  }
  d.seconds = seconds_since(t0);
  return d;
}

namespace {
std::string num(double x, const char* f = "%.17g") {
  if (std::isnan(x)) return "null";
  if (std::isinf(x)) return x > 0 ? "1e999" : "-1e999";
  char b[48];
  std::snprintf(b, sizeof b, f, x);
  return b;
}
std::string fixed(double x, const char* f) {
  if (std::isnan(x)) return "-";
  char b[48];
  std::snprintf(b, sizeof b, f, x);
  return b;
}
}  // namespace

std::string format_diagnosis(const Diagnosis& d, size_t max_list) {
  std::ostringstream o;
  const int64_t below = d.count[1] + d.count[2] + d.count[3];
  o << "  diagnosis at α < " << fixed(d.threshold, "%.3g") << ": " << below << " tets";
  if (below)
    o << " — " << d.count[1] << " locked by their boundary triangle, " << d.count[2]
      << " locked by constrained neighbours, " << d.count[3] << " improvable (not reached)";
  o << "\n";
  if (d.bound.triangles > 0 && !std::isnan(d.bound.alpha)) {
    o << "  bound from " << d.bound.triangles << " constrained triangles: any mesh keeping them has α ≤ "
      << fixed(d.bound.alpha, "%.4f") << ", min dihedral ≤ " << fixed(d.bound.dihedral_min, "%.2f")
      << "°, max dihedral ≥ " << fixed(d.bound.dihedral_max, "%.2f") << "°  (triangle of tet "
      << d.bound.alpha_tet + 1 << " at " << fixed(d.bound.alpha_location[0], "%.6g") << " "
      << fixed(d.bound.alpha_location[1], "%.6g") << " " << fixed(d.bound.alpha_location[2], "%.6g");
    if (!std::isnan(d.bound.alpha_wall_d)) o << ", capped by the wall facing it at d = " << fixed(d.bound.alpha_wall_d, "%.4g");
    if (d.bound.alpha_pair) o << ", sharing a sharp edge's angle with the kept triangle beside it";
    o << ")\n";
    const auto& b = d.bound.measure;
    auto at = [&](Measure k) { return b[static_cast<size_t>(k)]; };
    if (!std::isnan(at(Measure::SineMin)))
      o << "  and minimum sine ≤ " << fixed(at(Measure::SineMin), "%.4f") << ", scaled Jacobian ≤ "
        << fixed(at(Measure::ScaledJacobian), "%.4f") << ", radius ratio ≤ " << fixed(at(Measure::RadiusRatio), "%.4f")
        << ", mean ratio ≤ " << fixed(at(Measure::MeanRatio), "%.4f") << ", equivolume skewness ≥ "
        << fixed(at(Measure::EquivolumeSkewness), "%.4f") << "\n";
    const auto& c = d.bound.below_at_least;
    if (c[0] >= 0)
      o << "  and at least " << c[0] << " / " << c[1] << " / " << c[2]
        << " tets below α 0.1 / 0.2 / 0.3 (their boundary triangles allow no better apex)\n";
  }
  if (!std::isnan(d.vertex_bound))
    o << "  with no new vertex inside the walls (a vertex there splits the wall's thickness): α ≤ "
      << fixed(d.vertex_bound, "%.4f") << " (triangle of tet " << d.vertex_bound_tet + 1
      << ", its best apex among the vertices there)\n";
  for (size_t i = 0; i < d.poor.size() && i < max_list; ++i) {
    const PoorTet& p = d.poor[i];
    o << "    tet " << p.tet + 1 << "  α " << fixed(p.alpha, "%.4f") << "  kind " << p.kind << "  at "
      << fixed(p.centroid[0], "%.6g") << " " << fixed(p.centroid[1], "%.6g") << " " << fixed(p.centroid[2], "%.6g")
      << ": " << tet_class_name(p.cls);
    if (p.cls == TetClass::LockedByTriangle && !std::isnan(p.wedge_alpha))
      o << " and the boundary face beside it, meeting at " << fixed(p.wedge_deg, "%.1f") << "° (best possible α = "
        << fixed(p.best_alpha, "%.4f") << ")";
    else if (p.cls == TetClass::LockedByTriangle && p.walled) {
      o << " and the wall facing it, d = " << fixed(p.wall_d, "%.4g") << " (best possible α = "
        << fixed(p.best_alpha, "%.4f");
      if (!std::isnan(p.vertex_alpha))
        o << "; with no new vertex inside the wall " << fixed(p.vertex_alpha, "%.4f")
          << (p.vertex_alpha <= p.alpha + 1e-9 ? ", reached" : "");
      o << ")";
    }
    else if (p.cls == TetClass::LockedByTriangle && p.wedged)
      o << " and the sharp boundary edges around it (best possible α = " << fixed(p.best_alpha, "%.4f") << ")";
    else if (p.cls == TetClass::LockedByTriangle) o << " (best possible α = " << fixed(p.best_alpha, "%.4f") << ")";
    o << "\n";
  }
  return o.str();
}

std::string diagnosis_to_json(const Diagnosis& d, size_t max_list, int indent) {
  const std::string pad(static_cast<size_t>(indent), ' ');
  std::ostringstream o;
  o << "{\n";
  o << pad << "\"threshold\": " << num(d.threshold) << ",\n";
  o << pad << "\"below_threshold\": " << d.count[1] + d.count[2] + d.count[3] << ",\n";
  o << pad << "\"locked_by_triangle\": " << d.count[1] << ",\n";
  o << pad << "\"locked_by_neighbours\": " << d.count[2] << ",\n";
  o << pad << "\"improvable\": " << d.count[3] << ",\n";
  o << pad << "\"faces_searched\": " << d.faces_searched << ",\n";
  o << pad << "\"bound\": {\"constrained_triangles\": " << d.bound.triangles
    << ", \"alpha_upper_bound\": " << num(d.bound.alpha)
    << ", \"min_dihedral_upper_bound\": " << num(d.bound.dihedral_min)
    << ", \"max_dihedral_lower_bound\": " << num(d.bound.dihedral_max) << ", \"alpha_tet\": " << d.bound.alpha_tet
    << ", \"alpha_face\": " << d.bound.alpha_face << ", \"alpha_location\": [" << num(d.bound.alpha_location[0])
    << ", " << num(d.bound.alpha_location[1]) << ", " << num(d.bound.alpha_location[2])
    << "], \"alpha_wedge_deg\": " << num(d.bound.alpha_wedge_deg) << ", \"alpha_wall_d\": " << num(d.bound.alpha_wall_d)
    << ", \"alpha_pair\": " << (d.bound.alpha_pair ? "true" : "false")
    << ", \"measures\": {";
  // Every per-tet measure's bound by its key (null: not computed); the face
  // measures have none (diagnose.hpp, MeshBound::measure).
  for (int k = 0; k < kTetMeasureCount; ++k)
    o << (k ? ", " : "") << "\"" << kMeasures[k].key << "\": " << num(d.bound.measure[static_cast<size_t>(k)]);
  o << "}, \"tets_below_at_least\": ";
  if (d.bound.below_at_least[0] < 0) {
    o << "null";
  } else {
    o << "{";
    for (size_t k = 0; k < kCountThresholds.size(); ++k)
      o << (k ? ", " : "") << "\"" << fixed(kCountThresholds[k], "%.1f") << "\": " << d.bound.below_at_least[k];
    o << "}";
  }
  o << ", \"triangles_refined\": " << d.bound.refined << ", \"seconds\": " << num(d.bound.seconds) << "},\n";
  o << pad << "\"alpha_bound_no_new_wall_vertex\": " << num(d.vertex_bound) << ",\n";
  o << pad << "\"alpha_bound_no_new_wall_vertex_tet\": " << d.vertex_bound_tet << ",\n";
  o << pad << "\"seconds\": " << num(d.seconds) << ",\n";
  o << pad << "\"tets\": [";
  const size_t n = max_list ? std::min(max_list, d.poor.size()) : d.poor.size();
  for (size_t i = 0; i < n; ++i) {
    const PoorTet& p = d.poor[i];
    o << (i ? ",\n" : "\n") << pad << pad << "{\"id\": " << p.tet << ", \"class\": "
      << (p.cls == TetClass::LockedByTriangle ? "\"locked_by_triangle\""
          : p.cls == TetClass::LockedByNeighbours ? "\"locked_by_neighbours\""
                                                  : "\"improvable\"")
      << ", \"alpha\": " << num(p.alpha) << ", \"dihedral_min\": " << num(p.dihedral_min)
      << ", \"dihedral_max\": " << num(p.dihedral_max) << ", \"kind\": " << p.kind
      << ", \"best_alpha\": " << num(p.best_alpha) << ", \"face\": " << p.face
      << ", \"wedge_deg\": " << num(p.wedge_deg) << ", \"wall_d\": " << num(p.wall_d)
      << ", \"vertex_alpha\": " << num(p.vertex_alpha) << ", \"centroid\": ["
      << num(p.centroid[0]) << ", " << num(p.centroid[1]) << ", " << num(p.centroid[2]) << "]}";
  }
  o << (n ? "\n" + pad : "") << "]\n}";
  return o.str();
}

InsertionHint insertion_hint(const Diagnosis& d, double worst_alpha, bool insertion_available) {
  InsertionHint h;
  h.worst_alpha = worst_alpha;
  h.estimate = d.bound.alpha;
  for (const PoorTet& p : d.poor) {
    const bool headroom = p.cls != TetClass::LockedByTriangle ||
                          (!std::isnan(p.best_alpha) && p.alpha < kInsertionHintGap * p.best_alpha);
    h.tets += headroom;
    h.locked_by_neighbours += p.cls == TetClass::LockedByNeighbours;
  }
  h.show = insertion_available && d.bound.triangles > 0 && std::isfinite(d.bound.alpha) &&
           std::isfinite(worst_alpha) && worst_alpha < kInsertionHintGap * d.bound.alpha;
  return h;
}

std::string format_insertion_hint(const InsertionHint& h) {
  if (!h.show) return "";
  std::ostringstream o;
  o << "  insertion could lift the worst α from " << fixed(h.worst_alpha, "%.4f") << " toward "
    << fixed(h.estimate, "%.4f") << " (the bound";
  if (h.tets > 0) {
    o << "; " << h.tets << " tets below the threshold could gain from a new vertex";
    if (h.locked_by_neighbours > 0) o << ", " << h.locked_by_neighbours << " of them with no flip left";
  }
  o << "): try " << h.flag << "\n";
  return o.str();
}

std::string insertion_hint_to_json(const InsertionHint& h) {
  if (!h.show) return "null";
  std::ostringstream o;
  o << "{\"worst_alpha\": " << num(h.worst_alpha) << ", \"estimate\": " << num(h.estimate) << ", \"tets\": " << h.tets
    << ", \"locked_by_neighbours\": " << h.locked_by_neighbours << ", \"flag\": \"" << h.flag << "\"}";
  return o.str();
}

std::vector<CellField> diagnosis_cell_fields(const Diagnosis& d, int32_t nt) {
  std::vector<CellField> f;
  std::vector<double> cls(static_cast<size_t>(nt), 0.0), bound(static_cast<size_t>(nt), NAN);
  for (int32_t t = 0; t < nt && static_cast<size_t>(t) < d.tet_class.size(); ++t) cls[t] = d.tet_class[t];
  for (const PoorTet& p : d.poor)
    if (p.tet < nt) bound[p.tet] = p.best_alpha;
  f.push_back({"diagnosis", std::move(cls), true});
  f.push_back({"alpha_bound", std::move(bound), false});
  return f;
}

namespace {
void sorted_quad(const int32_t* v, int32_t out[4]) {
  for (int k = 0; k < 4; ++k) out[k] = v[k];
  std::sort(out, out + 4);
}
bool quad_less(const int32_t* a, const int32_t* b) { return std::lexicographical_compare(a, a + 4, b, b + 4); }
}  // namespace

TetValueMap::TetValueMap(const TetMesh& m, const std::vector<double>& values) {
  const int32_t nt = m.nt();
  entries_.resize(static_cast<size_t>(nt));
  for (int32_t t = 0; t < nt; ++t) {
    sorted_quad(m.tet(t), entries_[t].v);
    entries_[t].value = t < static_cast<int32_t>(values.size()) ? values[t] : NAN;
  }
  std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) { return quad_less(a.v, b.v); });
}

std::vector<double> TetValueMap::lookup(const TetMesh& m) const {
  const int32_t nt = m.nt();
  std::vector<double> out(static_cast<size_t>(nt), NAN);
  for (int32_t t = 0; t < nt; ++t) {
    Entry key;
    sorted_quad(m.tet(t), key.v);
    auto it = std::lower_bound(entries_.begin(), entries_.end(), key,
                               [](const Entry& a, const Entry& b) { return quad_less(a.v, b.v); });
    if (it != entries_.end() && std::equal(key.v, key.v + 4, it->v)) out[t] = it->value;
  }
  return out;
}

int64_t TetValueMap::matched(const TetMesh& m) const {
  int64_t n = 0;
  for (double x : lookup(m)) n += !std::isnan(x);
  return n;
}

}  // namespace tetopt
