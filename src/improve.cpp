// The combined improvement driver (see improve.hpp).
#include "tetopt/improve.hpp"

#include "tetopt/face_pass.hpp"

#include <chrono>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>
#include <vector>

#include "tetopt/diagnose.hpp"
#include "tetopt/insert.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/relax.hpp"
#include "tetopt/report.hpp"
#include "tetopt/smooth.hpp"
#include "tetopt/topo.hpp"
#include "tetopt/untangle.hpp"
#include "detail/parallel.hpp"
#include "detail/vec3.hpp"

namespace tetopt {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// ImproveOptions::gradation (a ratio R, MMG's hgrad) as the remesher's slope
// log R (RefineOptions / RemeshOptions::gradation); 0 stays the default.
double grade_slope(double ratio) { return ratio > 0 ? std::log(ratio) : 0.0; }

// What mode best's trials report: the counters of the kept trial (what
// made the output) with the time spent by all of them.
ImproveReport with_times_of(ImproveReport counters, const ImproveReport& times) {
  counters.seconds_smooth = times.seconds_smooth;
  counters.seconds_topo = times.seconds_topo;
  counters.seconds_check = times.seconds_check;
  counters.seconds_polish = times.seconds_polish;
  counters.guard_takes = times.guard_takes;
  return counters;
}

// The poor-tet polish's threshold (Driver::polish_poor), and the level no
// flip at the bound may add tets below (Driver::polish_at_bound).
constexpr double kPoorBelow = 0.2;

// The radius of the guards' zone around a forced split's vertex
// (forced_split_stage), in longest edges of its star.
constexpr double kZoneEdges = 3;

// What decides whether the poor-tet insertion and the stage at the bound
// are kept (improve()): the tets below kPoorBelow, then the mean alpha.
struct PoorTally {
  int64_t below = 0;
  double mean = 0;
  bool better_than(const PoorTally& o) const { return below != o.below ? below < o.below : mean >= o.mean; }
};

// Runs the phases of one mode and accumulates counters and times in rep.
class Driver {
 public:
  Driver(TetMesh& m, const ImproveOptions& o, ImproveReport& r, const LogFn& log,
         const std::atomic<bool>* interrupted, Guard* guard)
      : m_(m), o_(o), r_(r), log_(log), stop_(interrupted), threads_(o.threads), guard_(guard) {
    // The passes' own Info lines are detail at the driver's level.
    if (log_)
      sub_log_ = [this](LogLevel l, const std::string& s) { log_(l == LogLevel::Info ? LogLevel::Debug : l, s); };
  }

  // The caller asked the run to stop: its progress callback returned false
  // or `interrupted` (an abort, also polled inside the passes) is set.
  bool stopped() const { return cancelled_ || aborted(); }
  bool aborted() const { return stop_ && stop_->load(); }

  // A phase boundary: ImproveOptions::progress hears of it (with the worst q
  // of the cache when the cache is current, not refilled for it: the
  // passes' results do not depend on the callback).  False when the run
  // must stop here.
  bool checkpoint(const char* phase, double phases_done = 0) {
    if (o_.progress && !cancelled_) {
      if (static_cast<int32_t>(alpha_.size()) == m_.nt() && !alpha_.empty()) last_worst_ = worst();
      ImproveProgress p;
      p.phase = phase;
      p.round = round_;
      const double planned = o_.mode == ImproveMode::Smooth || o_.mode == ImproveMode::Topo
                                 ? 1.0
                                 : static_cast<double>(std::max(1, o_.iterations)) * trials_;
      // Outside the rounds (dihedral pass, polish): the rounds run so far.
      const double f = round_ > 0 ? (round_base_ + round_ - 1 + phases_done) / planned : (round_base_ + r_.rounds) / planned;
      last_fraction_ = std::max(last_fraction_, std::clamp(f, 0.0, 1.0));
      if (std::string(phase) == "done") last_fraction_ = 1.0;
      p.fraction = last_fraction_;
      p.worst = last_worst_;
      if (round_ > 0) p.threshold = std::isnan(round_gamma_) ? o_.threshold : round_gamma_;
      if (!o_.progress(p)) cancelled_ = true;
    }
    return !stopped();
  }

  void info(const std::string& s) const {
    if (log_) log_(LogLevel::Info, s);
  }
  void progress(const std::string& s) const {
    if (log_) log_(LogLevel::Progress, s);
  }

  SmoothOptions smooth_opts(double gamma, int sweeps, bool maxmin, uint64_t seed) const {
    SmoothOptions so;
    so.weight = o_.weight;
    so.threshold = gamma;
    so.iterations = sweeps;
    so.optimizer = maxmin ? Optimizer::MaxMin : Optimizer::Paper;
    so.seed = seed;
    so.threads = o_.threads;
    so.objective = o_.objective;
    so.guard = guard_;
    so.stop = stop_;
    return so;
  }

  void smooth(const SmoothOptions& so) {
    const auto t = Clock::now();
    SmoothStats st = smooth_pass(m_, so, sub_log_, &alpha_);
    r_.smooth_moves += st.moves_applied;
    r_.smooth_tried += st.moves_tried;
    r_.seconds_smooth += since(t);
  }

  void add(const TopoStats& st, double seconds) {
    r_.flip23 += st.flip23;
    r_.flip32 += st.flip32;
    r_.flip44 += st.flip44;
    r_.flip22 += st.flip22;
    r_.edge_removals += st.edge_removals;
    r_.multi_face_removals += st.multi_face_removals;
    r_.all_boundary_removed += st.all_boundary_removed;
    r_.seconds_topo += seconds;
  }

  Status algorithm4(bool strict, double gamma) {
    const auto t = Clock::now();
    TopoOptions to;
    to.must_improve = strict;
    to.worsen_bound = strict ? 0.0 : 0.5;
    to.quality_threshold = gamma;
    to.passes = 3;
    to.threads = threads_;
    to.rebuild_stars = false;
    to.objective = o_.objective;
    to.guard = guard_;
    to.stop = stop_;
    TopoStats st = remove_all_boundary_tets(m_, to, sub_log_, &alpha_);
    add(st, since(t));
    return st.status;
  }

  // The two-operation search (topo.hpp, improve_tet_pair) on the worst tets.
  Status pairs(double gamma) {
    const auto t = Clock::now();
    TopoOptions to;
    to.quality_threshold = gamma;
    to.passes = kPairPasses;
    to.threads = threads_;
    to.rebuild_stars = false;
    to.objective = o_.objective;
    to.guard = guard_;
    to.stop = stop_;
    TopoStats st = pair_flip_pass(m_, to, kPairBand, kPairMax, /*stop_at_worst=*/true, sub_log_, &alpha_);
    add(st, since(t));
    r_.pair_flips += st.pairs;
    return st.status;
  }

  Status flips(double gamma) { return flips(gamma, o_.objective); }
  Status flips(double gamma, Objective objective, double alpha_keep = 0, int passes = 3) {
    const auto t = Clock::now();
    TopoOptions to;
    to.quality_threshold = gamma;
    to.alpha_keep = alpha_keep;
    to.passes = passes;
    to.threads = threads_;
    to.rebuild_stars = false;
    to.objective = objective;
    to.guard = guard_;
    to.stop = stop_;
    TopoStats st = flip_pass(m_, to, sub_log_, &alpha_);
    add(st, since(t));
    return st.status;
  }

  Status run() {
    switch (o_.mode) {
      case ImproveMode::Smooth:
        round_ = 1;
        smooth(smooth_opts(o_.threshold, std::max(1, o_.iterations), o_.maxmin_optimizer, o_.seed));
        r_.rounds = 1;
        checkpoint("smooth", 1);
        return Status::success();
      case ImproveMode::Topo: {
        round_ = 1;
        r_.rounds = 1;
        Status s = flips(o_.threshold);
        checkpoint("flips", 1);
        return s;
      }
      case ImproveMode::Combined: return combined();
      case ImproveMode::Best: return best(best_trial_gammas(o_).front());
    }
    return Status::success();
  }

  // The paper's loop (§2), organised in rounds: the vertices of poor tets
  // (Phi) whose whole neighbourhood is constrained can only be helped through
  // their all-boundary tets, so each round first runs Algorithm 4 on the poor
  // all-boundary tets (transformations may worsen quality within a bound, as
  // the paper allows, because the smoothing that follows repairs them), then
  // one smoothing sweep over the remaining vertices of Phi.  Rounds repeat
  // until Phi is empty, nothing changes, or `iterations` rounds.
  Status combined() {
    for (int round = 0; round < std::max(1, o_.iterations) && !stopped(); ++round) {
      round_ = round + 1;
      const int64_t poor = count_below(o_.threshold);
      progress("round " + std::to_string(round + 1) + ": " + std::to_string(poor) + " tets with alpha < " +
               std::to_string(o_.threshold));
      if (poor == 0) break;
      const int64_t before_ops = ops();
      if (Status s = algorithm4(/*strict=*/round > 0, o_.threshold); !s) return s;
      if (!checkpoint("all-boundary", 0.5)) {
        r_.rounds = round + 1;
        break;
      }
      const int64_t before_moves = r_.smooth_moves;
      smooth(smooth_opts(o_.threshold, 1, o_.maxmin_optimizer, o_.seed + static_cast<uint64_t>(round)));
      r_.rounds = round + 1;
      if (!checkpoint("smooth", 1)) break;
      if (ops() == before_ops && r_.smooth_moves == before_moves) break;
    }
    return Status::success();
  }

