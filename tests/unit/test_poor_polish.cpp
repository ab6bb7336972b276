// The poor-tet polish after the remesher (improve.cpp, Driver::polish_poor):
// the rounds' max-min moves leave the other poor tets of a star at the
// level of its worst; a sum-of-1/alpha smoothing of the vertices of the
// tets below 0.2, under guards that keep every extreme, lifts some of them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <string>
#include <vector>

#include "needle_box.hpp"
#include "tetopt/diagnose.hpp"
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

// At the bound (the 0.999 needle holds the worst alpha at the mesh bound)
// one insertion call aims at the tets below 0.2 before their polish
// (improve.cpp, Driver::insert_poor).  Without it these ended with 6, 23
// and 26 tets below 0.2; the worst alpha is the same either way.
TEST(PoorPolish, InsertionAtTheBoundLiftsPoorTets) {
  struct Case {
    uint64_t seed;
    double off;
    int64_t at_most;
  };
  for (const Case c : {Case{5, 0.8, 3}, Case{6, 0.9, 20}, Case{2, 0.9, 21}}) {
    TetMesh m = two_needle_box(6, 2, c.seed, c.off);
    ASSERT_TRUE(build_topology(m).ok());
    const double bound = mesh_bound(m, 1, false, /*walls=*/false).alpha;
    const Result r = improve_with_insertion(m);
    ASSERT_GE(r.worst, 0.99 * bound) << "seed " << c.seed << ": not at the bound, nothing to show";
    EXPECT_LE(r.below, c.at_most) << "seed " << c.seed;
  }
}

// Mode best with --allow-insert, once the worst alpha is within 1% of the
// mesh bound (improve.cpp, Driver::worst_at_bound): no round can raise the
// worst, so a round that raised nothing raises the threshold only while at
// most 5% of the tets or 2,000 lie below the new one (kWideFraction,
// kWideMinAtBound; without the bound, up to 20,000 tets or a quantile).
// With the bound ignored this fails (2,202 tets below a raised threshold).  The progress callback sees each
// round's threshold (ImproveProgress::threshold) and the mesh at the end of
// each round ("smooth-maxmin"), from which the next round's set is counted
// as the driver counts it.  The box must meet such a refusal (a raise the
// rule without the bound would have made), else the test shows nothing.
TEST(PoorPolish, AtTheBoundTheRoundsWidenOverAFewTetsOnly) {
  TetMesh m = tetopt_test::needle_box(26, 3, 5);
  ASSERT_TRUE(build_topology(m).ok());
  const double bound = mesh_bound(m, 1, false, /*walls=*/false).alpha;
  ASSERT_GT(bound, 0);
  struct End {
    int round;
    double gamma, worst;
    std::vector<double> alpha;
  };
  std::vector<End> ends;
  int last_round = 0;
  int checked = 0, refused = 0;
  // The decision after round e, seen at the start of the next one (or at
  // the end of the run: next_gamma NaN).
  auto judge = [&](const End& e, const End* before, double next_gamma) {
    if (!(e.worst >= 0.99 * bound)) return;
    if (before && before->round + 1 == e.round && e.worst > before->worst + 1e-6) return;  // the worst rose
    auto below = [&](double g) { return std::count_if(e.alpha.begin(), e.alpha.end(), [&](double a) { return a < g; }); };
    const double fifth = std::max(0.05 * static_cast<double>(e.alpha.size()), 2000.0);
    if (next_gamma > e.gamma + 1e-12) {
      ++checked;
      EXPECT_LE(static_cast<double>(below(next_gamma)), fifth) << "round " << e.round << " -> threshold " << next_gamma;
    } else if (e.gamma < 0.6 - 1e-12 && static_cast<double>(below(std::min(0.6, e.gamma + 0.1))) > fifth) {
      ++refused;
    }
  };
  ImproveOptions o;
  o.mode = ImproveMode::Best;
  o.allow_insert = o.allow_remove = true;
  o.progress = [&](const ImproveProgress& p) {
    if (p.round > 0 && std::string(p.phase) == "all-boundary") {
      if (!ends.empty() && ends.back().round + 1 == p.round)
        judge(ends.back(), ends.size() > 1 ? &ends[ends.size() - 2] : nullptr, p.threshold);
      else if (!ends.empty() && p.round <= last_round)
        judge(ends.back(), ends.size() > 1 ? &ends[ends.size() - 2] : nullptr, NAN);
      last_round = p.round;
    }
    if (p.round > 0 && std::string(p.phase) == "smooth-maxmin") {
      End e{p.round, p.threshold, 1, {}};
      for (int32_t t = 0; t < m.nt(); ++t) e.alpha.push_back(tet_alpha(m, t));
      e.worst = *std::min_element(e.alpha.begin(), e.alpha.end());
      ends.push_back(std::move(e));
    }
    return true;
  };
  ImproveReport r;
  ASSERT_TRUE(improve(m, o, r).ok());
  if (!ends.empty()) judge(ends.back(), ends.size() > 1 ? &ends[ends.size() - 2] : nullptr, NAN);
  RecordProperty("checked", checked);
  RecordProperty("refused", refused);
  EXPECT_GT(refused, 0) << "no round at the bound met a set too large: nothing shown";
}

