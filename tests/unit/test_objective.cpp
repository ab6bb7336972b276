// --objective and the guards (issue 26 items 2-3): objective.hpp, guard.hpp
// and improve() with them.  Every run here also proves the boundary promise
// (improve's check_invariants: constrained vertices bit-identical,
// constrained faces kept, no inverted tet, region volumes kept).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <limits>
#include <vector>

#include "tetopt/face_pass.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/guard.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/measures.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/objective.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/smooth.hpp"
#include "needle_box.hpp"

using namespace tetopt;

namespace {
const double kReg[4][3] = {{1, 1, 1}, {-1, 1, -1}, {1, -1, -1}, {-1, -1, 1}};  // regular, positive

// A jittered two-region box with its topology (a mesh made here).
TetMesh box(int n, double jitter, uint64_t seed) {
  TetMesh m = make_box_mesh({.nx = n, .ny = n, .nz = n, .jitter = jitter, .seed = seed, .regions = 2});
  EXPECT_TRUE(build_topology(m));
  return m;
}

// The needle box (needle_box.hpp) with its topology: a thin wall meshed
// coarsely, where the unguarded run trades other measures for alpha.
TetMesh needle_mesh(int nx, int nz, uint64_t seed) {
  TetMesh m = tetopt_test::needle_box(nx, nz, seed);
  EXPECT_TRUE(build_topology(m));
  return m;
}

// The worst value of every per-tet measure, oriented so higher is better.
std::vector<double> worst_oriented(const TetMesh& m) {
  const QualityStats s = compute_stats(m, 1, true);
  std::vector<double> w;
  for (int k = 0; k < kTetMeasureCount; ++k)
    w.push_back(oriented(static_cast<Measure>(k), s.measures.m[static_cast<size_t>(k)].worst));
  return w;
}
}  // namespace

TEST(Objective, RegularTetScoresOneFlatZeroInvertedNegative) {
  for (Objective o : {Objective::Alpha, Objective::Sine, Objective::Jacobian, Objective::Skewness}) {
    SCOPED_TRACE(objective_name(o));
    EXPECT_NEAR(objective_quality(o, kReg[0], kReg[1], kReg[2], kReg[3]), 1.0, 1e-12);
    // d moved onto the plane of a, b, c: flat, q = 0 (up to rounding).
    const double flat[3] = {(kReg[0][0] + kReg[1][0] + kReg[2][0]) / 3, (kReg[0][1] + kReg[1][1] + kReg[2][1]) / 3,
                            (kReg[0][2] + kReg[1][2] + kReg[2][2]) / 3};
    EXPECT_NEAR(objective_quality(o, kReg[0], kReg[1], kReg[2], flat), 0.0, 1e-12);
    // Half way there: between the two.
    const double half[3] = {(flat[0] + kReg[3][0]) / 2, (flat[1] + kReg[3][1]) / 2, (flat[2] + kReg[3][2]) / 2};
    const double qh = objective_quality(o, kReg[0], kReg[1], kReg[2], half);
    EXPECT_GT(qh, 0.0);
    EXPECT_LT(qh, 1.0);
    // Swapping two vertices inverts the tet: q <= 0.
    EXPECT_LE(objective_quality(o, kReg[1], kReg[0], kReg[2], kReg[3]), 0.0);
    Objective back;
    ASSERT_TRUE(parse_objective(objective_name(o), back));
    EXPECT_EQ(back, o);
  }
  Objective x;
  EXPECT_FALSE(parse_objective("checkmesh", x));
  ASSERT_TRUE(parse_objective("openfoam", x));
  EXPECT_EQ(x, Objective::OpenFoam);
  EXPECT_EQ(objective_measure(Objective::OpenFoam), Measure::NonOrthogonality);
  // The scaling the engine relies on: sine divided by its regular value.
  EXPECT_NEAR(objective_quality(Objective::Sine, kReg[0], kReg[1], kReg[2], kReg[3]) * kRegularSine,
              sine_min(kReg[0], kReg[1], kReg[2], kReg[3]), 1e-15);
}