  // Past the paper: attack the worst tets until a round improves nothing.
  // Each round: Algorithm 4 on all-boundary tets, quality-driven flips
  // everywhere below gamma, then smoothing with the paper's optimiser and with
  // the max-min optimiser (which directly raises the worst alpha of a star);
  // gamma rises from the user's threshold as the poor tets disappear.
  static constexpr double kInsertBand = 0.05;
  static constexpr double kInsertRise = 0.01;
  static constexpr double kInsertLive = 0.02;
  // Pair search (improve_tet_pair) on the tets below the worst alpha +
  // kPairBand, at most kPairMax per pass, up to kPairPasses passes while the
  // worst alpha rises.  On the demo impeller it lifts the worst alpha from
  // 0.2314 to 0.3631 (cube-clip-5: 0.3803 to 0.4378) for about 0.05 s; the
  // same impeller with its tets in Morton order ended at 0.0342 without it
  // (a sliver that a single flip only made 0.0008 better, leaving a 4-4 flip
  // + 2-3 flip pair as the only way out).  A band of 0.1 doubled the time on
  // cub_wedge_like for no gain; 256 tets per pass gave the same as 64.
  static constexpr double kPairBand = 0.05;
  static constexpr int64_t kPairMax = 64;
  static constexpr int kPairPasses = 8;
  static constexpr double kGammaMax = 0.6;       // mode best: highest threshold
  static constexpr double kWideFraction = 0.05;  // mode best: a raised threshold may take in this
  static constexpr double kWideMin = 20000;      // fraction of the tets, or this many
  static constexpr double kWideMinAtBound = 2000;  // or this many, once the worst is at the bound
  static constexpr double kMinRise = 0.01;       // mode best: smallest rise of gamma worth a round
  // The dihedral pass may not add tets below this alpha (TopoOptions::
  // alpha_keep).  With only the worst alpha as its floor, a mesh whose worst
  // tets stand on needle boundary triangles (alpha 0.0003 at best on
  // aorta_vessel) let the pass put new tets just above that floor beside
  // good ones: aorta_vessel ended with 2,010 tets below alpha 0.1 (1,670 in
  // the input), 885 with an angle below 5 degrees and 105 above 175; now
  // 1,527, 670 and 11, mean alpha 0.5005 -> 0.5043.  A box with 41 needle
  // triangles (the unit test) went from 127 tets below 0.1 to 459; now 122.
  // 0.02 rather than 0.1: at 0.05 and 0.1 the pass also stopped mending the
  // tets of milder needles (below 5 degrees: 8 -> 93 / 120 on that box with
  // needles of 0.97), and 0.005 / 0.01 left half the damage on aorta_vessel.
  // Meshes whose worst alpha is 0.02 or more (the impeller, tire, flange, ...)
  // cannot tell the difference.
  static constexpr double kDihedralAlphaKeep = 0.02;
  // Nor add tets with a dihedral angle above this (TopoOptions::angle_keep).
  // The measure rates 179.5 degrees like 0.375, so the pass bought needle
  // tets' smallest angles up (0.2 -> 0.4 degrees) with new tets of 175-179.5:
  // aorta_vessel (1 tet above 170 in the input) ended with 82, 11 of them
  // above 175; now 6 (5 above 175, made by the alpha rounds before the
  // pass), and 1,413 tets below alpha 0.1 instead of 1,527, mean alpha
  // 0.5043 -> 0.5053; tets with an angle below 5 degrees 670 -> 771.  175
  // instead: 59 above 170, 1,514 below alpha 0.1.  hinge_raw: above 170
  // 19 -> 7.  Every other shared mesh and the demo impeller: same bytes.
  static constexpr double kDihedralAngleKeep = 170.0;

  // Mode best's trials (issue 27: a higher --threshold never gives a worse
  // worst alpha).  The rounds' gamma starts at the threshold, and a run that
  // starts higher ends in a different local optimum, better or worse: on
  // walls one tet thick (tests/data/gmsh/thin_wall.geo) gamma 0.5 ended at 0.2898
  // where 0.3 reached 0.3059 (the 0.3 run's last gain was a pair of flips at
  // gamma 0.6 in its sixth round, on a mesh its rounds at 0.3-0.5 had
  // shaped; the 0.5 run stalled twice at 0.6 first); at its defaults 0.2
  // ended at 0.0611 and 0.3 at 0.0603.  So a threshold G >= 0.4 runs
  // the rounds (with the dihedral pass and the mean polish) once from each
  // of kBaseGamma, kBaseGamma + kGammaStep, ... up to G, each from the
  // input, and keeps the result with the best worst q (then mean alpha;
  // the first on a tie): the trials of a lower threshold are a prefix of a
  // higher one's, so the worst cannot fall as G rises.  The default
  // threshold runs one trial, as before; a threshold below kBaseGamma runs
  // the default's (G still sets which tets the diagnosis reports), one
  // between two steps the trials below it (0.45 as 0.4).  Each trial costs
  // about a default run (improve() keeps a copy of the input and of the
  // best result meanwhile).  Chained trials instead (each from the previous
  // result) kept the prefix property but found nothing past the first
  // trial's local optimum on these walls (t 0.01: 0.1257 at every threshold,
  // where the trial from 0.4 alone reaches 0.1342).  tetopt-mpi's parts run
  // one trial from their round's threshold (ImproveOptions::threshold_trials).
  static constexpr double kBaseGamma = 0.3;
  static constexpr double kGammaStep = 0.1;
  static std::vector<double> best_trial_gammas(const ImproveOptions& o) {
    const double threshold = o.threshold;
    if (!o.threshold_trials) return {threshold};  // tetopt-mpi's parts: the rounds from the round's threshold
    std::vector<double> g{kBaseGamma};
    for (int k = 1; kBaseGamma + k * kGammaStep <= threshold + 1e-9; ++k) g.push_back(kBaseGamma + k * kGammaStep);
    return g;
  }
  // Before a further trial: the mesh is the input again (the caller put it
  // back), so the cache goes, the guards take its extremes again (their
  // refusal counts go on) and the progress moves past the trial before.
  void set_trials(int n) { trials_ = std::max(1, n); }
  void next_trial() {
    alpha_.clear();
    insert_memo_.refused.clear();  // the input again, and its guards are looser
    if (guard_) {
      const auto t = Clock::now();
      Guard::take(m_, threads_, *guard_);
      ++r_.guard_takes;
      r_.seconds_check += since(t);
    }
    round_base_ += std::max(1, o_.iterations);
    round_ = 0;
  }
  // The worst q of the objective on the mesh as it is now (cache refilled)
  // and its mean alpha: what the trials are compared by.
  std::pair<double, double> score() {
    alpha_.clear();
    return {worst(), mean_alpha()};
  }
  // The remesher's rounds once more (see improve(): a run whose worst
  // alpha after the rounds and the mean polish is far below the bound):
  // mode best's rounds and dihedral pass, without the relaxation and the
  // remesher, from gamma0 again and with the next seeds.
  Status again(double gamma0) {
    again_ = true;
    refresh_guard();
    const Status s = best(gamma0);
    again_ = false;
    return s;
  }
  Status best(double gamma0) {
    // A globally bad mesh (a quarter of its tets below alpha 0.1, e.g. a lazy
    // random triangulation) first gets a global relaxation: local passes on
    // the worst tets cannot reorganise thousands of vertices (relax.hpp).
    if (!again_ && relax_wanted(m_, RelaxOptions{}, o_.threads)) {
      const auto t = Clock::now();
      RelaxOptions ro;
      ro.guard = guard_;
      ro.threads = threads_;
      const RelaxStats rs = relax_pass(m_, ro, sub_log_);
      alpha_.clear();
      r_.smooth_moves += rs.moves;
      r_.smooth_tried += rs.moves + rs.put_back;
      r_.seconds_smooth += since(t);
      if (!rs.status) return rs.status;
      if (!checkpoint("relax")) return Status::success();
    }
    if (!again_ && o_.allow_insert && o_.remesh)
      if (Status s = remesh(); !s) return s;
    double gamma = gamma0;
    double prev_worst = worst();
    bool insert_live = true;
    double insert_tried_at = -1;
    int stale = 0;
    bool capped = false;  // gamma was last raised to the widest affordable set, not by 0.1
    const int round0 = again_ ? std::max(1, o_.iterations) : 0;  // again(): the next seeds
    for (int round = 0; round < std::max(1, o_.iterations) && !stopped(); ++round) {
      if (round > 0) refresh_guard();
      round_ = round + 1;
      round_gamma_ = gamma;
      progress("round " + std::to_string(round + 1) + ": worst alpha " + std::to_string(prev_worst) + ", threshold " +
               std::to_string(gamma));
      // A stop between phases ends the run there (rounds counts the round
      // begun): every phase leaves a valid mesh.
      constexpr double kPhases = 6;
      r_.rounds = round + 1;
      if (Status s = algorithm4(true, gamma); !s) return s;
      if (!checkpoint("all-boundary", 1 / kPhases)) return Status::success();
      if (Status s = flips(gamma); !s) return s;
      if (!checkpoint("flips", 2 / kPhases)) return Status::success();
      if (Status s = pairs(gamma); !s) return s;
      if (!checkpoint("pairs", 3 / kPhases)) return Status::success();
      // Insertion (--allow-insert) aims at the worst tets only: those below
      // min(gamma, worst alpha + kInsertBand).  It stops when a pass inserts
      // nothing and starts again when gamma rises.  On the demo impeller
      // (438k tets): 0.3644 in 2.7 s; the former rule (first two rounds,
      // every tet below gamma) gave 0.3278 in 2.1 s, and every tet below a
      // rising gamma in every round 0.4108 in 81 s (2,550 vertices).
      // Since the twentieth session it starts again only when its own
      // threshold rises by kInsertRise (gamma rising above worst alpha +
      // kInsertBand changes nothing), and stops when a pass neither raises
      // the worst alpha nor changes kInsertLive of the tets it tried: on raw
      // tetgen output of tests/data/gmsh/thin_wall.geo (tw_A, 13.5k tets) ten
      // passes of about 3,100 tets each, 1.2 s apiece, made 5-30 changes each
      // and left the worst alpha where it was (12.6 of 13.0 s).
      const double insert_at = std::min(gamma, worst() + kInsertBand);
      if ((o_.allow_insert || o_.allow_remove) && (insert_live || insert_at > insert_tried_at + kInsertRise)) {
        insert_live = true;
        insert_tried_at = insert_at;
        const InsertStats is = insert_below(insert_at);
        if (!is.status) return is.status;
        // tried + skipped: a tet skipped as unchanged since its refusal in
        // an earlier call (InsertMemo) counts as the refusal it would have
        // met again, as it did when it was tried again.
        if (!(is.alpha_worst_after > is.alpha_worst_before) &&
            static_cast<double>(is.inserted + is.removed) < kInsertLive * static_cast<double>(is.tried + is.skipped))
          insert_live = false;
        if (!checkpoint("insert", 3.5 / kPhases)) return Status::success();
      }
      smooth(smooth_opts(gamma, 3, false, o_.seed + static_cast<uint64_t>(round0 + round)));
      if (!checkpoint("smooth", 4.5 / kPhases)) return Status::success();
      smooth(smooth_opts(gamma, 3, true, o_.seed + static_cast<uint64_t>(round0 + round)));
      if (!checkpoint("smooth-maxmin", 1)) return Status::success();
      const double w = worst();
      // A round that does not raise the worst alpha raises gamma, so the next
      // round works on a wider set of tets (flips and moves around the worst
      // ones that a strict local search refused), as long as the wider set
      // is affordable: at most kWideFraction of the tets or kWideMin tets.
      // On the demo impeller the worst alpha rises from 0.1837 to 0.2314 at
      // gamma 0.5 (the former rule, two rounds without gain, ended at gamma
      // 0.4); gamma 0.6 would put 13% of its tets in play for no further gain.
      // When gamma + 0.1 is not affordable, gamma rises to the alpha below
      // which the affordable number of tets lie (alpha_quantile), provided
      // the worst tet has a free vertex (one with four constrained vertices
      // changes only by flips, already tried at this gamma) or insertion is
      // on (which changes such a tet too, in a cavity around it: the demo
      // impeller with --allow-insert --allow-remove stopped at a kind-4 tet
      // at 0.4797 in 3 of 4 seeds, and widened went on to 0.5142 in 3 of 4;
      // no other bench mesh changed, docs/benchmarks.md, twenty-second
      // session), and the rise is
      // at least kMinRise; a round so widened that gains nothing ends the
      // run, as do two rounds in a row without gain otherwise.  Generally
      // poor meshes stopped with the worst alpha exactly at gamma before:
      // jittered boxes of 162k / 384k tets ended at 0.4000 / 0.3000 (1.3 /
      // 2.2 s at 2 threads), now 0.5087 / 0.4685 (4.2 / 4.8 s); the
      // impeller (worst tet all-boundary) and the shared meshes end as before.
      // With --allow-insert, once the worst alpha is at the mesh's bound
      // (worst_at_bound) no round can raise it, and a wider set only serves
      // the distribution: the threshold then rises only while at most
      // kWideFraction of the tets or kWideMinAtBound lie below it (not
      // kWideMin, and never capped).  The mean polish and the poor-tet
      // polish see to the distribution after the rounds.  On bib_0p25 the
      // round at 0.6 took 16,350 of its 131k tets (a quarter of the run)
      // for a mean alpha of 0.7543 instead of 0.7483, with the same 16 tets
      // below 0.2; farm-bench: 0.73x the time (bib_0p5 0.7614 -> 0.7555,
      // flange 0.7362 -> 0.7332, the same count below 0.2;
      // docs/benchmarks.md, twenty-fifth session).  Without the floor of
      // 2,000 a needle box of 432 tets (test_poor_polish) ended with 5 tets
      // below 0.2 instead of 4: on small meshes the wide rounds are cheap.
      if (w <= prev_worst + 1e-6) {
        ++stale;
        if (capped) break;
        const double next = std::min(kGammaMax, gamma + 0.1);
        const bool at_bound = worst_at_bound(w);
        const double wide = std::max(kWideFraction * static_cast<double>(m_.nt()), at_bound ? kWideMinAtBound : kWideMin);
        if (next > gamma && static_cast<double>(count_below(next)) <= wide) {
          gamma = next;
        } else if (const double q = next > gamma && !at_bound && (o_.allow_insert || worst_has_free_vertex())
                                        ? std::min(next, alpha_quantile(static_cast<int64_t>(wide)))
                                        : gamma;
                   q > gamma + kMinRise) {
          gamma = q;
          capped = true;
        } else if (stale >= 2) {
          break;
        }
      } else {
        stale = 0;
        capped = false;
      }
      prev_worst = std::max(prev_worst, w);
    }
    // Dihedral angles are a different objective from alpha: a last pass of
    // flips and vertex relocations raises the smallest / lowers the largest
    // angles of the poor tets, with the current worst alpha as a floor so it
    // never undoes what the rounds reached.
    if (!stopped()) {
      refresh_guard();
      const auto t = Clock::now();
      TopoOptions d;
      d.measure = TopoMeasure::Dihedral;
      d.quality_threshold = 0.3;
      d.passes = 2;
      d.threads = threads_;
      d.rebuild_stars = false;
      d.objective = o_.objective;
      d.guard = guard_;
      d.stop = stop_;
      d.alpha_floor = worst();
      d.alpha_keep = kDihedralAlphaKeep;
      d.angle_keep = kDihedralAngleKeep;
      const TopoStats st = dihedral_pass(m_, d, sub_log_);
      alpha_.clear();
      add(st, since(t));
      r_.vertex_moves += st.vertex_moves;
      if (!st.status) return st.status;
      round_ = 0;
      checkpoint("dihedral", 1);
    }
    return Status::success();
  }

