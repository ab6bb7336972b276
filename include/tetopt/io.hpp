// tetopt/io.hpp — reading and writing every common tet-mesh format.
//
// Formats, chosen by file extension (format_from_path):
//   .mesh / .meshb    Medit / GMF, ASCII and binary (versions 1-4)
//   .msh              Gmsh 2.2 and 4.1, ASCII and binary; ANSYS Fluent mesh,
//                     ASCII and binary (told apart by content: a Fluent file
//                     starts with '(', a Gmsh file with "$MeshFormat")
//   .vtk / .vtu       VTK legacy (ASCII and binary) and XML UnstructuredGrid
//   .node / .ele      TetGen (.face and region attributes read when present)
//   .inp              Abaqus / CalculiX input: nodes, C3D4, sets, surfaces
//   .cgns             CGNS (HDF5 or ADF): one unstructured zone, TETRA_4 and
//                     TRI_3 sections, BCs and families (through libcgns)
//   .exo .e .ex2      Exodus II: element blocks, side sets, node sets
//                     (through the Exodus II library)
//   .../polyMesh      OpenFOAM polyMesh folder (a path ending in "polyMesh",
//                     or any folder holding an `owner` file or a case's
//                     constant/polyMesh), ASCII and binary
//
// Readers parse from a byte span, so tests and fuzzers need no files, and
// never trust a count before the data is shown to exist (a lying count ends
// in an error, not an allocation).  Every error is one line: "FILE:LINE: what"
// (or "FILE: record N: what" for binary files).
//
// What tetopt does not change comes back out: vertex / triangle / tet refs,
// listed edges, required entities, corners, ridges, physical names, Gmsh
// entity tags, VTK point data.  Coordinates are written with 17 significant
// digits (or raw doubles in binary formats) and read back bit-identical.
// write_mesh writes to "PATH.tmp-XXXX" and renames at the end, so a failed
// run never leaves half a file.
#pragma once
#include <functional>
#include <string>
#include <string_view>

#include "tetopt/mesh.hpp"
#include "tetopt/status.hpp"

