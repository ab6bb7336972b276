// tetopt/mesh.hpp — the one mesh type that flows through every stage.
//
// TetMesh owns flat arrays (no Tet objects):
//   xyz       3*nv doubles, x y z interleaved (the layout orient3d consumes)
//   tets      4*nt int32, 0-based vertex ids, positively oriented after
//             read (see conventions.hpp; files in the opposite convention are
//             normalised on read and written back in their own convention)
//   tet_ref   nt region refs (Medit ref, Gmsh physical volume, VTK/TetGen
//             region attribute); faces between different refs are interfaces
//   vert_ref, tris/tri_ref, edges/edge_ref, required_*, corners, ridges,
//             physical_names: what the file carried, written back unchanged.
//
// Derived topology, filled by build_topology() and valid until the
// connectivity changes (topo passes rebuild it, see topology_epoch):
//   vt_offsets/vt_tets  vertex -> tet CSR (counting sort, ascending tet ids;
//                       the same for every thread count)
//   adj                 4*nt packed neighbour faces 4t'+f', or -1 (boundary)
//   face_mask           per tet, bit f set when face f is constrained
//   vert_constrained    1 when the vertex never moves
//   tet_kind            number of constrained vertices, 0..4 (paper Fig. 1;
//                       4 = "all boundary element")
//   tri_keys            the listed triangles as ascending vertex triples, in
//                       lexicographic order (lookup by binary search)
//
// Constrained entities (DESIGN.md): a face is constrained when it lies on one
// tet, between tets of different refs or of different Gmsh entities (when the
// file has entity tags), or is listed among the file's triangles (every
// listed triangle is kept, so its ref survives).  A vertex is
// constrained when it lies on a constrained face, on a listed triangle (also
// one that is no tet's face), on a listed edge, or is listed as required /
// corner.  Constrained vertices never move, bit for bit;
// constrained faces are never removed.
//
// Complexity: build_topology is O(nt + nv) time and memory apart from sorting
// the faces around each vertex (small buckets).
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "tetopt/attachment.hpp"
#include "tetopt/conventions.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

/// A name given to a physical group (Gmsh $PhysicalNames).
struct PhysicalName {
  int dim = 3;
  int tag = 0;
  std::string name;
};

struct TetMesh {
  // ---- primary data (what files carry) ----
  std::vector<double> xyz;           ///< nv x 3, interleaved
  std::vector<int32_t> tets;         ///< nt x 4, 0-based, positive orientation
  std::vector<int32_t> tet_ref;      ///< nt
  std::vector<int32_t> vert_ref;     ///< nv (0 when the file has none)
  std::vector<int32_t> tris;         ///< ntri x 3 listed triangles (0-based)
  std::vector<int32_t> tri_ref;      ///< ntri
  std::vector<int32_t> edges;        ///< nedge x 2 listed edges (0-based)
  std::vector<int32_t> edge_ref;     ///< nedge
  std::vector<int32_t> required_vertices;  ///< vertex ids
  std::vector<int32_t> required_tris;      ///< indices into tris
  std::vector<int32_t> required_edges;     ///< indices into edges
  std::vector<int32_t> corners;            ///< vertex ids
  std::vector<int32_t> ridges;             ///< indices into edges
  std::vector<PhysicalName> physical_names;
  /// The physical tags of one Gmsh 4.1 $Entities entry, in the file's order
  /// (possibly none).
  struct GmshEntity {
    int dim = 3;
    int tag = 0;
    std::vector<int32_t> physicals;
  };
  /// Gmsh 4.1 $Entities as read; from a 2.2 file, the entities whose
  /// elements all had physical tag 0 (in no group), with no physicals;
  /// empty for other files.  The 4.1 writer gives an entity it writes with
  /// the same dimension and tag these physical tags back when the ref it
  /// writes is theirs (the first of them, or the entity tag itself when
  /// there are none), so an entity in two physical groups, or in none, stays
  /// so; otherwise it lists the ref.  The 2.2 writer writes physical tag 0
  /// for an element of an entity in none whose ref is the entity tag.
  std::vector<GmshEntity> gmsh_entities;
  /// Gmsh elementary entity tags of tets / listed triangles (empty when the
  /// file has none); written back by the Gmsh writers.
  std::vector<int32_t> tet_entity, tri_entity;
  /// Per-vertex data arrays the file carried (VTK point data such as "fixed"),
  /// written back by the VTK writers.  values: nv * components.
  struct PointField {
    std::string name;
    int components = 1;
    bool integer = false;
    std::vector<double> values;
  };
  std::vector<PointField> point_fields;
  /// True when the file stored tets in the opposite orientation; a writer of
  /// the same format (source_format) swaps local vertices kFlipA/kFlipB back
  /// so the file keeps its convention.  Writers of other formats use their
  /// format's native convention (positive for all, TetGen .ele included).
  bool flipped_on_read = false;
  int source_format = 0;  ///< tetopt::Format the mesh was read from (io.hpp), 0 unknown
  /// What the file said about its groups beyond refs and names (OpenFOAM
  /// patch types, Fluent zone types): attachment.hpp.  The one place for
  /// format-specific extras; nothing in it is needed to improve the mesh.
  Attachment attachment;