  // The interior remesher (issue 27; insert.hpp, remesh_pass): up to
  // kRemeshSweeps sweeps, each of kRemeshLoops (collect, split) loops of the
  // long edges and as many of collapses of the short ones toward the size
  // field, then flips and one smoothing sweep over the tets below
  // kRemeshGamma, until a sweep changes nothing.  Raw `tetgen -p` output of
  // tests/data/gmsh/body_in_box.geo at s = 0.25 (25,148 tets, all but 16 of
  // them all-boundary, worst alpha 0.0004): 328k-371k tets, worst alpha
  // 0.0394-0.0396 against a bound of 0.0397 in every variant tried; mean
  // alpha / tets below 0.2 / seconds (same machine, busy):
  //   1 loop, 8 sweeps 0.6967 / 194 / 24.8; 2 loops 0.7362 / 51 / 18.7;
  //   3 loops 0.7412 / 17 / 26.1; 2 loops, 5 sweeps 0.7109 / 131 / 19.7;
  //   no smoothing in the sweeps 0.6917 / 606; no flips 0.5153 / 2507;
  //   flips and smoothing below 0.35 / 0.4 instead of 0.5: 0.7072 / 0.6967;
  //   loops until little was left to split (12): 595k splits and 450k
  //   collapses, 159 s (a split without smoothing makes short edges);
  //   refusing split points within 0.6 h of a ring vertex: 3 sweeps left
  //   0.5916.
  // MMG 5 (mmg3d -optim -nosurf) on the same input: 112,561 tets, mean
  // 0.7000, 13 s, with its boundary triangles changed.  The numbers above
  // came with the surface's size at every raw vertex; with the graded size
  // of a raw vertex (insert.hpp, size field) the same run gives 73,894 tets,
  // worst 0.0396, mean 0.7042, 21 below 0.2 in 15-16 s where the former
  // field took 41-44 s (MMG 13 s; docs/benchmarks.md, nineteenth session).
  // Two flip passes instead of three, no multi-face removal or shells of at
  // most 8 in these flips saved no time that showed through the noise and
  // left more tets below 0.3 (66-85 against 46); smoothing before the flips
  // instead of after took longer (17-21 s against 16-17 s).  Flips and
  // smoothing only on the tets below 0.5 with a vertex of a tet the sweep
  // made visited 0.3-14% fewer tets (nearly every poor tet is next to a
  // split or collapse): no faster, 9 more tets below 0.2; one or two flip
  // passes 2-10% faster with a lower worst alpha; a split search of 24
  // evaluations instead of 96 left mean 0.6637 (docs/benchmarks.md,
  // nineteenth session).
  // Since the twentieth session the sweeps start from a Delaunay refinement
  // (refine_pass: circumcentres of the tets whose circumradius exceeds 0.8
  // times their size, then flips and one smoothing sweep), split only edges
  // longer than kRemeshSplit = 1.8 sizes (1.4 for an edge joining two
  // constrained vertices: on a jittered 8^3 box, 1.8 there left 107 of its
  // 132 all-boundary tets and a worst alpha of 0.5087 where 1.4 gave 0.5479
  // and 7; the former build 0.5549), and stop once a sweep changes
  // fewer than kRemeshSettled of the tets.  On bib_0p25 the split-only
  // sweeps inserted 43,786 vertices and collapsed 34,607 of them again
  // (73,894 tets, mean 0.7042, 21 below 0.2, 8.9 s CPU); refinement inserts
  // 14,869 circumcentres, the sweeps then make about 1,300 splits and 1,000
  // collapses: 110,185 tets, mean 0.7383, 23 below 0.2, 3.1-3.9 s CPU
  // (radius ratio 0.7: 154,726 tets, mean 0.7540, 4.2 s; 0.9: 87,103 tets,
  // mean 0.7180, 65 below 0.2, 3.9 s; splits above 1.4: 130,659 tets, mean
  // 0.7128, 6.6 s; no sweeps at all: mean 0.7329, 109 below 0.2).  Stopping
  // the rounds once the worst alpha was within 1% of the bound saved 1.2 s
  // there but left 68 tets below 0.2: the rounds' wider sets are what clean
  // the distribution.  Every variant: worst 0.0394-0.0396, bound 0.0397.
  static constexpr int kRemeshSweeps = 8;
  static constexpr int kRemeshLoops = 2;
  static constexpr double kRemeshGamma = 0.5;
  static constexpr double kRemeshSplit = 1.8;
  static constexpr double kRemeshSettled = 0.005;
  static constexpr double kRemeshRefused = 0.1;
  Status remesh() {
    std::vector<double> h;
    const int32_t nv_input = m_.nv();
    const auto t0 = Clock::now();
    {
      // Delaunay refinement first (refine_pass): on raw `tetgen -p` output it
      // puts the interior's vertices where edge splits would overshoot and
      // collapse most of theirs again (see the note above).
      const auto t = Clock::now();
      RefineOptions fo;
      fo.size = o_.size;
      fo.gradation = grade_slope(o_.gradation);
      fo.objective = o_.objective;
      fo.guard = guard_;
      fo.stop = stop_;
      fo.threads = threads_;
      const RefineStats fs = refine_pass(m_, h, fo, sub_log_);
      alpha_.clear();
      r_.insertions += fs.inserted;
      r_.seconds_remesh += since(t);
      r_.seconds_topo += since(t);
      if (!fs.status) return fs.status;
      progress("refine: " + std::to_string(fs.inserted) + " circumcentres inserted, " + std::to_string(m_.nt()) +
               " tets");
      if (fs.inserted > 0) {
        if (Status s = flips(kRemeshGamma); !s) return s;
        smooth(smooth_opts(kRemeshGamma, 1, false, o_.seed + 0x5EF1AE5u));
      }
      if (!checkpoint("refine")) return Status::success();
    }
    for (int sweep = 0; sweep < kRemeshSweeps && !stopped(); ++sweep) {
      const auto t = Clock::now();
      RemeshOptions ro;
      ro.split_above = kRemeshSplit;
      ro.size = o_.size;
      ro.gradation = grade_slope(o_.gradation);
      ro.objective = o_.objective;
      ro.guard = guard_;
      ro.stop = stop_;
      ro.removable_from = o_.allow_remove ? 0 : nv_input;
      ro.max_loops = kRemeshLoops;
      const RemeshStats rs = remesh_pass(m_, h, ro, sub_log_);
      alpha_.clear();
      r_.insertions += rs.splits;
      r_.removals += rs.collapses;
      r_.edge_splits += rs.splits;
      r_.edge_collapses += rs.collapses;
      r_.removed_vertices.insert(r_.removed_vertices.end(), rs.removed_vertices.begin(), rs.removed_vertices.end());
      r_.seconds_remesh += since(t);
      r_.seconds_topo += since(t);
      if (!rs.status) return rs.status;
      progress("remesh sweep " + std::to_string(sweep + 1) + ": " + std::to_string(rs.splits) + " splits, " +
               std::to_string(rs.collapses) + " collapses, " + std::to_string(m_.nt()) + " tets");
      if (Status s = flips(kRemeshGamma); !s) return s;
      smooth(smooth_opts(kRemeshGamma, 1, false, o_.seed + 0x51ED270B2A7C3u + static_cast<uint64_t>(sweep)));
      if (log_)
        log_(LogLevel::Debug, "remesh sweep " + std::to_string(sweep + 1) + " done at " + std::to_string(since(t0)) +
                                  " s: " + std::to_string(m_.nt()) + " tets, worst " + std::to_string(worst()));
      if (!checkpoint("remesh")) return Status::success();
      // Settled: few changes against the mesh, or against the edges found
      // (most refused: the next sweep would find and refuse them again;
      // hinge_raw repeated 19 splits and 19 collapses of its ~790 edges in
      // every sweep).
      const double ops = static_cast<double>(rs.splits + rs.collapses);
      if (ops < kRemeshSettled * m_.nt() || ops < kRemeshRefused * static_cast<double>(rs.long_edges + rs.short_edges))
        break;
    }
    return Status::success();
  }

