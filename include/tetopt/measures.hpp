// tetopt/measures.hpp — every measure a tet or a face is judged by, in one
// table (kMeasures), with its formula, its source, its ideal value, the
// direction in which it is better and the thresholds the tools that use it
// document.  docs/measures.md says the same in prose, with the
// cross-checks.
//
// Per tet (pure functions of four points a, b, c, d; V signed, positive for
// the orientation of conventions.hpp):
//   alpha                 quality.hpp: 6√6·V / (Σ face areas · longest edge)
//                         (Liu et al. 2012, eq. 3.1)                 higher
//   sine_min              min over the 6 edges of sin(dihedral angle) =
//                         3·V·l_ij / (2·A_k·A_l) (Klingner & Shewchuk
//                         2007, Stellar's QUALMINSINE); signed      higher
//   dihedral_min / _max   smallest / largest dihedral angle, degrees
//                         (quality.hpp dihedral_extremes)   higher / lower
//   scaled_jacobian       Verdict's normalised scaled Jacobian (Stimpson
//                         et al. 2007): √2·J / max(the four corner
//                         products of edge lengths, |J|), J = 6V    higher
//   radius_ratio          3·r_in / r_circ (quality.hpp)              higher
//   mean_ratio            12·(3V)^(2/3) / Σ l² (quality.hpp)         higher
//   equivolume_skewness   (V_ideal − V) / V_ideal, V_ideal the volume of
//                         the regular tet with the same circumradius
//                         (ANSYS Fluent / Meshing)                   lower
// Per face (pure functions of the face triangle a, b, c, its normal
// (b−a)×(c−a) pointing OUT of the owner tet, the owner's fourth vertex p
// and the neighbour's fourth vertex q; cell centre = tet centroid, face
// centre = triangle centroid, as OpenFOAM computes them for tets):
//   non_orthogonality     angle between the face area vector and the line
//                         of the cell centres, degrees (checkMesh)   lower
//   face_skewness         checkMesh's skewness (primitiveMeshTools::
//                         faceSkewness); boundary faces by its
//                         boundaryFaceSkewness (face_skewness_boundary)
//                                                                    lower
// An optimiser calls these functions directly (no table lookup, no virtual
// call), or tet_measure()/face_measure(), a switch; oriented() turns any
// value into one where higher is better.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace tetopt {

struct TetMesh;

// ---- per-tet measures (alpha, mean_ratio, radius_ratio: quality.hpp) ----

/// Stellar's minimum sine of the six dihedral angles: min over the edges ij
/// of 3·V·l_ij / (2·A_k·A_l), A_k the area of the face opposite vertex k.
/// 2√2/3 = 0.9428 for the regular tet, 0 when flat, negative when inverted
/// (V signed).  Small for angles near 0 and near 180 degrees alike.
double sine_min(const double* a, const double* b, const double* c, const double* d);
/// The smallest / largest dihedral angle in degrees (dihedral_extremes).
double dihedral_min_deg(const double* a, const double* b, const double* c, const double* d);
double dihedral_max_deg(const double* a, const double* b, const double* c, const double* d);
/// Verdict's tet scaled Jacobian: √2·J / L, J = 6V (signed) and L the
/// largest of the four corner products of the three edge lengths there (and
/// of |J|).  1 regular, 0 flat, negative inverted (≥ −1); 0 when every
/// product is below DBL_MIN (Verdict returns DBL_MAX there).
double scaled_jacobian(const double* a, const double* b, const double* c, const double* d);
/// Fluent's equivolume (equilateral-volume) skewness 1 − V / V_ideal,
/// V_ideal = 8√3/27·R³ the volume of the regular tet with circumradius R.
/// 0 regular, 1 flat (also when R is infinite or undefined), above 1 when
/// inverted (V signed; at most 2).  Rounding below 0 is clamped to 0.
double equivolume_skewness(const double* a, const double* b, const double* c, const double* d);

// ---- per-face measures (OpenFOAM checkMesh) ----

/// checkMesh's non-orthogonality of an interior face, in degrees: the angle
/// between the face area vector S = ½(b−a)×(c−a) (out of the owner, whose
/// fourth vertex is p) and d = C_nei − C_own (neighbour's fourth vertex q):
/// acos(d·S / (|d||S| + ROOTVSMALL)).  0 orthogonal; 90 or more is
/// checkMesh's "non-orthogonality error".
double face_non_orthogonality(const double* a, const double* b, const double* c, const double* p,
                              const double* q);
/// checkMesh's skewness of an interior face: |sv| / fd with sv = C_f − X,
/// X where the line of the cell centres meets the face plane, and fd =
/// max(0.2|d|, the largest |ŝv·(vertex − C_f)|) (primitiveMeshTools::
/// faceSkewness).  0 when the line passes through the face centroid.
double face_skewness(const double* a, const double* b, const double* c, const double* p, const double* q);
/// checkMesh's skewness of a boundary face (primitiveMeshTools::
/// boundaryFaceSkewness): as if the owner were mirrored in the face, with
/// fd = max(0.4|d|, ...), d the normal part of C_f − C_own.
double face_skewness_boundary(const double* a, const double* b, const double* c, const double* p);

// ---- the table ----

enum class Measure : uint8_t {
  Alpha,
  SineMin,
  DihedralMin,
  DihedralMax,
  ScaledJacobian,
  RadiusRatio,
  MeanRatio,
  EquivolumeSkewness,
  NonOrthogonality,  // per interior face
  FaceSkewness,      // per face (boundary faces by the boundary formula)
};
inline constexpr int kMeasureCount = 10;
inline constexpr int kTetMeasureCount = 8;  ///< Measure values below this are per tet

