// Optimisation-based smoothing with the paper's boundary weight C
// (Liu, Dai, Dong, Tan 2012, §3; Freitag, Jones, Plassmann 1995; Freitag &
// Ollivier-Gooch 1997).  See smooth.hpp for the model and the commit rule.
#include "tetopt/smooth.hpp"
#include "tetopt/objective.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "detail/parallel.hpp"
#include "detail/star_errors.hpp"
#include "detail/sum.hpp"
#include "detail/vec3.hpp"
#include "tetopt/conventions.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"

namespace tetopt {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const double kTwoSqrt6 = 2.0 * std::sqrt(6.0);
// Golden-section fractions of Alg. 2 (0.382 / 0.618 in the paper).
const double kGoldHi = (std::sqrt(5.0) - 1.0) / 2.0;
const double kGoldLo = 1.0 - kGoldHi;

using detail::cross;
using detail::dot;
using detail::norm;
using detail::sub;

// One star tet seen from its free vertex x as (x, a, b, c), positively
// oriented: (a, b, c) = kFaceVertex[slot] is the face opposite x, whose
// outward normal points away from x, so det(a-x, b-x, c-x) > 0.
// Coordinates are relative to the star's origin (the vertex's position when
// the star was gathered), which keeps the arithmetic well conditioned.
struct LocalTet {
  double a[3], b[3], c[3];
  double n0[3];   // (b-a) x (c-a): |n0| = twice the area of the face opposite x
  double n0len;
  double lfix2;   // longest squared edge not containing x
  double w;       // weight of eq. 3.4
  int32_t ia, ib, ic;  // mesh ids of a, b, c (exact check)
  int32_t t;
  int32_t slot;   // local index of the free vertex in tet t
  Objective obj = Objective::Alpha;  // what e = 1/q measures (objective.hpp); Alpha: the analytic path below
};

void make_local(const TetMesh& m, int32_t t, int slot, const double* origin, double w, LocalTet& L,
                Objective obj = Objective::Alpha) {
  const int32_t* tv = m.tet(t);
  L.t = t;
  L.obj = obj;
  L.slot = slot;
  L.ia = tv[kFaceVertex[slot][0]];
  L.ib = tv[kFaceVertex[slot][1]];
  L.ic = tv[kFaceVertex[slot][2]];
  sub(m.point(L.ia), origin, L.a);
  sub(m.point(L.ib), origin, L.b);
  sub(m.point(L.ic), origin, L.c);
  double ab[3], ac[3], bc[3];
  sub(L.b, L.a, ab);
  sub(L.c, L.a, ac);
  sub(L.c, L.b, bc);
  cross(ab, ac, L.n0);
  L.n0len = norm(L.n0);
  L.lfix2 = std::max({dot(ab, ab), dot(ac, ac), dot(bc, bc)});
  L.w = w;
}

// e(T) = A*L/(6 sqrt6 V) = A2*L/(2 sqrt6 D) with A2 = twice the total face
// area and D = 6V, at the free vertex position x (relative coordinates).  When
// g is given, also the gradient with the longest edge held:
//   grad e = e * (grad A2 / A2 + grad L / L - grad D / D)
//   grad D = -n0 (constant);  grad |n| for a face (x, p, q) with
//   n = (p-x) x (q-x) is (p-q) x n/|n|;  grad L = (x - y)/L when the
//   longest edge is x-y, else 0.
double objective_error(const LocalTet& T, const double* x, double* g);

inline double local_error(const LocalTet& T, const double* x, double* g) {
  if (T.obj != Objective::Alpha) return objective_error(T, x, g);
  double u[3], w[3], z[3];
  sub(T.a, x, u);
  sub(T.b, x, w);
  sub(T.c, x, z);
  double n1[3], n2[3], n3[3];
  cross(u, w, n1);
  cross(w, z, n2);
  cross(z, u, n3);
  const double D = dot(u, n2);
  if (!(D > 0)) {
    if (g) g[0] = g[1] = g[2] = 0;
    return kInf;
  }
  const double s1 = norm(n1), s2 = norm(n2), s3 = norm(n3);
  const double A2 = T.n0len + s1 + s2 + s3;
  const double lu = dot(u, u), lw = dot(w, w), lz = dot(z, z);
  double L2 = T.lfix2;
  const double* held = nullptr;
  if (lu > L2) { L2 = lu; held = u; }
  if (lw > L2) { L2 = lw; held = w; }
  if (lz > L2) { L2 = lz; held = z; }
  const double e = A2 * std::sqrt(L2) / (kTwoSqrt6 * D);
  if (g) {
    double dA[3] = {0, 0, 0};
    auto face = [&](const double* p, const double* q, const double* n, double s) {
      if (!(s > 0)) return;
      double pq[3], r[3];
      sub(p, q, pq);
      cross(pq, n, r);
      dA[0] += r[0] / s; dA[1] += r[1] / s; dA[2] += r[2] / s;
    };
    face(u, w, n1, s1);
    face(w, z, n2, s2);
    face(z, u, n3, s3);
    for (int k = 0; k < 3; ++k) g[k] = e * (dA[k] / A2 + T.n0[k] / D);
    if (held) {
      // L = |x - y| = |held|, held = y - x:  grad L / L = -held / L^2
      for (int k = 0; k < 3; ++k) g[k] -= e * held[k] / L2;
    }
  }
  return e;
}

// e = 1/q for an objective other than alpha (objective.hpp), q of the tet
// (x, a, b, c); +inf when q <= 0.  The gradient, when asked for, by central
// differences with a step of 1e-7 of the tet's longest fixed edge (each of
// the measures is smooth where it is positive, up to the switch of the
// active angle or corner that the optimisers already handle for alpha).
double objective_error(const LocalTet& T, const double* x, double* g) {
  const double q = objective_quality(T.obj, x, T.a, T.b, T.c);
  if (!(q > 0)) {
    if (g) g[0] = g[1] = g[2] = 0;
    return kInf;
  }
  const double e = 1.0 / q;
  if (g) {
    const double h = 1e-7 * std::sqrt(T.lfix2);
    for (int k = 0; k < 3; ++k) {
      double xp[3] = {x[0], x[1], x[2]}, xm[3] = {x[0], x[1], x[2]};
      xp[k] += h;
      xm[k] -= h;
      const double qp = objective_quality(T.obj, xp, T.a, T.b, T.c);
      const double qm = objective_quality(T.obj, xm, T.a, T.b, T.c);
      // d(1/q) = -dq / q^2; a side where q <= 0 falls back to one-sided.
      double dq = 0;
      if (qp > 0 && qm > 0) dq = (qp - qm) / (2 * h);
      else if (qp > 0) dq = (qp - q) / h;
      else if (qm > 0) dq = (q - qm) / h;
      g[k] = -dq * e * e;
    }
  }
  return e;
}

using detail::Sum;

inline double clamp_weight(double w) {
  if (!(w >= 0.5)) return 0.5;
  if (w > 1.0) return 1.0;
  return w;
}
inline double tet_weight(const TetMesh& m, int32_t t, double C) { return m.tet_kind[t] > 0 ? C : 1.0 - C; }

inline int slot_of(const TetMesh& m, int32_t t, int32_t v) {
  const int32_t* tv = m.tet(t);
  for (int i = 0; i < 4; ++i)
    if (tv[i] == v) return i;
  return -1;
}

// Per-thread scratch, grown on demand and never shrunk: no allocation per
// vertex solve once it has seen the largest star.
struct Scratch {
  std::vector<LocalTet> tets;
  std::vector<double> alpha, grad;  // MaxMin: per-tet alpha and gradient (3 each)
  std::vector<double> star_alpha;   // alphas of the star at the last candidate checked
  // The star's fixed parts as a structure of arrays (Alpha only), kSoa
  // arrays of `stride` (n rounded up to 4; the padding copies tet 0) for
  // star_errors4: ax ay az bx by bz cx cy cz n0len lfix2.
  static constexpr int kSoa = 11;
  std::vector<double> soa;
  int stride = 0;
  double origin[3] = {0, 0, 0};
  double mean_len = 0;
  int n = 0;
  Objective obj = Objective::Alpha;
};

void gather(const TetMesh& m, int32_t v, double C, Scratch& s) {
  const int32_t* b = m.star_begin(v);
  const int n = static_cast<int>(m.star_end(v) - b);
  if (static_cast<int>(s.tets.size()) < n) s.tets.resize(n);
  s.n = n;
  const double* o = m.point(v);
  s.origin[0] = o[0]; s.origin[1] = o[1]; s.origin[2] = o[2];
  double len = 0;
  for (int i = 0; i < n; ++i) {
    const int32_t t = b[i];
    LocalTet& L = s.tets[i];
    make_local(m, t, slot_of(m, t, v), s.origin, tet_weight(m, t, C), L, s.obj);
    len += norm(L.a) + norm(L.b) + norm(L.c);
  }
  s.mean_len = n ? len / (3.0 * n) : 0.0;
  s.stride = 0;
  if (s.obj != Objective::Alpha || n == 0) return;
  s.stride = (n + 3) / 4 * 4;
  if (s.soa.size() < static_cast<size_t>(Scratch::kSoa * s.stride)) s.soa.resize(Scratch::kSoa * s.stride);
  double* a = s.soa.data();
  const int st = s.stride;
  for (int i = 0; i < st; ++i) {
    const LocalTet& L = s.tets[i < n ? i : 0];
    for (int k = 0; k < 3; ++k) {
      a[k * st + i] = L.a[k];
      a[(3 + k) * st + i] = L.b[k];
      a[(6 + k) * st + i] = L.c[k];
    }
    a[9 * st + i] = L.n0len;
    a[10 * st + i] = L.lfix2;
  }
}

// local_error(s.tets[i], x, nullptr) for i = i0 .. i0 + 3 (Alpha, from the
// structure of arrays), lane by lane its operations in its order, so each
// lane has its bits; in a form GCC vectorises (the line searches' star_f
// calls are most of a smoothing pass).
inline void star_errors4(const Scratch& s, int i0, const double* x, double* out) {
  const double* a = s.soa.data();
  const int st = s.stride;
  const double x0 = x[0], x1 = x[1], x2 = x[2];
  double den[4];
  for (int l = 0; l < 4; ++l) {
    const int i = i0 + l;
    const double u0 = a[i] - x0, u1 = a[st + i] - x1, u2 = a[2 * st + i] - x2;
    const double w0 = a[3 * st + i] - x0, w1 = a[4 * st + i] - x1, w2 = a[5 * st + i] - x2;
    const double z0 = a[6 * st + i] - x0, z1 = a[7 * st + i] - x1, z2 = a[8 * st + i] - x2;
    // n1 = u x w, n2 = w x z, n3 = z x u (detail::cross).
    const double n10 = u1 * w2 - u2 * w1, n11 = u2 * w0 - u0 * w2, n12 = u0 * w1 - u1 * w0;
    const double n20 = w1 * z2 - w2 * z1, n21 = w2 * z0 - w0 * z2, n22 = w0 * z1 - w1 * z0;
    const double n30 = z1 * u2 - z2 * u1, n31 = z2 * u0 - z0 * u2, n32 = z0 * u1 - z1 * u0;
    const double D = u0 * n20 + u1 * n21 + u2 * n22;
    const double s1 = std::sqrt(n10 * n10 + n11 * n11 + n12 * n12);
    const double s2 = std::sqrt(n20 * n20 + n21 * n21 + n22 * n22);
    const double s3 = std::sqrt(n30 * n30 + n31 * n31 + n32 * n32);
    const double A2 = a[9 * st + i] + s1 + s2 + s3;
    const double lu = u0 * u0 + u1 * u1 + u2 * u2, lw = w0 * w0 + w1 * w1 + w2 * w2,
                 lz = z0 * z0 + z1 * z1 + z2 * z2;
    double L2 = a[10 * st + i];
    L2 = lu > L2 ? lu : L2;
    L2 = lw > L2 ? lw : L2;
    L2 = lz > L2 ? lz : L2;
    out[l] = A2 * std::sqrt(L2) / (kTwoSqrt6 * D);
    den[l] = D;
  }
  // Apart, so that GCC computes every lane's quotient (in the loop above it
  // sank the division under the test and gave up on vectorising it).
  for (int l = 0; l < 4; ++l) out[l] = den[l] > 0 ? out[l] : kInf;
}

double star_f(const Scratch& s, const double* x) {
  double f = 0;
  if (s.stride > 0) {  // Alpha: four tets at a time, summed in order as below
    double e[4];
    for (int i0 = 0; i0 < s.n; i0 += 4) {
      star_errors4(s, i0, x, e);
      for (int l = 0; l < 4 && i0 + l < s.n; ++l) {
        if (e[l] == kInf) return kInf;
        f += s.tets[i0 + l].w * e[l];
      }
    }
    return f;
  }
  for (int i = 0; i < s.n; ++i) {
    const LocalTet& T = s.tets[i];
    const double e = local_error(T, x, nullptr);
    if (e == kInf) return kInf;
    f += T.w * e;
  }
  return f;
}

double star_f_grad(const Scratch& s, const double* x, double* g) {
  double f = 0;
  g[0] = g[1] = g[2] = 0;
  for (int i = 0; i < s.n; ++i) {
    const LocalTet& T = s.tets[i];
    double ge[3];
    const double e = local_error(T, x, ge);
    if (e == kInf) return kInf;
    f += T.w * e;
    g[0] += T.w * ge[0]; g[1] += T.w * ge[1]; g[2] += T.w * ge[2];
  }
  return f;
}

// Worst alpha of the star at relative position x (1 / largest e).
double star_worst_alpha(const Scratch& s, const double* x) {
  double emax = 0;
  for (int i = 0; i < s.n; ++i) {
    const double e = local_error(s.tets[i], x, nullptr);
    if (e == kInf) return 0.0;
    emax = std::max(emax, e);
  }
  return emax > 0 ? 1.0 / emax : 0.0;
}

// Objective and worst alpha of v's star with v placed at absolute position p,
// evaluated exactly as vertex_objective does once v sits at p (coordinates
// relative to p) and alpha exactly as compute_stats does (tetopt::alpha on the
// tet's own vertex order).
// When alphas_out is given, it receives each star tet's alpha (CSR order).
void star_at(const TetMesh& m, int32_t v, const double* p, double C, double* f_out, double* worst_out,
             double* alphas_out = nullptr, Objective obj = Objective::Alpha) {
  double f = 0, worst = kInf;
  for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
    const int32_t t = *it;
    const int slot = slot_of(m, t, v);
    if (f_out) {
      LocalTet L;
      make_local(m, t, slot, p, tet_weight(m, t, C), L, obj);
      const double zero[3] = {0, 0, 0};
      const double e = local_error(L, zero, nullptr);
      f = (e == kInf || f == kInf) ? kInf : f + L.w * e;
    }
    if (worst_out) {
      const int32_t* tv = m.tet(t);
      const double* q[4];
      for (int k = 0; k < 4; ++k) q[k] = k == slot ? p : m.point(tv[k]);
      const double a = objective_quality(obj, q[0], q[1], q[2], q[3]);
      worst = std::min(worst, a);
      if (alphas_out) alphas_out[it - m.star_begin(v)] = a;
    }
  }
  if (f_out) *f_out = f;
  if (worst_out) *worst_out = worst;
}