  // ---- derived topology (build_topology) ----
  std::vector<int32_t> vt_offsets;     ///< nv+1
  std::vector<int32_t> vt_tets;        ///< vt_offsets[nv]
  std::vector<int32_t> adj;            ///< nt x 4 packed neighbour faces or -1
  std::vector<uint8_t> face_mask;      ///< nt, bit f: face f constrained
  std::vector<uint8_t> vert_constrained;  ///< nv
  std::vector<uint8_t> tet_kind;       ///< nt, 0..4 constrained vertices
  std::vector<int32_t> tri_keys;       ///< 3 x ntri, sorted triples of tris (flattened)
  uint64_t topology_epoch = 0;         ///< bumped by every topology rebuild

  int32_t nv() const { return static_cast<int32_t>(xyz.size() / 3); }
  int32_t nt() const { return static_cast<int32_t>(tets.size() / 4); }
  int32_t ntri() const { return static_cast<int32_t>(tris.size() / 3); }
  const double* point(int32_t v) const { return &xyz[3 * static_cast<size_t>(v)]; }
  double* point(int32_t v) { return &xyz[3 * static_cast<size_t>(v)]; }
  const int32_t* tet(int32_t t) const { return &tets[4 * static_cast<size_t>(t)]; }
  /// Tets around vertex v (valid after build_topology / build_vertex_tets /
  /// ensure_vertex_tets; a topology pass run with TopoOptions::rebuild_stars
  /// false leaves the CSR empty).
  const int32_t* star_begin(int32_t v) const { return vt_tets.data() + vt_offsets[v]; }
  const int32_t* star_end(int32_t v) const { return vt_tets.data() + vt_offsets[v + 1]; }
  bool is_boundary_tet(int32_t t) const { return tet_kind[t] > 0; }
};

/// Checks what a reader must guarantee before anything else runs: at least one
/// tet, every index in range, finite coordinates, array sizes consistent.
/// `name` prefixes the message (usually the file name).
/// threads: for the vertex and tet scans (the first error in index order is
/// reported whatever the count).
Status check_arrays(const TetMesh& m, const std::string& name = "mesh", int threads = 1);

/// Whether the quality measures can be computed: every coordinate at most
/// 1e60 in magnitude (or NaN-free; check_arrays refuses NaN and infinity).
/// The readers keep any finite value (convert loses no digit); quality,
/// improve, tetopt-mpi and the Python module refuse the rest with this
/// (InvalidMesh, naming the first vertex, 1-based; `name` prefixes the
/// message unless empty).
Status check_measurable(const TetMesh& m, const std::string& name = "mesh", int threads = 1);

/// Result of looking at every tet's exact orientation.
struct OrientationReport {
  int64_t positive = 0, negative = 0, flat = 0;
  bool flipped = false;                ///< the whole mesh was flipped to positive
  std::vector<int32_t> inverted;       ///< tets still negative after normalising (ids)
  std::vector<int32_t> flat_tets;      ///< tets with zero exact volume (ids)
  std::vector<int32_t> reoriented;     ///< tets whose vertex order disagreed with their neighbours' (ids; see orient_consistently)
};

/// Makes tets positive: if most are negative the file used the opposite
/// convention, so every tet is flipped and m.flipped_on_read toggles.  Tets
/// that disagree with the majority or are flat are listed, not changed.
OrientationReport normalize_orientation(TetMesh& m, int threads = 1);

