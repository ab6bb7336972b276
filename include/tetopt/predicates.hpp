// tetopt/predicates.hpp — exact geometric predicates.
//
// Every validity decision in tetopt (is this tet inverted? flat?) goes through
// orient3d here, which is exact for all double inputs: CGAL's filtered kernel
// (Exact_predicates_inexact_constructions_kernel) evaluates the determinant in
// interval arithmetic and falls back to exact multiprecision arithmetic only
// when the filter cannot decide.  No initialisation is needed and the call is
// thread-safe.
//
// Sign convention (stated once, here):
//   orient3d(a,b,c,d) = sign of det[b-a; c-a; d-a]
//   Sign::Positive for the unit corner tet a=(0,0,0) b=(1,0,0) c=(0,1,0)
//   d=(0,0,1), i.e. d lies on the side the right-hand normal of (a,b,c)
//   points to.  tetopt stores tets positively oriented.
#pragma once

namespace tetopt {

enum class Sign : int { Negative = -1, Zero = 0, Positive = 1 };

/// Exact orientation of four points (each a pointer to 3 doubles).
Sign orient3d(const double* a, const double* b, const double* c, const double* d);

/// Convenience: true when orient3d is Positive.
inline bool is_positive(const double* a, const double* b, const double* c, const double* d) {
  return orient3d(a, b, c, d) == Sign::Positive;
}

/// Exact orientation of three points projected on the coordinate plane that
/// drops axis `drop` (0,1,2); used for coplanarity tie-breaks.
Sign orient2d_projected(const double* a, const double* b, const double* c, int drop);

}  // namespace tetopt
