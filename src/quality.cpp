// Quality measures and statistics (see quality.hpp).
#include "tetopt/quality.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>

#include "detail/parallel.hpp"
#include "detail/sum.hpp"
#include "detail/tet_kernels.hpp"
#include "detail/vec3.hpp"
#include "tetopt/conventions.hpp"
#include "tetopt/mesh.hpp"

namespace tetopt {
namespace {
using detail::cross;
using detail::dot;
using detail::norm;
using detail::sub;
// cos(10 j degrees), j = 1..17, decreasing: histogram bin edges.
const std::array<double, 17> kBinCos = [] {
  std::array<double, 17> c{};
  for (int j = 1; j <= 17; ++j) c[j - 1] = std::cos(10.0 * j * M_PI / 180.0);
  return c;
}();
const double kCos5 = std::cos(5.0 * M_PI / 180.0), kCos175 = std::cos(175.0 * M_PI / 180.0);

using detail::Sum;
}  // namespace

double tet_signed_volume(const double* a, const double* b, const double* c, const double* d) {
  double u[3], v[3], w[3], x[3];
  sub(b, a, u); sub(c, a, v); sub(d, a, w);
  cross(v, w, x);
  return dot(u, x) / 6.0;
}

using detail::alpha_from;
using detail::EdgeLengths2;
using detail::edge_lengths2;
using detail::face_area_sum;
using detail::mean_ratio_from;
using detail::radius_ratio_from;

double alpha(const double* a, const double* b, const double* c, const double* d) {
  const double* p[4] = {a, b, c, d};
  return alpha_from(tet_signed_volume(a, b, c, d), face_area_sum(p), edge_lengths2(p).max);
}

namespace {
// Each edge's dihedral angle as atan2(s[e], c[e]), from the normals n of
// the two faces at the edge (the faces opposite the vertices of the
// opposite edge, both outward or both inward): c = -n_f . n_g and
// s = |n_f x n_g|, so that c / (|n_f| |n_g|) is the angle's cosine and
// |n_f x n_g| = |n_f| |n_g| sin(theta) (= 6 |V| |e|).  Four normals for the
// six edges: a third of the work of projecting the two other vertices on
// the plane normal to each edge (the former way, 16% of a hinge_raw run
// with insertion went to it).  The points are taken relative to the first;
// where the largest coordinate difference is beyond 2^+-120 they are scaled
// by a power of two (exact) into [0.5, 1), so that products of four lengths
// neither overflow nor underflow (the unit test has scales of 1e+-150).
// Returns false for a non-finite input.
struct DihedralParts {
  double n[4][3], nl[4];
};
bool dihedral_parts(const double* const p[4], DihedralParts& d) {
  double q[4][3] = {};
  double big = 0;
  for (int k = 1; k < 4; ++k)
    for (int j = 0; j < 3; ++j) {
      q[k][j] = p[k][j] - p[0][j];
      big = std::max(big, std::fabs(q[k][j]));
    }
  if (!std::isfinite(big)) return false;
  // Only far from 1 (a libm call per tet cost 4% of a run).  A power of two
  // scales s and c alike and exactly, so the angles do not depend on it.
  if (big > 0 && (big > 0x1p+120 || big < 0x1p-120)) {
    int ex = 0;
    std::frexp(big, &ex);
    const double scale = std::ldexp(1.0, -ex);
    for (int k = 1; k < 4; ++k)
      for (int j = 0; j < 3; ++j) q[k][j] *= scale;
  }
  const double* qp[4] = {q[0], q[1], q[2], q[3]};
  detail::face_normals(qp, d.n, d.nl);
  return true;
}
// The two faces at edge e.
inline int face_a(int e) { return kEdgeVertex[kEdgeOpposite[e]][0]; }
inline int face_b(int e) { return kEdgeVertex[kEdgeOpposite[e]][1]; }
void edge_sin_cos(const DihedralParts& d, int e, double& s, double& cth) {
  const double *nf = d.n[face_a(e)], *ng = d.n[face_b(e)];
  double x[3];
  cross(nf, ng, x);
  s = norm(x);
  cth = -dot(nf, ng);
}
double angle_deg(double s, double cth) { return (s == 0 && cth == 0) ? 0.0 : std::atan2(s, cth) * (180.0 / M_PI); }
}  // namespace

void dihedral_angles(const double* a, const double* b, const double* c, const double* d,
                     double out[6]) {
  const double* p[4] = {a, b, c, d};
  DihedralParts dp;
  if (!dihedral_parts(p, dp)) {
    for (int e = 0; e < 6; ++e) out[e] = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  for (int e = 0; e < 6; ++e) {
    double s, cth;
    edge_sin_cos(dp, e, s, cth);
    out[e] = angle_deg(s, cth);
  }
}

void dihedral_extremes(const double* a, const double* b, const double* c, const double* d, double& lo_deg,
                       double& hi_deg) {
  const double* p[4] = {a, b, c, d};
  DihedralParts dp;
  double cosine[6];
  bool finite = dihedral_parts(p, dp);
  for (int e = 0; e < 6 && finite; ++e) {
    // The cosine from the two normals' lengths; a degenerate face (zero
    // normal) gives the angle 0, as atan2's (0, 0) case does.
    const int f = face_a(e), g = face_b(e);
    const double den = dp.nl[f] * dp.nl[g];
    cosine[e] = den > 0 ? -dot(dp.n[f], dp.n[g]) / den : 1.0;
    finite = std::isfinite(cosine[e]);
  }
  lo_deg = std::numeric_limits<double>::infinity();
  hi_deg = -std::numeric_limits<double>::infinity();
  if (!finite) {  // NaN or infinite input: the six angles as dihedral_angles has them
    double dh[6];
    dihedral_angles(a, b, c, d, dh);
    lo_deg = *std::min_element(dh, dh + 6);
    hi_deg = *std::max_element(dh, dh + 6);
    return;
  }
  // atan2 only where the cosine is within kTie of the largest (smallest).
  // The cosine c / (|n_f| |n_g|) and the c / sqrt(s^2 + c^2) that atan2(s,
  // c) orders by differ by a few ulps (Lagrange's identity, with s and c
  // computed from the same two vectors), far below kTie, so the edge whose
  // atan2 is the smallest (largest) is always among them and the result is
  // the min (max) of dihedral_angles, bit for bit (the unit test
  // DihedralExtremesEqualTheMinAndMaxOfTheSixAngles checks it).
  constexpr double kTie = 1e-9;
  const double cmax = *std::max_element(cosine, cosine + 6), cmin = *std::min_element(cosine, cosine + 6);
  for (int e = 0; e < 6; ++e) {
    const bool at_lo = cosine[e] >= cmax - kTie, at_hi = cosine[e] <= cmin + kTie;
    if (!at_lo && !at_hi) continue;
    double s, cth;
    edge_sin_cos(dp, e, s, cth);
    const double ang = angle_deg(s, cth);
    if (at_lo) lo_deg = std::min(lo_deg, ang);
    if (at_hi) hi_deg = std::max(hi_deg, ang);
  }
}

double mean_ratio(const double* a, const double* b, const double* c, const double* d) {
  const double* p[4] = {a, b, c, d};
  return mean_ratio_from(tet_signed_volume(a, b, c, d), edge_lengths2(p).sum);
}

double radius_ratio(const double* a, const double* b, const double* c, const double* d) {
  const double* p[4] = {a, b, c, d};
  return radius_ratio_from(p, tet_signed_volume(a, b, c, d), face_area_sum(p));
}

double tet_alpha(const TetMesh& m, int32_t t) {
  const int32_t* v = m.tet(t);
  return alpha(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]));
}