TEST(Guard, AdmitsTheMeshOwnTetsAndRefusesAWorseOne) {
  TetMesh m = box(4, 0.3, 3);
  Guard g;
  Guard::take(m, 1, g);
  ASSERT_TRUE(g.on());
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    ASSERT_TRUE(g.admits(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]))) << "tet " << t;
  }
  EXPECT_EQ(g.refused_total(), 0);
  // The extremes are the mesh's worst values.
  const QualityStats s = compute_stats(m, 1, true);
  for (int k = 0; k < kTetMeasureCount; ++k)
    EXPECT_EQ(g.extreme(static_cast<Measure>(k)), s.measures.m[static_cast<size_t>(k)].worst) << kMeasures[k].key;
  // A sliver is worse than a jittered box on every measure: refused, and
  // counted against the first measure it fails (alpha).
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, d[3] = {0.3, 0.3, 0.01};
  EXPECT_FALSE(g.admits(a, b, c, d));
  EXPECT_EQ(g.refused(Measure::Alpha), 1);
  // Exempt alpha (the objective's own rules): the next measure refuses it.
  g.exempt(Measure::Alpha);
  EXPECT_FALSE(g.admits(a, b, c, d));
  EXPECT_EQ(g.refused(Measure::Alpha), 1);
  EXPECT_EQ(g.refused_total(), 2);
}

// Guard::add_zone (improve.cpp's forced split): a tet with a vertex inside
// a zone is admitted whatever its measures, with an infinite slack; the
// same tet outside every zone is refused again once they are cleared.
TEST(Guard, ZonesAdmitWhatTouchesThemOnly) {
  TetMesh m = box(4, 0.3, 3);
  Guard g;
  Guard::take(m, 1, g);
  const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, d[3] = {0.3, 0.3, 0.01};
  ASSERT_FALSE(g.admits(a, b, c, d));
  ASSERT_LT(g.slack(a, b, c, d), 0);
  const int64_t refused = g.refused_total();
  const double far[3] = {5, 5, 5};
  g.add_zone(far, 1.0);  // no vertex of the sliver within 1 of (5, 5, 5)
  EXPECT_TRUE(g.has_zones());
  EXPECT_FALSE(g.admits(a, b, c, d));
  const double near_b[3] = {1.2, 0.1, 0};
  g.add_zone(near_b, 0.5);  // b is 0.22 from it
  EXPECT_TRUE(g.admits(a, b, c, d));
  EXPECT_EQ(g.slack(a, b, c, d), std::numeric_limits<double>::infinity());
  EXPECT_EQ(g.refused_total(), refused + 1);  // the refusal with the far zone only
  g.clear_zones();
  EXPECT_FALSE(g.has_zones());
  EXPECT_FALSE(g.admits(a, b, c, d));
}

TEST(Guard, StaleOnlyWhenATetHoldingAnExtremeChanged) {
  TetMesh m = box(4, 0.3, 5);
  Guard g;
  Guard::take(m, 1, g);
  EXPECT_FALSE(g.stale(m));
  // Move a free vertex of the worst-alpha tet a little: stale.
  const QualityStats s = compute_stats(m, 1);
  const int32_t* v = m.tet(s.worst_tet);
  int32_t free_v = -1;
  for (int k = 0; k < 4; ++k)
    if (!m.vert_constrained[v[k]]) free_v = v[k];
  ASSERT_GE(free_v, 0);
  const double keep = m.point(free_v)[0];
  m.point(free_v)[0] = keep + 1e-9;
  EXPECT_TRUE(g.stale(m));
  m.point(free_v)[0] = keep;
  EXPECT_FALSE(g.stale(m));
}

// Guard::extremes and restore (improve.cpp's poor-tet insertion returns to
// a copy of the mesh): the extremes of one mesh put back after a take() on
// another are that mesh's again, value for value, and not stale on it.
TEST(Guard, RestoredExtremesAreTheFirstMeshs) {
  TetMesh a = box(4, 0.3, 5), b = box(4, 0.1, 6);
  Guard g;
  Guard::take(a, 1, g);
  std::vector<double> first;
  for (int k = 0; k < kTetMeasureCount; ++k) first.push_back(g.extreme(static_cast<Measure>(k)));
  const Guard::Extremes saved = g.extremes();
  Guard::take(b, 1, g);
  int differ = 0;
  for (int k = 0; k < kTetMeasureCount; ++k) differ += g.extreme(static_cast<Measure>(k)) != first[static_cast<size_t>(k)];
  ASSERT_GT(differ, 0) << "the two boxes have the same extremes: nothing shown";
  g.restore(saved);
  for (int k = 0; k < kTetMeasureCount; ++k) EXPECT_EQ(g.extreme(static_cast<Measure>(k)), first[static_cast<size_t>(k)]) << kMeasures[k].key;
  EXPECT_FALSE(g.stale(a));
}

