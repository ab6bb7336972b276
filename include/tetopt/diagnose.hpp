// tetopt/diagnose.hpp — why is this tet still bad?
//
// A boundary-preserving method keeps every constrained triangle (boundary,
// region interface, listed triangle), and each such triangle is a face of at
// least one tet on every side that has tets.  Whatever the method does, the
// tet standing on triangle T has some apex D, so its quality is at most
//
//     best_alpha(T) = max over apex positions D (off T's plane) of alpha(T, D)
//
// and the mesh's worst alpha can never rise above min_T best_alpha(T), the
// *mesh-wide bound*.  The same holds for the smallest dihedral angle (bounded
// from above by the best min-dihedral) and the largest (bounded from below).
//
// The best apex is searched in T's frame: T scaled so its longest edge is 1,
// a at the origin, b on the x axis, c in the xy plane, apex (x, y, z) with
// z > 0 (alpha(T, x, y, -z) = -alpha(T, x, y, z), so one side suffices; an
// interface triangle has the same bound on both sides).  The apex is kept within
// 4 longest edges of a along each axis: farther apexes never matter for
// alpha, and the dihedral objectives, whose supremum may lie at infinity
// (a right triangle's largest dihedral tends to 90 degrees as the apex
// rises), are then bounds over that box.  The objective is
// smooth except where the longest edge, or the extreme dihedral angle,
// switches, so the search is: candidate apexes (above the centroid, the
// incentre and the circumcentre at the regular tet's height ratio), a coarse
// 9x9x6 grid over the triangle's neighbourhood, then Nelder–Mead (Nelder and
// Mead 1965) from the best few, each restarted once (restarts cure most
// stalls at the kinks), and a final compass search (Kolda, Lewis and Torczon
// 2003).  The result is an *achieved* value (some apex really gives it), so it
// can only under-estimate the true maximum; the search is multi-start to make
// that gap negligible (tests check it against dense random sampling).
//
// Cost.  One triangle costs about 2000 evaluations (~0.1 ms for alpha).  The
// mesh-wide bound first evaluates every triangle at the candidate apexes only
// (an achieved value, hence a lower estimate of each triangle's best), sorts,
// and refines triangles in ascending order while their cheap value is below
// the smallest refined value: a triangle whose achieved value already exceeds
// the current minimum cannot hold the minimum (a short compass polish of the
// cheap value is tried before the full search; values within 1e-4 in alpha,
// 0.01 degree in angle, of the current minimum are not refined, so the bound
// is exact to that tolerance).  The dihedral bounds cluster (a triangle with
// one small angle allows a min dihedral near 60 degrees), so for them only
// the 64 triangles lowest by cheap value are searched: estimates, like those
// of ../shared/tools/bound.py, which polishes its 25 lowest.  The per-tet classification
// refines lazily, only the constrained faces of tets below the threshold whose
// cheap value is below the threshold.
//
// Walls (issue 27, item 2: a wall one tet thick).  A side of a kept face
// sees more than its triangle: the tet standing on T there, with apex D,
// contains the open segment from T's centroid g to D (its points have
// positive barycentric coordinates), and no tet of a conforming mesh that
// keeps the triangles has a point of a kept triangle inside it.  So D is
// impossible whenever that segment crosses a kept triangle, and
//     best_alpha(T, side) <= max alpha(T, D) over D whose segment from g
//                            crosses no kept triangle
// for any set of kept triangles tested: fewer only loosens it, so the sets
// chosen need no proof of coverage.  Tested: the kept faces within 3.5
// longest edges reachable through that side's tets, when a walk along T's
// normal meets one within one longest edge (side_bound; a crossing counts
// when clear of the wall's plane by 1e-9 longest edges, at a point of the
// wall grown by 1e-9 across its edges, so no search escapes through the
// edge two walls share).  The allowed set is star-shaped
// from g, so the search maximises alpha at the first wall point on the
// segment toward each trial apex.  A slab d thick over triangles of size L
// caps the apex near height d: alpha about sqrt(6) d / L for d << L.
//
// Classification of a tet t with alpha(t) < gamma (the threshold):
//   LockedByTriangle    t has a constrained face T with best_alpha(T) < gamma:
//                       no method that keeps T can lift T's tet to gamma (it
//                       may still be improved up to best_alpha(T)); T's
//                       bound on t's side counts its wedges and walls.
//   LockedByNeighbours  not the above, and all four vertices of t are
//                       constrained (kind 4): smoothing cannot move any of
//                       them, only a topological change can help, and the
//                       topology passes found none.
//   Improvable          otherwise: a better mesh exists as far as these bounds
//                       tell; the method did not reach it.
// Tets with alpha >= gamma are Good.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "tetopt/measures.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/report.hpp"

