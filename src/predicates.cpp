// Exact predicates through CGAL's filtered kernel (see predicates.hpp).
#include "tetopt/predicates.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace tetopt {
namespace {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
inline K::Point_3 P(const double* p) { return K::Point_3(p[0], p[1], p[2]); }
}  // namespace

Sign orient3d(const double* a, const double* b, const double* c, const double* d) {
  // CGAL::orientation(p,q,r,s) is POSITIVE when det[q-p; r-p; s-p] > 0
  // (checked by tests/unit/test_predicates.cpp on the unit corner tet).
  const CGAL::Orientation o = CGAL::orientation(P(a), P(b), P(c), P(d));
  return o == CGAL::POSITIVE ? Sign::Positive : (o == CGAL::NEGATIVE ? Sign::Negative : Sign::Zero);
}

Sign orient2d_projected(const double* a, const double* b, const double* c, int drop) {
  const int i = drop == 0 ? 1 : 0;
  const int j = drop == 2 ? 1 : 2;
  using P2 = K::Point_2;
  const CGAL::Orientation o =
      CGAL::orientation(P2(a[i], a[j]), P2(b[i], b[j]), P2(c[i], c[j]));
  return o == CGAL::POSITIVE ? Sign::Positive : (o == CGAL::NEGATIVE ? Sign::Negative : Sign::Zero);
}

}  // namespace tetopt
