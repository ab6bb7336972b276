// Exact orientation: sign convention and exactness on near-degenerate input.
#include <gtest/gtest.h>

#include <cmath>

#include "tetopt/predicates.hpp"

using namespace tetopt;

TEST(Predicates, UnitCornerTetIsPositive) {
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, d[3] = {0, 0, 1};
  EXPECT_EQ(orient3d(a, b, c, d), Sign::Positive);
  EXPECT_EQ(orient3d(b, a, c, d), Sign::Negative);
  EXPECT_EQ(orient3d(a, b, c, a), Sign::Zero);
}

TEST(Predicates, ExactOnNearlyCoplanarPoints) {
  // d is a rounding error away from the plane z = 0; naive evaluation of
  // large shifted coordinates loses it, the exact predicate must not.
  const double s = 1e15;
  const double a[3] = {s, s, 0}, b[3] = {s + 1, s, 0}, c[3] = {s, s + 1, 0};
  const double up[3] = {s + 0.5, s + 0.5, std::ldexp(1.0, -60)};
  const double on[3] = {s + 0.5, s + 0.5, 0};
  const double down[3] = {s + 0.5, s + 0.5, -std::ldexp(1.0, -60)};
  EXPECT_EQ(orient3d(a, b, c, up), Sign::Positive);
  EXPECT_EQ(orient3d(a, b, c, on), Sign::Zero);
  EXPECT_EQ(orient3d(a, b, c, down), Sign::Negative);
}

TEST(Predicates, CoplanarFourPointsAreZeroExactly) {
  // Points on the plane x + y + z = 1 given by exactly representable values.
  const double a[3] = {1, 0, 0}, b[3] = {0, 1, 0}, c[3] = {0, 0, 1}, d[3] = {0.25, 0.25, 0.5};
  EXPECT_EQ(orient3d(a, b, c, d), Sign::Zero);
  const double e[3] = {0.25, 0.25, std::nextafter(0.5, 1.0)};
  EXPECT_NE(orient3d(a, b, c, e), Sign::Zero);
}

TEST(Predicates, Orient2dProjected) {
  const double a[3] = {0, 0, 5}, b[3] = {1, 0, 7}, c[3] = {0, 1, 9};
  EXPECT_EQ(orient2d_projected(a, b, c, 2), Sign::Positive);
  EXPECT_EQ(orient2d_projected(b, a, c, 2), Sign::Negative);
}