  // Mean polish (issue 26: the mean alpha guard, and --polish).  The rounds
  // raise the worst tets and may trade the others for it (tire's mean alpha
  // fell 0.6496 -> 0.6369 unguarded).  A guarded best run whose mean alpha
  // ended below the input's, or any with ImproveOptions::polish, ends with
  // one sweep of smart Laplacian smoothing (Freitag, Jones & Plassmann 1995:
  // the mean of the neighbours, kept only when it helps) over every free
  // vertex: the move is committed when the paper's sum of 1/alpha over the
  // star falls (weight 0.5: every tet alike, as the mean counts them) and
  // no tet of the star is worse than the mesh's current worst on any
  // measure, alpha's included (the guards, none exempt).  A star's own worst
  // alpha may fall (protect_worst off) as long as it stays above the mesh's.
  // With every extreme unchanged, mean alpha on the demo impeller 0.7040 ->
  // 0.7396 (the paper's optimiser instead, 10 sweeps: 0.7462 for 20x the
  // polish's time; with flips over every tet first, 0.7502 for 40x).  The
  // sweep costs about a third of a default run there (farm-bench median
  // 1.37x the CPU time of a run without it; 1.13x when only the vertices of
  // tets below alpha 0.55 are tried, for 0.7237), so it is not on by
  // default: item 4 of issue 26 keeps the default within 1.1x.
  static constexpr int kPolishSweeps = 10;
  double polish_mean(double mean_input, bool always) {
    const double mean_before = mean_alpha();
    if (stopped() || !guard_ || (!always && !(mean_before < mean_input))) return mean_before;
    refresh_guard();
    const auto t = Clock::now();
    // The driver's cache holds the objective's q: dropped before and after
    // when that is not alpha.
    const bool other = o_.objective != Objective::Alpha;
    if (other) alpha_.clear();
    // Where the mean fell below the input's, first the flips over every tet
    // that raise a local worst alpha (the former polish's first step; with
    // a non-alpha objective they also lift the worst alpha, under the
    // objective's guard: tire --objective sine 0.1658 -> 0.1742).  Not for
    // --polish alone: over every tet of the demo impeller they cost about
    // ten times the smoothing sweep.
    if (mean_before < mean_input) {
      if (other && guard_) guard_->exempt_only(Measure::Alpha);
      if (!flips(1.01, Objective::Alpha)) return mean_alpha();
      if (other) alpha_.clear();
    }
    guard_->exempt_none();
    SmoothOptions so = smooth_opts(1.01, 1, false, o_.seed + 0x9E3779B97F4A7C15ull);
    so.optimizer = Optimizer::SmartLaplace;
    so.weight = 0.5;
    so.objective = Objective::Alpha;
    so.protect_worst = false;  // the guards keep every extreme, alpha's included
    smooth(so);
    // The mean may not end below the input's (the mean alpha guard): should
    // one sweep leave it there, the paper's optimiser over every vertex, up
    // to kPolishSweeps sweeps (the former polish, without protect_worst).
    if (mean_alpha() < mean_input && !stopped()) {
      so.optimizer = Optimizer::Paper;
      so.iterations = kPolishSweeps;
      so.all_vertices = true;
      smooth(so);
    }
    guard_->exempt_only(objective_measure(o_.objective));
    if (other) alpha_.clear();
    const double mean = mean_alpha();
    r_.seconds_polish += since(t);
    round_ = 0;
    checkpoint("polish", 1);
    if (log_)
      log_(LogLevel::Debug, "mean polish: mean alpha " + std::to_string(mean_before) + " -> " + std::to_string(mean) +
                                " in " + std::to_string(r_.seconds_polish) + " s");
    return mean;
  }
  // One insertion call (insert_pass: its passes, the rounds' memo) on the
  // tets below `below`, counted in the report.
  InsertStats insert_below(double below) {
    const auto t = Clock::now();
    InsertOptions io;
    io.quality_threshold = below;
    // The rounds once more (again()) insert in tets with two constrained
    // vertices too: the first rounds, which visit only those with three or
    // four (InsertOptions::min_kind), stopped far below the bound.  Raw
    // tetgen -pAQ output of tests/data/gmsh/cylinder_hole.geo: at h = 0.1
    // (ch_0p1_A) 0.4093 -> 0.4572 of a 0.4672 bound, at h = 0.15 0.4753 ->
    // 0.4998; every other bench mesh and 6 more generated ones the same
    // worst alpha.  Two or more in every round instead: ch_0p1_A 0.4572 but
    // bp_raw 0.5406 -> 0.5235 (the rounds' path changes); one or more, or
    // any, here: 0.4112 and 0.4335 (twenty-eighth session,
    // docs/benchmarks.md).
    if (again_) io.min_kind = 2;
    io.insert = o_.allow_insert;
    io.remove = o_.allow_remove;
    io.objective = o_.objective;
    io.guard = guard_;
    io.memo = &insert_memo_;
    io.threads = threads_;
    const InsertStats is = insert_pass(m_, io, sub_log_);
    alpha_.clear();
    r_.insertions += is.inserted;
    r_.removals += is.removed;
    r_.removed_vertices.insert(r_.removed_vertices.end(), is.removed_vertices.begin(), is.removed_vertices.end());
    r_.seconds_topo += since(t);
    return is;
  }
  // The poor-tet insertion (improve(), at the bound): insert_below under
  // the guards as the rounds left them.
  InsertStats insert_poor(double below) {
    if (stopped() || !(o_.allow_insert || o_.allow_remove)) return {};
    refresh_guard();
    return insert_below(below);
  }
  // Where the worst alpha is at the bound after the rounds, the rounds once
  // more (improve()) do not run, and neither do their flips and mean
  // polish, which also raised the mean: flips on the tets below
  // kBoundFlipGamma, then the mean polish.  Since the bound of two kept
  // faces at a sharp edge (twenty-eighth session) put the blade meshes at
  // their bound, the mean had fallen (raw tetgen blade at s 0.1: 0.7598 ->
  // 0.7491); with these, 0.7600 (0.30 s -> 0.35 s); with the polish alone
  // 0.7519, with flips below 0.5 0.7537, below 1.01 0.7595 in 0.48 s
  // (cub_wedge_like 0.7720 -> 0.7787 at 0.7; twenty-ninth session).  One
  // flip pass: the second applied 36 flips of 33,600 tets visited on
  // bib_0p25 and the same means came with one; no flip adds a tet below
  // kPoorBelow (TopoOptions::alpha_keep).  Cost, insertion runs against
  // the build before (median wall of paired runs): bib_0p25 1.17x (mean
  // 0.7483 -> 0.7599), aorta_vessel 1.15x (0.6658 -> 0.6740, tets below
  // 0.2 2,019 -> 1,903).
  static constexpr double kBoundFlipGamma = 0.7;
  void polish_at_bound(double mean_input) {
    if (stopped()) return;
    refresh_guard();
    if (!flips(kBoundFlipGamma, Objective::Alpha, kPoorBelow, 1)) return;
    alpha_.clear();
    ensure_vertex_tets(m_, o_.threads);
    polish_mean(mean_input, true);
  }
  // The worst tets with four constrained vertices split (split_locked_worst,
  // insert.hpp) under the guards as the rounds left them; returns how many.
  // forced (0 < forced < 1): splits that need not lift those tets, with no
  // guard (forced_split_stage checks the measures after the rounds).
  int64_t split_locked(double forced = 0) {
    if (stopped() || !o_.allow_insert) return 0;
    const auto t = Clock::now();
    refresh_guard();
    InsertOptions io;
    io.objective = o_.objective;
    io.guard = guard_;
    const int64_t n = split_locked_worst(m_, io, forced);
    alpha_.clear();
    r_.insertions += n;
    r_.seconds_topo += since(t);
    if (log_)
      log_(LogLevel::Debug, std::string(forced > 0 ? "locked worst tets split (forced): " : "locked worst tets split: ") +
                                std::to_string(n));
    return n;
  }
  // The guards hold these extremes, not taken again until unpinned, and
  // look away inside a ball of kZoneEdges longest edges of its star around
  // each vertex from `zoned_from` on (Guard::add_zone; forced_split_stage:
  // the extremes from before a split the guards did not see, while the
  // rounds repair its tets).
  void pin_guard(const Guard::Extremes& e, int32_t zoned_from) {
    if (!guard_) return;
    guard_->restore(e);
    guard_pinned_ = true;
    ensure_vertex_tets(m_, threads_);
    for (int32_t v = zoned_from; v < m_.nv(); ++v) {
      double longest = 0;
      for (const int32_t* t = m_.star_begin(v); t != m_.star_end(v); ++t)
        for (int j = 0; j < 4; ++j) {
          double edge[3];
          detail::sub(m_.point(v), m_.point(m_.tet(*t)[j]), edge);
          longest = std::max(longest, detail::norm(edge));
        }
      guard_->add_zone(m_.point(v), kZoneEdges * longest);
    }
  }
  void unpin_guard() {
    guard_pinned_ = false;
    if (guard_) guard_->clear_zones();
  }
  // The guards take the mesh's extremes; returns whether none of them but
  // alpha's (the objective here: the caller compares it) is worse than in
  // `saved`.  Where it is, the caller puts back the mesh `saved` came with
  // (Saved::put_back restores the extremes too).  Both are floored alike
  // (Guard::set_floor): a fall below the floor is one the guards allow.
  bool extremes_no_worse(const Guard::Extremes& saved) {
    if (!guard_) return true;
    const auto t = Clock::now();
    Guard::take(m_, threads_, *guard_);
    ++r_.guard_takes;
    r_.seconds_check += since(t);
    for (int k = 0; k < kTetMeasureCount; ++k) {
      const Measure mk = static_cast<Measure>(k);
      const double was = saved.worst[static_cast<size_t>(k)];
      if (mk != Measure::Alpha && worse(mk, guard_->extreme(mk), was)) {
        if (log_)
          log_(LogLevel::Debug, std::string("worse than before: ") + measure_info(mk).key + " " +
                                    std::to_string(guard_->extreme(mk)) + " against " + std::to_string(was));
        return false;
      }
    }
    return true;
  }
  PoorTally poor_tally(double below) { return {count_below(below), mean_alpha()}; }
  // The guards' extremes, to put back with the mesh they were taken from
  // (the poor-tet insertion's two branches, improve()).
  Guard::Extremes guard_extremes() const { return guard_ ? guard_->extremes() : Guard::Extremes{}; }
  // The mesh was replaced by a copy: the cache dropped, and the guards'
  // extremes those saved with that copy.
  void mesh_replaced(const Guard::Extremes& e) {
    alpha_.clear();
    if (guard_) guard_->restore(e);
  }
  // The poor-tet polish (after the remesher): the paper's optimiser (not
  // the mean polish's Laplacian step, nor the rounds' max-min) over the free
  // vertices of the tets below gamma, minimising the sum of 1/alpha over
  // each star with every tet weighted alike (Freitag & Ollivier-Gooch 1997's
  // sum of inverses; the paper's eq. 3.4 with C = 0.5), under the guards
  // with no measure exempt: no tet of a star may end worse than the mesh's
  // worst on any measure, so every extreme stays, and a star's own worst may
  // fall.  The rounds stop where the worst alpha can rise no further; their
  // max-min moves leave the other poor tets of a star at the level of its
  // worst (bib_0p25: a free vertex 1e-3 above a boundary sheet, pinned there
  // by the tet on a needle boundary triangle at the bound, with nine tets
  // below 0.2 around it).  Returns the moves made.
  int64_t polish_poor(double gamma) {
    if (stopped() || !guard_) return 0;
    refresh_guard();
    guard_->exempt_none();
    const int64_t before = r_.smooth_moves;
    SmoothOptions so = smooth_opts(gamma, kPolishSweeps, false, o_.seed + 0x5851F42D4C957F2Dull);
    so.weight = 0.5;
    so.objective = Objective::Alpha;
    so.protect_worst = false;  // the guards keep every extreme, alpha's included
    smooth(so);
    alpha_.clear();
    guard_->exempt_only(objective_measure(o_.objective));
    return r_.smooth_moves - before;
  }
  // --objective openfoam: the face pass (face_pass.hpp) after every other
  // stage, under the guards with no measure exempt (alpha's worst is kept
  // too), or, with --no-guard, above the mesh's worst alpha.
  void face_pass_openfoam() {
    if (stopped()) return;
    FacePassOptions fo;
    if (guard_) {
      refresh_guard();
      guard_->exempt_none();
      fo.guard = guard_;
    } else {
      fo.alpha_floor = worst();
    }
    const FacePassStats fs = face_pass(m_, fo);
    if (guard_) guard_->exempt_only(Measure::Alpha);
    alpha_.clear();
    r_.face_pass_on = true;
    r_.non_orthogonality_before = fs.worst_before;
    r_.non_orthogonality_after = fs.worst_after;
    r_.face_moves = fs.moves;
    r_.face_face_removals = fs.face_removals;
    r_.face_edge_removals = fs.edge_removals;
    r_.face_combined = fs.combined;
    r_.face_worst_move_floor = fs.worst_move_floor;
    r_.face_worst_lowering = fs.worst_lowering_options;
    r_.face_worst_constrained_refused = fs.worst_constrained_refused;
    r_.seconds_face = fs.seconds;
    if (log_)
      log_(LogLevel::Debug, "face pass: largest non-orthogonality " + std::to_string(fs.worst_before) + " -> " +
                                std::to_string(fs.worst_after) + " degrees, " + std::to_string(fs.moves) +
                                " moves, " + std::to_string(fs.face_removals) + " face and " +
                                std::to_string(fs.edge_removals) + " edge removals in " + std::to_string(fs.sweeps) +
                                " sweeps");
  }
  // The guards' extremes are those of the mesh now (guard.hpp): the extremes
  // a round reached are not given back by a later round, the final dihedral
  // pass or the polish.  About one measure pass over the tets each, taken
  // only when a tet holding an extreme has changed (Guard::stale).
  void refresh_guard() {
    if (!guard_ || guard_pinned_ || !guard_->stale(m_)) return;
    const auto t = Clock::now();
    Guard::take(m_, threads_, *guard_);
    ++r_.guard_takes;
    r_.seconds_check += since(t);
  }
  double mean_alpha() const {
    if (m_.nt() == 0) return 0;
    const double sum = detail::parallel_reduce_blocks(
        m_.nt(), threads_, 0.0,
        [&](int64_t b, int64_t e) {
          double x = 0;
          for (int64_t t = b; t < e; ++t) x += tet_alpha(m_, static_cast<int32_t>(t));
          return x;
        },
        [](double x, double y) { return x + y; });
    return sum / m_.nt();
  }

