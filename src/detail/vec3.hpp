// Private 3-vector helpers on raw double[3] (the xyz layout of TetMesh).
#pragma once
#include <cmath>

#include "tetopt/conventions.hpp"

namespace tetopt::detail {

inline void sub(const double* a, const double* b, double* r) {
  r[0] = a[0] - b[0]; r[1] = a[1] - b[1]; r[2] = a[2] - b[2];
}
inline void cross(const double* a, const double* b, double* r) {
  r[0] = a[1] * b[2] - a[2] * b[1];
  r[1] = a[2] * b[0] - a[0] * b[2];
  r[2] = a[0] * b[1] - a[1] * b[0];
}
inline double dot(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double norm(const double* a) { return std::sqrt(dot(a, a)); }

/// Normals of the four faces of tet p[0..3] in kFaceVertex order,
/// cross(q1 - q0, q2 - q0) for face (q0, q1, q2) (outward for a positive
/// tet), and their lengths.  One definition for the statistics, the flip
/// passes' dihedral bound and the diagnosis, so they agree to the bit.
inline void face_normals(const double* const p[4], double n[4][3], double nl[4]) {
  for (int f = 0; f < 4; ++f) {
    double e1[3], e2[3];
    sub(p[kFaceVertex[f][1]], p[kFaceVertex[f][0]], e1);
    sub(p[kFaceVertex[f][2]], p[kFaceVertex[f][0]], e2);
    cross(e1, e2, n[f]);
    nl[f] = norm(n[f]);
  }
}

/// Circumcentre cc and squared circumradius r2 of tet (a, b, c, d): with b,
/// c, d relative to a, cc = a + (|b|^2 c x d + |c|^2 d x b + |d|^2 b x c) /
/// (2 b . (c x d)).  False for a flat tet.
inline bool circumsphere(const double* a, const double* b, const double* c, const double* d, double* cc, double& r2) {
  const double ba[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double ca[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double da[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  double cd[3], db[3], bc[3];
  cross(ca, da, cd);
  cross(da, ba, db);
  cross(ba, ca, bc);
  const double den = 2 * dot(ba, cd);
  if (!(std::abs(den) > 0)) return false;
  const double nb = dot(ba, ba), nc = dot(ca, ca), nd = dot(da, da);
  double off[3];
  for (int k = 0; k < 3; ++k) off[k] = (nb * cd[k] + nc * db[k] + nd * bc[k]) / den;
  r2 = dot(off, off);
  for (int k = 0; k < 3; ++k) cc[k] = a[k] + off[k];
  return std::isfinite(r2);
}

}  // namespace tetopt::detail
