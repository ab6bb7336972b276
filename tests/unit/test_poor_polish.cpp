// The poor-tet polish after the remesher (improve.cpp, Driver::polish_poor):
// the rounds' max-min moves leave the other poor tets of a star at the
// level of its worst; a sum-of-1/alpha smoothing of the vertices of the
// tets below 0.2, under guards that keep every extreme, lifts some of them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "needle_box.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"

namespace {

using namespace tetopt;

// needle_box (needle_box.hpp) with needles of two strengths: the first
// movable vertex goes almost onto its +x neighbour (x = i + 0.999: the
// mesh's worst, far below the others), the rest to x = i + off.  The tets on
// the milder needles hold free vertices near the bottom face, where the
// max-min moves leave flat tets around them.
TetMesh two_needle_box(int nx, int nz, uint64_t seed, double off) {
  return tetopt_test::needle_box(nx, nz, seed, nullptr, off);
}

struct Result {
  double worst = 1;
  int64_t below = 0;  // tets below alpha 0.2
};

Result improve_with_insertion(TetMesh& m) {
  ImproveOptions o;
  o.mode = ImproveMode::Best;
  o.allow_insert = o.allow_remove = true;
  ImproveReport r;
  EXPECT_TRUE(improve(m, o, r).ok());
  Result res;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const double q = tet_alpha(m, t);
    res.worst = std::min(res.worst, q);
    res.below += q < 0.2;
  }
  return res;
}

}  // namespace

// Without the poor-tet polish these ended with 26 and 6 tets below 0.2 (22
// and 3 with it); the worst alpha is the same either way (the 0.999 needle).
TEST(PoorPolish, LiftsPoorTetsAroundMilderNeedlesWithoutLoweringTheWorst) {
  struct Case {
    uint64_t seed;
    double off;
    int64_t at_most;
  };
  for (const Case c : {Case{3, 0.9, 23}, Case{2, 0.8, 4}}) {
    TetMesh m = two_needle_box(6, 2, c.seed, c.off);
    ASSERT_TRUE(build_topology(m).ok());
    const Result r = improve_with_insertion(m);
    EXPECT_LE(r.below, c.at_most) << "seed " << c.seed;
    EXPECT_GT(r.worst, 0.001) << "seed " << c.seed;
  }
}
