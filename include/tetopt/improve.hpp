// tetopt/improve.hpp — the combined improvement driver (Liu et al. 2012, §2).
//
// improve() runs on a mesh with topology built and never moves a constrained
// vertex or removes a constrained face.  Modes:
//   Smooth    the paper's weighted optimisation-based smoothing alone (§3)
//   Topo      the quality-driven flip pass alone (§4 operations)
//   Combined  the paper's loop: Phi = vertices of tets with alpha < gamma;
//             pick one in seeded random order; if it and all its neighbours
//             are constrained, topology optimisation (Algorithm 4) on its
//             all-boundary tets, else weighted smoothing; until Phi is empty
//             or `iterations` rounds
//   Best      (default) past the paper: rounds of Algorithm 4, flips
//             everywhere in the interior, smoothing with both optimisers, with
//             rising thresholds, until a round improves nothing
// Every run ends with check_invariants (invariants.hpp); a failure returns
// ErrorCode::Invariant and the caller must not write the mesh.
#pragma once
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>

#include "tetopt/guard.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/objective.hpp"
#include "tetopt/quality.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

enum class ImproveMode { Smooth, Topo, Combined, Best };

/// Where a run stands, handed to ImproveOptions::progress at every phase
/// boundary (the same points the run may stop at).
struct ImproveProgress {
  /// "start", "relax", "all-boundary", "flips", "pairs", "insert",
  /// "smooth", "smooth-maxmin", "dihedral", "polish" (each once it has
  /// run), "done" (before the final check).
  const char* phase = "start";
  int round = 0;          ///< 1-based round of the loop, 0 outside the rounds
  /// A rough share of the run done, 0..1: (rounds done + phases done in this
  /// round / phases of a round) / iterations (times the trials of mode best,
  /// ImproveOptions::threshold; round counts each trial's from 1).  Mode best
  /// usually converges before `iterations` rounds, so it jumps to 1 at "done".
  double fraction = 0;
  /// The worst q of the objective (alpha by default) as the driver last saw
  /// it (its cache is not refilled for this; NaN before it is first known).
  double worst = NAN;
  /// The round's threshold: the tets below it are the round's poor tets
  /// (ImproveOptions::threshold, or mode best's raised one); NaN outside
  /// the rounds.
  double threshold = NAN;
};
/// Progress callback: return false to stop the run at this point; improve()
/// then returns ErrorCode::Stopped with a valid mesh.  Called on the thread
/// that called improve(), never concurrently.
using ProgressFn = std::function<bool(const ImproveProgress&)>;

struct ImproveOptions {
  ImproveMode mode = ImproveMode::Best;
  bool maxmin_optimizer = false;  ///< Smooth/Combined: Freitag's max-min instead of the paper's scheme
  double weight = 0.75;           ///< C of eq. (3.4), 0.5 <= C < 1
  /// gamma: tets with alpha < gamma are poor.  Mode best: the rounds' gamma
  /// starts at 0.3 and rises; a threshold of 0.4 or more adds a trial of the
  /// rounds from each further 0.1 up to it, each from the input, the best
  /// result kept, so a higher threshold never ends with a worse worst q
  /// (improve.cpp, Driver::best_trial_gammas; issue 27); one below 0.3 runs
  /// the default's rounds.  Each trial costs about a default run.
  double threshold = 0.3;
  /// Mode best: false runs one trial, its rounds from `threshold` itself
  /// (tetopt-mpi's parts, whose round thresholds are its own schedule).
  bool threshold_trials = true;
  int iterations = 10;            ///< rounds (sweeps of the loop)
  uint64_t seed = 0;              ///< visiting order
  int threads = 1;                ///< worker threads (results are identical for any count)
  bool check_invariants = true;   ///< prove the promise at the end (recommended)
  /// Best mode: allow inserting new free vertices in cavities of poor tets
  /// (appended after the existing ones, which keep their ids); off by default
  /// because some users need the vertex set unchanged.
  bool allow_insert = false;
  /// Best mode: allow removing free vertices (edge contraction,
  /// TopoEditor::remove_vertex) where that raises the worst alpha of their
  /// star; off by default for the same reason.  The removed vertices are
  /// dropped at the end (compact_vertices: the other vertices keep their
  /// order, ids shift down) unless keep_vertex_ids is set.
  bool allow_remove = false;
  /// With allow_insert, mode best: the interior remesher first (insert.hpp,
  /// remesh_pass): sweeps of edge splits toward the size field, collapses of
  /// short edges (of vertices the remesher made, or any free vertex with
  /// allow_remove), flips and smoothing, before the rounds.  > 0: the target
  /// edge length everywhere (--size); 0: the size field of remesh_pass (a
  /// point field "size", else the constrained triangles' edge lengths).
  double size = 0;
  /// With allow_insert on a raw mesh (constrained vertices with no free
  /// vertex near them, `tetgen -p`): R > 1, the most the interior's size may
  /// grow per edge length away from the surface's (--gradation R, MMG's
  /// -hgrad R: a slope of log R per unit length); 0: the default, a slope
  /// of 0.15 (R = 1.16).  Larger: fewer, larger interior tets.
  double gradation = 0;
  bool remesh = true;  ///< false: allow_insert inserts only in the cavities of the worst tets (the former mode)
  /// With allow_remove: leave removed vertices in the array, referenced by no
  /// tet (ImproveReport::removed_vertices), so every id stays valid (tetopt-mpi
  /// merges parts by id and drops them once at the end).
  bool keep_vertex_ids = false;
  /// What every stage optimises (objective.hpp): alpha (the paper's, the
  /// default), sine, jacobian or skewness.  threshold and the internal
  /// thresholds apply to this q (1 regular, 0 flat).
  Objective objective = Objective::Alpha;
  /// Guards (guard.hpp): no operation may create a tet worse than the
  /// input's worst on any per-tet measure of measures.hpp; the run's report
  /// says which measure refused how many operations.  false: --no-guard.
  bool guard = true;
  /// With guard, mode best: end with the mean polish (improve.cpp: one
  /// guarded smart-Laplacian sweep over every free vertex, then the paper's
  /// optimiser if the mean alpha is still below the input's) whatever the
  /// mean alpha.  Off: the polish runs only when the mean alpha fell below
  /// the input's.  On the demo impeller it raises the mean alpha 0.704 ->
  /// 0.740 with every extreme kept, for about a third more time (--polish).
  bool polish = false;
  /// With guard: extremes no stricter than these (values of each per-tet
  /// measure; NaN: none).  tetopt-mpi gives every part the whole mesh's
  /// extremes, so that a part whose own worst tets are better is not held
  /// to them.
  std::array<double, kTetMeasureCount> guard_floor = {NAN, NAN, NAN, NAN, NAN, NAN, NAN, NAN};
  /// Called at every phase boundary (ImproveProgress); empty: none.
  ProgressFn progress;
};

