// objective.hpp's per-tet entry point.
#include "tetopt/objective.hpp"

#include "tetopt/mesh.hpp"

namespace tetopt {

double tet_objective(const TetMesh& m, int32_t t, Objective o) {
  if (o == Objective::Alpha) return tet_alpha(m, t);
  const int32_t* v = m.tet(t);
  return objective_quality(o, m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]));
}

}  // namespace tetopt
