// The measures table and its statistics (see measures.hpp, docs/measures.md).
#include "tetopt/measures.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <sstream>

#include "detail/parallel.hpp"
#include "detail/sum.hpp"
#include "detail/tet_kernels.hpp"
#include "detail/vec3.hpp"
#include "tetopt/conventions.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/quality.hpp"

namespace tetopt {
namespace {
using detail::cross;
using detail::dot;
using detail::norm;
using detail::sub;
using detail::Sum;

constexpr double kRad2Deg = 180.0 / M_PI;
// OpenFOAM's ROOTVSMALL for double (sqrt of VSMALL = 1e-300): the guard its
// checkMesh formulas add to denominators; kept so values match its own.
constexpr double kRootVSmall = 1e-150;
// 8√3/27: V_ideal = kIdealVolume·R³ for the regular tet of circumradius R
// (edge 4R/√6, volume edge³/(6√2)).
const double kIdealVolume = 8.0 * std::sqrt(3.0) / 27.0;
const double kSin5 = std::sin(5.0 * M_PI / 180.0);

inline void centroid4(const double* a, const double* b, const double* c, const double* d, double* g) {
  for (int k = 0; k < 3; ++k) g[k] = 0.25 * (a[k] + b[k] + c[k] + d[k]);
}
inline void centroid3(const double* a, const double* b, const double* c, double* g) {
  for (int k = 0; k < 3; ++k) g[k] = (a[k] + b[k] + c[k]) / 3.0;
}
// The face area vector OpenFOAM computes for a triangle: ½(b−a)×(c−a).
inline void area_vector(const double* a, const double* b, const double* c, double* s) {
  double u[3], v[3];
  sub(b, a, u);
  sub(c, a, v);
  cross(u, v, s);
  for (int k = 0; k < 3; ++k) s[k] *= 0.5;
}
// checkMesh's skewness from the face, its centre cf, area vector s, the
// vector cpf = cf − C_own, the vector d along which the skewness is measured
// and the factor of |d| below which fd does not go (0.2 interior, 0.4
// boundary): |sv| / fd, sv = cpf − (s·cpf)/(s·d)·d.
double skewness_from(const double* const f[3], const double* cf, const double* s, const double* cpf,
                     const double* d, double fd_factor) {
  const double t = dot(s, cpf) / (dot(s, d) + kRootVSmall);
  double sv[3];
  for (int k = 0; k < 3; ++k) sv[k] = cpf[k] - t * d[k];
  const double msv = norm(sv);
  double svhat[3];
  for (int k = 0; k < 3; ++k) svhat[k] = sv[k] / (msv + kRootVSmall);
  double fd = fd_factor * norm(d) + kRootVSmall;
  for (int i = 0; i < 3; ++i) {
    double r[3];
    sub(f[i], cf, r);
    fd = std::max(fd, std::fabs(dot(svhat, r)));
  }
  return msv / fd;
}
}  // namespace

namespace {
// The pieces the per-tet measures share, each computed one way only, so
// that the standalone functions and the statistics' fused kernel give the
// same bits: the signed volume, the face normals of detail::face_normals
// (|n_f| = 2·A_f) and the six edge lengths in kEdgeVertex order.
struct TetPieces {
  const double* p[4];
  double vol;
  double n[4][3], nl[4];
  double l[6];
};
[[gnu::always_inline]] inline void edge_lengths(const double* const p[4], double l[6]) {
  for (int e = 0; e < 6; ++e) {
    double u[3];
    sub(p[kEdgeVertex[e][1]], p[kEdgeVertex[e][0]], u);
    l[e] = norm(u);
  }
}
[[gnu::always_inline]] inline void tet_pieces(const double* a, const double* b, const double* c, const double* d,
                                              TetPieces& t) {
  t.p[0] = a; t.p[1] = b; t.p[2] = c; t.p[3] = d;
  t.vol = tet_signed_volume(a, b, c, d);
  detail::face_normals(t.p, t.n, t.nl);
  edge_lengths(t.p, t.l);
}
// Edge e lies on the faces opposite the two vertices of the opposite edge:
// sin = 3·V·l / (2·A_k·A_l) = 6·V·l / (|n_k|·|n_l|).
[[gnu::always_inline]] inline double sine_min_from(const TetPieces& t) {
  double best = std::numeric_limits<double>::infinity();
  for (int e = 0; e < 6; ++e) {
    const int k = kEdgeVertex[kEdgeOpposite[e]][0], l = kEdgeVertex[kEdgeOpposite[e]][1];
    const double den = t.nl[k] * t.nl[l];
    const double s = den > 0 ? 6.0 * t.vol * t.l[e] / den : 0.0;
    best = std::min(best, std::isfinite(s) ? s : 0.0);
  }
  return best;
}
// Verdict's side vectors e0 = b−a, e1 = c−b, e2 = a−c, e3 = d−a, e4 = d−b,
// e5 = d−c; J = e3·(e2×e0) = 6V; the edges at a are e0, e2, e3, at b e0,
// e1, e4, at c e1, e2, e5, at d e3, e4, e5.  Their lengths are l[] (|a−c| =
// |c−a| bit for bit): e0 = l01, e1 = l12, e2 = l02, e3 = l03, e4 = l13,
// e5 = l23.
[[gnu::always_inline]] inline double scaled_jacobian_from(const double* const p[4], const double l[6]) {
  double e0[3], e2[3], e3[3], x[3];
  sub(p[1], p[0], e0);
  sub(p[0], p[2], e2);
  sub(p[3], p[0], e3);
  cross(e2, e0, x);
  const double jac = dot(e3, x);
  const double l0 = l[0], l1 = l[3], l2 = l[1], l3 = l[2], l4 = l[4], l5 = l[5];
  double lp = std::max({l0 * l2 * l3, l0 * l1 * l4, l1 * l2 * l5, l3 * l4 * l5});
  lp = std::max(lp, std::fabs(jac));
  if (!(lp >= DBL_MIN)) return 0.0;
  const double q = std::sqrt(2.0) * jac / lp;
  return std::isfinite(q) ? q : 0.0;
}
[[gnu::always_inline]] inline double equivolume_skewness_from(const double* const p[4], double vol) {
  if (!(std::fabs(vol) > 0)) return 1.0;
  // Circumradius R = |num| / (12|V|), num = |u|²(v×w) + |v|²(w×u) + |w|²(u×v)
  // with u, v, w the edges from p0.
  double u[3], v[3], w[3], vw[3], wu[3], uv[3];
  sub(p[1], p[0], u); sub(p[2], p[0], v); sub(p[3], p[0], w);
  cross(v, w, vw); cross(w, u, wu); cross(u, v, uv);
  const double lu = dot(u, u), lv = dot(v, v), lw = dot(w, w);
  double num[3];
  for (int k = 0; k < 3; ++k) num[k] = lu * vw[k] + lv * wu[k] + lw * uv[k];
  const double r = norm(num) / (12.0 * std::fabs(vol));
  if (!(r > 0) || !std::isfinite(r)) return 1.0;
  const double ratio = vol / (kIdealVolume * r * r * r);
  if (!std::isfinite(ratio)) return 1.0;
  return std::max(0.0, 1.0 - ratio);
}

// Both checkMesh measures of an interior face, and the cosine whose acos
// is the non-orthogonality (checkMesh averages the cosines).
struct InteriorFace {
  double cosine, non_ortho, skew;
};
[[gnu::always_inline]] inline InteriorFace interior_face(const double* a, const double* b, const double* c,
                                                         const double* p, const double* q) {
  const double* f[3] = {a, b, c};
  double s[3], cf[3], co[3], cn[3], cpf[3], d[3];
  area_vector(a, b, c, s);
  centroid3(a, b, c, cf);
  centroid4(a, b, c, p, co);
  centroid4(a, b, c, q, cn);
  sub(cf, co, cpf);
  sub(cn, co, d);
  InteriorFace r;
  r.cosine = dot(d, s) / (norm(d) * norm(s) + kRootVSmall);
  r.non_ortho = std::acos(std::clamp(r.cosine, -1.0, 1.0)) * kRad2Deg;
  r.skew = skewness_from(f, cf, s, cpf, d, 0.2);
  return r;
}
}  // namespace

namespace detail {
TetMeasureValues tet_measure_values(const double* a, const double* b, const double* c, const double* d) {
  // tet_pieces with the squared edge lengths kept: the lengths are their
  // square roots (norm() is sqrt(dot)), their max and sum in edge order are
  // edge_lengths2's, and the area sum adds 0.5 |n_f| in face order as
  // face_area_sum does from the same normals.
  TetPieces t;
  t.p[0] = a; t.p[1] = b; t.p[2] = c; t.p[3] = d;
  t.vol = tet_signed_volume(a, b, c, d);
  face_normals(t.p, t.n, t.nl);
  double l2max = 0, l2sum = 0;
  for (int e = 0; e < 6; ++e) {
    double u[3];
    sub(t.p[kEdgeVertex[e][1]], t.p[kEdgeVertex[e][0]], u);
    const double l2 = dot(u, u);
    l2max = std::max(l2max, l2);
    l2sum += l2;
    t.l[e] = std::sqrt(l2);
  }
  double area = 0;
  for (int f = 0; f < 4; ++f) area += 0.5 * t.nl[f];
  TetMeasureValues r;
  r.alpha = alpha_from(t.vol, area, l2max);
  r.mean_ratio = mean_ratio_from(t.vol, l2sum);
  r.scaled_jacobian = scaled_jacobian_from(t.p, t.l);
  r.sine_min = sine_min_from(t);
  r.radius_ratio = radius_ratio_from(t.p, t.vol, area);
  r.equivolume_skewness = equivolume_skewness_from(t.p, t.vol);
  // The faces at edge e are those opposite the two ends of the opposite
  // edge.  Only where the product of the normals' lengths is far from
  // underflow and overflow (the normals are not scaled here as
  // dihedral_parts scales them): else NaN, and the caller measures.
  r.cos_max = -std::numeric_limits<double>::infinity();
  r.cos_min = std::numeric_limits<double>::infinity();
  for (int e = 0; e < 6; ++e) {
    const int f = kEdgeVertex[kEdgeOpposite[e]][0], g = kEdgeVertex[kEdgeOpposite[e]][1];
    const double den = t.nl[f] * t.nl[g];
    const double cs =
        den >= 0x1p-960 && den <= 0x1p+960 ? -dot(t.n[f], t.n[g]) / den : std::numeric_limits<double>::quiet_NaN();
    if (!std::isfinite(cs)) {
      r.cos_max = r.cos_min = std::numeric_limits<double>::quiet_NaN();
      break;
    }
    r.cos_max = std::max(r.cos_max, cs);
    r.cos_min = std::min(r.cos_min, cs);
  }
  return r;
}
}  // namespace detail

double sine_min(const double* a, const double* b, const double* c, const double* d) {
  TetPieces t;
  tet_pieces(a, b, c, d, t);
  return sine_min_from(t);
}

double dihedral_min_deg(const double* a, const double* b, const double* c, const double* d) {
  double lo, hi;
  dihedral_extremes(a, b, c, d, lo, hi);
  return lo;
}

double dihedral_max_deg(const double* a, const double* b, const double* c, const double* d) {
  double lo, hi;
  dihedral_extremes(a, b, c, d, lo, hi);
  return hi;
}

double scaled_jacobian(const double* a, const double* b, const double* c, const double* d) {
  const double* p[4] = {a, b, c, d};
  double l[6];
  edge_lengths(p, l);
  return scaled_jacobian_from(p, l);
}

double equivolume_skewness(const double* a, const double* b, const double* c, const double* d) {
  const double* p[4] = {a, b, c, d};
  return equivolume_skewness_from(p, tet_signed_volume(a, b, c, d));
}

double face_non_orthogonality(const double* a, const double* b, const double* c, const double* p,
                              const double* q) {
  return interior_face(a, b, c, p, q).non_ortho;
}

double face_skewness(const double* a, const double* b, const double* c, const double* p, const double* q) {
  return interior_face(a, b, c, p, q).skew;
}

double face_skewness_boundary(const double* a, const double* b, const double* c, const double* p) {
  const double* f[3] = {a, b, c};
  double s[3], cf[3], co[3], cpf[3], nrm[3], d[3];
  area_vector(a, b, c, s);
  centroid3(a, b, c, cf);
  centroid4(a, b, c, p, co);
  sub(cf, co, cpf);
  const double ms = norm(s) + kRootVSmall;
  for (int k = 0; k < 3; ++k) nrm[k] = s[k] / ms;
  const double dn = dot(nrm, cpf);
  for (int k = 0; k < 3; ++k) d[k] = nrm[k] * dn;
  return skewness_from(f, cf, s, cpf, d, 0.4);
}

// ---- the table ----

namespace {
constexpr const char* kLiu = "Liu, Dai, Dong & Tan, A Novel Mesh Quality Improvement Method for Boundary Elements, "
                             "J. Appl. Math. 2012, eq. 3.1";
constexpr const char* kStellar = "Klingner & Shewchuk, Aggressive Tetrahedral Mesh Improvement, IMR 2007 "
                                 "(Stellar's QUALMINSINE: sine = 3·V·l_ij / (2·A_k·A_l))";
constexpr const char* kVerdict = "Stimpson, Ernst, Knupp, Pébay & Thompson, The Verdict Geometric Quality Library, "
                                 "SAND2007-1751 (tet scaled Jacobian; Verdict's tet_scaled_jacobian)";
constexpr const char* kFluent = "ANSYS Meshing User's Guide, Skewness: equilateral-volume-based skewness = "
                                "(optimal cell size − cell size) / optimal cell size, optimal = the equilateral "
                                "cell with the same circumradius";
constexpr const char* kFluentBands = "ANSYS Meshing User's Guide (2024 R2), Skewness table: 0 equilateral, "
                                     ">0–0.25 excellent, 0.25–0.5 good, 0.5–0.75 fair, 0.75–0.9 poor, "
                                     "0.9–<1 bad (sliver), 1 degenerate";
constexpr const char* kCheckMesh = "OpenFOAM checkMesh: primitiveMeshTools::faceOrthogonality / faceSkewness / "
                                   "boundaryFaceSkewness, primitiveMesh::checkFaceOrthogonality / checkFaceSkewness";
constexpr const char* kInverted = "volume ≤ 0: inverted or flat, rejected by every solver";
constexpr const char* kTetoptDihedral = "tetopt's report (tets_dihedral_below_5 / _above_175); a rule of thumb, "
                                        "no tool's documented limit";

constexpr MeasureBands kNoBands{};
const MeasureBands kFluentSkewBands{6,
                                    {"excellent", "good", "fair", "poor", "bad", "degenerate"},
                                    {0.25, 0.5, 0.75, 0.9, 1.0, INFINITY},
                                    kFluentBands};
}  // namespace

const std::array<MeasureInfo, kMeasureCount> kMeasures = {{
    {Measure::Alpha, "alpha", "α (Liu et al.)", "", Better::Higher, false, &alpha, nullptr, 1.0, 0.0, 1.0, 10,
     "6√6·V / (Σ face areas · longest edge); signed", kLiu, 2,
     {MeasureThreshold{"le_0", Cmp::Le, 0.0, "inverted or flat", kInverted},
      MeasureThreshold{"lt_0.1", Cmp::Lt, 0.1, "α < 0.1", "tetopt's report (alpha_below_0.1); no tool's limit"}},
     kNoBands},
    {Measure::SineMin, "sine_min", "min sine of the dihedral angles (Stellar)", "", Better::Higher, false, &sine_min,
     nullptr, 2.0 * std::sqrt(2.0) / 3.0, 0.0, 1.0, 10, "min over edges ij of 3·V·l_ij / (2·A_k·A_l); signed",
     kStellar, 2,
     {MeasureThreshold{"le_0", Cmp::Le, 0.0, "inverted or flat", kInverted},
      MeasureThreshold{"lt_sin5", Cmp::Lt, kSin5, "an angle < 5° or > 175°", kTetoptDihedral}},
     kNoBands},
    {Measure::DihedralMin, "dihedral_min", "smallest dihedral angle", "deg", Better::Higher, false,
     &dihedral_min_deg, nullptr, 70.528779365509308, 0.0, 90.0, 18, "min of the six dihedral angles",
     "dihedral angle between the two faces at each edge", 1,
     {MeasureThreshold{"lt_5", Cmp::Lt, 5.0, "an angle < 5°", kTetoptDihedral}}, kNoBands},
    {Measure::DihedralMax, "dihedral_max", "largest dihedral angle", "deg", Better::Lower, false, &dihedral_max_deg,
     nullptr, 70.528779365509308, 90.0, 180.0, 18, "max of the six dihedral angles",
     "dihedral angle between the two faces at each edge", 1,
     {MeasureThreshold{"gt_175", Cmp::Gt, 175.0, "an angle > 175°", kTetoptDihedral}}, kNoBands},
    {Measure::ScaledJacobian, "scaled_jacobian", "scaled Jacobian (Verdict)", "", Better::Higher, false,
     &scaled_jacobian, nullptr, 1.0, -1.0, 1.0, 20,
     "√2·J / max(corner products of the 3 edge lengths, |J|), J = 6V signed", kVerdict, 2,
     {MeasureThreshold{"le_0", Cmp::Le, 0.0, "inverted or flat (J ≤ 0)", kInverted},
      MeasureThreshold{"lt_0.2", Cmp::Lt, 0.2, "scaled Jacobian < 0.2",
                       "tetopt's low band (a common FEM rule of thumb; Verdict documents no limit for it)"}},
     kNoBands},
    {Measure::RadiusRatio, "radius_ratio", "radius ratio", "", Better::Higher, false, &radius_ratio, nullptr, 1.0,
     0.0, 1.0, 10, "3·r_in / r_circ; unsigned",
     "Cavendish, Field & Frey 1985; Verdict's tet_radius_ratio is its inverse r_circ / (3·r_in)", 0, {}, kNoBands},
    {Measure::MeanRatio, "mean_ratio", "mean ratio", "", Better::Higher, false, &mean_ratio, nullptr, 1.0, 0.0, 1.0,
     10, "12·(3V)^(2/3) / Σ l²; signed", "Liu & Joe 1994, Relationship between tetrahedron shape measures", 1,
     {MeasureThreshold{"le_0", Cmp::Le, 0.0, "inverted or flat", kInverted}}, kNoBands},
    {Measure::EquivolumeSkewness, "equivolume_skewness", "equivolume skewness (Fluent)", "", Better::Lower, false,
     &equivolume_skewness, nullptr, 0.0, 0.0, 1.0, 20,
     "1 − V / V_ideal, V_ideal = 8√3/27·R³ (regular tet, same circumradius R); > 1 when inverted", kFluent, 3,
     {MeasureThreshold{"gt_0.75", Cmp::Gt, 0.75, "poor or worse (> 0.75)", kFluentBands},
      MeasureThreshold{"gt_0.9", Cmp::Gt, 0.9, "bad (sliver) or worse (> 0.9)", kFluentBands},
      MeasureThreshold{"ge_1", Cmp::Ge, 1.0, "degenerate or inverted (≥ 1)", kFluentBands}},
     kFluentSkewBands},
    {Measure::NonOrthogonality, "non_orthogonality", "face non-orthogonality (checkMesh)", "deg", Better::Lower,
     true, nullptr, &face_non_orthogonality, 0.0, 0.0, 90.0, 18,
     "acos(d·S / (|d||S|)), d between the cell centres (centroids), S the face area vector; interior faces",
     kCheckMesh, 2,
     {MeasureThreshold{"gt_70", Cmp::Gt, 70.0, "severely non-orthogonal (> 70°)",
                       "OpenFOAM primitiveMesh::nonOrthThreshold_ = 70 (checkMesh default)"},
      MeasureThreshold{"ge_90", Cmp::Ge, 90.0, "non-orthogonality error (≥ 90°, d·S ≤ 0)",
                       "OpenFOAM checkFaceOrthogonality: d·S/(|d||S|) ≤ SMALL is an error"}},
     kNoBands},
    {Measure::FaceSkewness, "skewness", "face skewness (checkMesh)", "", Better::Lower, true, nullptr,
     &face_skewness, 0.0, 0.0, 5.0, 20,
     "|C_f − X| / max(0.2|d|, face extent along it), X the cell-centre line's crossing of the face plane; "
     "boundary faces: mirrored owner, 0.4|d|",
     kCheckMesh, 1,
     {MeasureThreshold{"gt_4", Cmp::Gt, 4.0, "highly skew (> 4)",
                       "OpenFOAM primitiveMesh::skewThreshold_ = 4 (checkMesh default)"}},
     kNoBands},
}};

const MeasureInfo* find_measure(const std::string& key) {
  for (const MeasureInfo& m : kMeasures)
    if (key == m.key) return &m;
  return nullptr;
}

double tet_measure(Measure m, const double* a, const double* b, const double* c, const double* d) {
  switch (m) {
    case Measure::Alpha: return alpha(a, b, c, d);
    case Measure::SineMin: return sine_min(a, b, c, d);
    case Measure::DihedralMin: return dihedral_min_deg(a, b, c, d);
    case Measure::DihedralMax: return dihedral_max_deg(a, b, c, d);
    case Measure::ScaledJacobian: return scaled_jacobian(a, b, c, d);
    case Measure::RadiusRatio: return radius_ratio(a, b, c, d);
    case Measure::MeanRatio: return mean_ratio(a, b, c, d);
    case Measure::EquivolumeSkewness: return equivolume_skewness(a, b, c, d);
    default: return NAN;
  }
}

double face_measure(Measure m, const double* a, const double* b, const double* c, const double* p,
                    const double* q) {
  switch (m) {
    case Measure::NonOrthogonality: return face_non_orthogonality(a, b, c, p, q);
    case Measure::FaceSkewness: return face_skewness(a, b, c, p, q);
    default: return NAN;
  }
}

bool fails(const MeasureThreshold& t, double v) {
  if (std::isnan(v)) return true;
  switch (t.cmp) {
    case Cmp::Lt: return v < t.value;
    case Cmp::Le: return v <= t.value;
    case Cmp::Gt: return v > t.value;
    case Cmp::Ge: return v >= t.value;
  }
  return false;
}

// ---- statistics ----

namespace {
int hist_bin(const MeasureInfo& mi, double v) {
  const int n = mi.hist_bins;
  if (std::isnan(v)) return mi.better == Better::Higher ? 0 : n - 1;
  if (!(v > mi.hist_lo)) return 0;
  if (!(v < mi.hist_hi)) return n - 1;
  return std::min(n - 1, static_cast<int>((v - mi.hist_lo) / (mi.hist_hi - mi.hist_lo) * n));
}

struct Acc {
  MeasureSummary s;
  Sum sum;
  void init(const MeasureInfo& mi) { s.histogram.assign(static_cast<size_t>(mi.hist_bins), 0); }
  void add(const MeasureInfo& mi, double v, int32_t t, int f) {
    if (s.count == 0 || worse(mi.id, v, s.worst)) {
      s.worst = v;
      s.worst_tet = t;
      s.worst_face = static_cast<int8_t>(f);
    }
    s.count++;
    sum.add(v);
    s.histogram[static_cast<size_t>(hist_bin(mi, v))]++;
    for (int k = 0; k < mi.n_thresholds; ++k) s.fail[static_cast<size_t>(k)] += fails(mi.thresholds[k], v);
    if (mi.bands.n > 0) {
      int b = 0;
      while (b < mi.bands.n - 1 && !(v < mi.bands.upper[b])) ++b;
      s.band[static_cast<size_t>(b)]++;
    }
  }
  // o's items come after this one's: ties keep this one's worst.
  void merge(const MeasureInfo& mi, const Acc& o) {
    if (o.s.count == 0) return;
    if (s.count == 0 || worse(mi.id, o.s.worst, s.worst)) {
      s.worst = o.s.worst;
      s.worst_tet = o.s.worst_tet;
      s.worst_face = o.s.worst_face;
    }
    s.count += o.s.count;
    sum.add(o.sum);
    for (size_t k = 0; k < s.histogram.size(); ++k) s.histogram[k] += o.s.histogram[k];
    for (size_t k = 0; k < s.fail.size(); ++k) s.fail[k] += o.s.fail[k];
    for (size_t k = 0; k < s.band.size(); ++k) s.band[k] += o.s.band[k];
  }
};

// The dihedral measures from the cosines of the six angles (the outward
// face normals, as compute_stats has them): classified against the
// cosines of the bin edges and thresholds, averaged through acos, and the
// worst tet found by its cosine; the worst value itself comes from
// dihedral_extremes on that tet at the end (so it is compute_stats'
// dihedral_min / dihedral_max and the field's value, bit for bit).
struct DihedralAcc {
  Sum sum;
  int64_t count = 0, fail = 0;
  double key = NAN;  // the extreme cosine (largest for the minimum angle, smallest for the maximum)
  int32_t tet = -1;
  std::vector<int64_t> histogram;
};
// cos of the histogram's inner bin edges and of the threshold, per measure.
struct DihedralEdges {
  std::vector<double> bin_cos;  // decreasing
  double fail_cos;
};
DihedralEdges dihedral_edges(Measure k) {
  const MeasureInfo& mi = measure_info(k);
  DihedralEdges e;
  for (int j = 1; j < mi.hist_bins; ++j)
    e.bin_cos.push_back(std::cos((mi.hist_lo + (mi.hist_hi - mi.hist_lo) * j / mi.hist_bins) / kRad2Deg));
  e.fail_cos = std::cos(mi.thresholds[0].value / kRad2Deg);
  return e;
}
// Built on first use, not at static initialisation: an allocation that
// fails there cannot be reported (the process aborts before main, as
// `tetopt --version` did under `ulimit -v 10000`, tests/scripts/test_oom.sh),
// while in main it is the CLI's out-of-memory exit.
const DihedralEdges& dih_min_edges() {
  static const DihedralEdges e = dihedral_edges(Measure::DihedralMin);
  return e;
}
const DihedralEdges& dih_max_edges() {
  static const DihedralEdges e = dihedral_edges(Measure::DihedralMax);
  return e;
}

struct Part {
  std::array<Acc, kMeasureCount> acc;
  DihedralAcc dih_min, dih_max;
  Sum cos_sum;  // checkMesh's average non-orthogonality
  int64_t interior = 0, boundary = 0;
  double skew_interior = NAN, skew_boundary = NAN;
  Part() {
    for (int k = 0; k < kMeasureCount; ++k) acc[static_cast<size_t>(k)].init(kMeasures[static_cast<size_t>(k)]);
    dih_min.histogram.assign(static_cast<size_t>(measure_info(Measure::DihedralMin).hist_bins), 0);
    dih_max.histogram.assign(static_cast<size_t>(measure_info(Measure::DihedralMax).hist_bins), 0);
  }
};

double max_nan(double a, double b) { return std::isnan(a) ? b : std::isnan(b) ? a : std::max(a, b); }

// The face f of tet t as its owner sees it: (a, b, c) with the normal out of
// t (kFaceVertex), p = t's vertex f.
struct FaceView {
  const double *a, *b, *c, *p;
};
FaceView face_of(const TetMesh& m, int32_t t, int f) {
  const int32_t* v = m.tet(t);
  return {m.point(v[kFaceVertex[f][0]]), m.point(v[kFaceVertex[f][1]]), m.point(v[kFaceVertex[f][2]]),
          m.point(v[f])};
}

// One tet's extreme dihedral cosine into acc: larger_is_worse for the
// minimum angle (its largest cosine), else the maximum angle (smallest).
void add_dihedral(DihedralAcc& acc, const DihedralEdges& edges, bool larger_is_worse, double cs, int32_t t) {
  acc.count++;
  acc.sum.add(std::acos(std::clamp(cs, -1.0, 1.0)) * kRad2Deg);
  const bool worse_key = std::isnan(acc.key) || (larger_is_worse ? cs > acc.key : cs < acc.key);
  if (acc.tet < 0 || worse_key) { acc.key = cs; acc.tet = t; }
  int bin = 0;  // the number of bin edges at or below the angle
  for (double e : edges.bin_cos) bin += e >= cs;
  if (std::isnan(cs)) bin = larger_is_worse ? 0 : static_cast<int>(acc.histogram.size()) - 1;
  acc.histogram[static_cast<size_t>(bin)]++;
  acc.fail += larger_is_worse ? cs > edges.fail_cos : cs < edges.fail_cos;
}
void merge_dihedral(DihedralAcc& a, const DihedralAcc& b, bool larger_is_worse) {
  if (b.count == 0) return;
  if (a.tet < 0 || (larger_is_worse ? b.key > a.key : b.key < a.key)) { a.key = b.key; a.tet = b.tet; }
  a.count += b.count;
  a.fail += b.fail;
  a.sum.add(b.sum);
  for (size_t k = 0; k < a.histogram.size(); ++k) a.histogram[k] += b.histogram[k];
}

void measure_block(const TetMesh& m, bool faces, int32_t t0, int32_t t1, Part& part) {
  const int32_t nt = m.nt();
  const MeasureInfo& non_ortho = measure_info(Measure::NonOrthogonality);
  const MeasureInfo& skew = measure_info(Measure::FaceSkewness);
  auto acc = [&](Measure k) -> Acc& { return part.acc[static_cast<size_t>(k)]; };
  const DihedralEdges& dih_min = dih_min_edges();
  const DihedralEdges& dih_max = dih_max_edges();
  for (int32_t t = t0; t < t1; ++t) {
    const int32_t* v = m.tet(t);
    const double *a = m.point(v[0]), *b = m.point(v[1]), *c = m.point(v[2]), *d = m.point(v[3]);
    TetPieces tp;
    tet_pieces(a, b, c, d, tp);
    acc(Measure::Alpha).add(measure_info(Measure::Alpha), alpha(a, b, c, d), t, -1);
    acc(Measure::SineMin).add(measure_info(Measure::SineMin), sine_min_from(tp), t, -1);
    acc(Measure::ScaledJacobian).add(measure_info(Measure::ScaledJacobian), scaled_jacobian_from(tp.p, tp.l), t, -1);
    acc(Measure::RadiusRatio).add(measure_info(Measure::RadiusRatio), radius_ratio(a, b, c, d), t, -1);
    acc(Measure::MeanRatio).add(measure_info(Measure::MeanRatio), mean_ratio(a, b, c, d), t, -1);
    acc(Measure::EquivolumeSkewness)
        .add(measure_info(Measure::EquivolumeSkewness), equivolume_skewness_from(tp.p, tp.vol), t, -1);
    // The dihedral cosines exactly as compute_stats computes them.
    double cmax = -2, cmin = 2;
    bool nan = false;
    for (int e = 0; e < 6; ++e) {
      const int k = kEdgeVertex[kEdgeOpposite[e]][0], l = kEdgeVertex[kEdgeOpposite[e]][1];
      const double den = tp.nl[k] * tp.nl[l];
      double cs = den > 0 ? -dot(tp.n[k], tp.n[l]) / den : 1.0;
      cs = std::clamp(cs, -1.0, 1.0);
      nan |= std::isnan(cs);
      cmax = std::max(cmax, cs);
      cmin = std::min(cmin, cs);
    }
    if (nan) cmax = cmin = NAN;
    add_dihedral(part.dih_min, dih_min, true, cmax, t);
    add_dihedral(part.dih_max, dih_max, false, cmin, t);
    if (!faces) continue;
    for (int f = 0; f < 4; ++f) {
      const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)];
      const FaceView fv = face_of(m, t, f);
      if (nb < 0) {
        const double sk = face_skewness_boundary(fv.a, fv.b, fv.c, fv.p);
        part.boundary++;
        acc(Measure::FaceSkewness).add(skew, sk, t, f);
        part.skew_boundary = max_nan(part.skew_boundary, sk);
        continue;
      }
      const int32_t u = nb >> 2;
      if (u <= t || u >= nt) continue;  // the lower tet owns an interior face (OpenFOAM's owner < neighbour)
      const InteriorFace r = interior_face(fv.a, fv.b, fv.c, fv.p, m.point(m.tet(u)[nb & 3]));
      part.interior++;
      acc(Measure::NonOrthogonality).add(non_ortho, r.non_ortho, t, f);
      acc(Measure::FaceSkewness).add(skew, r.skew, t, f);
      part.skew_interior = max_nan(part.skew_interior, r.skew);
      part.cos_sum.add(r.cosine);
    }
  }
}