bool star_positive_at(const TetMesh& m, const Scratch& s, const double* p) {
  for (int i = 0; i < s.n; ++i) {
    const LocalTet& T = s.tets[i];
    if (orient3d(p, m.point(T.ia), m.point(T.ib), m.point(T.ic)) != Sign::Positive) return false;
  }
  return true;
}

// ---- Paper optimiser: steepest descent + Alg. 3 bracketing + Alg. 2 golden section ----

struct LineFn {
  const Scratch& s;
  const double* x;
  const double* d;
  double operator()(double t) const {
    const double y[3] = {x[0] + t * d[0], x[1] + t * d[1], x[2] + t * d[2]};
    return star_f(s, y);
  }
};

// Advance-retreat interval search (paper Alg. 3): finds a < tb < c with
// phi(tb) < phi(a) and phi(tb) <= phi(c).  Starting from t = h, it retreats
// (shrinks h by 4) while phi(h) >= phi(0), otherwise advances with doubling
// steps until phi stops decreasing.  False when no t > 0 improves on phi(0).
bool bracket(const LineFn& phi, double f0, double h, double& a, double& c, double& tb, double& fb) {
  double t1 = h, f1 = phi(t1);
  if (!(f1 < f0)) {
    double prev = t1;
    for (int k = 0; k < 24 && !(f1 < f0); ++k) {
      prev = t1;
      t1 *= 0.25;
      f1 = phi(t1);
    }
    if (!(f1 < f0)) return false;
    a = 0; c = prev; tb = t1; fb = f1;
    return true;
  }
  double t0 = 0;
  double step = h;
  for (int k = 0; k < 40; ++k) {
    step *= 2;
    const double t2 = t1 + step, f2 = phi(t2);
    if (!(f2 < f1)) {
      a = t0; c = t2; tb = t1; fb = f1;
      return true;
    }
    t0 = t1; t1 = t2; f1 = f2;
  }
  a = t0; c = t1; tb = t1; fb = f1;
  return true;
}