namespace tetopt {

enum class Format { Unknown, Medit, MeditBinary, Gmsh, Vtk, Vtu, TetGen, OpenFoam, Fluent, Abaqus, Cgns, Exodus };

/// The files of an OpenFOAM polyMesh folder, in the order parse_openfoam
/// and format_openfoam take them (the last three are optional on read).
inline constexpr const char* kFoamFileNames[8] = {"points",   "faces",     "owner",     "neighbour",
                                                  "boundary", "cellZones", "faceZones", "pointZones"};

/// The polyMesh folder a path names for reading: the path itself when it
/// ends in "polyMesh" or holds an `owner` file, PATH/constant/polyMesh when
/// that holds one (a case folder); empty otherwise.
std::string openfoam_dir(const std::string& path);

/// Format from the extension (.mesh .meshb .msh .vtk .vtu .node .ele .inp
/// .cgns .exo .e .ex2; a
/// trailing .gz is not supported and gives Unknown); OpenFoam for a path
/// ending in "polyMesh" (or "polyMesh/") and for a folder openfoam_dir
/// accepts.
Format format_from_path(const std::string& path);

struct WriteOptions {
  int msh_version = 41;       ///< 22 or 41 for .msh
  bool binary = false;        ///< binary .msh / .vtk / polyMesh; .meshb is always binary
  int meditb_version = 3;     ///< GMF version for .meshb: 2 (32-bit ints), 3 or 4 (64-bit)
  int threads = 1;            ///< .mesh: format lines on this many threads, 0 = all cores (same bytes for any count)
  /// What a .msh output is: Auto writes Fluent when the mesh was read from a
  /// Fluent file (TetMesh::source_format), Gmsh otherwise.
  enum class Msh { Auto, Gmsh, Fluent } msh = Msh::Auto;
};

/// Whether write_mesh writes a .msh path as a Fluent mesh (see WriteOptions::msh).
bool msh_is_fluent(const TetMesh& m, const WriteOptions& opt);

/// Parses `data` (the bytes of a file named `name`, used in messages) into m's
/// primary arrays.  For TetGen, `data` is the .node file and `aux` maps
/// ".ele" / ".face" to the other files' bytes via load_sibling (see read_mesh).
/// No orientation normalisation, no topology.
/// threads != 1: the big sections (Vertices, Triangles, Tetrahedra, at least
/// 20,000 records laid out one per line) are parsed in parallel; the result
/// and every error message are those of threads = 1.
Status parse_medit(std::string_view data, const std::string& name, TetMesh& m, int threads = 1);
Status parse_meditb(std::string_view data, const std::string& name, TetMesh& m);
Status parse_gmsh(std::string_view data, const std::string& name, TetMesh& m);
Status parse_vtk(std::string_view data, const std::string& name, TetMesh& m);
Status parse_vtu(std::string_view data, const std::string& name, TetMesh& m);
/// node, ele: required; face: may be empty.
Status parse_tetgen(std::string_view node, std::string_view ele, std::string_view face,
                    const std::string& name, TetMesh& m);
/// files: the 8 files of kFoamFileNames (boundary may be empty when there
/// are no boundary faces, the zone files when absent); dir names them in
/// messages ("DIR/faces:12: ...").  Patches, zones: see docs/formats.md.
Status parse_openfoam(const std::string_view* files, const std::string& dir, TetMesh& m);
/// A Fluent .msh (ASCII or binary sections); zones: see docs/formats.md.
Status parse_fluent(std::string_view data, const std::string& name, TetMesh& m);
/// An Abaqus / CalculiX .inp: *NODE, *ELEMENT TYPE=C3D4, *ELSET, *NSET, *SURFACE.
Status parse_abaqus(std::string_view data, const std::string& name, TetMesh& m);

/// CGNS and Exodus II are read and written through their libraries, which
/// take a file name, not bytes (so these take a path; `name` is the file
/// name messages give).  Built only where CMake found libcgns-dev /
/// libexodusii-dev (options TETOPT_CGNS, TETOPT_EXODUS); elsewhere they
/// return an Unsupported error saying so, and cgns_available() /
/// exodus_available() are false.  What they keep: docs/formats.md.
bool cgns_available();
bool exodus_available();
Status parse_cgns_file(const std::string& path, const std::string& name, TetMesh& m);
Status parse_exodus_file(const std::string& path, const std::string& name, TetMesh& m);
/// Write the file at path itself (not through a temporary: write_mesh does that).
Status format_cgns_file(const TetMesh& m, const std::string& path);
Status format_exodus_file(const TetMesh& m, const std::string& path);

/// Serialises m in the given format into `out` (bytes).  For TetGen, out is
/// the .node text and out_ele / out_face receive the other files.
///
/// format_medit with `flush`: whenever `out` holds at least 4 MiB of whole
/// lines (never at the end), flush(out) is called to take the text; `out` is
/// cleared after it (the callee may swap in a spare buffer, whose capacity is
/// then reused).  The caller writes what is left in `out` after the call.
/// The flushed pieces and the rest, joined, are the text format_medit writes
/// without flush, byte for byte.
using TextFlush = std::function<void(std::string& out)>;
Status format_medit(const TetMesh& m, std::string& out, int threads = 1, const TextFlush& flush = {});
Status format_meditb(const TetMesh& m, std::string& out, int version);
Status format_gmsh(const TetMesh& m, std::string& out, int version, bool binary);
Status format_vtk(const TetMesh& m, std::string& out, bool binary);
Status format_vtu(const TetMesh& m, std::string& out);
Status format_tetgen(const TetMesh& m, std::string& node, std::string& ele, std::string& face);
/// out: 8 strings, the files of kFoamFileNames (all written, zone files
/// with no zones too, so that no stale file of an earlier mesh stays).
Status format_openfoam(const TetMesh& m, std::string* out, bool binary);
/// A Fluent .msh: ASCII, or binary sections (3010 / 3013, doubles and 32-bit ints).
Status format_fluent(const TetMesh& m, std::string& out, bool binary);
/// An Abaqus / CalculiX .inp (element sets per tet ref, node sets per vertex
/// ref, an element surface per triangle ref).
Status format_abaqus(const TetMesh& m, std::string& out);

/// Reads a file: format by extension (a .ele path reads its .node sibling
/// and vice versa), parse, check_arrays, then normalize_orientation.  The
/// orientation report (flipped? inverted / flat tet ids) goes to *orient when
/// given.  Topology is not built.
Status read_mesh(const std::string& path, TetMesh& m, OrientationReport* orient = nullptr, int threads = 1);

/// Writes m (tets in the file's own orientation convention, see
/// TetMesh::flipped_on_read) atomically: temporary file, then rename.
Status write_mesh(const std::string& path, const TetMesh& m, const WriteOptions& opt = {});

/// The files a mesh path stands for: a TetGen name (.node or .ele) its
/// .node, .ele and .face (the .face of an input may be absent); any other
/// path itself.
std::vector<std::string> mesh_files(const std::string& path);

/// What m holds that a file of the given format cannot carry and the writer
/// therefore leaves out, one phrase per kind with its count, e.g. "vertex
/// refs (12 nonzero)", "physical names (3)"; empty when the file keeps
/// everything (see docs/formats.md, "What is kept").  The command line tool
/// prints them as a warning and lists them in improve's report.
std::vector<std::string> dropped_by_format(const TetMesh& m, Format f, const WriteOptions& opt = {});

/// Reads a whole file into memory (Io error naming the path on failure).
Status read_file_bytes(const std::string& path, std::string& out);
/// Writes bytes to path through a temporary file and rename.
Status write_file_atomic(const std::string& path, std::string_view bytes);

/// Whether path can take an output written through a temporary file and a
/// rename, checked before any work (Io error naming the path if not): after
/// following symbolic links, the target is a regular file or absent (a
/// folder, device, FIFO or socket is refused: renaming over it would replace
/// it), and its folder exists and is writable.  A TetGen output checks its
/// .node, .ele and .face.  The writers follow the same links, so a link to a
/// file keeps pointing at the rewritten file.
Status check_output_path(const std::string& path);

/// The file a write to path replaces: path with its symbolic links followed
/// (a link that points nowhere gives the path it points to, which the write
/// creates), or path itself when it names no link.
std::string output_target(const std::string& path);

/// Removes the temporary files of the writes in progress (in any thread):
/// for a program's handler of SIGTERM, SIGHUP or SIGINT, which would
/// otherwise leave them beside the outputs.  Only unlink(2), which is
/// async-signal-safe; the library installs no handler itself.
void remove_pending_temporaries() noexcept;

}  // namespace tetopt