// The summary of a dihedral measure: worst from dihedral_extremes on the
// tet found by its cosine.
MeasureSummary dihedral_summary(const TetMesh& m, const DihedralAcc& acc, Measure k) {
  MeasureSummary s;
  s.count = acc.count;
  s.histogram = acc.histogram;
  s.fail[0] = acc.fail;
  s.worst_tet = acc.tet;
  if (acc.count > 0) {
    s.mean = acc.sum.value() / static_cast<double>(acc.count);
    const int32_t* v = m.tet(acc.tet);
    s.worst = tet_measure(k, m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]));
  }
  return s;
}
}  // namespace

MeasureStats compute_measure_stats(const TetMesh& m, int threads) {
  const int32_t nt = m.nt();
  const bool faces = m.adj.size() == 4 * static_cast<size_t>(nt);
  Part all;
  for (const Part& p : detail::parallel_map_blocks(nt, threads, [&](int64_t b, int64_t e) {
         Part part;
         measure_block(m, faces, static_cast<int32_t>(b), static_cast<int32_t>(e), part);
         return part;
       })) {
    for (int k = 0; k < kMeasureCount; ++k)
      all.acc[static_cast<size_t>(k)].merge(kMeasures[static_cast<size_t>(k)], p.acc[static_cast<size_t>(k)]);
    merge_dihedral(all.dih_min, p.dih_min, true);
    merge_dihedral(all.dih_max, p.dih_max, false);
    all.cos_sum.add(p.cos_sum);
    all.interior += p.interior;
    all.boundary += p.boundary;
    all.skew_interior = max_nan(all.skew_interior, p.skew_interior);
    all.skew_boundary = max_nan(all.skew_boundary, p.skew_boundary);
  }
  MeasureStats s;
  s.computed = true;
  s.faces_measured = faces;
  for (int k = 0; k < kMeasureCount; ++k) {
    Acc& a = all.acc[static_cast<size_t>(k)];
    if (a.s.count > 0) a.s.mean = a.sum.value() / static_cast<double>(a.s.count);
    s.m[static_cast<size_t>(k)] = std::move(a.s);
  }
  s.m[static_cast<size_t>(Measure::DihedralMin)] = dihedral_summary(m, all.dih_min, Measure::DihedralMin);
  s.m[static_cast<size_t>(Measure::DihedralMax)] = dihedral_summary(m, all.dih_max, Measure::DihedralMax);
  s.interior_faces = all.interior;
  s.boundary_faces = all.boundary;
  if (all.interior > 0)
    s.non_orthogonality_checkmesh_average =
        std::acos(std::clamp(all.cos_sum.value() / static_cast<double>(all.interior), -1.0, 1.0)) * kRad2Deg;
  s.skewness_interior_worst = all.skew_interior;
  s.skewness_boundary_worst = all.skew_boundary;
  return s;
}