  // The per-tet alpha cache shared by the topology and smoothing passes
  // (filled on demand; every pass that edits the mesh outside them clears it).
  void ensure_cache() {
    if (static_cast<int32_t>(alpha_.size()) == m_.nt()) return;
    alpha_.resize(m_.nt());
    detail::parallel_for_each(m_.nt(), threads_,
                              [&](int64_t t) { alpha_[t] = tet_objective(m_, static_cast<int32_t>(t), o_.objective); });
  }
  double worst() {
    ensure_cache();
    return alpha_.empty() ? INFINITY
                          : detail::parallel_min(static_cast<int64_t>(alpha_.size()), threads_,
                                                 [&](int64_t t) { return alpha_[t]; });
  }
  // Whether the worst alpha w is within kAtBound of what the constrained
  // faces allow any mesh that keeps them (mesh_bound without walls: fixed
  // for the run, as those faces never change; 0.05 s on bib_0p25).
  // Only with --allow-insert and the alpha objective (the default mode
  // keeps its time; another objective's worst is not an alpha).
  bool worst_at_bound(double w) {
    if (!o_.allow_insert || o_.objective != Objective::Alpha) return false;
    return w >= kAtBound * bound();
  }
  // The mesh bound on alpha without walls (mesh_bound), computed once.
  double bound() {
    if (bound_ < 0) {
      const auto t = Clock::now();
      bound_ = mesh_bound(m_, threads_, false, /*walls=*/false).alpha;
      if (log_)
        log_(LogLevel::Debug, "mesh bound " + std::to_string(bound_) + " (" + std::to_string(since(t)) + " s)");
    }
    return bound_;
  }
  static constexpr double kAtBound = 0.99;
  double bound_ = -1;  // worst_at_bound's mesh bound, once computed
  bool guard_pinned_ = false;  // pin_guard
  // Whether the worst tet (the first of the smallest cached alpha) has a
  // vertex smoothing may move.  A worst tet with four constrained vertices
  // changes only by flips, which every round at the current gamma tried.
  bool worst_has_free_vertex() {
    ensure_cache();
    if (alpha_.empty()) return false;
    const int32_t t = static_cast<int32_t>(std::min_element(alpha_.begin(), alpha_.end()) - alpha_.begin());
    return m_.tet_kind[t] < 4;
  }
  // The alpha below which k tets lie (the k-th smallest cached alpha).
  double alpha_quantile(int64_t k) {
    ensure_cache();
    if (alpha_.empty()) return 0;
    k = std::clamp<int64_t>(k, 0, static_cast<int64_t>(alpha_.size()) - 1);
    std::vector<double> a(alpha_);
    std::nth_element(a.begin(), a.begin() + k, a.end());
    return a[static_cast<size_t>(k)];
  }
  int64_t count_below(double gamma) {
    ensure_cache();
    return detail::parallel_count(static_cast<int64_t>(alpha_.size()), threads_,
                                  [&](int64_t t) { return alpha_[t] < gamma; });
  }

