// Neumaier-compensated sum (Neumaier 1974): deterministic, and accurate to
// about 1e-15 relative over millions of tets.  Partial sums of fixed blocks
// are joined in block order with add(other), which gives the same bits for
// every thread count.
#pragma once
#include <cmath>

namespace tetopt::detail {

struct Sum {
  double s = 0, c = 0;
  void add(double x) {
    const double t = s + x;
    c += std::fabs(s) >= std::fabs(x) ? (s - t) + x : (x - t) + s;
    s = t;
  }
  /// Adds another partial sum (its sum, then its compensation).
  void add(const Sum& o) {
    add(o.s);
    add(o.c);
  }
  double value() const { return s + c; }
};

}  // namespace tetopt::detail
