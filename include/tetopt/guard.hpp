// tetopt/guard.hpp — never worsen the measures one does not optimise
// (issue 26, item 3).
//
// A Guard holds, for every per-tet measure of the table (measures.hpp:
// alpha, minimum sine, smallest and largest dihedral angle, scaled
// Jacobian, radius ratio, mean ratio, equivolume skewness), the worst value
// over the mesh it was taken from.  An operation (a smoothing move, a flip,
// an edge removal, an insertion or removal, a dihedral-pass relocation) is
// committed only when every tet it creates is at least as good as those
// extremes on every measure: the mesh's worst value of each measure can
// then only stay or improve, whatever the objective.  The engine takes the
// extremes of the input once (improve()); the input's own tets all satisfy
// them, bit for bit (a tet rebuilt unchanged gives the same values).
//
// Cost: a tet is measured in order of cost and given up at its first
// failure; the dihedral angles (atan2) are computed only when the minimum
// sine cannot decide them (every dihedral angle θ has sin θ >= sine_min, the
// smallest angle is at most 70.53° and the largest at least that).  Only
// new tets of committed candidates are measured, never the line searches.
//
// Face measures (OpenFOAM non-orthogonality, face skewness) depend on two
// tets' centroids; they are reported and compared before/after, not
// guarded per operation.
#pragma once
#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <vector>

#include "tetopt/measures.hpp"

namespace tetopt {

struct TetMesh;

class Guard {
  struct Holder {  // the first tet holding an extreme, as it was
    int32_t tet = -1;
    int32_t v[4] = {-1, -1, -1, -1};
    double x[12] = {};
  };

 public:
  /// Sets g's extremes to those of m's tets now (tets with a non-positive
  /// volume skipped: untangling owns those).  The refusal counts are kept:
  /// the driver takes the extremes again as the run improves them, so an
  /// operation may not push an extreme past the current one.
  static void take(const TetMesh& m, int threads, Guard& g);

  /// The extremes and the tets holding them, to put back with restore()
  /// when the mesh they were taken from is put back (improve.cpp keeps a
  /// copy of the mesh and may return to it): cheaper than take().
  struct Extremes {
    std::array<double, kTetMeasureCount> worst{};
    std::array<Holder, kTetMeasureCount> holder{};
    double sine_enough = 2;
  };
  Extremes extremes() const { return {worst_, holder_, sine_enough_}; }
  void restore(const Extremes& e) {
    worst_ = e.worst;
    holder_ = e.holder;
    sine_enough_ = e.sine_enough;
    set_angle_cosines();
  }

  /// Whether tet (a, b, c, d) is no worse than every extreme; when not, the
  /// refusal is counted against the first measure it fails.
  bool admits(const double* a, const double* b, const double* c, const double* d) const;
  /// How far tet (a, b, c, d) is from failing: the smallest relative margin
  /// over the guarded measures, (v - e) / |e| where higher is better and
  /// (e - v) / |e| where lower is (e the extreme).  Not negative exactly when
  /// admits() holds; negative by how far the worst measure falls short.
  /// Counts no refusal.  +inf when off.  Used to steer a search toward
  /// positions the guard admits (TopoEditor::insert_vertex).
  double slack(const double* a, const double* b, const double* c, const double* d) const;

  /// From the next take() on, each extreme is lowered to floor[k] (a value
  /// of measure k; NaN: none) where that is worse: tetopt-mpi's parts are
  /// guarded by the whole mesh's extremes, not by their own better ones.
  void set_floor(const std::array<double, kTetMeasureCount>& floor);

