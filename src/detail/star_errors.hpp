// For the tests: smoothing's four-at-a-time star errors (star_errors4 in
// smooth.cpp, which GCC vectorises) against the scalar local_error they
// repeat lane by lane.
#pragma once

#include <cstdint>

namespace tetopt {
struct TetMesh;
namespace detail {

/// Gathers vertex v's star (objective alpha, weight C; the vertex stars must
/// be built) as a smoothing solve does, puts v at its position + dx, and
/// compares each star tet's error from star_errors4 with local_error's, bit
/// for bit.  Returns how many differ; *finite (when given) receives how many
/// of the errors were finite (a tet inverted at dx has an infinite error).
int star_errors_mismatches(const TetMesh& m, int32_t v, const double* dx, double C, int* finite = nullptr);

}  // namespace detail
}  // namespace tetopt