  int64_t ops() const {
    return r_.flip23 + r_.flip32 + r_.flip44 + r_.flip22 + r_.edge_removals + r_.multi_face_removals;
  }

 private:
  TetMesh& m_;
  const ImproveOptions& o_;
  ImproveReport& r_;
  const LogFn& log_;
  LogFn sub_log_;
  const std::atomic<bool>* stop_;
  bool cancelled_ = false;  // the progress callback returned false
  double round_gamma_ = NAN;  // mode best's threshold in its rounds (NaN: o_.threshold)
  int round_ = 0;           // 1-based round for ImproveProgress, 0 outside the rounds
  int round_base_ = 0;      // rounds planned for the trials before this one (mode best)
  int trials_ = 1;          // mode best's trials (best_trial_gammas), for ImproveProgress::fraction
  double last_worst_ = NAN;
  double last_fraction_ = 0;  // ImproveProgress::fraction never falls
  int threads_;
  Guard* guard_;
  bool again_ = false;  // again(): best() without the relaxation and the remesher
  std::vector<double> alpha_;  // tet_alpha of every tet when its size is nt (see ensure_cache)
  InsertMemo insert_memo_;     // the insertion rounds' refusals, across rounds (InsertMemo)
};
}  // namespace

const char* mode_name(ImproveMode m) {
  switch (m) {
    case ImproveMode::Smooth: return "smooth";
    case ImproveMode::Topo: return "topo";
    case ImproveMode::Combined: return "combined";
    case ImproveMode::Best: return "best";
  }
  return "?";
}

namespace {
constexpr double kAgainBelow = 0.9;
constexpr double kAgainGain = 0.01;
constexpr int kAgainRuns = 4;
// The rounds once more are for a worst alpha the boundary lets rise by more
// than 1 / kAgainBelow.  Besides the mesh-wide bound (cheap: no walls), the
// walled sides of the tets a rise would have to lift: the kAgainSides
// lowest tets below worst / kAgainBelow, each constrained face's side_bound
// (walls facing it; and the best apex among the vertices there when no new
// vertex is inside the wall, SideBound::vertex_alpha).  A side whose bound
// is below worst / kAgainBelow caps the mesh's worst alpha there in every
// mesh that keeps the boundary (vertex_alpha: and adds no vertex inside
// that wall; the rounds may add one, so that part rests on the argument in
// docs/measures.md that such a vertex cannot help, not on a proof).  On
// raw tetgen output of tests/data/gmsh/thin_wall.geo (tw_A) the rounds end
// at 0.0735 and a side of tet 2239 allows 0.0770 with the wall's vertices;
// the rounds once more cost 38% of the run there (0.69 of 1.80 s) and
// raised nothing.  Walled sides cost milliseconds each, hence the cap.
constexpr int kAgainSides = 32;
double near_worst_cap(const TetMesh& m, double worst) {
  std::vector<std::pair<double, int32_t>> low;
  for (int32_t t = 0; t < m.nt(); ++t)
    if (const double a = tet_alpha(m, t); a < worst / kAgainBelow && m.face_mask[t] != 0) low.emplace_back(a, t);
  const size_t n = std::min(low.size(), static_cast<size_t>(kAgainSides));
  std::partial_sort(low.begin(), low.begin() + static_cast<std::ptrdiff_t>(n), low.end());
  double cap = INFINITY;
  for (size_t i = 0; i < n; ++i)
    for (int f = 0; f < 4; ++f) {
      const int32_t t = low[i].second;
      if (!((m.face_mask[t] >> f) & 1u)) continue;
      const SideBound sb = side_bound(m, 4 * t + f);
      if (sb.alpha < cap) cap = sb.alpha;
      if (sb.vertex_alpha < cap) cap = sb.vertex_alpha;
    }
  return cap;
}

// A mesh, its report and the guards' extremes, as they were before a stage
// that may be dropped (poor_tet_stage, at_bound_stage): put_back makes
// them the run's again.  The caller refreshes the guards before taking
// their extremes.
struct Saved {
  TetMesh mesh;
  ImproveReport rep;
  Guard::Extremes guard;
  void put_back(Driver& d, TetMesh& m, ImproveReport& r) {
    m = std::move(mesh);
    r = with_times_of(rep, r);
    d.mesh_replaced(guard);
  }
};

// The poor-tet stage after the remesher's rounds (improve()): the tets
// below kPoorBelow, which the rounds left at the level of their star's
// worst, polished (see Driver::polish_poor).
// At the bound the rounds' insertion, which aims at the worst tets
// (below the worst alpha + kInsertBand), has nothing left to lift:
// one insertion call (Driver::insert_poor) then aims at the tets below
// kPoorBelow, before their polish.  bib_0p25: 16 -> 14 tets below
// 0.2 (3 vertices inserted); needle boxes (test_poor_polish) 6 -> 3,
// 26 -> 21, 23 -> 20, and in one of 18 boxes 29 -> 30; every other
// bench mesh byte-identical (docs/benchmarks.md, twenty-fifth session).
//
// The insertion is kept only when, after the polish, it leaves fewer
// tets below kPoorBelow than the polish alone would (equal: the higher
// mean alpha): an insertion may raise its cavity's worst alpha and
// still leave more tets below 0.2 there, and its new tets, most of
// them below the mean, lower the mean.  On aorta_vessel the call
// inserted 835 vertices and the run ended with 2,202 tets below 0.2
// and a mean of 0.6621; the polish alone gives 2,019 and 0.6658.  A
// copy of the mesh before the call is polished too when the call
// changed anything (twenty-eighth session, docs/benchmarks.md).
Status poor_tet_stage(Driver& d, TetMesh& m, ImproveReport& rep, int threads, const LogFn& log) {
  auto polish = [&] {
    ensure_vertex_tets(m, threads);
    const int64_t moves = d.polish_poor(kPoorBelow);
    if (log) log(LogLevel::Debug, "poor-tet polish: " + std::to_string(moves) + " moves");
  };
  if (!d.worst_at_bound(d.score().first)) {
    polish();
    return Status::success();
  }
  d.refresh_guard();
  Saved plain{m, rep, d.guard_extremes()};
  const InsertStats is = d.insert_poor(kPoorBelow);
  if (log)
    log(LogLevel::Debug, "poor-tet insertion: " + std::to_string(is.inserted) + " inserted, " +
                             std::to_string(is.removed) + " removed");
  if (!is.status || d.stopped()) return is.status;
  polish();
  if (is.inserted + is.removed == 0 || d.stopped()) return Status::success();
  const PoorTally with = d.poor_tally(kPoorBelow);
  d.refresh_guard();
  Saved inserted{std::move(m), rep, d.guard_extremes()};
  plain.put_back(d, m, rep);
  polish();
  const PoorTally without = d.poor_tally(kPoorBelow);
  const bool keep = d.stopped() || with.better_than(without);
  if (log)
    log(LogLevel::Debug, "poor-tet insertion then polish: " + std::to_string(with.below) + " tets below " +
                             std::to_string(kPoorBelow) + ", mean " + std::to_string(with.mean) +
                             "; the polish alone: " + std::to_string(without.below) + ", " +
                             std::to_string(without.mean) + (keep ? "; insertion kept" : "; insertion dropped"));
  if (keep) inserted.put_back(d, m, rep);
  return Status::success();
}

// Driver::polish_at_bound, kept only where it leaves no more tets below
// kPoorBelow and a higher mean: its flips raise local worst alphas and its
// polish the mean, and either can add a tet below 0.2 (the needle boxes of
// tests/unit/test_poor_polish.cpp: 3 -> 5, 20 -> 22, 21 -> 23).
void at_bound_stage(Driver& d, TetMesh& m, ImproveReport& rep, int threads, const LogFn& log) {
  d.refresh_guard();
  const PoorTally before = d.poor_tally(kPoorBelow);
  Saved plain{m, rep, d.guard_extremes()};
  d.polish_at_bound(rep.before.alpha_mean);
  ensure_vertex_tets(m, threads);
  d.polish_poor(kPoorBelow);
  const PoorTally after = d.poor_tally(kPoorBelow);
  const bool keep = d.stopped() || (after.below <= before.below && after.mean > before.mean);
  if (log)
    log(LogLevel::Debug, "flips and polish at the bound: " + std::to_string(before.below) + " -> " +
                             std::to_string(after.below) + " tets below " + std::to_string(kPoorBelow) + ", mean " +
                             std::to_string(before.mean) + " -> " + std::to_string(after.mean) +
                             (keep ? ", kept" : ", dropped"));
  if (!keep) plain.put_back(d, m, rep);
}

// Where the rounds once more stall with the worst tet's four vertices
// constrained and no split of it lifting it by itself (split_locked),
// a split that may lower its shell for a step (Driver::split_locked with
// kForcedKeep), then a run of the rounds and the mean polish: kept only
// where the run ends with a higher worst alpha and no guarded measure's
// worst below the mesh's before the split (the split itself is not
// guarded); otherwise the mesh, the report and the guards' extremes are
// put back.  bp_g (a gmsh mesh of tests/data/gmsh/blade_passage.geo): the
// worst tet stood on a floor triangle with its apex a vertex of the wall
// above, 0.4829 of a 0.5875 bound; a probe's unguarded midpoint split of
// one of its interior edges (new worst 0.37) and one run of tetopt gave
// 0.5429 (thirtieth session).  The guards hold their extremes from before
// the split during that run, except inside a ball of kZoneEdges longest
// edges around each new vertex (Driver::pin_guard, Guard::add_zone), where
// the split's tets are repaired: taking the extremes again after the split
// instead let the rounds spend the split's slack anywhere (bp_g: a tet
// 0.44 away from it ended with a minimum sine of 0.4459 against the
// mesh's 0.4539 before, and the run was dropped); pinning them with no ball
// left the split unrepaired.  The mean polish runs only on a kept run,
// after the zones are gone (inside them it had lowered the worst alpha
// to 0.4668).  Returns the worst alpha kept, or -1 when put back or when
// nothing was split.
constexpr double kForcedKeep = 0.5;
double forced_split_stage(Driver& d, TetMesh& m, ImproveReport& rep, double gamma0, int threads, const LogFn& log,
                          Status& status) {
  const double before = d.score().first;
  d.refresh_guard();
  Saved plain{m, rep, d.guard_extremes()};
  const int32_t first = m.nv();
  if (d.split_locked(kForcedKeep) == 0) return -1;
  d.pin_guard(plain.guard, first);
  status = d.again(gamma0);
  d.unpin_guard();
  // Stopped in the middle (the caller's stop): the split may be unrepaired,
  // and the copy from before it is the better mesh.
  const bool keep = status && !d.stopped() && d.score().first > before && d.extremes_no_worse(plain.guard);
  if (keep) {
    ensure_vertex_tets(m, threads);
    d.polish_mean(rep.before.alpha_mean, true);
  }
  const double after = d.score().first;
  if (log)
    log(LogLevel::Debug, "forced split then rounds: worst alpha " + std::to_string(before) + " -> " +
                             std::to_string(after) + (keep ? ", kept" : ", dropped"));
  if (!keep && status) {
    plain.put_back(d, m, rep);
    ensure_vertex_tets(m, threads);
    return -1;
  }
  return after;
}
}  // namespace