namespace tetopt {

/// What a best-apex search maximises.
enum class ApexObjective {
  Alpha,        ///< alpha (eq. 3.1)
  MinDihedral,  ///< the smallest of the six dihedral angles
  MaxDihedral,  ///< minus the largest dihedral angle (so: the largest is minimised)
  // The other per-tet measures of measures.hpp (issue 26): the same
  // reasoning holds for each (the tet on a kept triangle has some apex), so
  // min over triangles of the best apex bounds the mesh's worst.
  SineMin,         ///< Stellar's minimum sine of the dihedral angles
  ScaledJacobian,  ///< Verdict's normalised scaled Jacobian
  RadiusRatio,     ///< 3 r / R
  MeanRatio,       ///< 12 (3V)^(2/3) / sum l^2
  Skewness         ///< minus the equivolume skewness (so: the skewness is minimised)
};
inline constexpr int kApexObjectives = 8;

/// Result of a best-apex search on one triangle.
struct ApexResult {
  double value = 0;      ///< alpha, or min dihedral (deg), or max dihedral (deg) at the apex
  double apex[3] = {0, 0, 0};  ///< the apex in world coordinates, on the side of normal (b-a)x(c-a)
};

/// Best apex for triangle (a, b, c) (3 doubles each) under the objective.
/// For MaxDihedral `value` is the smallest largest-dihedral found (degrees).
/// A degenerate triangle (collinear or repeated points) gives alpha 0, min
/// dihedral 0, max dihedral 180.
ApexResult best_apex(const double* a, const double* b, const double* c, ApexObjective obj = ApexObjective::Alpha);

/// A closed-form ceiling on the alpha of any tet on triangle (a, b, c): with
/// apex height h over its plane, area A, perimeter P and longest edge L,
/// the volume is A h / 3, the faces' areas sum to at least A + h P / 2
/// (each side face's height over its edge is at least h) and the longest
/// edge is at least max(L, h), so alpha <= 2 sqrt(6) A h / ((A + h P / 2)
/// max(L, h)), largest at h = L: 2 sqrt(6) A / (A + L P / 2).  Loose for
/// fair triangles (above 1), tight enough to call a needle bad without a
/// search (the count floor, MeshBound::below_at_least).
double alpha_ceiling(const double* a, const double* b, const double* c);

/// The highest alpha of a tet on triangle (p, q, r) whose apex lies in the
/// wedge between that triangle and triangle (p, q, s) (same side of
/// (p, q, r) as s, same side of (p, q, s) as r): a search like best_apex's,
/// from the grid, the closed-form candidates, points of the wedge and s.
double wedge_best_alpha(const double* p, const double* q, const double* r, const double* s);

/// The same with a wedge at each edge of (p, q, r) that has one: s[0] for
/// edge (p, q), s[1] for (q, r), s[2] for (r, p), nullptr for none; every
/// s on the same side of (p, q, r).  The apex must lie in all the wedges.
/// An estimate like best_apex's (achieved: some apex in them gives it).
double wedges_best_alpha(const double* p, const double* q, const double* r, const double* const s[3]);

/// The cheap estimate: the best objective value over a few closed-form apex
/// candidates (achieved, hence <= best_apex for Alpha and MinDihedral, >= for
/// MaxDihedral).
double cheap_apex_value(const double* a, const double* b, const double* c, ApexObjective obj = ApexObjective::Alpha);

/// The bound on one side of a kept face: the best alpha of a tet standing
/// on it there, in any mesh keeping the kept triangles.
struct SideBound {
  double alpha = NAN;
  bool wedged = false;          ///< its apex kept inside the wedges of sharp edges (face_wedges)
  bool walled = false;          ///< its apex kept clear of walls facing it (see the essay)
  double wall_distance = NAN;   ///< walled: distance from the centroid along the normal to the first wall
  /// walled: the best alpha of the tet on this side with its apex at a
  /// vertex the mesh already has (within the walls' reach, clear of the
  /// walls like `alpha`'s apexes), and that vertex; NaN / -1 when the side
  /// is not walled or a free vertex lies within reach (the region is not
  /// one layer of kept vertices).  A bound for every mesh that adds no
  /// vertex inside the wall: a wall d thick leaves a new vertex there at
  /// height z < d over T and d - z under the triangles facing it, so the
  /// continuous bound `alpha` (an apex anywhere below the facing wall)
  /// overstates what a conforming mesh of the wall reaches (issue: tw_A).
  double vertex_alpha = NAN;
  int32_t vertex_apex = -1;
};
/// packed = 4 t + f, f a constrained face of tet t: the side is t's.
/// Requires m's topology.
SideBound side_bound(const TetMesh& m, int32_t packed);

/// Mesh-wide bound over all constrained triangles (each counted once).
struct MeshBound {
  int64_t triangles = 0;          ///< constrained triangles
  double alpha = NAN;             ///< min over triangles of best alpha (NaN when none)
  double dihedral_min = NAN;      ///< min over triangles of best min-dihedral (upper bound, deg; estimate)
  double dihedral_max = NAN;      ///< max over triangles of best max-dihedral (lower bound, deg; estimate)
  /// Every per-tet measure's bound, indexed by Measure (alpha, sine_min,
  /// dihedral_min, dihedral_max as above): the best worst value any mesh
  /// keeping the constrained triangles can have (higher-is-better measures:
  /// an upper bound; dihedral_max and equivolume_skewness: a lower bound).
  /// NaN when not computed (without all_measures: all but alpha and the
  /// dihedral angles).  alpha, radius ratio,
  /// mean ratio and scaled Jacobian are exact to 1e-4 (pruned search over
  /// every triangle); sine_min, the dihedral angles and the skewness are
  /// estimates from the 64 triangles lowest by their cheap value.  The face
  /// measures (non-orthogonality, face skewness) have none: they depend on
  /// the two tets on either side of an interior face, and a kept triangle
  /// fixes neither tet's apex, so no per-triangle reasoning bounds them.
  std::array<double, kTetMeasureCount> measure{NAN, NAN, NAN, NAN, NAN, NAN, NAN, NAN};
  int32_t alpha_tet = -1, alpha_face = -1;  ///< a tet and local face holding the alpha bound
  double alpha_location[3] = {NAN, NAN, NAN};  ///< centroid of that triangle
  /// diagnose() only: when a poor tet's wedge bound (PoorTet::wedge_alpha)
  /// is below every triangle's, alpha is that bound and this its angle.
  double alpha_wedge_deg = NAN;
  /// When the alpha bound's triangle side is capped by a wall facing it
  /// (side_bound), the wall's distance along its normal; NaN otherwise.
  double alpha_wall_d = NAN;
  /// Whether the alpha bound is that of its triangle and the kept triangle
  /// beside it at a sharp edge, whose tets share the angle there (the
  /// worse of the two is at most alpha; see the essay).
  bool alpha_pair = false;
  int64_t refined = 0;            ///< triangles searched in full (all objectives)
  /// The fewest tets below alpha kCountThresholds[k] that any mesh keeping
  /// the constrained triangles has (-1: not computed).  Each side of a kept
  /// triangle that has tets is a face of some tet there; when the
  /// triangle's best apex is below the threshold (a "bad" triangle, best
  /// alpha + 1e-4 below it, the search's tolerance), so is that tet.  Two
  /// faces of one tet always share an edge, so a bad triangle sharing no
  /// edge with another bad one needs a tet of its own on each side, and
  /// the others at least one tet per four sides (two bad triangles count as
  /// sharing an edge only when each one's far vertex lies on a side of the
  /// other that has tets, as faces of one tet must): the count is
  ///   sum over isolated bad triangles of their sides
  ///   + ceil(sides of the other bad triangles / 4).
  /// A lower bound on the count below the threshold (issue 27: the count of
  /// tets below 0.2 against a peer that may change the boundary).
  std::array<int64_t, 3> below_at_least{-1, -1, -1};
  double seconds = 0;
};
/// The thresholds of MeshBound::below_at_least (the quality report's bands).
inline constexpr std::array<double, 3> kCountThresholds{0.1, 0.2, 0.3};

/// Computes the mesh-wide bound.  Requires m's topology.
/// all_measures: also the bounds of sine_min, scaled Jacobian, radius ratio,
/// mean ratio and equivolume skewness (MeshBound::measure), about twice the
/// time.
/// walls: cap thin sides by the kept faces facing them (side_bound); off
/// gives the bound without that search (see DiagnoseOptions::walls).
MeshBound mesh_bound(const TetMesh& m, int threads = 1, bool all_measures = false, bool walls = true);

enum class TetClass : uint8_t { Good = 0, LockedByTriangle = 1, LockedByNeighbours = 2, Improvable = 3 };
const char* tet_class_name(TetClass c);

/// One tet below the threshold.
struct PoorTet {
  int32_t tet = -1;
  TetClass cls = TetClass::Improvable;
  double alpha = 0;
  double dihedral_min = 0, dihedral_max = 0;
  int kind = 0;                 ///< constrained vertices
  int constrained_faces = 0;    ///< number of its faces that are constrained
  /// min best_alpha over its constrained faces that were searched; NaN when
  /// none was (no constrained face, or every one has an apex reaching gamma)
  double best_alpha = NAN;
  int32_t face = -1;            ///< local face giving best_alpha, -1 when none
  /// Two of its faces on the domain boundary: the best alpha of a tet on one
  /// of them with its apex inside the wedge the two faces make (it is the
  /// only tet at their common edge, so every mesh keeping them has its tet
  /// there in that wedge), when that is below the triangle's own bound
  /// (then best_alpha equals it); NaN otherwise.  wedge_deg: the wedge's
  /// dihedral angle (degrees).  An estimate like best_apex's.
  double wedge_alpha = NAN, wedge_deg = NAN;
  int32_t wedge_face = -1;
  /// best_alpha comes from a face on the domain boundary with sharp convex
  /// edges, its apex kept inside the wedges there (wedges_best_alpha).
  bool wedged = false;
  /// best_alpha comes from a face whose side is capped by kept triangles
  /// facing it (side_bound: a wall one tet thick); wall_d is the distance
  /// from the face's centroid to the first of them along its normal.
  bool walled = false;
  double wall_d = NAN;
  /// walled: SideBound::vertex_alpha of that face (the best apex among the
  /// vertices already there); NaN otherwise.
  double vertex_alpha = NAN;
  double centroid[3] = {0, 0, 0};
};

struct Diagnosis {
  double threshold = 0.3;
  int64_t tets = 0;
  int64_t count[4] = {0, 0, 0, 0};  ///< by TetClass
  std::vector<PoorTet> poor;        ///< every tet below the threshold, worst alpha first
  std::vector<uint8_t> tet_class;   ///< nt, TetClass per tet
  MeshBound bound;                  ///< filled when DiagnoseOptions::mesh_bound
  /// The lowest PoorTet::vertex_alpha over the poor tets and its tet: no
  /// mesh that adds no vertex inside the walls has alpha above it (NaN / -1
  /// when no poor tet is walled).
  double vertex_bound = NAN;
  int32_t vertex_bound_tet = -1;
  int64_t faces_searched = 0;
  double seconds = 0;
};

struct DiagnoseOptions {
  double threshold = 0.3;   ///< gamma
  bool mesh_bound = true;   ///< also compute the mesh-wide bound
  int threads = 1;          ///< for the scans over all tets and triangles (same result for every count)
  bool all_measures = false;  ///< the bound of every per-tet measure (mesh_bound's all_measures)
  /// Cap thin sides by the walls facing them (the essay, "Walls").  Each
  /// walled side costs milliseconds: raw thin-walled meshes have thousands
  /// (tw_A, 13.5k tets: 4.4 s against 0.33 s without).  tetopt quality
  /// keeps it on; tetopt improve's summary turns it off, so that the default
  /// mode stays as fast (its bound is then the looser one).
  bool walls = true;
};

/// Classifies every tet of m (see the essay above).  Requires m's topology.
Diagnosis diagnose(const TetMesh& m, const DiagnoseOptions& opt = {});

/// Text summary: counts per class, the mesh-wide bound, and the `max_list`
/// worst tets with their class (ids 1-based, as the CLI prints them).
std::string format_diagnosis(const Diagnosis& d, size_t max_list = 5);

/// JSON object: threshold, counts, bound, and the `max_list` worst poor tets
/// (0 = all) with id (0-based), class, alpha, kind, best_alpha, centroid.
std::string diagnosis_to_json(const Diagnosis& d, size_t max_list = 0, int indent = 2);

/// What inserting vertices could buy (issue 27): a run that kept the vertex
/// set (mode best without --allow-insert) and ended with its worst alpha
/// below 95% of the mesh-wide bound stopped where flips and smoothing end,
/// short of what the boundary triangles allow; only a change of the vertex
/// set can go further (insertion in the cavities of the worst tets: tets
/// with four constrained vertices that no flip improved, or interiors with
/// too few vertices, as in raw `tetgen -p` output).  The estimate is the
/// bound itself: a ceiling that any mesh keeping the boundary triangles
/// obeys, which --allow-insert often approaches (within 10% on the meshes
/// of issue 27) but does not promise (walls one tet thick stay far below).
struct InsertionHint {
  bool show = false;          ///< the worst alpha is below kInsertionHintGap x the bound, insertion unused
  double worst_alpha = NAN;   ///< the run's worst alpha
  double estimate = NAN;      ///< the bound (MeshBound::alpha): how far insertion could lift it at most
  /// Tets below the diagnosis threshold that a new vertex could lift:
  /// locked by constrained neighbours, improvable (not reached), and locked
  /// by a triangle whose best apex is still above kInsertionHintGap^-1 x
  /// their alpha.
  int64_t tets = 0;
  int64_t locked_by_neighbours = 0;  ///< of them: all four vertices constrained, no flip found
  const char* flag = "--allow-insert";
};
/// No hint when the worst alpha is within 5% of the bound.
inline constexpr double kInsertionHintGap = 0.95;

/// The hint for a run whose mesh d diagnoses (with its bound) and whose
/// worst alpha is worst_alpha; insertion_available: the run could have
/// inserted but did not (mode best without allow_insert).  show is false
/// when insertion was used or unavailable, the bound is unknown, or the
/// worst alpha is within 5% of it.
InsertionHint insertion_hint(const Diagnosis& d, double worst_alpha, bool insertion_available);

/// One summary line ("  insertion could lift ...: try --allow-insert\n"),
/// empty when !h.show.
std::string format_insertion_hint(const InsertionHint& h);

/// JSON object {"worst_alpha", "estimate", "tets", "locked_by_neighbours",
/// "flag"}, or null when !h.show.
std::string insertion_hint_to_json(const InsertionHint& h);

/// Cell fields "diagnosis" (TetClass as an integer) and "alpha_bound" (the
/// searched best alpha of the tet's constrained faces, NaN elsewhere).
std::vector<CellField> diagnosis_cell_fields(const Diagnosis& d, int32_t nt);

/// Per-tet values of a mesh kept by their sorted vertex quadruple, to carry
/// values across an improvement that keeps vertex ids (flips and smoothing
/// do): tets of the new mesh with the same four vertices get the old value.
class TetValueMap {
 public:
  TetValueMap() = default;
  TetValueMap(const TetMesh& m, const std::vector<double>& values);
  /// values for the tets of `m` (NaN for tets whose vertex set is new).
  std::vector<double> lookup(const TetMesh& m) const;
  int64_t matched(const TetMesh& m) const;

 private:
  struct Entry {
    int32_t v[4];
    double value;
  };
  std::vector<Entry> entries_;  ///< sorted by v
};

}  // namespace tetopt