// Golden-section search on [a, c] (paper Alg. 2) to |mu - nu| < eps.  Ties
// (including two infinite values: both points beyond an inversion) move the
// interval left, toward the known finite value.  Returns the best point seen,
// starting from the bracket's (tb, fb).
void golden(const LineFn& phi, double a, double c, double eps, double& tb, double& fb) {
  double mu = a + kGoldLo * (c - a), nu = a + kGoldHi * (c - a);
  double fmu = phi(mu), fnu = phi(nu);
  for (int i = 0; i < 200 && std::fabs(nu - mu) >= eps; ++i) {
    if (!(fmu > fnu)) {
      if (fmu < fb) { fb = fmu; tb = mu; }
      c = nu; nu = mu; fnu = fmu;
      mu = a + kGoldLo * (c - a);
      fmu = phi(mu);
    } else {
      if (fnu < fb) { fb = fnu; tb = nu; }
      a = mu; mu = nu; fmu = fnu;
      nu = a + kGoldHi * (c - a);
      fnu = phi(nu);
    }
  }
  const double lam = 0.5 * (mu + nu), fl = phi(lam);
  if (fmu < fb) { fb = fmu; tb = mu; }
  if (fnu < fb) { fb = fnu; tb = nu; }
  if (fl < fb) { fb = fl; tb = lam; }
}