// The promise of item 3: with the guards on (the default), a run ends no
// worse than its input on the worst of any per-tet measure, for every
// objective, and the boundary is kept (check_invariants inside improve).
TEST(Objective, GuardedRunsEndNoWorseOnAnyMeasure) {
  for (Objective o : {Objective::Alpha, Objective::Sine, Objective::Jacobian, Objective::Skewness}) {
    SCOPED_TRACE(objective_name(o));
    TetMesh m = box(5, 0.42, 11);
    const std::vector<double> before = worst_oriented(m);
    const double mean_before = compute_stats(m, 1).alpha_mean;
    ImproveOptions opt;
    opt.objective = o;
    opt.iterations = 4;
    ImproveReport rep;
    const Status st = improve(m, opt, rep);
    ASSERT_TRUE(st) << st.message;
    EXPECT_TRUE(rep.invariants_ok) << rep.invariant_message;
    EXPECT_TRUE(rep.guard_on);
    const std::vector<double> after = worst_oriented(m);
    for (int k = 0; k < kTetMeasureCount; ++k)
      EXPECT_GE(after[static_cast<size_t>(k)], before[static_cast<size_t>(k)]) << kMeasures[k].key;
    // The objective's own worst rose.
    const Measure om = objective_measure(o);
    EXPECT_GT(after[static_cast<size_t>(om)], before[static_cast<size_t>(om)]) << kMeasures[static_cast<int>(om)].key;
    EXPECT_GE(rep.after.alpha_mean, mean_before);
  }
}

// Where the unguarded run ends worse than its input on some measure (the
// needle box), the guarded one does not.
TEST(Objective, GuardsKeepWhatTheUnguardedRunLoses) {
  const TetMesh m0 = needle_mesh(8, 4, 1);
  const std::vector<double> before = worst_oriented(m0);
  int worse_unguarded = 0;
  for (bool guard : {false, true}) {
    SCOPED_TRACE(guard ? "guarded" : "unguarded");
    TetMesh m = m0;
    ImproveOptions opt;
    opt.guard = guard;
    ImproveReport rep;
    ASSERT_TRUE(improve(m, opt, rep));
    EXPECT_TRUE(rep.invariants_ok) << rep.invariant_message;
    const std::vector<double> after = worst_oriented(m);
    for (int k = 0; k < kTetMeasureCount; ++k) {
      const bool worse = after[static_cast<size_t>(k)] < before[static_cast<size_t>(k)];
      if (!guard) worse_unguarded += worse;
      if (!guard && worse) {
        std::printf("unguarded worsens %s: %.6g -> %.6g\n", kMeasures[k].key, before[static_cast<size_t>(k)],
                    after[static_cast<size_t>(k)]);
      }
      if (guard) {
        EXPECT_FALSE(worse) << kMeasures[k].key;
      }
    }
    if (guard) {
      int64_t refused = 0;
      for (int64_t n : rep.guard_refused) refused += n;
      EXPECT_GT(refused, 0);
    }
  }
  EXPECT_GT(worse_unguarded, 0) << "the mesh no longer shows what the guards are for";
}

// Each objective raises its own measure's worst more than the default
// (alpha) run does on the same mesh, or as much: what --objective is for.
TEST(Objective, EachObjectiveLeadsOnItsOwnMeasure) {
  TetMesh base = box(5, 0.42, 13);
  ImproveOptions opt;
  opt.iterations = 4;
  TetMesh ma = base;
  ImproveReport ra;
  ASSERT_TRUE(improve(ma, opt, ra));
  const std::vector<double> wa = worst_oriented(ma);
  for (Objective o : {Objective::Sine, Objective::Jacobian}) {
    SCOPED_TRACE(objective_name(o));
    TetMesh m = base;
    ImproveOptions oo = opt;
    oo.objective = o;
    ImproveReport r;
    ASSERT_TRUE(improve(m, oo, r));
    const size_t k = static_cast<size_t>(objective_measure(o));
    EXPECT_GE(worst_oriented(m)[k], wa[k]);
  }
}

// --no-guard (guard = false): no guards taken, none reported.
TEST(Objective, NoGuardTakesNoExtremes) {
  TetMesh m = box(4, 0.3, 17);
  ImproveOptions opt;
  opt.guard = false;
  opt.iterations = 2;
  ImproveReport rep;
  ASSERT_TRUE(improve(m, opt, rep));
  EXPECT_FALSE(rep.guard_on);
  EXPECT_EQ(rep.guard_takes, 0);
  const std::string js = report_to_json(rep, opt, "in", "out");
  EXPECT_NE(js.find("\"guards\": {\"on\": false}"), std::string::npos) << js;
  EXPECT_NE(js.find("\"guard\": false"), std::string::npos);
}