Status improve(TetMesh& m, const ImproveOptions& opt_in, ImproveReport& rep, const LogFn& log,
               const std::atomic<bool>* interrupted) {
  const auto t0 = Clock::now();
  // --objective openfoam: every per-tet stage raises alpha (a face measure
  // is not a per-tet objective), then the face pass (face_pass.hpp).
  ImproveOptions opt = opt_in;
  const bool openfoam = opt.objective == Objective::OpenFoam;
  if (openfoam) opt.objective = Objective::Alpha;
  if (m.adj.size() != m.tets.size()) return Status::error(ErrorCode::Invariant, "improve: topology not built");
  rep = ImproveReport{};
  rep.before = compute_stats(m, opt.threads);
  InvariantSnapshot snap;
  if (opt.check_invariants) {
    const auto tc = Clock::now();
    snap = capture_invariants(m, opt.threads);
    rep.seconds_check += since(tc);
  }
  // Inverted or flat input tets: untangle first by moving free vertices; the
  // snapshot above was taken before, so the final check accepts only tets
  // that were already non-positive in the input (invariants.hpp).
  if (rep.before.inverted_or_flat > 0) {
    const auto tu = Clock::now();
    const UntangleStats u = untangle(m, log);
    rep.smooth_moves += u.moves;
    rep.seconds_smooth += since(tu);
    rep.untangled = u.nonpositive_before - u.nonpositive_after;
    rep.still_inverted = u.nonpositive_after;
    if (!u.status) return u.status;
  }

  if (opt.weight < 0.5 || opt.weight >= 1.0)
    return Status::error(ErrorCode::InvalidMesh, "improve: weight C must satisfy 0.5 <= C < 1");
  if (!(opt.gradation == 0 || (opt.gradation > 1 && std::isfinite(opt.gradation))))
    return Status::error(ErrorCode::InvalidMesh, "improve: gradation must be 0 (the default) or a ratio above 1");
  // Guards: the extremes of the mesh as it is now (untangled), so that no
  // stage ends the run worse than its input on any per-tet measure.
  Guard guard;
  if (opt.guard) {
    const auto tg = Clock::now();
    guard.set_floor(opt.guard_floor);
    Guard::take(m, opt.threads, guard);
    rep.guard_takes = 1;
    guard.exempt(objective_measure(opt.objective));
    rep.seconds_check += since(tg);
  }
  Driver d(m, opt, rep, log, interrupted, opt.guard ? &guard : nullptr);
  // Mode best with a threshold of 0.4 or more: further trials from this
  // mesh (Driver::best_trial_gammas), the best result kept.
  const std::vector<double> trials =
      opt.mode == ImproveMode::Best ? Driver::best_trial_gammas(opt) : std::vector<double>{};
  d.set_trials(static_cast<int>(trials.size()));
  TetMesh input;
  const ImproveReport rep_input = rep;
  if (trials.size() > 1) input = m;
  // The topology passes run without rebuilding the vertex stars after each
  // (TopoOptions::rebuild_stars); the caller gets them built, error or not.
  Status run_status = d.checkpoint("start") ? d.run() : Status::success();
  if (run_status && opt.guard && opt.mode == ImproveMode::Best && !d.stopped()) {
    ensure_vertex_tets(m, opt.threads);
    // After the remesher the distribution is the goal: the polish always.
    d.polish_mean(rep.before.alpha_mean, opt.polish || (opt.allow_insert && opt.remesh));
    // After the remesher the rounds may end in a local optimum far below
    // what the boundary allows: body_in_box at s = 0.25 with only the box
    // kept stopped at 0.2571, three tets around one free vertex, where a
    // second run of tetopt on that output reached 0.4509-0.5055.  Running the
    // rounds again in the same process right after them did not help (the
    // same 0.2571); after the mean polish, which moved that vertex, it does.
    // So a remesher run whose worst alpha is then below kAgainBelow of the
    // bound (mesh_bound) runs the rounds and the polish once more.
    if (opt.allow_insert && opt.remesh && opt.objective == Objective::Alpha && !d.stopped()) {
      const auto tb = Clock::now();
      double ceiling = d.bound();
      double w = d.score().first;
      if (w < kAgainBelow * ceiling) {
        const double cap = near_worst_cap(m, w);
        if (log)
          log(LogLevel::Debug, "walled sides near the worst allow alpha " + std::to_string(cap) + " (" +
                                   std::to_string(since(tb)) + " s with the mesh bound " + std::to_string(ceiling) + ")");
        ceiling = std::min(ceiling, cap);
      }
      rep.seconds_check += since(tb);
      // Again while the last run raised the worst alpha by more than
      // kAgainGain and it is still below kAgainBelow of the ceiling, at most
      // kAgainRuns runs: raw cylinder_hole at h = 0.15 0.0841 -> 0.4998 ->
      // 0.5094 -> 0.5425 in three runs (0.9 of its bound), at h = 0.25
      // 0.5809 -> 0.5874 in two; every other bench mesh and 15 more
      // generated ones stopped after one (twenty-eighth session).
      for (int run = 0; run < kAgainRuns && run_status && !d.stopped() && w < kAgainBelow * ceiling; ++run) {
        if (log)
          log(LogLevel::Info, "rounds again: worst alpha " + std::to_string(w) + ", bound " + std::to_string(ceiling));
        run_status = d.again(Driver::best_trial_gammas(opt).front());
        if (run_status && !d.stopped()) {
          ensure_vertex_tets(m, opt.threads);
          d.polish_mean(rep.before.alpha_mean, true);
        }
        const double w_next = d.score().first;
        if (!(w_next > w * (1 + kAgainGain))) {
          // Stalled.  Where the worst tet has four constrained vertices, an
          // edge split gives it a free one, and the rounds go once more: raw
          // tetgen -pQ output of tests/data/gmsh/crank.geo at s = 0.03, a
          // tet on a web's face with its apex on the web's rim held the
          // worst at 0.5376 with the tets around lifted to just above it;
          // after its split 0.5507 (5.9 s -> 7.5 s).  Splitting such tets
          // in every insertion call of the rounds once more instead took
          // raw cylinder_hole h = 0.1 from 0.4572 to 0.4100 (twenty-ninth
          // session, docs/benchmarks.md).
          if (run + 1 < kAgainRuns && w_next < kAgainBelow * ceiling) {
            if (d.split_locked() > 0) {
              w = d.score().first;
              continue;
            }
            // No split lifts it by itself: a forced one and a run (its own).
            ++run;
            const double w_forced = forced_split_stage(d, m, rep, Driver::best_trial_gammas(opt).front(),
                                                       opt.threads, log, run_status);
            if (w_forced > w_next * (1 + kAgainGain) && run_status && !d.stopped()) {
              w = w_forced;
              continue;
            }
          }
          break;
        }
        w = w_next;
      }
      // Then the tets below 0.2 (poor_tet_stage).
      if (run_status && !d.stopped()) run_status = poor_tet_stage(d, m, rep, opt.threads, log);
      // At the bound (0.9 of the ceiling, from the start or after runs once
      // more): the flips and polish of a run once more, without its rounds.
      if (!(w < kAgainBelow * ceiling) && run_status && !d.stopped()) at_bound_stage(d, m, rep, opt.threads, log);
    }
  }
  if (trials.size() > 1 && run_status && !d.aborted()) {
    ensure_vertex_tets(m, opt.threads);
    std::pair<double, double> kept_score = d.score();
    TetMesh kept = std::move(m);
    ImproveReport kept_rep = rep;
    for (size_t k = 1; k < trials.size() && !d.stopped(); ++k) {
      m = input;
      rep = with_times_of(rep_input, rep);
      d.next_trial();
      run_status = d.best(trials[k]);
      if (!run_status || d.aborted()) break;
      if (opt.guard && !d.stopped()) {
        ensure_vertex_tets(m, opt.threads);
        d.polish_mean(rep.before.alpha_mean, opt.polish);
      }
      ensure_vertex_tets(m, opt.threads);
      // A trial stopped early left a valid mesh too: compared like the others.
      if (const std::pair<double, double> sc = d.score(); sc > kept_score) {
        kept_score = sc;
        kept = std::move(m);
        kept_rep = rep;
      }
    }
    if (run_status && !d.aborted()) {
      m = std::move(kept);
      rep = with_times_of(kept_rep, rep);
      d.score();  // the cache now describes the kept mesh
      // The guards' extremes as reported: the kept mesh's.
      if (opt.guard) Guard::take(m, opt.threads, guard);
    }
  }
  if (run_status && openfoam) {
    ensure_vertex_tets(m, opt.threads);
    d.face_pass_openfoam();
  }
  ensure_vertex_tets(m, opt.threads);
  rep.guard_on = guard.on();
  for (int k = 0; k < kTetMeasureCount && guard.on(); ++k) {
    rep.guard_extreme[static_cast<size_t>(k)] = guard.extreme(static_cast<Measure>(k));
    rep.guard_refused[static_cast<size_t>(k)] = guard.refused(static_cast<Measure>(k));
  }
  if (!run_status) return run_status;
  rep.stopped_early = d.stopped();
  // An abort (`interrupted`): a valid mesh the caller discards, as soon as
  // possible: no proof, no after statistics.
  if (d.aborted()) {
    rep.seconds_total = since(t0);
    return Status::error(ErrorCode::Stopped, "interrupted; the mesh is valid but not checked again");
  }
  if (!rep.stopped_early) d.checkpoint("done");

  if (opt.check_invariants) {
    const auto tc = Clock::now();
    Status s = check_invariants(m, snap, opt.threads);
    rep.seconds_check += since(tc);
    rep.invariants_checked = true;
    rep.invariants_ok = s.ok();
    rep.invariant_message = s.message;
    if (!s) return s;
  }
  // Removed vertices are referenced by no tet; drop them (after the proof,
  // which compares constrained vertices by id).
  if (!opt.keep_vertex_ids && !rep.removed_vertices.empty())
    if (Status s = compact_vertices(m, rep.removed_vertices); !s) return s;
  rep.after = compute_stats(m, opt.threads);
  rep.seconds_total = since(t0);
  if (rep.stopped_early)
    return Status::error(ErrorCode::Stopped, "stopped early at the caller's request after " +
                                                 std::to_string(rep.rounds) + " rounds; the mesh is valid");
  return Status::success();
}