// The poor-tet insertion is kept only when, after the polish, it leaves
// fewer tets below 0.2 than the polish alone would, or as many with a mean
// alpha at least as high (improve.cpp; on aorta_vessel the insertion left
// 2,202 tets below 0.2 where the polish alone leaves 2,019).  The debug log
// gives both branches' counts and means; the mesh returned must be the
// better one (or what the stage at the bound, which may run after it, made
// of that one where it kept its change).  Seed 6 is a box where both leave 4 tets below 0.2 and the
// insertion's mean is lower (dropped), seed 5 one where the insertion
// leaves 3 against 6 (kept): keeping the insertion always fails the first,
// dropping it always the second.
TEST(PoorPolish, InsertionKeptOnlyWhereItLeavesFewerPoorTets) {
  struct Case {
    uint64_t seed;
    bool kept;
  };
  for (const Case c : {Case{6, false}, Case{5, true}}) {
    TetMesh m = two_needle_box(6, 2, c.seed, 0.8);
    ASSERT_TRUE(build_topology(m).ok());
    ImproveOptions o;
    o.mode = ImproveMode::Best;
    o.allow_insert = o.allow_remove = true;
    ImproveReport r;
    std::string line, at_bound;
    ASSERT_TRUE(improve(m, o, r, [&](LogLevel, const std::string& s) {
                  if (s.find("poor-tet insertion then polish") != std::string::npos) line = s;
                  if (s.find("flips and polish at the bound") != std::string::npos) at_bound = s;
                }).ok());
    ASSERT_FALSE(line.empty()) << "seed " << c.seed << ": the poor-tet insertion changed nothing, nothing shown";
    long long with_below = -1, without_below = -1;
    double with_mean = 0, without_mean = 0, level = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "poor-tet insertion then polish: %lld tets below %lf, mean %lf; the polish alone: %lld, %lf",
                          &with_below, &level, &with_mean, &without_below, &without_mean),
              5)
        << line;
    EXPECT_EQ(line.find("insertion kept") != std::string::npos, c.kept) << line;
    int64_t below = 0;
    double sum = 0;
    for (int32_t t = 0; t < m.nt(); ++t) {
      const double q = tet_alpha(m, t);
      below += q < 0.2;
      sum += q;
    }
    const double mean = sum / m.nt();
    // The stage at the bound runs after it when the worst alpha is there
    // (at_bound_stage): where it keeps its change, the mesh is what it
    // reports, which starts from the kept branch.
    long long bound_before = -1, bound_after = -1;
    double bound_mean0 = 0, bound_mean1 = 0;
    if (!at_bound.empty()) {
      ASSERT_EQ(std::sscanf(at_bound.c_str(), "flips and polish at the bound: %lld -> %lld tets below %lf, mean %lf -> %lf",
                            &bound_before, &bound_after, &level, &bound_mean0, &bound_mean1),
                5)
          << at_bound;
      EXPECT_EQ(bound_before, std::min(with_below, without_below)) << line << " | " << at_bound;
      EXPECT_NEAR(bound_mean0, c.kept ? with_mean : without_mean, 1e-5) << line << " | " << at_bound;
    }
    if (at_bound.find(", kept") != std::string::npos) {
      EXPECT_EQ(below, bound_after) << at_bound;
      EXPECT_NEAR(mean, bound_mean1, 1e-5) << at_bound;
    } else {
      EXPECT_EQ(below, std::min(with_below, without_below)) << line;
      EXPECT_NEAR(mean, c.kept ? with_mean : without_mean, 1e-5) << line;
      if (with_below == without_below) {
        EXPECT_NEAR(mean, std::max(with_mean, without_mean), 1e-5) << line;
      }
    }
  }
}