// Minimises f_v from x = 0; leaves the best position in x.  False when the
// star is invalid at the start.
bool optimize_paper(const Scratch& s, const SmoothOptions& o, double* x) {
  x[0] = x[1] = x[2] = 0;
  double g[3];
  double f = star_f_grad(s, x, g);
  if (!std::isfinite(f)) return false;
  const double eps = o.line_tol * s.mean_len;
  double h = 0.05 * s.mean_len;
  for (int step = 0; step < o.max_steps; ++step) {
    const double gn = norm(g);
    if (!(gn > 0) || !std::isfinite(gn)) break;
    const double d[3] = {-g[0] / gn, -g[1] / gn, -g[2] / gn};
    LineFn phi{s, x, d};
    double a, c, tb, fb;
    if (!bracket(phi, f, h, a, c, tb, fb)) break;
    golden(phi, a, c, eps, tb, fb);
    if (!(fb < f)) break;
    for (int k = 0; k < 3; ++k) x[k] += tb * d[k];
    const double gain = f - fb;
    h = std::max(0.5 * tb, 1e-3 * s.mean_len);
    if (gain < o.step_tol * fb) break;
    f = star_f_grad(s, x, g);
  }
  return true;
}

// ---- MaxMin optimiser (Freitag et al.) ----

// Minimum-norm point of the convex hull of k <= 8 vectors G[3i..3i+2]: the
// steepest direction d that raises every active alpha at rate >= |d|^2.  It
// lies on a face of at most three of them (Caratheodory in R^3) and is the one
// candidate with g_j . d >= |d|^2 for all j.  Zero when the origin is in the
// hull (x is stationary for the max-min problem).
void min_norm_point(const double* G, int k, double* d) {
  double best = kInf;
  d[0] = d[1] = d[2] = 0;
  auto consider = [&](const double* p) {
    const double pp = dot(p, p);
    if (!(pp < best)) return;
    const double tol = 1e-12 * std::max(pp, 1e-300);
    for (int j = 0; j < k; ++j)
      if (dot(G + 3 * j, p) < pp - tol) return;
    best = pp;
    d[0] = p[0]; d[1] = p[1]; d[2] = p[2];
  };
  for (int i = 0; i < k; ++i) consider(G + 3 * i);
  for (int i = 0; i < k; ++i)
    for (int j = i + 1; j < k; ++j) {
      const double* gi = G + 3 * i;
      double e[3];
      sub(G + 3 * j, gi, e);
      const double ee = dot(e, e);
      if (!(ee > 0)) continue;
      const double t = -dot(gi, e) / ee;
      if (!(t > 0 && t < 1)) continue;
      const double p[3] = {gi[0] + t * e[0], gi[1] + t * e[1], gi[2] + t * e[2]};
      consider(p);
    }
  for (int i = 0; i < k; ++i)
    for (int j = i + 1; j < k; ++j)
      for (int l = j + 1; l < k; ++l) {
        const double* gi = G + 3 * i;
        double e1[3], e2[3];
        sub(G + 3 * j, gi, e1);
        sub(G + 3 * l, gi, e2);
        // minimise |gi + s e1 + t e2|^2: normal equations
        const double a11 = dot(e1, e1), a12 = dot(e1, e2), a22 = dot(e2, e2);
        const double b1 = -dot(gi, e1), b2 = -dot(gi, e2);
        const double det = a11 * a22 - a12 * a12;
        if (!(det > 1e-14 * a11 * a22)) continue;
        const double sc = (b1 * a22 - b2 * a12) / det, tc = (a11 * b2 - a12 * b1) / det;
        if (!(sc > 0 && tc > 0 && sc + tc < 1)) continue;
        const double p[3] = {gi[0] + sc * e1[0] + tc * e2[0], gi[1] + sc * e1[1] + tc * e2[1],
                             gi[2] + sc * e1[2] + tc * e2[2]};
        consider(p);
      }
  if (best == kInf) d[0] = d[1] = d[2] = 0;
}

