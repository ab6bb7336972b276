// tetopt/conventions.hpp — the one place that fixes local numbering.
//
// A tet t owns tets[4t .. 4t+3] = (v0, v1, v2, v3).  It is *positively
// oriented* when orient3d(v0, v1, v2, v3) = det(v1-v0, v2-v0, v3-v0) > 0
// (right-hand rule: for the unit corner tet (0,0,0),(1,0,0),(0,1,0),(0,0,1)
// the determinant is +1).  This is the orientation of Medit, Gmsh and VTK
// files; TetGen's .ele and Netgen use the opposite one.
//
//                  v3                 face f is the face opposite vertex
//                 /|\ .               f; its vertices kFaceVertex[f] are
//                / | \ .              ordered so that their normal points
//               /  |  \ .             OUT of a positive tet.
//             v0---|---v2 .           Edge le joins kEdgeVertex[le]; the
//               \  |  / .             edge opposite le is
//                \ | / .              kEdgeOpposite[le].
//                 \|/ .
//                  v1
//
// Packed ids: 4t+i means "vertex i of tet t" or "face i of tet t".  The
// tet-tet adjacency stores, for face 4t+f, the packed face 4t'+f' of the
// neighbour across it, or -1 when the face is on the mesh boundary.
//
// No other file of tetopt writes literal local index tuples.
#pragma once
#include <cstdint>

namespace tetopt {

/// Vertices of the face opposite local vertex f, outward for a positive tet.
inline constexpr int kFaceVertex[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/// The two local vertices of local edge le (0..5).
inline constexpr int kEdgeVertex[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

/// The local edge opposite local edge le (shares no vertex with it).
inline constexpr int kEdgeOpposite[6] = {5, 4, 3, 2, 1, 0};

/// Local edge joining local vertices a != b.
constexpr int local_edge(int a, int b) {
  if (a > b) { int t = a; a = b; b = t; }
  return a == 0 ? b - 1 : (a == 1 ? b + 1 : 5);
}

/// Transposition used to normalise files whose tets are negatively oriented:
/// local vertices 2 and 3 are swapped on read and swapped back on write.
inline constexpr int kFlipA = 2;
inline constexpr int kFlipB = 3;

}  // namespace tetopt