std::string report_to_json(const ImproveReport& r, const ImproveOptions& o, const std::string& input,
                           const std::string& output) {
  std::ostringstream j;
  char buf[64];
  auto num = [&](double x) {
    std::snprintf(buf, sizeof buf, "%.17g", x);
    return std::string(buf);
  };
  j << "{\n";
  j << "  \"tool\": \"tetopt\",\n  \"version\": \"0.1.0\",\n";
  j << "  \"input\": " << json_string(input) << ",\n  \"output\": " << json_string(output) << ",\n";
  j << "  \"options\": {\"mode\": \"" << mode_name(o.mode) << "\", \"optimizer\": \""
    << (o.maxmin_optimizer ? "maxmin" : "paper") << "\", \"weight\": " << num(o.weight)
    << ", \"threshold\": " << num(o.threshold) << ", \"iterations\": " << o.iterations << ", \"seed\": " << o.seed
    << ", \"threads\": " << detail::resolve_threads(o.threads) << ", \"allow_insert\": " << (o.allow_insert ? "true" : "false")
    << ", \"allow_remove\": " << (o.allow_remove ? "true" : "false") << ", \"objective\": \""
    << objective_name(o.objective) << "\", \"guard\": " << (o.guard ? "true" : "false")
    << ", \"polish\": " << (o.polish ? "true" : "false") << "},\n";
  j << "  \"before\": " << stats_to_json(r.before, 4) << ",\n";
  j << "  \"after\": " << stats_to_json(r.after, 4) << ",\n";
  j << "  \"operations\": {\"smoothing_moves\": " << r.smooth_moves << ", \"smoothing_tried\": " << r.smooth_tried
    << ", \"flip23\": " << r.flip23 << ", \"flip32\": " << r.flip32 << ", \"edge_removals\": " << r.edge_removals
    << ", \"multi_face_removals\": " << r.multi_face_removals << ", \"flip22\": " << r.flip22
    << ", \"flip44\": " << r.flip44 << ", \"pair_flips\": " << r.pair_flips
    << ", \"all_boundary_removed\": " << r.all_boundary_removed
    << ", \"untangled\": " << r.untangled << ", \"still_inverted\": " << r.still_inverted
    << ", \"insertions\": " << r.insertions << ", \"vertex_removals\": " << r.removals
    << ", \"edge_splits\": " << r.edge_splits << ", \"edge_collapses\": " << r.edge_collapses
    << ", \"dihedral_vertex_moves\": " << r.vertex_moves
    << ", \"rounds\": " << r.rounds << "},\n";
  // Removed vertices, 0-based ids of the input numbering (ascending): the
  // output numbers the remaining vertices in order, so a caller can map
  // vertex data (new id = old id - removed ids below it).
  {
    std::vector<int32_t> ids = r.removed_vertices;
    std::sort(ids.begin(), ids.end());
    j << "  \"removed_vertices\": [";
    for (size_t i = 0; i < ids.size(); ++i) j << (i ? ", " : "") << ids[i];
    j << "],\n";
  }
  // Guards: the extreme each measure held and how many operations it
  // refused (the first measure a refused tet failed, in guard.cpp's order).
  // --objective openfoam: the face pass (face_pass.hpp).
  if (r.face_pass_on)
    j << "  \"face_pass\": {\"non_orthogonality_before\": " << num(r.non_orthogonality_before)
      << ", \"non_orthogonality_after\": " << num(r.non_orthogonality_after) << ", \"moves\": " << r.face_moves
      << ", \"face_removals\": " << r.face_face_removals << ", \"edge_removals\": " << r.face_edge_removals << ", \"combined\": " << r.face_combined
      << ", \"worst_move_floor\": " << num(r.face_worst_move_floor)
      << ", \"worst_lowering_options\": " << r.face_worst_lowering
      << ", \"worst_constrained_refused\": " << r.face_worst_constrained_refused
      << ", \"seconds\": " << num(r.seconds_face) << "},\n";
  j << "  \"guards\": {\"on\": " << (r.guard_on ? "true" : "false");
  if (r.guard_on) {
    int64_t total = 0;
    for (int64_t n : r.guard_refused) total += n;
    // The mean alpha guard: the run may not end below the input's mean
    // alpha (improve's polish); false says it could not be kept.
    j << ", \"refused_total\": " << total << ", \"extremes_taken\": " << r.guard_takes
      << ", \"mean_alpha_kept\": " << (r.after.alpha_mean >= r.before.alpha_mean ? "true" : "false") << ", \"measures\": {";
    for (int k = 0; k < kTetMeasureCount; ++k) {
      const MeasureInfo& mi = kMeasures[static_cast<size_t>(k)];
      const double x = r.guard_extreme[static_cast<size_t>(k)];
      j << (k ? ", " : "") << "\"" << mi.key << "\": {\"extreme\": " << (std::isfinite(x) ? num(x) : "null")
        << ", \"refused\": " << r.guard_refused[static_cast<size_t>(k)] << "}";
    }
    j << "}";
  }
  j << "},\n";
  j << "  \"seconds\": {\"total\": " << num(r.seconds_total) << ", \"smoothing\": " << num(r.seconds_smooth)
    << ", \"topology\": " << num(r.seconds_topo) << ", \"invariant_check\": " << num(r.seconds_check) << ", \"mean_polish\": " << num(r.seconds_polish) << ", \"remesh\": " << num(r.seconds_remesh) << "},\n";
  j << "  \"stopped_early\": " << (r.stopped_early ? "true" : "false") << ",\n";
  j << "  \"boundary_unchanged\": {\"checked\": " << (r.invariants_checked ? "true" : "false")
    << ", \"ok\": " << (r.invariants_ok ? "true" : "false") << ", \"message\": " << json_string(r.invariant_message)
    << "}\n}\n";
  return j.str();
}

}  // namespace tetopt