namespace {
// Per-block partial statistics of compute_stats, merged in block order.
struct StatsPart {
  QualityStats s;
  Sum all, bnd, inr;
  double cos_min_dih = -2, cos_max_dih = 2;  // largest / smallest cosine seen
  int32_t min_dih_tet = -1, max_dih_tet = -1;
  std::set<int32_t> refs;
  StatsPart() {
    s.alpha_worst = s.alpha_boundary_worst = s.alpha_interior_worst = INFINITY;
    s.mean_ratio_worst = s.radius_ratio_worst = INFINITY;
  }
};

// a then b (b's tets come after a's): "first tet wins" ties stay as serial.
void merge(StatsPart& a, const StatsPart& b) {
  for (int k = 0; k < 5; ++k) a.s.kind_count[k] += b.s.kind_count[k];
  a.all.add(b.all);
  a.bnd.add(b.bnd);
  a.inr.add(b.inr);
  if (b.s.alpha_worst < a.s.alpha_worst) { a.s.alpha_worst = b.s.alpha_worst; a.s.worst_tet = b.s.worst_tet; }
  a.s.alpha_boundary_worst = std::min(a.s.alpha_boundary_worst, b.s.alpha_boundary_worst);
  a.s.alpha_interior_worst = std::min(a.s.alpha_interior_worst, b.s.alpha_interior_worst);
  a.s.inverted_or_flat += b.s.inverted_or_flat;
  a.s.alpha_below_01 += b.s.alpha_below_01;
  a.s.alpha_below_02 += b.s.alpha_below_02;
  a.s.alpha_below_03 += b.s.alpha_below_03;
  for (size_t k = 0; k < a.s.alpha_histogram.size(); ++k) a.s.alpha_histogram[k] += b.s.alpha_histogram[k];
  for (size_t k = 0; k < a.s.dihedral_histogram.size(); ++k) a.s.dihedral_histogram[k] += b.s.dihedral_histogram[k];
  if (b.cos_min_dih > a.cos_min_dih) { a.cos_min_dih = b.cos_min_dih; a.min_dih_tet = b.min_dih_tet; }
  if (b.cos_max_dih < a.cos_max_dih) { a.cos_max_dih = b.cos_max_dih; a.max_dih_tet = b.max_dih_tet; }
  a.s.dihedral_below_5 += b.s.dihedral_below_5;
  a.s.dihedral_above_175 += b.s.dihedral_above_175;
  a.s.mean_ratio_worst = std::min(a.s.mean_ratio_worst, b.s.mean_ratio_worst);
  a.s.radius_ratio_worst = std::min(a.s.radius_ratio_worst, b.s.radius_ratio_worst);
  a.refs.insert(b.refs.begin(), b.refs.end());
}

// Per tet: alpha, mean ratio and radius ratio from one volume, one set of
// face normals and one set of edge lengths (the pieces alpha(),
// mean_ratio() and radius_ratio() are made of, so the same bits), and the
// dihedral cosines from the same normals.
void stats_block(const TetMesh& m, int32_t t0, int32_t t1, StatsPart& p) {
  QualityStats& s = p.s;
  const bool have_kind = static_cast<int32_t>(m.tet_kind.size()) == m.nt();
  int32_t last_ref = 0;
  for (int32_t t = t0; t < t1; ++t) {
    const int32_t* v = m.tet(t);
    const double* pt[4] = {m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])};
    const double vol = tet_signed_volume(pt[0], pt[1], pt[2], pt[3]);
    double n[4][3], nl[4], area = 0;  // face_area_sum, keeping the normals
    detail::face_normals(pt, n, nl);
    for (int f = 0; f < 4; ++f) area += 0.5 * nl[f];
    const EdgeLengths2 l2 = edge_lengths2(pt);
    const double q = alpha_from(vol, area, l2.max);
    const double mr = mean_ratio_from(vol, l2.sum);
    const double rr = radius_ratio_from(pt, vol, area);
    const int kind = have_kind ? m.tet_kind[t] : 0;
    s.kind_count[kind]++;
    p.all.add(q);
    if (q < s.alpha_worst) { s.alpha_worst = q; s.worst_tet = t; }
    if (kind > 0) { p.bnd.add(q); s.alpha_boundary_worst = std::min(s.alpha_boundary_worst, q); }
    else { p.inr.add(q); s.alpha_interior_worst = std::min(s.alpha_interior_worst, q); }
    if (q <= 0) s.inverted_or_flat++;
    if (q < 0.1) s.alpha_below_01++;
    if (q < 0.2) s.alpha_below_02++;
    if (q < 0.3) s.alpha_below_03++;
    int bin = q <= 0 ? 0 : std::min(9, static_cast<int>(q * 10));
    s.alpha_histogram[bin]++;
    // Dihedral cosines from the outward face normals (cheap); angles proper
    // (atan2, dihedral_angles) only for the extreme tets at the end.
    bool small = false, large = false;
    for (int e = 0; e < 6; ++e) {
      const int k = kEdgeVertex[kEdgeOpposite[e]][0], l = kEdgeVertex[kEdgeOpposite[e]][1];
      const double den = nl[k] * nl[l];
      double cs = den > 0 ? -dot(n[k], n[l]) / den : 1.0;
      cs = std::clamp(cs, -1.0, 1.0);
      if (cs > p.cos_min_dih) { p.cos_min_dih = cs; p.min_dih_tet = t; }
      if (cs < p.cos_max_dih) { p.cos_max_dih = cs; p.max_dih_tet = t; }
      // bin k holds angles in [10k, 10k+10): the number of bin edges
      // cos(10j deg) >= cs (kBinCos decreases; a NaN cosine goes last).
      int dbin = 0;
      for (double edge : kBinCos) dbin += edge >= cs;
      if (std::isnan(cs)) dbin = 17;
      s.dihedral_histogram[dbin]++;
      small |= cs > kCos5;
      large |= cs < kCos175;
    }
    s.dihedral_below_5 += small;
    s.dihedral_above_175 += large;
    s.mean_ratio_worst = std::min(s.mean_ratio_worst, mr);
    s.radius_ratio_worst = std::min(s.radius_ratio_worst, rr);
    const int32_t r = m.tet_ref.empty() ? 0 : m.tet_ref[t];
    if (t == t0 || r != last_ref) p.refs.insert(r);
    last_ref = r;
  }
}
}  // namespace

