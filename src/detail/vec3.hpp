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

}  // namespace tetopt::detail