/// What a run did.
struct ImproveReport {
  QualityStats before, after;
  int64_t smooth_moves = 0, smooth_tried = 0;
  int64_t flip23 = 0, flip32 = 0, edge_removals = 0, multi_face_removals = 0, flip22 = 0, flip44 = 0;
  int64_t pair_flips = 0;  ///< two-operation changes (topo.hpp, improve_tet_pair), also counted in the flips
  int64_t all_boundary_removed = 0;
  int64_t insertions = 0;     ///< vertices inserted (allow_insert)
  int64_t removals = 0;       ///< vertices removed (allow_remove)
  int64_t edge_splits = 0;    ///< the remesher's edge splits (also counted in insertions)
  int64_t edge_collapses = 0; ///< the remesher's edge collapses (also counted in removals)
  double seconds_remesh = 0;  ///< the remesher's split / collapse sweeps (also counted in topo)
  /// Ids (in the numbering before the final compaction) of the removed vertices.
  std::vector<int32_t> removed_vertices;
  int64_t untangled = 0;      ///< input tets that were inverted or flat and are now positive
  int64_t still_inverted = 0; ///< input tets inverted or flat that untangling could not fix
  int64_t vertex_moves = 0;   ///< relocations by the final dihedral pass
  int rounds = 0;
  double seconds_total = 0, seconds_smooth = 0, seconds_topo = 0;
  double seconds_check = 0;  ///< invariant snapshot + proof
  double seconds_polish = 0; ///< the mean polish (guarded best mode), also counted in smooth / topo
  /// --objective openfoam: the face pass (face_pass.hpp) ran; the largest
  /// interior-face non-orthogonality (degrees) before and after it, its
  /// vertex moves, its face removals (2-3 flips and multi-face removals)
  /// and edge removals, and how many of those removals came with a move.
  bool face_pass_on = false;
  double non_orthogonality_before = 0, non_orthogonality_after = 0;
  int64_t face_moves = 0, face_face_removals = 0, face_edge_removals = 0, face_combined = 0;
  /// Why the largest face stays (FacePassStats::worst_move_floor,
  /// worst_lowering_options, worst_constrained_refused).
  double face_worst_move_floor = -1;
  int face_worst_lowering = 0, face_worst_constrained_refused = 0;
  double seconds_face = 0;
  bool invariants_checked = false, invariants_ok = false;
  std::string invariant_message;
  /// Guards: whether they were on, the extremes they held (the input's
  /// worst per tet measure, after untangling) and the operations each
  /// measure refused (index: Measure, per-tet measures only).
  bool guard_on = false;
  std::array<double, kTetMeasureCount> guard_extreme{};
  std::array<int64_t, kTetMeasureCount> guard_refused{};
  int guard_takes = 0;  ///< times the extremes were taken (the input, then each time one improved)
  /// The run stopped early at the caller's request (improve() returned
  /// ErrorCode::Stopped); the mesh is valid.
  bool stopped_early = false;
};

/// Improves m in place.  Requires build_topology(m); leaves it current.
/// Stopping early: when opt.progress returns false, the run stops at that
/// phase boundary, still runs the final check (opt.check_invariants) and the
/// after statistics, and returns ErrorCode::Stopped (Status::stopped(),
/// Status::mesh_valid()) with report.stopped_early.  `interrupted`, when
/// given, is an abort (Ctrl-C): polled between phases and inside the passes
/// (between colour classes of a smoothing sweep, windows of flips, single
/// operations), so the run returns within one of those; it also returns
/// ErrorCode::Stopped with a valid mesh (every committed operation keeps the
/// invariants) but skips the final proof and the after statistics
/// (report.invariants_checked is false): the caller is expected to discard
/// the mesh, as `tetopt improve` does (exit 130, nothing written).
Status improve(TetMesh& m, const ImproveOptions& opt, ImproveReport& report, const LogFn& log = {},
               const std::atomic<bool>* interrupted = nullptr);

const char* mode_name(ImproveMode m);

/// The run report as a JSON object (before/after statistics, operation
/// counts, time per phase, the invariant check and the options used).
std::string report_to_json(const ImproveReport& r, const ImproveOptions& o, const std::string& input,
                           const std::string& output);

}  // namespace tetopt