QualityStats compute_stats(const TetMesh& m, int threads, bool measures) {
  const int32_t nt = m.nt();
  // Fixed blocks merged in order: the same numbers for every thread count.
  StatsPart all;
  for (const StatsPart& p : detail::parallel_map_blocks(nt, threads, [&](int64_t b, int64_t e) {
         StatsPart part;
         stats_block(m, static_cast<int32_t>(b), static_cast<int32_t>(e), part);
         return part;
       }))
    merge(all, p);
  QualityStats& s = all.s;
  s.tets = nt;
  s.dihedral_min = INFINITY;
  s.dihedral_max = -INFINITY;
  std::vector<uint8_t> used(m.nv(), 0);
  for (int32_t v : m.tets) used[v] = 1;
  const int32_t min_dih_tet = all.min_dih_tet, max_dih_tet = all.max_dih_tet;
  const std::set<int32_t>& refs = all.refs;
  const Sum &all_sum = all.all, &bnd = all.bnd, &inr = all.inr;
  auto extreme = [&](int32_t t, bool want_min) {
    const int32_t* v = m.tet(t);
    double lo_deg, hi_deg;
    dihedral_extremes(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]), lo_deg, hi_deg);
    return want_min ? lo_deg : hi_deg;
  };
  if (min_dih_tet >= 0) s.dihedral_min = extreme(min_dih_tet, true);
  if (max_dih_tet >= 0) s.dihedral_max = extreme(max_dih_tet, false);
  for (uint8_t u : used) s.vertices += u;
  s.boundary_tets = nt - s.kind_count[0];
  s.all_boundary_tets = s.kind_count[4];
  s.regions = static_cast<int64_t>(refs.size());
  s.alpha_mean = nt ? all_sum.value() / nt : NAN;
  s.alpha_boundary_mean = s.boundary_tets ? bnd.value() / s.boundary_tets : NAN;
  s.alpha_interior_mean = s.kind_count[0] ? inr.value() / s.kind_count[0] : NAN;
  if (!s.boundary_tets) s.alpha_boundary_worst = NAN;
  if (!s.kind_count[0]) s.alpha_interior_worst = NAN;
  if (measures) s.measures = compute_measure_stats(m, threads);
  return all.s;
}