std::vector<double> compute_measure_field(const TetMesh& m, Measure k, int threads) {
  const int32_t nt = m.nt();
  std::vector<double> out(static_cast<size_t>(nt), 0.0);
  const MeasureInfo& mi = measure_info(k);
  const bool faces = m.adj.size() == 4 * static_cast<size_t>(nt);
  detail::parallel_for_each(nt, threads, [&](int64_t i) {
    const int32_t t = static_cast<int32_t>(i);
    const int32_t* v = m.tet(t);
    if (!mi.per_face) {
      out[static_cast<size_t>(t)] = tet_measure(k, m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]));
      return;
    }
    double w = k == Measure::NonOrthogonality ? 0.0 : NAN;
    if (!faces) { out[static_cast<size_t>(t)] = NAN; return; }
    for (int f = 0; f < 4; ++f) {
      const int32_t nb = m.adj[4 * static_cast<size_t>(t) + static_cast<size_t>(f)];
      const FaceView fv = face_of(m, t, f);
      double x;
      if (nb < 0 || (nb >> 2) >= nt) {
        if (k != Measure::FaceSkewness) continue;
        x = face_skewness_boundary(fv.a, fv.b, fv.c, fv.p);
      } else {
        // The value of the face as its owner (the lower tet) sees it, so
        // that both tets carry the statistics' number.
        const int32_t u = nb >> 2;
        if (u > t) {
          x = face_measure(k, fv.a, fv.b, fv.c, fv.p, m.point(m.tet(u)[nb & 3]));
        } else {
          const int g = nb & 3;
          const FaceView ov = face_of(m, u, g);
          x = face_measure(k, ov.a, ov.b, ov.c, ov.p, fv.p);
        }
      }
      w = std::isnan(w) ? x : std::max(w, x);
    }
    out[static_cast<size_t>(t)] = w;
  });
  return out;
}