// The mesh is the same for every thread count, and so are the guards'
// counts (refusals while planning in parallel are counted when the plan is
// used: Guard::Deferred).
TEST(Objective, GuardCountsAreTheSameForEveryThreadCount) {
  const TetMesh m0 = needle_mesh(8, 4, 2);
  std::vector<TetMesh> out;
  std::vector<ImproveReport> reps;
  for (int threads : {1, 2, 3}) {
    TetMesh m = m0;
    ImproveOptions opt;
    opt.threads = threads;
    ImproveReport rep;
    ASSERT_TRUE(improve(m, opt, rep));
    out.push_back(m);
    reps.push_back(rep);
  }
  int64_t refused = 0;
  for (int64_t n : reps[0].guard_refused) refused += n;
  EXPECT_GT(refused, 0);
  for (size_t i = 1; i < out.size(); ++i) {
    EXPECT_EQ(out[i].xyz, out[0].xyz);
    EXPECT_EQ(out[i].tets, out[0].tets);
    EXPECT_EQ(reps[i].guard_refused, reps[0].guard_refused);
    EXPECT_EQ(reps[i].guard_takes, reps[0].guard_takes);
  }
}

// --polish (ImproveOptions::polish): the same run with the mean polish at
// its end raises the mean alpha and the mean of the other measures, and ends
// no worse than the run without it on the worst value of any measure, alpha
// included (the polish guards every measure: a star's own worst may fall, the
// mesh's may not). It fails when alpha is left out of the polish's guards.
TEST(Objective, PolishRaisesTheMeanAndKeepsEveryWorst) {
  for (uint64_t seed : {3u, 8u, 11u}) {
    SCOPED_TRACE(seed);
    // A jittered box, whose worst tets are free to move, and the needle box.
    TetMesh a = seed == 8 ? needle_mesh(7, 4, seed) : box(6, 0.42, seed);
    TetMesh b = seed == 8 ? needle_mesh(7, 4, seed) : box(6, 0.42, seed);
    ImproveOptions opt;
    opt.iterations = 4;
    ImproveReport ra, rb;
    ASSERT_TRUE(improve(a, opt, ra));
    opt.polish = true;
    ASSERT_TRUE(improve(b, opt, rb));
    EXPECT_TRUE(rb.invariants_ok) << rb.invariant_message;
    const std::vector<double> wa = worst_oriented(a), wb = worst_oriented(b);
    for (int k = 0; k < kTetMeasureCount; ++k) EXPECT_GE(wb[static_cast<size_t>(k)], wa[static_cast<size_t>(k)]) << kMeasures[k].key;
    EXPECT_GT(rb.after.alpha_mean, ra.after.alpha_mean + 0.005);
    const QualityStats sa = compute_stats(a, 1, true), sb = compute_stats(b, 1, true);
    EXPECT_GT(sb.measures.m[static_cast<size_t>(Measure::MeanRatio)].mean,
              sa.measures.m[static_cast<size_t>(Measure::MeanRatio)].mean);
    EXPECT_GT(rb.seconds_polish, 0.0);
  }
}

// The smart Laplacian optimiser (smooth.hpp): every committed move lowers
// its star's f_v, so the pass lowers the mesh's f and never inverts a tet.
TEST(Objective, SmartLaplaceOnlyCommitsMovesThatLowerTheStarSum) {
  TetMesh m = box(6, 0.4, 5);
  SmoothOptions so;
  so.optimizer = Optimizer::SmartLaplace;
  so.threshold = 1.01;
  so.iterations = 1;
  so.weight = 0.5;
  const double f0 = mesh_objective(m, 0.5);
  const SmoothStats st = smooth_pass(m, so);
  EXPECT_GT(st.moves_applied, 0);
  EXPECT_LT(mesh_objective(m, 0.5), f0);
  EXPECT_TRUE(nonpositive_tets(m).empty());
}