/// After build_topology: checks that the tets' vertex orders agree across
/// every shared face (two tets sharing a face must induce opposite
/// orientations on it).  A tet listed with two vertices exchanged disagrees
/// with all its neighbours; left so, its region's signed volume is not the
/// region's volume and the boundary is not consistently oriented, so no
/// operation could keep both.  In every connected set of tets with a
/// disagreement, the orientation that gives the most tets a positive exact
/// volume wins, and the tets that differ from it are the disagreeing ones.
/// repair = false: fails (InvalidMesh, naming them, 1-based) when there are
/// any.  repair = true: reorients them (two vertices exchanged, like the
/// whole-mesh flip of normalize_orientation), rebuilds the topology and, when
/// `r` is given, lists them in r->reoriented and brings its counts and
/// inverted / flat lists up to date.  Fails (InvalidMesh, naming two tets)
/// when no consistent orientation exists.  Nothing changes and the cost is
/// one parallel scan of the faces when all agree.
Status orient_consistently(TetMesh& m, bool repair, OrientationReport* r = nullptr, int threads = 1);

/// Builds vertex->tet CSR, face adjacency and the constrained classification.
/// Fails (InvalidMesh, naming tet ids) when a face is shared by three or more
/// tets or two tets have the same four vertices.  threads: worker threads
/// for the parallel parts (0 = all cores); the result (and the error
/// reported, the first in serial order) is the same for every count.
Status build_topology(TetMesh& m, int threads = 1);

/// Whether m's derived topology (adjacency, face masks, kinds, constrained
/// vertices) has the sizes build_topology gives it: the passes rebuild it
/// when not.
bool topology_current(const TetMesh& m);

/// build_topology after the tets from `first_new` on were replaced by others
/// that fit the kept ones: the faces between kept and replaced tets are faces
/// of the new tets, and the constrained faces and vertices are those of
/// before.  Before the call, for the tets before first_new (their vertex ids
/// and order unchanged): adj links them to each other and is -1 where a
/// replaced tet was across; face_mask, tet_kind as built; vert_constrained
/// for the old vertices (new ones may be appended, free).  Rebuilds the
/// vertex->tet CSR and the adjacency buckets of the new tets' vertices only,
/// classifies the new tets, and leaves the rest.  The result is the one
/// build_topology gives (falls back to it when the links do not close up).
Status refresh_topology(TetMesh& m, int32_t first_new, int threads = 1);

/// Reorders the tets (with tet_ref and tet_entity) along a Morton curve of
/// their centroids, so that tets near in space are near in memory; vertex
/// ids do not change.  The topology arrays are cleared (call build_topology
/// after).  On a mesh whose tets come in no spatial order this makes the
/// star walks of the optimiser hit the cache (flange_large, 2.0M tets:
/// improve 8.3 s -> 6.1-6.7 s at 1 thread); the result differs, as the order
/// of the passes does.  Same permutation for every thread count.  order
/// (optional): order[new id] = old id.
void sort_tets_spatially(TetMesh& m, int threads = 1, std::vector<int32_t>* order = nullptr);

/// A region as the writers store it: (tet_ref, Gmsh entity tag or 0).
using RegionKey = std::pair<int32_t, int32_t>;

/// The regions of m in the order their first tets appear; with `order`
/// (order[id] = the tet's number in the file, as sort_tets_spatially gives
/// it) in the file's order.  For group_tets_by_region after improve.
std::vector<RegionKey> region_key_order(const TetMesh& m, const std::vector<int32_t>* order = nullptr);

/// Puts the tets of one region together (issue 28: a Gmsh 4.1 file then has
/// one element block per entity, and a Fluent file needs it anyway): a
/// stable sort by the rank of each tet's region in `keys` (regions not in
/// it after, in order of appearance), so the tets of one region keep their
/// order.  Returns whether any tet moved; the topology arrays are then
/// cleared (call build_topology after).  new_id (optional): new_id[old id]
/// = new id.  The same permutation for every thread count.
bool group_tets_by_region(TetMesh& m, const std::vector<RegionKey>& keys, std::vector<int32_t>* new_id = nullptr);

