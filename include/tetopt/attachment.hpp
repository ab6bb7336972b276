// tetopt/attachment.hpp — what a file carried beyond tets, refs and
// constrained entities.
//
// The project's rule (DESIGN.md, issue 28): TetMesh holds tets, refs and the
// constrained entities; what a solver format says *about* those groups (an
// OpenFOAM patch's type and further dictionary entries, a Fluent zone's
// type, an Abaqus set's name and kind) lives here, in one attachment next
// to the mesh (TetMesh::attachment), never in new fields of TetMesh.
//
// Everything in it is keyed by (dim, ref): dim 3 is a tet region (tet_ref),
// 2 a group of listed triangles (tri_ref), 0 a group of vertices
// (vert_ref).  Refs survive every operation of tetopt (tets are split,
// flipped, reordered, vertices renumbered; refs and listed triangles stay),
// so the attachment needs no update when the mesh changes.  Names are not
// here: a group's name is its TetMesh::physical_names entry (dim, tag = ref,
// name), the concept Gmsh, OpenFOAM, Fluent and Abaqus share, so a name
// survives a conversion between any two of them.
//
// Writers use what they understand and ignore the rest: a group written to
// OpenFOAM takes its `foam_type` (default "patch"), a Fluent zone its
// `fluent_type` (default "wall" for a boundary zone) and so on.  A group
// without an entry gets the format's default.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace tetopt {

/// What a format said about one group of the mesh.
struct GroupAttachment {
  int dim = 2;        ///< 3: tet_ref, 2: tri_ref, 0: vert_ref
  int32_t ref = 0;    ///< the ref the group's entities carry
  /// OpenFOAM: "patch" (a boundary patch), "faceZone", "cellZone", "pointZone".
  std::string foam_kind;
  /// OpenFOAM patch type (wall, patch, symmetryPlane, empty, ...); empty = not given.
  std::string foam_type;
  /// Further entries of an OpenFOAM patch dictionary, verbatim and in the
  /// file's order, each ending with ';' ("inGroups List<word> 1(wall);"),
  /// written back after type/nFaces/startFace.
  std::string foam_entries;
  /// Fluent zone type ("wall", "pressure-outlet", "interior", "fluid", ...)
  /// and zone id; empty / 0 = not given.
  std::string fluent_type;
  int32_t fluent_id = 0;
  /// CGNS: the BCType of a triangle group's BC_t as libcgns names it ("BCWall",
  /// "BCInflow", "UserDefined", ...;
  /// SIDS 9.7) and its FamilyName where that differs from the BC's name;
  /// empty = not given.
  std::string cgns_bctype;
  std::string cgns_family;
};

/// The groups a file described, in the file's order (a writer that keeps an
/// order, OpenFOAM's patches, writes the listed groups in this order first).
struct Attachment {
  std::vector<GroupAttachment> groups;

  /// The entry of (dim, ref), or nullptr.
  const GroupAttachment* find(int dim, int32_t ref) const {
    for (const GroupAttachment& g : groups)
      if (g.dim == dim && g.ref == ref) return &g;
    return nullptr;
  }
  /// The entry of (dim, ref), appended when absent.
  GroupAttachment& get(int dim, int32_t ref) {
    for (GroupAttachment& g : groups)
      if (g.dim == dim && g.ref == ref) return g;
    groups.push_back(GroupAttachment{});
    groups.back().dim = dim;
    groups.back().ref = ref;
    return groups.back();
  }
  bool empty() const { return groups.empty(); }
};

}  // namespace tetopt