// ---- JSON ----

namespace {
std::string num(double x) {
  if (std::isnan(x)) return "null";
  if (std::isinf(x)) return x > 0 ? "1e999" : "-1e999";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}
std::string quoted(const char* s) { return std::string("\"") + s + "\""; }

std::string summary_json(const MeasureInfo& mi, const MeasureSummary& s, const std::string& pad) {
  std::ostringstream o;
  const std::string in = pad + "  ";
  o << "{\n";
  o << in << "\"name\": " << quoted(mi.name) << ",\n";
  o << in << "\"unit\": " << quoted(mi.unit) << ",\n";
  o << in << "\"better\": " << quoted(mi.better == Better::Higher ? "higher" : "lower") << ",\n";
  o << in << "\"ideal\": " << num(mi.ideal) << ",\n";
  o << in << "\"count\": " << s.count << ",\n";
  o << in << "\"worst\": " << num(s.worst) << ",\n";
  o << in << "\"mean\": " << num(s.mean) << ",\n";
  o << in << "\"worst_tet\": " << s.worst_tet << ",\n";
  if (mi.per_face) o << in << "\"worst_face\": " << static_cast<int>(s.worst_face) << ",\n";
  o << in << "\"histogram\": {\"lo\": " << num(mi.hist_lo) << ", \"hi\": " << num(mi.hist_hi) << ", \"counts\": [";
  for (size_t i = 0; i < s.histogram.size(); ++i) o << (i ? ", " : "") << s.histogram[i];
  o << "]},\n";
  o << in << "\"fail\": {";
  for (int k = 0; k < mi.n_thresholds; ++k)
    o << (k ? ", " : "") << quoted(mi.thresholds[k].key) << ": " << s.fail[static_cast<size_t>(k)];
  o << "}";
  if (mi.bands.n > 0) {
    o << ",\n" << in << "\"bands\": {";
    for (int k = 0; k < mi.bands.n; ++k)
      o << (k ? ", " : "") << quoted(mi.bands.name[k]) << ": " << s.band[static_cast<size_t>(k)];
    o << "}";
  }
  return o.str();  // the caller closes it (face measures add members)
}
}  // namespace