// --objective openfoam: the face pass (face_pass.hpp) lowers the largest
// interior-face non-orthogonality of a jittered box (free vertices around
// the worst faces), never raises it, and keeps every per-tet measure's worst
// (the guards, alpha's included), with the boundary promise checked by
// improve().  The largest value agrees with the measures table's.
TEST(Objective, OpenFoamFacePassLowersTheLargestNonOrthogonality) {
  for (uint64_t seed : {2u, 7u}) {
    SCOPED_TRACE(seed);
    TetMesh a = box(6, 0.45, seed), b = box(6, 0.45, seed);
    ImproveOptions opt;
    opt.iterations = 4;
    ImproveReport ra, rb;
    ASSERT_TRUE(improve(a, opt, ra));
    opt.objective = Objective::OpenFoam;
    ASSERT_TRUE(improve(b, opt, rb));
    EXPECT_TRUE(rb.invariants_ok) << rb.invariant_message;
    ASSERT_TRUE(rb.face_pass_on);
    EXPECT_FALSE(ra.face_pass_on);
    // The per-tet stages ran as with alpha: the face pass starts where the
    // alpha run ended.
    EXPECT_DOUBLE_EQ(rb.non_orthogonality_before, max_non_orthogonality(a));
    EXPECT_LT(rb.non_orthogonality_after, rb.non_orthogonality_before - 0.1);
    EXPECT_GT(rb.face_moves, 0);
    EXPECT_DOUBLE_EQ(rb.non_orthogonality_after, max_non_orthogonality(b));
    const QualityStats sb = compute_stats(b, 1, true);
    EXPECT_NEAR(sb.measures.m[static_cast<size_t>(Measure::NonOrthogonality)].worst, rb.non_orthogonality_after, 1e-9);
    const std::vector<double> wa = worst_oriented(a), wb = worst_oriented(b);
    for (int k = 0; k < kTetMeasureCount; ++k) EXPECT_GE(wb[static_cast<size_t>(k)], wa[static_cast<size_t>(k)]) << kMeasures[k].key;
  }
}

// The face pass's topological step under the guards, after improve()'s
// per-tet stages: on jittered boxes it takes removals together with a move
// of a free vertex of their new tets (an operation whose refused tets that
// move makes admissible), keeps the promise and every per-tet worst of the
// alpha run, and ends no higher than where it started.
TEST(Objective, OpenFoamFacePassTakesRemovalsWithAVertexMove) {
  for (uint64_t seed : {1u, 3u}) {
    SCOPED_TRACE(seed);
    TetMesh a = box(6, 0.45, seed), b = box(6, 0.45, seed);
    ImproveOptions opt;
    opt.iterations = 4;
    ImproveReport ra, rb;
    ASSERT_TRUE(improve(a, opt, ra));
    opt.objective = Objective::OpenFoam;
    ASSERT_TRUE(improve(b, opt, rb));
    EXPECT_TRUE(rb.invariants_ok) << rb.invariant_message;
    EXPECT_GT(rb.face_face_removals + rb.face_edge_removals, 0);
    EXPECT_GT(rb.face_combined, 0);
    EXPECT_LE(rb.non_orthogonality_after, rb.non_orthogonality_before);
    EXPECT_DOUBLE_EQ(rb.non_orthogonality_after, max_non_orthogonality(b));
    EXPECT_TRUE(nonpositive_tets(b).empty());
    const std::vector<double> wa = worst_oriented(a), wb = worst_oriented(b);
    for (int k = 0; k < kTetMeasureCount; ++k) EXPECT_GE(wb[static_cast<size_t>(k)], wa[static_cast<size_t>(k)]) << kMeasures[k].key;
  }
}

// A face whose two tets have constrained apexes and whose own vertices are
// constrained but one: d between the centroids is fixed, so no move of the
// free vertex takes its non-orthogonality below asin(|d.e|/(|d||e|)), e the
// constrained edge (face_pass.hpp); the pass leaves such a face's value at
// or above that floor.
TEST(Objective, OpenFoamFaceWithFixedCentroidLineHasAFloor) {
  const double e0[3] = {0, 0, 0}, e1[3] = {1, 0.3, 0};
  const double x[3] = {0.2, 0.1, 1}, y[3] = {0.7, 0.5, -1};  // the apexes: d = (y - x) / 4
  const double ex = e1[0] - e0[0], ey = e1[1] - e0[1], ez = e1[2] - e0[2];
  const double dx = y[0] - x[0], dy = y[1] - x[1], dz = y[2] - x[2];
  const double floor_deg = std::asin(std::fabs(ex * dx + ey * dy + ez * dz) /
                                     (std::sqrt(ex * ex + ey * ey + ez * ez) * std::sqrt(dx * dx + dy * dy + dz * dz))) *
                           180.0 / M_PI;
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-2, 2);
  double best = 180;
  for (int i = 0; i < 20000; ++i) {
    const double v[3] = {u(rng), u(rng), 0.3 * u(rng)};
    // Owner: (e0, e1, v) + x, neighbour (e0, e1, v) + y.
    const double nonorth = face_non_orthogonality(e0, e1, v, x, y);
    best = std::min(best, std::min(nonorth, 180.0 - nonorth));
  }
  EXPECT_GE(best, floor_deg - 1e-9);
  EXPECT_LT(best, floor_deg + 1.0);  // and the floor is reached (the plane through e containing d's normal)
}
