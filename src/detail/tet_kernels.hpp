// Per-tet kernels the measures share, each written once, so that the
// standalone functions (alpha(), mean_ratio(), radius_ratio() in
// quality.cpp), compute_stats' fused kernel and tet_measure_values (the
// guards' fused evaluation, measures.cpp) give the same bits.
#pragma once
#include <algorithm>
#include <cmath>

#include "detail/vec3.hpp"
#include "tetopt/conventions.hpp"

namespace tetopt::detail {

inline const double kSixSqrt6 = 6.0 * std::sqrt(6.0);

// The sum of the four face areas, from the normals of detail::face_normals
// (the same expressions; written as one loop here because alpha() is the
// hot path, where an array of normals made it 55% slower).
[[gnu::always_inline]] inline double face_area_sum(const double* const p[4]) {
  double area = 0;
  for (int f = 0; f < 4; ++f) {
    double u[3], v[3], n[3];
    sub(p[kFaceVertex[f][1]], p[kFaceVertex[f][0]], u);
    sub(p[kFaceVertex[f][2]], p[kFaceVertex[f][0]], v);
    cross(u, v, n);
    area += 0.5 * norm(n);
  }
  return area;
}
struct EdgeLengths2 {
  double max = 0, sum = 0;  // of the six squared edge lengths
};
[[gnu::always_inline]] inline EdgeLengths2 edge_lengths2(const double* const p[4]) {
  EdgeLengths2 r;
  for (int e = 0; e < 6; ++e) {
    double u[3];
    sub(p[kEdgeVertex[e][1]], p[kEdgeVertex[e][0]], u);
    const double l2 = dot(u, u);
    r.max = std::max(r.max, l2);
    r.sum += l2;
  }
  return r;
}
[[gnu::always_inline]] inline double alpha_from(double vol, double area, double l2max) {
  const double den = area * std::sqrt(l2max);
  if (!(den > 0)) return 0.0;
  const double q = kSixSqrt6 * vol / den;
  return std::isfinite(q) ? q : 0.0;
}
[[gnu::always_inline]] inline double mean_ratio_from(double vol, double l2sum) {
  if (!(l2sum > 0)) return 0.0;
  const double q = 12.0 * std::cbrt(9.0 * vol * vol) / l2sum;
  return vol < 0 ? -q : q;
}
// 3 r_in / r_circ from the signed volume and the face area sum.
[[gnu::always_inline]] inline double radius_ratio_from(const double* const p[4], double signed_vol, double area) {
  const double vol = std::fabs(signed_vol);
  if (!(vol > 0) || !(area > 0)) return 0.0;
  double u[3], v[3], w[3], bc[3], ca[3], ab[3], num[3];
  sub(p[1], p[0], u); sub(p[2], p[0], v); sub(p[3], p[0], w);
  cross(v, w, bc); cross(w, u, ca); cross(u, v, ab);
  const double lu = dot(u, u), lv = dot(v, v), lw = dot(w, w);
  for (int k = 0; k < 3; ++k) num[k] = lu * bc[k] + lv * ca[k] + lw * ab[k];
  const double circum = norm(num) / (12.0 * vol);
  const double in = 3.0 * vol / area;
  const double q = 3.0 * in / circum;
  return std::isfinite(q) ? q : 0.0;
}

/// The six per-tet measures the guards compare besides the dihedral
/// extremes, from one volume, one set of face normals and one set of edge
/// lengths; each is its standalone function's value bit for bit (alpha(),
/// mean_ratio(), scaled_jacobian(), sine_min(), radius_ratio(),
/// equivolume_skewness(); unit test TetMeasureValuesAreTheStandaloneOnes).
/// Defined in measures.cpp.
struct TetMeasureValues {
  double alpha, mean_ratio, scaled_jacobian, sine_min, radius_ratio, equivolume_skewness;
  /// The largest and smallest cosine of the six dihedral angles (-n_f . n_g
  /// / (|n_f| |n_g|) from the same normals), NaN where a face normal is zero
  /// or not finite.  A fast test only: within a few ulps of the cosines of
  /// dihedral_extremes' angles, so a cosine beyond a threshold's cosine by
  /// far more than that (Guard: 1e-9) decides the comparison of the angle.
  double cos_max, cos_min;
};
TetMeasureValues tet_measure_values(const double* a, const double* b, const double* c, const double* d);

}  // namespace tetopt::detail
