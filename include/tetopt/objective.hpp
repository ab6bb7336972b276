// tetopt/objective.hpp — what improve() optimises (issue 26, --objective).
//
// Every stage (smoothing's sum of 1/q with the weight C and its max-min,
// flips, edge removal, insertion and removal, the pair search and the final
// dihedral pass's floor) works on one per-tet quality q, higher is better,
// 1 for the regular tet, 0 for a flat one and negative for an inverted one:
//
//   alpha     the paper's alpha (eq. 3.1), the default
//   sine      Stellar's minimum sine of the dihedral angles, divided by its
//             regular-tet value 2√2/3 (Klingner & Shewchuk 2007)
//   jacobian  Verdict's normalised scaled Jacobian (1 regular)
//   skewness  1 − Fluent's equivolume skewness (0 best skewness → q = 1;
//             a flat tet, skewness 1 → 0; inverted above 1 → negative)
//   openfoam  OpenFOAM's largest face non-orthogonality: a measure of a face
//             between two tets, not of a tet, so improve() runs every per-tet
//             stage with alpha and then the face pass (face_pass.hpp);
//             objective_quality gives alpha for it
//
// The measures themselves live in quality.hpp / measures.hpp (one table);
// this is only the switch the engine calls per tet, inlined, with no virtual
// call.  Alpha goes straight to alpha() so the default path costs what it
// did.
#pragma once
#include <cstdint>
#include <cstring>

#include "tetopt/measures.hpp"
#include "tetopt/quality.hpp"

namespace tetopt {

enum class Objective : uint8_t { Alpha, Sine, Jacobian, Skewness, OpenFoam };

/// Regular-tet value of sine_min: sin(acos(1/3)) = 2√2/3.
inline constexpr double kRegularSine = 0.94280904158206336587;

/// q of the objective for tet (a, b, c, d) (orientation of conventions.hpp).
inline double objective_quality(Objective o, const double* a, const double* b, const double* c, const double* d) {
  switch (o) {
    case Objective::Alpha: return alpha(a, b, c, d);
    case Objective::Sine: return sine_min(a, b, c, d) / kRegularSine;
    case Objective::Jacobian: return scaled_jacobian(a, b, c, d);
    case Objective::Skewness: return 1.0 - equivolume_skewness(a, b, c, d);
    case Objective::OpenFoam: return alpha(a, b, c, d);  // improve() runs it as alpha, then the face pass
  }
  return alpha(a, b, c, d);
}

/// The measure of the table (measures.hpp) the objective raises.
inline Measure objective_measure(Objective o) {
  switch (o) {
    case Objective::Alpha: return Measure::Alpha;
    case Objective::Sine: return Measure::SineMin;
    case Objective::Jacobian: return Measure::ScaledJacobian;
    case Objective::Skewness: return Measure::EquivolumeSkewness;
    case Objective::OpenFoam: return Measure::NonOrthogonality;
  }
  return Measure::Alpha;
}

/// q of tet t of m.
double tet_objective(const TetMesh& m, int32_t t, Objective o);

inline const char* objective_name(Objective o) {
  switch (o) {
    case Objective::Alpha: return "alpha";
    case Objective::Sine: return "sine";
    case Objective::Jacobian: return "jacobian";
    case Objective::Skewness: return "skewness";
    case Objective::OpenFoam: return "openfoam";
  }
  return "?";
}

/// Parses an objective name; false when unknown.
inline bool parse_objective(const char* s, Objective& o) {
  for (Objective x : {Objective::Alpha, Objective::Sine, Objective::Jacobian, Objective::Skewness, Objective::OpenFoam})
    if (std::strcmp(s, objective_name(x)) == 0) {
      o = x;
      return true;
    }
  return false;
}

}  // namespace tetopt