bool optimize_maxmin(Scratch& s, const SmoothOptions& o, double* x) {
  x[0] = x[1] = x[2] = 0;
  const int n = s.n;
  if (static_cast<int>(s.alpha.size()) < n) {
    s.alpha.resize(n);
    s.grad.resize(3 * static_cast<size_t>(n));
  }
  constexpr int kMaxActive = 8;
  for (int step = 0; step < o.max_steps; ++step) {
    double amin = kInf;
    for (int i = 0; i < n; ++i) {
      double ge[3];
      const double e = local_error(s.tets[i], x, ge);
      if (e == kInf) return step > 0;
      const double a = 1.0 / e, f = -a * a;  // grad alpha = -grad e / e^2
      s.alpha[i] = a;
      s.grad[3 * i] = f * ge[0]; s.grad[3 * i + 1] = f * ge[1]; s.grad[3 * i + 2] = f * ge[2];
      amin = std::min(amin, a);
    }
    // Active set: the (at most kMaxActive) smallest alphas within active_tol.
    int act[kMaxActive];
    int k = 0;
    const double lim = amin * (1.0 + o.active_tol);
    for (int i = 0; i < n; ++i) {
      if (s.alpha[i] > lim) continue;
      if (k < kMaxActive) {
        act[k++] = i;
      } else {
        int worst = 0;
        for (int j = 1; j < k; ++j)
          if (s.alpha[act[j]] > s.alpha[act[worst]]) worst = j;
        if (s.alpha[i] < s.alpha[act[worst]]) act[worst] = i;
      }
    }
    double G[3 * kMaxActive];
    for (int j = 0; j < k; ++j)
      for (int c = 0; c < 3; ++c) G[3 * j + c] = s.grad[3 * act[j] + c];
    double d[3];
    min_norm_point(G, k, d);
    const double r = dot(d, d);
    if (!(r > 0)) break;
    // Predicted step: where the linear model of an inactive tet meets the
    // rising worst (Freitag et al. 1995), capped to a quarter of the star size.
    double sstep = 0.25 * s.mean_len / std::sqrt(r);
    for (int i = 0; i < n; ++i) {
      const double gd = dot(&s.grad[3 * i], d);
      if (gd < r && s.alpha[i] > lim) sstep = std::min(sstep, (s.alpha[i] - amin) / (r - gd));
    }
    bool moved = false;
    double anew = amin;
    for (int h = 0; h < 12; ++h, sstep *= 0.5) {
      const double y[3] = {x[0] + sstep * d[0], x[1] + sstep * d[1], x[2] + sstep * d[2]};
      anew = star_worst_alpha(s, y);
      if (anew > amin) {
        x[0] = y[0]; x[1] = y[1]; x[2] = y[2];
        moved = true;
        break;
      }
    }
    if (!moved || anew - amin < o.step_tol * amin) break;
  }
  return true;
}

}  // namespace

double tet_error_and_gradient(const double* const p[4], int which, double grad[3]) {
  const double* x = p[which];
  LocalTet L;
  sub(p[kFaceVertex[which][0]], x, L.a);
  sub(p[kFaceVertex[which][1]], x, L.b);
  sub(p[kFaceVertex[which][2]], x, L.c);
  double ab[3], ac[3], bc[3];
  sub(L.b, L.a, ab);
  sub(L.c, L.a, ac);
  sub(L.c, L.b, bc);
  cross(ab, ac, L.n0);
  L.n0len = norm(L.n0);
  L.lfix2 = std::max({dot(ab, ab), dot(ac, ac), dot(bc, bc)});
  L.w = 1;
  L.obj = Objective::Alpha;  // was left unset: a garbage value sent some calls down objective_error
  const double zero[3] = {0, 0, 0};
  return local_error(L, zero, grad);
}

int detail::star_errors_mismatches(const TetMesh& m, int32_t v, const double* dx, double C, int* finite) {
  Scratch s;
  s.obj = Objective::Alpha;
  gather(m, v, clamp_weight(C), s);
  int bad = 0, fin = 0;
  double e[4];
  for (int i0 = 0; i0 < s.n; i0 += 4) {
    star_errors4(s, i0, dx, e);
    for (int l = 0; l < 4 && i0 + l < s.n; ++l) {
      const double ref = local_error(s.tets[i0 + l], dx, nullptr);
      bad += std::memcmp(&ref, &e[l], sizeof ref) != 0;
      fin += std::isfinite(ref);
    }
  }
  if (finite) *finite = fin;
  return bad;
}

double vertex_objective(const TetMesh& m, int32_t v, double weight) {
  double f = 0;
  star_at(m, v, m.point(v), clamp_weight(weight), &f, nullptr);
  return f;
}

double mesh_objective(const TetMesh& m, double weight) {
  const double C = clamp_weight(weight);
  Sum s;
  for (int32_t t = 0; t < m.nt(); ++t) {
    LocalTet L;
    const double* origin = m.point(m.tet(t)[0]);
    make_local(m, t, 0, origin, tet_weight(m, t, C), L);
    const double zero[3] = {0, 0, 0};
    const double e = local_error(L, zero, nullptr);
    if (e == kInf) return kInf;
    s.add(L.w * e);
  }
  return s.value();
}

