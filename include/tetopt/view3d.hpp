// tetopt/view3d.hpp — what the HTML report's 3D view draws, in compact form.
//
// The view (html_report.hpp, drawn with three.js in the page) shows where the
// bad tets are: the boundary surface (with the region interfaces), the tets
// below the threshold (before and after a run), the tets the diagnosis calls
// locked and the constrained triangles that cap their quality (diagnose.hpp).  Only these go into the
// page, never the whole volume (the 20.3M-tet box of docs/benchmarks.md has
// 374k boundary triangles and 2.0M tets below alpha 0.3, of which the page
// keeps the 50k worst).
//
// Sizes are bounded twice:
//   - the surface is decimated for display only when it has more triangles
//     than a budget (300k by default) by vertex clustering on a uniform grid
//     (Rossignac and Borrel 1993, "Multi-resolution 3D approximations for
//     rendering complex scenes"): the vertices in one grid cell merge into
//     their mean, triangles that collapse or repeat are dropped, and the cell
//     shrinks until the budget holds; the page says so.  The mesh itself is
//     never touched.
//   - at most `max_tets` poor tets are kept, the worst first; the page says
//     how many of how many it shows.
//
// Coordinates are float32 relative to the mesh's bounding-box centre (display
// precision; the table and the panel print the double values).  Each set
// carries its own compact vertex table.
//
// Pure functions of a mesh: nothing here modifies a mesh or prints.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "tetopt/diagnose.hpp"
#include "tetopt/mesh.hpp"

namespace tetopt {

/// The constrained surface: the boundary faces (one tet), outward, and the
/// constrained faces inside (region interfaces, listed triangles), each once,
/// facing away from the side with the smaller region ref; grouped by the ref
/// that colours them.
struct ViewSurface {
  double origin[3] = {0, 0, 0};   ///< view_origin(m); xyz are relative to it
  std::vector<float> xyz;         ///< n x 3 vertex positions
  std::vector<int32_t> tris;      ///< k x 3, into xyz, outward, sorted by group
  /// Groups of consecutive triangles with one ref: ref, first triangle, count.
  std::vector<int32_t> group_ref, group_start, group_count;
  bool by_patch = false;          ///< refs are the listed triangles' (patch) refs; else the tets' region refs
  int64_t triangles_full = 0;     ///< constrained triangles of the mesh
  bool decimated = false;         ///< tris has fewer triangles than the mesh (display only)
  double bbox_diagonal = 0;
};

/// The centre of m's bounding box (the origin of every set's coordinates;
/// the same before and after a run, which keeps the boundary).
void view_origin(const TetMesh& m, double origin[3]);

/// The constrained surface of m (requires m's topology; without it,
/// empty).  A face takes the ref of the listed triangle with its vertices
/// when the file lists triangles (the patch), otherwise the region ref of the
/// tet it is taken from.  More than `budget` triangles: decimated for
/// display (see above).
ViewSurface view_surface(const TetMesh& m, size_t budget = 300000);

/// A set of poor tets, worst alpha first.
struct ViewTets {
  double origin[3] = {0, 0, 0};      ///< the `origin` given; xyz are relative to it
  std::vector<float> xyz;            ///< n x 3 vertex positions, relative to the surface's origin
  std::vector<int32_t> tets;         ///< k x 4, into xyz (the mesh's local vertex order)
  std::vector<int32_t> ids;          ///< k tet ids, 0-based, as in the file the tet belongs to
  std::vector<float> alpha, dihedral_min, dihedral_max;  ///< k each (degrees for the angles)
  std::vector<uint8_t> kind;         ///< k, constrained vertices 0..4
  std::vector<uint8_t> cls;          ///< k, TetClass; empty when not diagnosed
  std::vector<float> best_alpha;     ///< k, PoorTet::best_alpha (NaN: none); empty when not diagnosed
  std::vector<int8_t> cap_face;      ///< k, local face that caps a LockedByTriangle tet, else -1; empty when not diagnosed
  std::vector<uint8_t> constrained_faces;  ///< k, PoorTet::constrained_faces; empty when not diagnosed
  int64_t below = 0;                 ///< tets below the threshold in the mesh (shown or not)
};

/// The tets of m with alpha < threshold, at most max_tets of them, worst
/// first (ties by id).  id_map, when given, maps m's tet ids to the ids shown
/// (the input file's numbering when the tets were reordered on reading).
/// Requires m's topology (for the kinds).  `origin`: see ViewSurface.
ViewTets view_poor_tets(const TetMesh& m, double threshold, size_t max_tets, const double origin[3],
                        const std::vector<int32_t>* id_map = nullptr, int threads = 1);

/// The diagnosed poor tets of m (d = diagnose(m)), at most max_tets of them,
/// in d.poor's order (worst first), with their class and capping face.
ViewTets view_diagnosed_tets(const TetMesh& m, const Diagnosis& d, size_t max_tets, const double origin[3]);

/// Base64 (RFC 4648, with padding) of n bytes.
std::string base64(const void* data, size_t n);

}  // namespace tetopt