TetQualityFields compute_fields(const TetMesh& m) {
  TetQualityFields f;
  const int32_t nt = m.nt();
  f.alpha.resize(nt);
  f.dihedral_min.resize(nt);
  f.dihedral_max.resize(nt);
  for (int32_t t = 0; t < nt; ++t) {
    const int32_t* v = m.tet(t);
    const double *a = m.point(v[0]), *b = m.point(v[1]), *c = m.point(v[2]), *d = m.point(v[3]);
    f.alpha[t] = alpha(a, b, c, d);
    dihedral_extremes(a, b, c, d, f.dihedral_min[t], f.dihedral_max[t]);
  }
  return f;
}

namespace {
std::string num(double x) {
  if (std::isnan(x)) return "null";
  if (std::isinf(x)) return x > 0 ? "1e999" : "-1e999";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}
}  // namespace

std::string stats_to_json(const QualityStats& s, int indent) {
  const std::string pad(indent, ' ');
  std::ostringstream o;
  o << "{\n";
  auto kv = [&](const char* k, const std::string& v, bool last = false) {
    o << pad << "\"" << k << "\": " << v << (last ? "\n" : ",\n");
  };
  kv("vertices", std::to_string(s.vertices));
  kv("tets", std::to_string(s.tets));
  kv("boundary_tets", std::to_string(s.boundary_tets));
  kv("all_boundary_tets", std::to_string(s.all_boundary_tets));
  kv("kind_counts", "[" + std::to_string(s.kind_count[0]) + ", " + std::to_string(s.kind_count[1]) +
                        ", " + std::to_string(s.kind_count[2]) + ", " + std::to_string(s.kind_count[3]) +
                        ", " + std::to_string(s.kind_count[4]) + "]");
  kv("regions", std::to_string(s.regions));
  kv("alpha_worst", num(s.alpha_worst));
  kv("alpha_mean", num(s.alpha_mean));
  kv("alpha_boundary_worst", num(s.alpha_boundary_worst));
  kv("alpha_boundary_mean", num(s.alpha_boundary_mean));
  kv("alpha_interior_worst", num(s.alpha_interior_worst));
  kv("alpha_interior_mean", num(s.alpha_interior_mean));
  kv("alpha_below_0.1", std::to_string(s.alpha_below_01));
  kv("alpha_below_0.2", std::to_string(s.alpha_below_02));
  kv("alpha_below_0.3", std::to_string(s.alpha_below_03));
  kv("dihedral_min", num(s.dihedral_min));
  kv("dihedral_max", num(s.dihedral_max));
  kv("tets_dihedral_below_5", std::to_string(s.dihedral_below_5));
  kv("tets_dihedral_above_175", std::to_string(s.dihedral_above_175));
  kv("mean_ratio_worst", num(s.mean_ratio_worst));
  kv("radius_ratio_worst", num(s.radius_ratio_worst));
  kv("inverted_or_flat", std::to_string(s.inverted_or_flat));
  kv("worst_tet", std::to_string(s.worst_tet));
  std::string h = "[";
  for (size_t i = 0; i < s.alpha_histogram.size(); ++i)
    h += (i ? ", " : "") + std::to_string(s.alpha_histogram[i]);
  kv("alpha_histogram_0.1", h + "]");
  h = "[";
  for (size_t i = 0; i < s.dihedral_histogram.size(); ++i)
    h += (i ? ", " : "") + std::to_string(s.dihedral_histogram[i]);
  kv("dihedral_histogram_10deg", h + "]", !s.measures.computed);
  if (s.measures.computed) o << measure_stats_to_json(s.measures, indent) << "\n";
  o << std::string(indent > 2 ? indent - 2 : 0, ' ') << "}";
  return o.str();
}

}  // namespace tetopt