  /// Leaves measure k to the engine's own rules: the objective's worst is
  /// what every stage raises, by rules that may lower it for a step (the
  /// paper's may-worsen policy for all-boundary tets, the pair search's
  /// first operation) and never end lower.
  void exempt(Measure k) {
    if (static_cast<int>(k) < kTetMeasureCount) exempt_[static_cast<size_t>(k)] = true;  // face measures: never guarded
  }
  /// Leaves only measure k to the engine (the polish of improve.cpp raises
  /// alpha whatever the objective, and guards the objective's measure).
  /// Guards every measure, the objective's too (the mean polish of
  /// improve.cpp, whose moves do not follow the objective's own rules).
  void exempt_none() { exempt_.fill(false); }
  void exempt_only(Measure k) {
    exempt_.fill(false);
    exempt(k);
  }

  /// Balls inside which the guard looks away: a tet with a vertex inside
  /// one is admitted whatever its measures (and its slack is +inf).
  /// improve.cpp's forced split: the split's tets, which the guard did not
  /// see, are repaired there by the rounds while every tet elsewhere stays
  /// guarded, and the run is kept only where the mesh's extremes end no
  /// worse.  A few balls at most (each admits() call tests them all).
  void add_zone(const double* c, double r);
  void clear_zones() { zones_.clear(); }
  bool has_zones() const { return !zones_.empty(); }

  /// Whether a tet that held an extreme when they were taken has changed
  /// since (its slot holds other vertices, or one of them moved): only then
  /// can an extreme have improved, since every tet created meanwhile was
  /// admitted.  The driver takes the extremes again only when stale.
  bool stale(const TetMesh& m) const;

  /// Refusal counts by measure.
  using Counts = std::array<int64_t, kTetMeasureCount>;
  /// While one is alive on a thread, the refusals made on that thread go to
  /// `into` instead of the guard: the topology passes plan windows of tets
  /// in parallel and plan again those a commit invalidated, so a plan's
  /// refusals are added (add_refused) only when the plan is used, and the
  /// counts are the same for every thread count, as the mesh is.
  class Deferred {
   public:
    explicit Deferred(Counts& into);
    ~Deferred();
    Deferred(const Deferred&) = delete;
    Deferred& operator=(const Deferred&) = delete;

   private:
    Counts* prev_;
  };
  void add_refused(const Counts& c) const;

  bool on() const { return on_; }
  double extreme(Measure k) const { return worst_[static_cast<size_t>(k)]; }
  int64_t refused(Measure k) const { return refused_[static_cast<size_t>(k)].load(std::memory_order_relaxed); }
  int64_t refused_total() const;

 private:
  bool on_ = false;
  std::array<double, kTetMeasureCount> worst_{};
  std::array<bool, kTetMeasureCount> exempt_{};
  std::array<Holder, kTetMeasureCount> holder_{};
  double sine_enough_ = 2;  // sine_min at or above this proves both dihedral extremes
  // Dihedral cosines at or below cos_lo_ and at or above cos_hi_ prove the
  // smallest angle above the extreme and the largest below it (the
  // cosines of the extremes, 1e-9 inside; -inf / +inf: never).
  double cos_lo_ = -std::numeric_limits<double>::infinity();
  double cos_hi_ = std::numeric_limits<double>::infinity();
  void set_angle_cosines();
  struct Zone {
    double c[3];
    double r2;
  };
  std::vector<Zone> zones_;
  bool in_zone(const double* a, const double* b, const double* c, const double* d) const;
  bool has_floor_ = false;
  std::array<double, kTetMeasureCount> floor_{};
  void apply_floor_and_sine();
  // Calls f(k, value, higher_is_better) for each guarded measure of tet
  // (a, b, c, d), cheapest first, while f returns true; the dihedral angles
  // only where sine_min does not prove them already (sine_enough_), nor,
  // with Decide (admits: only the outcome matters), their cosines.
  // Returns whether every call returned true.  admits() and slack() share it.
  template <bool Decide, class F>
  bool each_measure(const double* a, const double* b, const double* c, const double* d, F&& f) const;
  mutable std::array<std::atomic<int64_t>, kTetMeasureCount> refused_{};
};

}  // namespace tetopt