namespace {

// One vertex solve (see the essay: optimisers and commit rule).  own_before /
// own_after receive the vertex's own measure before and after (Paper: f_v,
// MaxMin: the star's worst alpha) and, after Applied, s.star_alpha holds the
// alpha of every star tet (CSR order) at the new position: bit for bit what
// tet_alpha() returns there, so a pass can update its cache without
// recomputing.
SmoothResult solve_vertex(TetMesh& m, int32_t v, const SmoothOptions& o, Scratch& s, double& own_before,
                          double& own_after) {
  if (m.vert_constrained[v] || m.star_begin(v) == m.star_end(v)) return SmoothResult::BoundaryLocked;
  const double C = clamp_weight(o.weight);
  s.obj = o.objective;
  const bool maxmin = o.optimizer == Optimizer::MaxMin;
  double x[3] = {0, 0, 0};
  if (o.optimizer == Optimizer::SmartLaplace) {
    // The mean of the star's other vertices (each counted once per star tet),
    // as a step from v: no local frames, no search.
    const double* org = m.point(v);
    s.origin[0] = org[0]; s.origin[1] = org[1]; s.origin[2] = org[2];
    s.n = static_cast<int>(m.star_end(v) - m.star_begin(v));
    if (static_cast<int>(s.tets.size()) < s.n) s.tets.resize(s.n);
    for (int i = 0; i < s.n; ++i) {
      const int32_t t = m.star_begin(v)[i];
      const int32_t* tv = m.tet(t);
      LocalTet& L = s.tets[i];  // only the vertex ids: star_positive_at reads them
      const int slot = slot_of(m, t, v);
      L.ia = tv[kFaceVertex[slot][0]];
      L.ib = tv[kFaceVertex[slot][1]];
      L.ic = tv[kFaceVertex[slot][2]];
      for (const int32_t u : {L.ia, L.ib, L.ic}) {
        const double* q = m.point(u);
        x[0] += q[0] - org[0]; x[1] += q[1] - org[1]; x[2] += q[2] - org[2];
      }
    }
    for (double& c : x) c /= 3.0 * s.n;
  } else {
    gather(m, v, C, s);
    const bool ok = maxmin ? optimize_maxmin(s, o, x) : optimize_paper(s, o, x);
    if (!ok) return SmoothResult::Inverted;
  }
  if (static_cast<int>(s.star_alpha.size()) < s.n) s.star_alpha.resize(s.n);

  double f_old = 0, worst_old = 0;
  star_at(m, v, s.origin, C, maxmin ? nullptr : &f_old, &worst_old, nullptr, o.objective);
  own_before = maxmin ? worst_old : f_old;
  bool inverted = false;
  for (int attempt = 0; attempt < 5; ++attempt, x[0] *= 0.5, x[1] *= 0.5, x[2] *= 0.5) {
    const double p[3] = {s.origin[0] + x[0], s.origin[1] + x[1], s.origin[2] + x[2]};
    if (p[0] == s.origin[0] && p[1] == s.origin[1] && p[2] == s.origin[2]) break;
    if (!star_positive_at(m, s, p)) {
      inverted = true;
      continue;
    }
    double f_new = 0, worst_new = 0;
    star_at(m, v, p, C, maxmin ? nullptr : &f_new, &worst_new, s.star_alpha.data(), o.objective);
    bool accept;
    if (maxmin) {
      accept = worst_old > 0 ? worst_new >= worst_old + o.margin * worst_old : worst_new > worst_old;
    } else {
      accept = std::isfinite(f_new) && f_new <= f_old - o.margin * f_old;
      if (accept && o.protect_worst) accept = worst_new >= worst_old;
    }
    if (!accept) continue;
    if (o.guard) {  // guards (guard.hpp): no star tet at p worse than the extremes
      bool admitted = true;
      for (const int32_t* it = m.star_begin(v); it != m.star_end(v) && admitted; ++it) {
        const int32_t* tv = m.tet(*it);
        const double* q4[4];
        for (int k = 0; k < 4; ++k) q4[k] = tv[k] == v ? p : m.point(tv[k]);
        admitted = o.guard->admits(q4[0], q4[1], q4[2], q4[3]);
      }
      if (!admitted) continue;
    }
    double* q = m.point(v);
    q[0] = p[0]; q[1] = p[1]; q[2] = p[2];
    own_after = maxmin ? worst_new : f_new;
    return SmoothResult::Applied;
  }
  return inverted ? SmoothResult::Inverted : SmoothResult::NotImproved;
}

Scratch& thread_scratch() {
  thread_local Scratch s;
  return s;
}

// A minimal fork-join pool for one pass: run(n, f) calls f(i) for every i in
// [0, n) on the calling thread and the workers (chunks handed out through an
// atomic counter) and returns when all calls are done.  Which thread runs
// which i is left to chance; callers make each f(i) write only its own data,
// so results never depend on it.
class WorkerPool {
 public:
  explicit WorkerPool(int threads) {
    for (int i = 1; i < threads; ++i) workers_.emplace_back([this] { loop(); });
  }
  ~WorkerPool() {
    {
      std::lock_guard<std::mutex> l(mu_);
      quit_ = true;
      ++generation_;
    }
    wake_.notify_all();
    for (std::thread& w : workers_) w.join();
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  void run(int64_t n, int64_t chunk, const std::function<void(int64_t)>& f) {
    if (workers_.empty() || n <= chunk) {
      for (int64_t i = 0; i < n; ++i) f(i);
      return;
    }
    {
      std::lock_guard<std::mutex> l(mu_);
      job_ = &f;
      n_ = n;
      chunk_ = chunk;
      next_.store(0, std::memory_order_relaxed);
      busy_ = static_cast<int>(workers_.size());
      ++generation_;
    }
    wake_.notify_all();
    work();
    std::unique_lock<std::mutex> l(mu_);
    done_.wait(l, [this] { return busy_ == 0; });
    job_ = nullptr;
  }

 private:
  void work() {
    for (;;) {
      const int64_t b = next_.fetch_add(chunk_, std::memory_order_relaxed);
      if (b >= n_) return;
      const int64_t e = std::min(n_, b + chunk_);
      for (int64_t i = b; i < e; ++i) (*job_)(i);
    }
  }
  void loop() {
    uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> l(mu_);
        wake_.wait(l, [&] { return generation_ != seen; });
        seen = generation_;
        if (quit_) return;
      }
      work();
      std::lock_guard<std::mutex> l(mu_);
      if (--busy_ == 0) done_.notify_one();
    }
  }