enum class Better : uint8_t { Higher, Lower };
enum class Cmp : uint8_t { Lt, Le, Gt, Ge };

/// A count the report gives: values v with `v cmp value` fail it.
struct MeasureThreshold {
  const char* key = nullptr;      ///< JSON key under "fail"
  Cmp cmp = Cmp::Lt;
  double value = 0;
  const char* meaning = nullptr;  ///< words for the text and HTML reports
  const char* source = nullptr;   ///< where the number comes from
};

/// Named bands (Fluent's skewness table): band i holds the values v with
/// v < upper[i] that no earlier band holds; the last band holds the rest
/// (and NaN).
struct MeasureBands {
  int n = 0;
  const char* name[6] = {};
  double upper[6] = {};
  const char* source = nullptr;
};

using TetMeasureFn = double (*)(const double*, const double*, const double*, const double*);
using FaceMeasureFn = double (*)(const double*, const double*, const double*, const double*, const double*);

struct MeasureInfo {
  Measure id;
  const char* key;      ///< JSON key and .vtu field name stem
  const char* name;     ///< human name
  const char* unit;     ///< "" or "deg"
  Better better;
  bool per_face;
  TetMeasureFn tet_fn;    ///< per-tet measures (else nullptr)
  FaceMeasureFn face_fn;  ///< interior-face measures (else nullptr)
  double ideal;           ///< regular tet / orthogonal, unskewed face
  double hist_lo, hist_hi;
  int hist_bins;          ///< equal bins over [lo, hi]; outside: first / last bin, NaN: the worst end
  const char* formula;
  const char* source;
  int n_thresholds;
  MeasureThreshold thresholds[4];
  MeasureBands bands;
};

/// Every measure, indexed by static_cast<int>(Measure).
extern const std::array<MeasureInfo, kMeasureCount> kMeasures;
inline const MeasureInfo& measure_info(Measure m) { return kMeasures[static_cast<size_t>(m)]; }
/// The measure with this JSON key, or nullptr.
const MeasureInfo* find_measure(const std::string& key);

/// Per-tet measure m (< kTetMeasureCount) of a, b, c, d: a switch over the
/// functions above, for callers that choose the measure at run time.
double tet_measure(Measure m, const double* a, const double* b, const double* c, const double* d);
/// Interior-face measure m (NonOrthogonality or FaceSkewness), arguments as
/// face_non_orthogonality's.
double face_measure(Measure m, const double* a, const double* b, const double* c, const double* p,
                    const double* q);
/// v such that higher is better: v, or −v for the measures where lower is.
inline double oriented(Measure m, double v) { return measure_info(m).better == Better::Higher ? v : -v; }
/// Whether x is strictly worse than y for measure m (NaN is worse than any number).
inline bool worse(Measure m, double x, double y) {
  if (std::isnan(y)) return false;
  if (std::isnan(x)) return true;
  return measure_info(m).better == Better::Higher ? x < y : x > y;
}
bool fails(const MeasureThreshold& t, double v);

// ---- statistics over a mesh ----

struct MeasureSummary {
  int64_t count = 0;      ///< tets, or faces, measured
  double worst = NAN;     ///< min (higher is better) or max (lower is better); NaN when count is 0
  double mean = NAN;
  int32_t worst_tet = -1; ///< the tet, or the face's owner tet (0-based); first in tet order on ties
  int8_t worst_face = -1; ///< local face of worst_tet (face measures)
  std::vector<int64_t> histogram;  ///< hist_bins of the table
  std::array<int64_t, 4> fail{};   ///< per table threshold
  std::array<int64_t, 6> band{};   ///< per table band
};

struct MeasureStats {
  bool computed = false;        ///< false: not computed (compute_stats without measures)
  bool faces_measured = false;  ///< false when m had no face adjacency
  std::array<MeasureSummary, kMeasureCount> m;
  int64_t interior_faces = 0, boundary_faces = 0;
  /// checkMesh's "average" non-orthogonality: acos of the mean cosine, degrees.
  double non_orthogonality_checkmesh_average = NAN;
  double skewness_interior_worst = NAN, skewness_boundary_worst = NAN;
  const MeasureSummary& operator[](Measure k) const { return m[static_cast<size_t>(k)]; }
};

/// Every measure over m's tets and faces (faces need m.adj).  The same
/// numbers for every thread count (fixed blocks merged in order).
MeasureStats compute_measure_stats(const TetMesh& m, int threads = 1);

/// Per-tet values of measure k (nt values): the tet measure, or for a face
/// measure the worst over the tet's faces (non-orthogonality: its interior
/// faces, 0 when it has none).
std::vector<double> compute_measure_field(const TetMesh& m, Measure k, int threads = 1);

/// JSON object {"<key>": {"before": worst, "after": worst, "kept": bool}, ...}
/// over every measure of the table (improve's `measures_before_after`:
/// kept is false when the run ended worse on that measure).
std::string measures_before_after_json(const MeasureStats& before, const MeasureStats& after);

/// JSON members `"measures": {...}, "faces": {...}` (no braces around them),
/// each line indented by `indent` spaces, no trailing newline.
std::string measure_stats_to_json(const MeasureStats& s, int indent);

}  // namespace tetopt
