// tetopt/quality.hpp — element quality measures and mesh statistics.
//
// All measures are pure functions of four points (pointers to 3 doubles) in
// floating point; they never decide validity (predicates.hpp does).
//
//   alpha        6*sqrt(6)*V / (sum of face areas * longest edge)
//                (Liu et al. 2012, eq. 3.1).  Range [-1, 1]: 1 for the
//                regular tet, 0 when flat, negative when inverted (V signed).
//                Invariant under translation, rotation and uniform scaling.
//   alpha_error  e = 1/alpha (eq. 3.2); +inf when alpha <= 0.
//   dihedral     the six interior dihedral angles in degrees, indexed by
//                local edge (conventions.hpp); 70.5288 deg for the regular tet.
//   mean_ratio   12*(3V)^(2/3) / sum of squared edge lengths; 1 regular, 0 flat,
//                negative when inverted.
//   radius_ratio 3*inradius/circumradius; 1 regular, 0 flat (unsigned).
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "tetopt/measures.hpp"

namespace tetopt {

struct TetMesh;

double tet_signed_volume(const double* a, const double* b, const double* c, const double* d);
double alpha(const double* a, const double* b, const double* c, const double* d);
inline double alpha_error(double alpha_value) {
  return alpha_value > 0 ? 1.0 / alpha_value : std::numeric_limits<double>::infinity();
}
void dihedral_angles(const double* a, const double* b, const double* c, const double* d,
                     double out_deg[6]);
/// The smallest and largest of dihedral_angles' six values, bit for bit,
/// with atan2 only for the edges whose angle is (nearly) the extreme one:
/// about a third of the cost.
void dihedral_extremes(const double* a, const double* b, const double* c, const double* d, double& lo_deg,
                       double& hi_deg);
double mean_ratio(const double* a, const double* b, const double* c, const double* d);
double radius_ratio(const double* a, const double* b, const double* c, const double* d);

/// alpha of tet t of m.
double tet_alpha(const TetMesh& m, int32_t t);

/// Statistics in the paper's columns (Table 1/2: worst and average alpha
/// overall and over boundary elements, i.e. kinds 1-4; Table 3: dihedral
/// extremes) plus counts and histograms.  Requires m's topology.
struct QualityStats {
  int64_t vertices = 0;           ///< vertices used by at least one tet
  int64_t tets = 0;
  int64_t boundary_tets = 0;      ///< kind 1..4
  int64_t all_boundary_tets = 0;  ///< kind 4
  int64_t kind_count[5] = {0, 0, 0, 0, 0};
  int64_t regions = 0;
  double alpha_worst = 0, alpha_mean = 0;
  double alpha_boundary_worst = 0, alpha_boundary_mean = 0;  ///< NaN when no boundary tet
  double alpha_interior_worst = 0, alpha_interior_mean = 0;  ///< NaN when no interior tet
  double dihedral_min = 0, dihedral_max = 0;
  double mean_ratio_worst = 0, radius_ratio_worst = 0;
  int64_t inverted_or_flat = 0;  ///< alpha <= 0
  int64_t alpha_below_01 = 0, alpha_below_02 = 0, alpha_below_03 = 0;
  int64_t dihedral_below_5 = 0, dihedral_above_175 = 0;  ///< tets with such an angle
  std::array<int64_t, 10> alpha_histogram{};       ///< bins of 0.1 over [0,1]; <0 goes to bin 0
  std::array<int64_t, 18> dihedral_histogram{};    ///< 10-degree bins of all 6*nt angles
  int32_t worst_tet = -1;
  /// Every measure of measures.hpp (its table): worst, mean, histogram and
  /// threshold counts per tet measure, and checkMesh's face measures; only
  /// when compute_stats was asked for them (measures.computed).
  MeasureStats measures;
};

/// threads: worker threads for the loop over tets (0 = all cores); the result is the same
/// for every count (fixed blocks merged in order).  measures: also fill
/// QualityStats::measures (compute_measure_stats: every measure of
/// measures.hpp, about 4-5 times the cost of the rest, so off where only
/// alpha and the dihedral angles are wanted, as in improve's before/after).
QualityStats compute_stats(const TetMesh& m, int threads = 1, bool measures = false);

/// Per-tet arrays (nt each) for fields and reports.
struct TetQualityFields {
  std::vector<double> alpha, dihedral_min, dihedral_max;
};
TetQualityFields compute_fields(const TetMesh& m);

/// JSON object text for stats (keys match meshcheck.py stats --json where they overlap);
/// the measures of measures.hpp, when computed, in the nested objects "measures" and "faces".
std::string stats_to_json(const QualityStats& s, int indent = 2);

}  // namespace tetopt