  std::vector<std::thread> workers_;
  std::mutex mu_;
  std::condition_variable wake_, done_;
  const std::function<void(int64_t)>* job_ = nullptr;
  int64_t n_ = 0, chunk_ = 1;
  std::atomic<int64_t> next_{0};
  int busy_ = 0;
  uint64_t generation_ = 0;
  bool quit_ = false;
};

}  // namespace

SmoothResult smooth_vertex(TetMesh& m, int32_t v, const SmoothOptions& o) {
  double before = 0, after = 0;
  return solve_vertex(m, v, o, thread_scratch(), before, after);
}

SmoothStats smooth_pass(TetMesh& m, const SmoothOptions& o, const LogFn& log) {
  return smooth_pass(m, o, log, nullptr);
}

SmoothStats smooth_pass(TetMesh& m, const SmoothOptions& o, const LogFn& log, std::vector<double>* alpha_cache) {
  const auto t_start = std::chrono::steady_clock::now();
  SmoothStats st;
  const int32_t nv = m.nv(), nt = m.nt();
  const double C = clamp_weight(o.weight);
  const int threads = detail::resolve_threads(o.threads);
  ensure_vertex_tets(m, threads);  // absent after topology passes run without rebuild_stars
  std::unique_ptr<WorkerPool> pool;
  auto get_pool = [&]() -> WorkerPool& {
    if (!pool) pool = std::make_unique<WorkerPool>(threads);
    return *pool;
  };

  // Per-tet alpha cache: the caller's when it has the right size (trusted),
  // else computed here (detail::parallel_for_each: every entry is independent).
  std::vector<double> own_cache;
  std::vector<double>& qa = alpha_cache ? *alpha_cache : own_cache;
  if (static_cast<int32_t>(qa.size()) != nt) {
    qa.resize(nt);
    detail::parallel_for_each(nt, threads,
                              [&](int64_t t) { qa[t] = tet_objective(m, static_cast<int32_t>(t), o.objective); });
  }
  // f of eq. 3.4 from the cache: sum of w_T / alpha_T, per fixed block of
  // tets and then over the blocks in order (the same bits for every thread
  // count).  These O(nt) scans ran serially twice per pass: with the small
  // active sets of mode best's later rounds they were most of a max-min
  // pass at 2 threads (demo impeller: 0.033 s of 0.036).
  auto objective = [&] {
    struct Part {
      Sum s;
      bool inf = false;
    };
    Sum total;
    for (const Part& p : detail::parallel_map_blocks(nt, threads, [&](int64_t b, int64_t e) {
           Part p;
           for (int64_t t = b; t < e && !p.inf; ++t) {
             if (!(qa[t] > 0)) p.inf = true;
             else p.s.add(tet_weight(m, static_cast<int32_t>(t), C) / qa[t]);
           }
           return p;
         })) {
      if (p.inf) return kInf;
      total.add(p.s);
    }
    return total.value();
  };
  auto worst_of_cache = [&] {
    return nt ? detail::parallel_min(nt, threads, [&](int64_t t) { return qa[t]; }) : 0.0;
  };
  st.objective_before = objective();
  st.worst_alpha_before = worst_of_cache();

  // Per-vertex state, allocated once per pass (flat arrays, no per-vertex
  // containers): visit stamps and colours of the current sweep.
  std::vector<uint32_t> stamp(nv, 0);
  uint32_t epoch = 0;
  std::vector<int32_t> colour(nv, -1);
  std::vector<uint64_t> colour_seen;  // per colour: stamp of the last vertex that saw it
  uint64_t seen_epoch = 0;
  std::vector<int32_t> active, moved, order, class_start, cursor;
  std::vector<uint8_t> result, reactivate, poor;
  std::mt19937_64 rng(o.seed);

  auto is_free = [&](int32_t u) { return !m.vert_constrained[u] && m.star_begin(u) != m.star_end(u); };
  auto touches_poor = [&](int32_t u) {
    for (const int32_t* it = m.star_begin(u); it != m.star_end(u); ++it)
      if (qa[*it] < o.threshold) return true;
    return false;
  };

  // One vertex of the current colour class; writes only its own slots of
  // result / reactivate, its own coordinates and the cache entries of its own
  // star (disjoint from every other vertex of the class).
  auto visit = [&](int64_t i) {
    const int32_t v = order[i];
    Scratch& s = thread_scratch();
    double before = 0, after = 0;
    const SmoothResult r = solve_vertex(m, v, o, s, before, after);
    result[i] = static_cast<uint8_t>(r);
    reactivate[i] = 0;
    if (r != SmoothResult::Applied) return;
    const int32_t* b = m.star_begin(v);
    const int n = static_cast<int>(m.star_end(v) - b);
    for (int k = 0; k < n; ++k) qa[b[k]] = s.star_alpha[k];
    if (o.reactivate_gain > 0) {
      const bool maxmin = o.optimizer == Optimizer::MaxMin;
      const double gain = maxmin ? after - before : before - after;
      reactivate[i] = gain >= o.reactivate_gain * std::fabs(maxmin ? before : after);
    } else {
      reactivate[i] = 1;
    }
  };

  for (int phase = 0; phase < (o.all_vertices ? 2 : 1) && !(o.stop && o.stop->load()); ++phase) {
    active.clear();
    ++epoch;
    if (phase == 0) {
      for (const int32_t t : detail::parallel_select(nt, threads, [&](int64_t t) { return qa[t] < o.threshold; })) {
        const int32_t* tv = m.tet(t);
        for (int k = 0; k < 4; ++k)
          if (stamp[tv[k]] != epoch && is_free(tv[k])) {
            stamp[tv[k]] = epoch;
            active.push_back(tv[k]);
          }
      }
      std::sort(active.begin(), active.end());
      st.initial_active = static_cast<int64_t>(active.size());
    } else {
      for (int32_t u = 0; u < nv; ++u)
        if (is_free(u)) active.push_back(u);
    }
    for (int sweep = 0; sweep < o.iterations && !active.empty() && !(o.stop && o.stop->load()); ++sweep) {
      // Fisher-Yates with the engine's raw output (portable, unlike std::shuffle).
      for (size_t i = active.size(); i > 1; --i) std::swap(active[i - 1], active[rng() % i]);
      // Greedy colouring in the shuffled order: each vertex takes the
      // smallest colour no already-coloured active neighbour has.  Vertices
      // of one colour share no tet, so their stars share no free vertex and
      // their solves are independent: a class can run in any order or in
      // parallel with the same result.
      int ncolours = 0;
      for (const int32_t v : active) {
        ++seen_epoch;
        for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
          const int32_t* tv = m.tet(*it);
          for (int k = 0; k < 4; ++k)
            if (colour[tv[k]] >= 0) colour_seen[colour[tv[k]]] = seen_epoch;
        }
        int c = 0;
        while (c < ncolours && colour_seen[c] == seen_epoch) ++c;
        if (c == ncolours) {
          ++ncolours;
          if (static_cast<int>(colour_seen.size()) < ncolours) colour_seen.push_back(0);
        }
        colour[v] = c;
      }
      // Classes in colour order, each in the shuffled order (counting sort).
      class_start.assign(ncolours + 1, 0);
      for (const int32_t v : active) ++class_start[colour[v] + 1];
      for (int c = 0; c < ncolours; ++c) class_start[c + 1] += class_start[c];
      order.resize(active.size());
      cursor.assign(class_start.begin(), class_start.end() - 1);
      for (const int32_t v : active) order[cursor[colour[v]]++] = v;
      for (const int32_t v : active) colour[v] = -1;
      result.assign(order.size(), 0);
      reactivate.assign(order.size(), 0);

      // o.stop (an abort): the pass ends between two classes; the classes
      // visited are counted.
      size_t visited = order.size();
      for (int c = 0; c < ncolours; ++c) {
        if (o.stop && o.stop->load(std::memory_order_relaxed)) {
          visited = static_cast<size_t>(class_start[c]);
          break;
        }
        const int64_t b = class_start[c], n = class_start[c + 1] - b;
        auto visit_class = [&](int64_t i) { visit(b + i); };
        if (threads > 1 && n >= 64) get_pool().run(n, 8, visit_class);
        else for (int64_t i = 0; i < n; ++i) visit_class(i);
      }

      moved.clear();
      int64_t applied_now = 0;
      for (size_t i = 0; i < visited; ++i) {
        st.moves_tried += result[i] != static_cast<uint8_t>(SmoothResult::BoundaryLocked);
        switch (static_cast<SmoothResult>(result[i])) {
          case SmoothResult::Applied:
            ++applied_now;
            if (reactivate[i]) moved.push_back(order[i]);
            break;
          case SmoothResult::NotImproved: st.not_improved++; break;
          case SmoothResult::Inverted: st.rejected_inverted++; break;
          case SmoothResult::BoundaryLocked: break;
        }
      }
      st.moves_applied += applied_now;
      st.sweeps++;
      if (log) {
        char buf[220];
        std::snprintf(buf, sizeof buf,
                      "smooth phase %d sweep %d: %zu active in %d colours, %lld moved (%zu re-activating), worst alpha %.6g",
                      phase + 1, sweep + 1, active.size(), ncolours, static_cast<long long>(applied_now),
                      moved.size(), worst_of_cache());
        log(LogLevel::Progress, buf);
      }
      if (visited < order.size()) break;  // stopped
      if (moved.empty()) break;  // nothing (worth re-visiting) changed
      // The free vertices of the moved vertices' stars, each once; in phase
      // 0 only those touching a poor tet.  That test reads a star's cached
      // alphas per candidate (the larger part of this serial loop at 2
      // threads on the demo impeller): it runs on the pool, a flag per
      // candidate.  The list is sorted after, so the order found is moot.
      active.clear();
      ++epoch;
      for (const int32_t v : moved)
        for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
          const int32_t* tv = m.tet(*it);
          for (int k = 0; k < 4; ++k) {
            const int32_t u = tv[k];
            if (stamp[u] == epoch) continue;
            stamp[u] = epoch;
            if (is_free(u)) active.push_back(u);
          }
        }
      if (phase == 0) {
        poor.assign(active.size(), 0);
        auto test = [&](int64_t i) { poor[i] = touches_poor(active[i]); };
        const auto na = static_cast<int64_t>(active.size());
        if (threads > 1 && na >= 512) get_pool().run(na, 64, test);
        else for (int64_t i = 0; i < na; ++i) test(i);
        size_t kept = 0;
        for (size_t i = 0; i < active.size(); ++i)
          if (poor[i]) active[kept++] = active[i];
        active.resize(kept);
      }
      std::sort(active.begin(), active.end());
    }
  }
  st.worst_alpha_after = worst_of_cache();
  st.objective_after = objective();
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return st;
}

}  // namespace tetopt