/// Lists the boundary and interface triangles m does not list yet (issue 28,
/// `--write-boundary`), so that a format that names groups of faces
/// (OpenFOAM patches and faceZones through gmshToFoam, Fluent zones, Abaqus
/// surfaces) gets real ones from a file that had none: the faces on one tet
/// of region r become the group "boundary_R", the faces between regions
/// a < b the group "interface_A_B" (R, A, B: the region's physical name, or
/// its ref), each with a new tri ref above every ref and dim-2 physical
/// tag in use, boundaries first, then interfaces, by ascending refs: the
/// same refs and names for the same mesh whatever its tet order.  A face
/// is listed as the face of its first tet (lowest id), facing out of it.
/// Returns the number of triangles added.  Needs no topology.
int32_t add_boundary_triangles(TetMesh& m);

/// How far apart consecutive tets lie: the mean distance between the
/// centroids of tets t and t+1, over the mean length of the edge between
/// their first two vertices (0 for fewer than 2 tets).  About 1 for tets in
/// a spatial order (a generated box 0.7, cube-clip-5 1.4), 5-17 for the
/// smaller shared meshes, 25 for the demo impeller and 44 for flange_large,
/// whose tets follow no spatial order.  Same value for every thread count.
double tet_order_spread(const TetMesh& m, int threads = 1);

/// Rebuilds only the vertex->tet CSR (after flips that kept adj up to date);
/// the same CSR for every thread count (0 = all cores).
void build_vertex_tets(TetMesh& m, int threads = 1);

/// build_vertex_tets when the CSR is absent (vt_offsets not nv+1 long), as
/// topology passes run with TopoOptions::rebuild_stars = false leave it.
/// Everything in the library that reads stars after such passes calls it.
void ensure_vertex_tets(TetMesh& m, int threads = 1);

/// Deletes the vertices listed in `drop` (ids, any order, duplicates
/// allowed) and renumbers the others in their order: xyz, vert_ref,
/// point_fields, vert_constrained and every vertex id in tets, tris, edges,
/// required_vertices and corners.  The dropped vertices must be referenced by
/// none of these (vertex removal leaves them so); Invariant error otherwise,
/// with nothing changed.  Rebuilds the vertex->tet CSR when it was built.
/// Returns the map old id -> new id (-1 for a dropped vertex) in `map`.
Status compact_vertices(TetMesh& m, const std::vector<int32_t>& drop, std::vector<int32_t>* map = nullptr);

/// Rebuilds face adjacency; same failure cases as build_topology.  Finds
/// each face's neighbour in the vertex stars; on any defect it falls back
/// to build_adjacency_sorted, whose error messages it reports.
Status build_adjacency(TetMesh& m, int threads = 1);

/// The same adjacency by an independent method (faces bucketed by their
/// smallest vertex and sorted); validate() compares against it.
Status build_adjacency_sorted(TetMesh& m, int threads = 1);

/// Recomputes face_mask, vert_constrained, tet_kind and tri_keys from adj, refs and the
/// listed entities.  Requires adj and the vertex stars (build_vertex_tets),
/// as build_topology leaves them.
void classify(TetMesh& m, int threads = 1);

/// TetMesh::tri_keys of `tris` (classify builds the mesh's own).
void build_tri_keys(const std::vector<int32_t>& tris, std::vector<int32_t>& keys);

/// Levels of validate(): Cheap checks sizes and ranges; Full also checks
/// adjacency symmetry, manifoldness and exact orientation of every tet.
enum class ValidateLevel { Cheap, Full };

/// Checks the invariants of a mesh with topology built.  Returns the first
/// problem found, naming the tet or vertex.
Status validate(const TetMesh& m, ValidateLevel level = ValidateLevel::Full);

/// Sorted vertex triple of face f of tet t (for keys and comparisons).
void face_key(const TetMesh& m, int32_t t, int f, int32_t out[3]);

/// Signed volume of tet t (floating point; positive for positive tets).
double tet_volume(const TetMesh& m, int32_t t);

/// Sum of signed tet volumes per region ref, as (ref, volume) sorted by ref,
/// summed in a fixed order (fixed blocks of tets, then the blocks in order:
/// the same bits for every thread count).
std::vector<std::pair<int32_t, double>> region_volumes(const TetMesh& m, int threads = 1);

}  // namespace tetopt