std::string measure_stats_to_json(const MeasureStats& s, int indent) {
  const std::string pad(static_cast<size_t>(indent), ' ');
  const std::string in = pad + "  ";
  std::ostringstream o;
  o << pad << "\"measures\": {\n";
  for (int k = 0; k < kTetMeasureCount; ++k) {
    const MeasureInfo& mi = kMeasures[static_cast<size_t>(k)];
    o << in << quoted(mi.key) << ": " << summary_json(mi, s.m[static_cast<size_t>(k)], in) << "\n"
      << in << "}" << (k + 1 < kTetMeasureCount ? ",\n" : "\n");
  }
  o << pad << "},\n";
  o << pad << "\"faces\": {\n";
  o << in << "\"measured\": " << (s.faces_measured ? "true" : "false") << ",\n";
  o << in << "\"interior\": " << s.interior_faces << ",\n";
  o << in << "\"boundary\": " << s.boundary_faces << ",\n";
  const MeasureInfo& no = measure_info(Measure::NonOrthogonality);
  o << in << quoted(no.key) << ": " << summary_json(no, s[Measure::NonOrthogonality], in) << ",\n"
    << in << "  \"checkmesh_average\": " << num(s.non_orthogonality_checkmesh_average) << "\n"
    << in << "},\n";
  const MeasureInfo& sk = measure_info(Measure::FaceSkewness);
  o << in << quoted(sk.key) << ": " << summary_json(sk, s[Measure::FaceSkewness], in) << ",\n"
    << in << "  \"interior_worst\": " << num(s.skewness_interior_worst) << ",\n"
    << in << "  \"boundary_worst\": " << num(s.skewness_boundary_worst) << "\n"
    << in << "}\n";
  o << pad << "}";
  return o.str();
}

std::string measures_before_after_json(const MeasureStats& before, const MeasureStats& after) {
  std::string ba = "{";
  char num[64];
  auto fmt = [&](double x) {
    if (!std::isfinite(x)) return std::string("null");
    std::snprintf(num, sizeof num, "%.17g", x);
    return std::string(num);
  };
  for (int k = 0; k < kMeasureCount; ++k) {
    const Measure mk = static_cast<Measure>(k);
    const double wb = before[mk].worst, wa = after[mk].worst;
    ba += std::string(k ? ", " : "") + "\"" + kMeasures[static_cast<size_t>(k)].key + "\": {\"before\": " + fmt(wb) +
          ", \"after\": " + fmt(wa) + ", \"kept\": " + (worse(mk, wa, wb) ? "false" : "true") + "}";
  }
  return ba + "}";
}

}  // namespace tetopt
