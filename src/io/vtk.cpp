// VTK readers and writers: legacy .vtk (ASCII and BINARY, DATASET
// UNSTRUCTURED_GRID, both the classic CELLS layout and the 5.x
// OFFSETS/CONNECTIVITY layout) and XML .vtu (UnstructuredGrid; DataArrays in
// ascii, inline base64 binary, appended raw or base64; optional zlib
// compression).
//
// Format references: "VTK File Formats" (VTK User's Guide, chapter 19, and
// docs.vtk.org "VTK File Formats"), which fix the legacy keywords, big-endian
// legacy binary data, and the XML binary header layouts (one header_type word
// holding the byte count, or [nblocks, blocksize, lastblocksize, sizes...]
// followed by zlib blocks when compressor="vtkZLibDataCompressor").
//
// Mapping into TetMesh: cell type 10 -> tets, 5 -> tris, 3 -> edges,
// 1 (vertex) -> corners; any other cell type is Unsupported.  The region ref
// is the first integer cell array whose name is one of ref, medit:ref,
// gmsh:physical, CellEntityIds, region, MaterialIds (in that priority), else
// the first one-component integer cell array that is not an id numbering
// (GLOBAL_ID, GlobalIds, vtkOriginalCellIds, ...).  gmsh:geometrical fills
// tet_entity / tri_entity.  Point data arrays become m.point_fields and are
// written back unchanged.  Coordinates declared float are read as float32
// (the value VTK and meshio hold) and widened to double.
#include <algorithm>
#include <cmath>
#include <cctype>
#include <cstdio>
#include <string>
#include <vector>

#include "io/common.hpp"
#include "io/checked.hpp"
#include "io/scan_gmsh_vtk.hpp"
#include "tetopt/io.hpp"

#if defined(TETOPT_HAVE_ZLIB) && __has_include(<zlib.h>)
#include <zlib.h>
#define TETOPT_VTK_ZLIB 1
#endif

namespace tetopt {

namespace {

using gvscan::Cursor;

std::string shorten(std::string_view t) { return detail::shown_token(t, true); }

// A DataArray as an error message names it: 'name', or (unnamed).
std::string array_label(const std::string& name) {
  if (name.empty()) return "(unnamed)";
  std::string s = "'";
  s += shorten(name);
  s += '\'';
  return s;
}

// Upper-cased copy of a keyword token, for comparisons.  At most 64 bytes
// are copied (every keyword is shorter): a file with a 2 GB run of bytes in
// one token once took 2 GB of heap here.  A longer token gets a trailing
// '\x01', so it equals no keyword.
std::string upper(std::string_view t) {
  constexpr size_t kMost = 64;
  std::string s(t.substr(0, kMost));
  if (t.size() > kMost) s += '\x01';
  for (char& ch : s) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return s;
}

const char* cell_type_name(int64_t t) {
  switch (t) {
    case 1: return "vertex";
    case 2: return "poly-vertex";
    case 3: return "line";
    case 4: return "poly-line";
    case 5: return "triangle";
    case 6: return "triangle strip";
    case 7: return "polygon";
    case 8: return "pixel";
    case 9: return "quad";
    case 10: return "tetrahedron";
    case 11: return "voxel";
    case 12: return "hexahedron";
    case 13: return "wedge";
    case 14: return "pyramid";
    case 21: return "quadratic edge";
    case 22: return "quadratic triangle";
    case 24: return "quadratic tetrahedron";
    case 42: return "polyhedron";
    default: return "unknown";
  }
}

// Longest array name kept (bytes).  VTK sets no limit; a longer "name" is a
// corrupt file, refused rather than copied (issue 25: no unbounded token
// copies).
constexpr size_t kMaxNameBytes = 4096;

int cell_nodes(int64_t t) {
  switch (t) {
    case 1: return 1;
    case 3: return 2;
    case 5: return 3;
    case 10: return 4;
    default: return 0;
  }
}

/// A numeric type of a legacy or XML data array.
struct NumType {
  int bytes = 0;      // 0: unknown
  bool integer = false;
  bool is_signed = true;
  bool is_float32 = false;
};

NumType legacy_type(std::string_view t) {
  const std::string u = upper(t);
  if (u == "FLOAT") return {4, false, true, true};
  if (u == "DOUBLE") return {8, false, true, false};
  if (u == "INT") return {4, true, true, false};
  if (u == "UNSIGNED_INT") return {4, true, false, false};
  if (u == "SHORT") return {2, true, true, false};
  if (u == "UNSIGNED_SHORT") return {2, true, false, false};
  if (u == "CHAR") return {1, true, true, false};
  if (u == "UNSIGNED_CHAR") return {1, true, false, false};
  if (u == "VTKTYPEINT8") return {1, true, true, false};
  if (u == "VTKTYPEUINT8") return {1, true, false, false};
  if (u == "VTKTYPEINT16") return {2, true, true, false};
  if (u == "VTKTYPEUINT16") return {2, true, false, false};
  if (u == "VTKTYPEINT32") return {4, true, true, false};
  if (u == "VTKTYPEUINT32") return {4, true, false, false};
  if (u == "VTKTYPEFLOAT32") return {4, false, true, true};
  if (u == "VTKTYPEFLOAT64") return {8, false, true, false};
  if (u == "LONG" || u == "VTKTYPEINT64" || u == "VTKIDTYPE") return {8, true, true, false};
  if (u == "UNSIGNED_LONG" || u == "VTKTYPEUINT64") return {8, true, false, false};
  return {};
}

NumType xml_type(std::string_view t) {
  if (t == "Float32") return {4, false, true, true};
  if (t == "Float64") return {8, false, true, false};
  if (t == "Int8") return {1, true, true, false};
  if (t == "UInt8") return {1, true, false, false};
  if (t == "Int16") return {2, true, true, false};
  if (t == "UInt16") return {2, true, false, false};
  if (t == "Int32") return {4, true, true, false};
  if (t == "UInt32") return {4, true, false, false};
  if (t == "Int64") return {8, true, true, false};
  if (t == "UInt64") return {8, true, false, false};
  return {};
}

/// Converts one binary value to double.
double binary_value(const char* p, const NumType& t, bool big) {
  if (!t.integer) return t.bytes == 4 ? static_cast<double>(gvscan::load<float>(p, big)) : gvscan::load<double>(p, big);
  switch (t.bytes) {
    case 1: return t.is_signed ? static_cast<double>(static_cast<int8_t>(*p)) : static_cast<double>(static_cast<uint8_t>(*p));
    // Each branch converted on its own: `c ? int32_t : uint32_t` has type
    // uint32_t, which read a binary Int32 ref of -1 as 4294967295.
    case 2: return t.is_signed ? static_cast<double>(gvscan::load<int16_t>(p, big))
                               : static_cast<double>(gvscan::load<uint16_t>(p, big));
    case 4: return t.is_signed ? static_cast<double>(gvscan::load<int32_t>(p, big))
                               : static_cast<double>(gvscan::load<uint32_t>(p, big));
    default:
      return t.is_signed ? static_cast<double>(gvscan::load<int64_t>(p, big))
                         : static_cast<double>(gvscan::load<uint64_t>(p, big));
  }
}

/// A data array as read (values as doubles: exact for every integer tetopt
/// stores and for every float32 / float64 value).
struct Array {
  std::string name;
  int components = 1;
  bool integer = false;
  std::vector<double> values;
};

bool is_id_numbering(const std::string& n) {
  return n == "GLOBAL_ID" || n == "GlobalIds" || n == "GlobalCellIds" || n == "vtkOriginalCellIds" ||
         n == "vtkGhostType" || n == "vtkOriginalPointIds" || n == "GlobalNodeIds" || n == "gmsh:geometrical";
}

bool is_int32_value(double v) { return v == std::floor(v) && v >= INT32_MIN && v <= INT32_MAX; }

bool all_integral(const Array& a) { return std::all_of(a.values.begin(), a.values.end(), is_int32_value); }

const char* const kRefNames[] = {"ref", "medit:ref", "gmsh:physical", "CellEntityIds", "region", "MaterialIds"};

/// Whether a cell array's name makes it a ref (kRefNames) or gmsh:geometrical.
bool is_ref_name(const std::string& n) {
  if (n == "gmsh:geometrical") return true;
  for (const char* want : kRefNames)
    if (n == want) return true;
  return false;
}

/// A one-component cell array named as a ref (kRefNames) or gmsh:geometrical
/// that holds a value no int32 ref can be (7.5, 1e10): an error naming the
/// array, the cell and the value, rather than refs silently set to 0 in the
/// output.
Status check_ref_arrays(const std::vector<Array>& cell, const std::string& name) {
  for (const Array& a : cell) {
    if (a.components != 1 || !is_ref_name(a.name)) continue;
    for (size_t c = 0; c < a.values.size(); ++c) {
      const double v = a.values[c];
      if (is_int32_value(v)) continue;
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.17g", v);
      return Status::error(ErrorCode::InvalidMesh, name + ": cell array " + a.name + " holds " + buf + " at cell " +
                                                       std::to_string(c) +
                                                       " (ids from 0); refs are whole numbers that fit in 32 bits");
    }
  }
  return Status::success();
}

/// The cell array used as region ref (see the file comment), or -1.
int pick_ref_array(const std::vector<Array>& cell) {
  for (const char* want : kRefNames)
    for (size_t i = 0; i < cell.size(); ++i)
      if (cell[i].name == want && cell[i].components == 1 && all_integral(cell[i])) return static_cast<int>(i);
  for (size_t i = 0; i < cell.size(); ++i)
    if (cell[i].integer && cell[i].components == 1 && !is_id_numbering(cell[i].name) && all_integral(cell[i]))
      return static_cast<int>(i);
  return -1;
}

/// Cells, points and data as read by either reader; builds the TetMesh.
struct Grid {
  std::vector<double> xyz;
  std::vector<int64_t> offsets;  // ncells + 1
  std::vector<int64_t> conn;
  std::vector<int64_t> types;
  std::vector<Array> cell_data, point_data;
};

/// Index values (offsets, connectivity, cell types) read as doubles, into
/// out.  A value outside int64's range or NaN has no index and its
/// conversion is undefined behaviour (a fuzzed 9.2e18 offset): false, with
/// *bad its position.
bool is_index(double x) {
  constexpr double kLim = 9223372036854775808.0;  // 2^63, exact in a double
  return x >= -kLim && x < kLim;                  // false for NaN
}

bool to_indices(const std::vector<double>& v, std::vector<int64_t>& out, size_t* bad) {
  out.clear();
  out.reserve(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    if (!is_index(v[i])) {
      *bad = i;
      return false;
    }
    out.push_back(static_cast<int64_t>(v[i]));
  }
  return true;
}

std::string index_range_error(const std::string& what, size_t i, double x) {
  return what + " value " + std::to_string(i + 1) + " (" + shorten(std::to_string(x)) + ") is not an index";
}

/// Fills m from g; `where` prefixes messages ("FILE" or "FILE:LINE").
Status build_mesh(Grid& g, const std::string& name, TetMesh& m) {
  const int64_t nv = static_cast<int64_t>(g.xyz.size() / 3);
  if (nv > INT32_MAX) return Status::error(ErrorCode::Unsupported, name + ": more than 2^31 points");
  const size_t nc = g.types.size();
  if (g.offsets.size() != nc + 1)
    return Status::error(ErrorCode::Parse, name + ": the cell count differs between cells and cell types");
  for (size_t v = 0; v < g.xyz.size(); ++v)
    if (!std::isfinite(g.xyz[v]))
      return Status::error(ErrorCode::InvalidMesh,
                           name + ": point " + std::to_string(v / 3) + " (ids from 0) has a NaN or infinite coordinate");
  std::vector<int8_t> kind(nc);
  std::vector<int32_t> pos(nc);
  for (size_t c = 0; c < nc; ++c) {
    const int64_t t = g.types[c];
    const int k = cell_nodes(t);
    if (k == 0)
      return Status::error(ErrorCode::Unsupported, name + ": cell " + std::to_string(c) + " (ids from 0) has VTK cell type " +
                                                       std::to_string(t) + " (" + cell_type_name(t) +
                                                       "), which is not supported: tetopt reads tetrahedra (10), "
                                                       "triangles (5), lines (3) and vertices (1)");
    const int64_t b = g.offsets[c], e = g.offsets[c + 1];
    if (b < 0 || e < b || e > static_cast<int64_t>(g.conn.size()))
      return Status::error(ErrorCode::Parse, name + ": cell " + std::to_string(c) + " (ids from 0) has a bad offset");
    if (e - b != k)
      return Status::error(ErrorCode::Parse, name + ": cell " + std::to_string(c) + " (ids from 0) of type " + std::to_string(t) +
                                                 " (" + cell_type_name(t) + ") lists " + std::to_string(e - b) +
                                                 " points instead of " + std::to_string(k));
    int32_t v[4];
    for (int j = 0; j < k; ++j) {
      const int64_t p = g.conn[static_cast<size_t>(b + j)];
      if (p < 0 || p >= nv)
        return Status::error(ErrorCode::InvalidMesh, name + ": cell " + std::to_string(c) + " (ids from 0) names point " +
                                                         std::to_string(p) + ", outside 0.." + std::to_string(nv - 1));
      v[j] = static_cast<int32_t>(p);
    }
    kind[c] = static_cast<int8_t>(k);
    switch (k) {
      case 4: pos[c] = m.nt(); m.tets.insert(m.tets.end(), v, v + 4); break;
      case 3: pos[c] = m.ntri(); m.tris.insert(m.tris.end(), v, v + 3); break;
      case 2: pos[c] = static_cast<int32_t>(m.edges.size() / 2); m.edges.insert(m.edges.end(), v, v + 2); break;
      default: pos[c] = static_cast<int32_t>(m.corners.size()); m.corners.push_back(v[0]); break;
    }
  }
  if (m.tets.empty())
    return Status::error(ErrorCode::InvalidMesh, name + ": no tetrahedra (cell type 10): a surface-only mesh?");
  m.xyz = std::move(g.xyz);
  for (const Array& a : g.cell_data)
    if (a.values.size() != nc * static_cast<size_t>(a.components))
      return Status::error(ErrorCode::Parse, name + ": cell array " + a.name + " has " +
                                                 std::to_string(a.values.size()) + " values for " + std::to_string(nc) +
                                                 " cells");
  auto scatter = [&](const Array& a, std::vector<int32_t>& tet_out, std::vector<int32_t>& tri_out,
                     std::vector<int32_t>* edge_out) {
    tet_out.assign(static_cast<size_t>(m.nt()), 0);
    tri_out.assign(static_cast<size_t>(m.ntri()), 0);
    if (edge_out) edge_out->assign(m.edges.size() / 2, 0);
    for (size_t c = 0; c < nc; ++c) {
      const int32_t r = static_cast<int32_t>(a.values[c]);
      if (kind[c] == 4) tet_out[static_cast<size_t>(pos[c])] = r;
      else if (kind[c] == 3) tri_out[static_cast<size_t>(pos[c])] = r;
      else if (kind[c] == 2 && edge_out) (*edge_out)[static_cast<size_t>(pos[c])] = r;
    }
  };
  if (Status s = check_ref_arrays(g.cell_data, name); !s) return s;
  if (const int ri = pick_ref_array(g.cell_data); ri >= 0)
    scatter(g.cell_data[static_cast<size_t>(ri)], m.tet_ref, m.tri_ref, &m.edge_ref);
  for (const Array& a : g.cell_data)
    if (a.name == "gmsh:geometrical" && a.components == 1 && all_integral(a))
      scatter(a, m.tet_entity, m.tri_entity, nullptr);
  for (Array& a : g.point_data) {
    if (a.values.size() != static_cast<size_t>(nv) * static_cast<size_t>(a.components))
      return Status::error(ErrorCode::Parse, name + ": point array " + a.name + " has " +
                                                 std::to_string(a.values.size()) + " values for " + std::to_string(nv) +
                                                 " points");
    m.point_fields.push_back({a.name, a.components, a.integer, std::move(a.values)});
  }
  return Status::success();
}

// ================================================================ legacy

class LegacyReader {
 public:
  LegacyReader(std::string_view data, const std::string& name) : name_(name) { c_.s = data; }

  Status run(TetMesh& m) {
    const std::string_view l1 = c_.rest_of_line();
    if (l1.substr(0, 5) != "# vtk" && l1.substr(0, 5) != "# VTK")
      return fail(ErrorCode::Parse, "not a legacy VTK file (the first line must start with \"# vtk DataFile Version\")", 1);
    c_.rest_of_line();  // title
    const std::string enc = upper(c_.token());
    if (enc == "BINARY") binary_ = true;
    else if (enc != "ASCII") return fail(ErrorCode::Parse, "expected ASCII or BINARY, found '" + shorten(enc) + "'");
    if (upper(c_.token()) != "DATASET") return fail(ErrorCode::Parse, "expected DATASET");
    if (const std::string ds = upper(c_.token()); ds != "UNSTRUCTURED_GRID")
      return fail(ErrorCode::Unsupported, "DATASET " + shorten(ds) + " is not supported (only UNSTRUCTURED_GRID)");
    bool have_points = false, have_cells = false, have_types = false, have_cell_data = false, have_point_data = false;
    int64_t ncells = -1;
    std::vector<Array>* target = nullptr;  // CELL_DATA / POINT_DATA arrays
    int64_t target_n = 0;
    for (;;) {
      const std::string_view tok = c_.token();
      if (tok.empty()) break;
      const std::string kw = upper(tok);
      Status s;
      if (kw == "POINTS") {
        if (have_points) return fail(ErrorCode::Parse, "a second POINTS section");
        have_points = true;
        int64_t n = 0;
        if (s = count(n, "the number of points"); !s) return s;
        const NumType t = legacy_type(c_.token());
        if (t.bytes == 0 || t.integer) return fail(ErrorCode::Parse, "POINTS type must be float or double");
        int64_t nv3 = 0;
        if (s = product(3, n, nv3, "POINTS"); !s) return s;
        s = values(nv3, t, g_.xyz, "POINTS");
      } else if (kw == "CELLS") {
        if (have_cells) return fail(ErrorCode::Parse, "a second CELLS section");
        have_cells = true;
        s = read_cells(ncells);
      } else if (kw == "CELL_TYPES") {
        if (have_types) return fail(ErrorCode::Parse, "a second CELL_TYPES section");
        have_types = true;
        int64_t n = 0;
        if (s = count(n, "the number of cell types"); !s) return s;
        if (ncells >= 0 && n != ncells)
          return fail(ErrorCode::Parse, "CELL_TYPES count " + std::to_string(n) + " differs from the CELLS count " +
                                            std::to_string(ncells));
        std::vector<double> v;
        if (s = values(n, binary_ ? NumType{4, true, true, false} : NumType{8, true, true, false}, v, "CELL_TYPES"); !s)
          return s;
        if (size_t bad = 0; !to_indices(v, g_.types, &bad))
          return fail(ErrorCode::Parse, index_range_error("CELL_TYPES", bad, v[bad]));
      } else if (kw == "CELL_DATA" || kw == "POINT_DATA") {
        // One section of each per dataset (VTK's file-formats manual); a
        // second one was appended to the first and its refs silently lost.
        bool& seen = kw == "CELL_DATA" ? have_cell_data : have_point_data;
        if (seen) return fail(ErrorCode::Parse, "a second " + kw + " section (a legacy VTK dataset has at most one)");
        seen = true;
        if (s = count(target_n, "the number of data tuples"); !s) return s;
        target = kw == "CELL_DATA" ? &g_.cell_data : &g_.point_data;
      } else if (kw == "SCALARS" || kw == "VECTORS" || kw == "NORMALS" || kw == "TENSORS" ||
                 kw == "TEXTURE_COORDINATES" || kw == "COLOR_SCALARS") {
        if (!target) return fail(ErrorCode::Parse, kw + " outside CELL_DATA / POINT_DATA");
        s = read_attribute(kw, target_n, *target);
      } else if (kw == "LOOKUP_TABLE") {  // a table given as data: name size, then size RGBA tuples
        c_.token();
        int64_t n = 0;
        if (s = count(n, "the lookup table size"); !s) return s;
        std::vector<double> v;
        int64_t n4 = 0;
        if (s = product(4, n, n4, "LOOKUP_TABLE"); !s) return s;
        s = values(n4, binary_ ? NumType{1, true, false, false} : NumType{8, false, true, false}, v, "LOOKUP_TABLE");
      } else if (kw == "FIELD") {
        s = read_field(target, target_n);
      } else if (kw == "METADATA") {
        s = skip_metadata();
      } else {
        return fail(ErrorCode::Parse, "unexpected keyword '" + shorten(tok) + "' (a count that does not match the data?)");
      }
      if (!s) return s;
    }
    if (!have_points) return fail(ErrorCode::Parse, "no POINTS section");
    if (!have_cells) return fail(ErrorCode::Parse, "no CELLS section");
    if (!have_types) return fail(ErrorCode::Parse, "no CELL_TYPES section");
    return build_mesh(g_, name_, m);
  }

 private:
  const std::string& name_;
  Cursor c_;
  bool binary_ = false;
  Grid g_;

  Status fail(ErrorCode code, const std::string& what, long line = -1) const {
    const long l = line >= 0 ? line : c_.line;
    return Status::error(code, name_ + ":" + std::to_string(l) + ": " + what, l);
  }
  Status fail_bin(const std::string& what) const {
    return Status::error(ErrorCode::Parse, name_ + ": byte " + std::to_string(c_.pos) + ": " + what,
                         static_cast<long>(c_.pos));
  }
  Status bad_token(std::string_view t, const std::string& what) const {
    if (t.empty()) return fail(ErrorCode::Parse, "unexpected end of file while reading " + what + " (truncated file?)");
    return fail(ErrorCode::Parse, "expected " + what + ", found '" + shorten(t) + "'");
  }
  /// The next token as a name: never empty, at most kMaxNameBytes.
  Status name_token(std::string& out, const char* what) {
    const std::string_view t = c_.token();
    if (t.empty()) return bad_token(t, what);
    if (t.size() > kMaxNameBytes)
      return fail(ErrorCode::Parse, std::string(what) + " of " + std::to_string(t.size()) + " bytes (more than " +
                                        std::to_string(kMaxNameBytes) + ")");
    out.assign(t);
    return Status::success();
  }
  /// out = a * b for a count derived from two file values (components x
  /// tuples); an error naming `what` when it overflows.
  Status product(int64_t a, int64_t b, int64_t& out, const std::string& what) const {
    if (!detail::ck_mul(a, b, out)) return fail(ErrorCode::Parse, what + ": count " + std::to_string(a) + " x " +
                                                                     std::to_string(b) + " overflows");
    return Status::success();
  }
  Status count(int64_t& n, const char* what) {
    const std::string_view t = c_.token();
    if (!gvscan::parse_int(t, n)) return bad_token(t, what);
    if (n < 0) return fail(ErrorCode::Parse, std::string("negative ") + what);
    return Status::success();
  }

  /// Reads n values of type t (ASCII tokens or big-endian binary right after
  /// the current line).  The count is checked against the bytes left first.
  Status values(int64_t n, const NumType& t, std::vector<double>& out, const std::string& what) {
    out.clear();
    if (n < 0) return fail(ErrorCode::Parse, "negative count in " + what);
    if (binary_) {
      c_.rest_of_line();
      const size_t bytes = static_cast<size_t>(t.bytes);
      if (static_cast<uint64_t>(n) > c_.remaining() / bytes)
        return fail_bin(what + " declares " + std::to_string(n) + " values but only " +
                        std::to_string(c_.remaining()) + " bytes remain (truncated file or lying count)");
      out.resize(static_cast<size_t>(n));
      const char* p = c_.s.data() + c_.pos;
      for (size_t i = 0; i < out.size(); ++i) out[i] = binary_value(p + i * bytes, t, true);
      c_.pos += out.size() * bytes;
      return Status::success();
    }
    if (static_cast<uint64_t>(n) > c_.remaining() / 2 + 1)
      return fail(ErrorCode::Parse, what + " declares " + std::to_string(n) + " values but only " +
                                        std::to_string(c_.remaining()) + " bytes remain (truncated file or lying count)");
    out.resize(static_cast<size_t>(n));
    for (size_t i = 0; i < out.size(); ++i) {
      const std::string_view tok = c_.token();
      bool ok;
      if (t.integer) {
        int64_t v = 0;
        ok = gvscan::parse_int(tok, v);
        out[i] = static_cast<double>(v);
      } else {
        ok = t.is_float32 ? gvscan::parse_float32(tok, out[i]) : gvscan::parse_double(tok, out[i]);
      }
      if (!ok)
        return bad_token(tok, std::string(t.integer ? "an integer" : "a number") + " in " + what + " (value " +
                                  std::to_string(i + 1) + " of " + std::to_string(n) + ")");
    }
    return Status::success();
  }

  Status read_cells(int64_t& ncells) {
    int64_t n = 0, size = 0;
    if (Status s = count(n, "the number of cells"); !s) return s;
    if (Status s = count(size, "the cell list size"); !s) return s;
    std::vector<double> v;
    if (upper(c_.peek()) == "OFFSETS") {  // VTK 5.x layout: CELLS noffsets nconn
      c_.token();
      const NumType t = legacy_type(c_.token());
      if (t.bytes == 0 || !t.integer) return fail(ErrorCode::Parse, "OFFSETS type must be an integer type");
      if (n < 1) return fail(ErrorCode::Parse, "OFFSETS needs at least one value");
      if (Status s = values(n, t, v, "OFFSETS"); !s) return s;
      if (size_t bad = 0; !to_indices(v, g_.offsets, &bad))
        return fail(ErrorCode::Parse, index_range_error("OFFSETS", bad, v[bad]));
      if (upper(c_.token()) != "CONNECTIVITY") return fail(ErrorCode::Parse, "expected CONNECTIVITY after OFFSETS");
      const NumType t2 = legacy_type(c_.token());
      if (t2.bytes == 0 || !t2.integer) return fail(ErrorCode::Parse, "CONNECTIVITY type must be an integer type");
      if (Status s = values(size, t2, v, "CONNECTIVITY"); !s) return s;
      if (size_t bad = 0; !to_indices(v, g_.conn, &bad))
        return fail(ErrorCode::Parse, index_range_error("CONNECTIVITY", bad, v[bad]));
      if (g_.offsets.front() != 0 || g_.offsets.back() != size)
        return fail(ErrorCode::Parse, "OFFSETS do not span CONNECTIVITY");
      ncells = n - 1;
      return Status::success();
    }
    const NumType t = binary_ ? NumType{4, true, true, false} : NumType{8, true, true, false};
    if (size < n) return fail(ErrorCode::Parse, "CELLS size " + std::to_string(size) + " is smaller than the cell count");
    if (Status s = values(size, t, v, "CELLS"); !s) return s;
    g_.offsets.assign(static_cast<size_t>(n) + 1, 0);
    g_.conn.reserve(static_cast<size_t>(size - n));
    size_t at = 0;
    for (int64_t c = 0; c < n; ++c) {
      if (at >= v.size()) return fail(ErrorCode::Parse, "CELLS data ends inside cell " + std::to_string(c));
      const double k = v[at++];
      if (k < 0 || k > static_cast<double>(v.size() - at))
        return fail(ErrorCode::Parse, "cell " + std::to_string(c) + " has a bad point count " +
                                          (k == std::floor(k) && std::fabs(k) < 1e15 ? std::to_string(static_cast<int64_t>(k))
                                                                                   : shorten(std::to_string(k))));
      for (int64_t j = 0; j < static_cast<int64_t>(k); ++j, ++at) {
        if (!is_index(v[at]))
          return fail(ErrorCode::Parse, index_range_error("CELLS", at, v[at]));
        g_.conn.push_back(static_cast<int64_t>(v[at]));
      }
      g_.offsets[static_cast<size_t>(c) + 1] = static_cast<int64_t>(g_.conn.size());
    }
    if (at != v.size())
      return fail(ErrorCode::Parse, "CELLS size " + std::to_string(size) + " does not match the cells' point counts");
    ncells = n;
    return Status::success();
  }

  Status read_attribute(const std::string& kw, int64_t n, std::vector<Array>& target) {
    Array a;
    if (Status s = name_token(a.name, "an array name"); !s) return s;
    int comps = 1;
    NumType t;
    if (kw == "COLOR_SCALARS") {
      int64_t k = 0;
      if (Status s = count(k, "the number of color components"); !s) return s;
      comps = static_cast<int>(std::clamp<int64_t>(k, 1, 4));
      t = binary_ ? NumType{1, true, false, false} : NumType{4, false, true, true};
    } else if (kw == "TEXTURE_COORDINATES") {
      int64_t k = 0;
      if (Status s = count(k, "the texture dimension"); !s) return s;
      comps = static_cast<int>(std::clamp<int64_t>(k, 1, 3));
      t = legacy_type(c_.token());
    } else {
      const std::string_view tt = c_.token();
      t = legacy_type(tt);
      if (t.bytes == 0) return fail(ErrorCode::Unsupported, "data type '" + shorten(tt) + "' of " + a.name);
      comps = kw == "TENSORS" ? 9 : (kw == "SCALARS" ? 1 : 3);
      if (kw == "SCALARS") {
        // optional component count, then LOOKUP_TABLE name (optional in practice)
        int64_t k = 0;
        Cursor save = c_;
        const std::string_view maybe = c_.token();
        if (gvscan::parse_int(maybe, k)) {
          if (k < 1 || k > 4) return fail(ErrorCode::Parse, "SCALARS component count must be 1..4");
          comps = static_cast<int>(k);
        } else {
          c_ = save;
        }
        save = c_;
        if (upper(c_.token()) == "LOOKUP_TABLE") c_.token();
        else c_ = save;
      }
    }
    if (t.bytes == 0) return fail(ErrorCode::Unsupported, "unknown data type for " + a.name);
    a.components = comps;
    a.integer = t.integer;
    int64_t total = 0;
    if (Status s = product(n, comps, total, kw + " " + a.name); !s) return s;
    if (Status s = values(total, t, a.values, kw + " " + a.name); !s) return s;
    target.push_back(std::move(a));
    return Status::success();
  }

  Status read_field(std::vector<Array>* target, int64_t target_n) {
    c_.token();  // field name
    int64_t narr = 0;
    if (Status s = count(narr, "the number of field arrays"); !s) return s;
    if (static_cast<uint64_t>(narr) > c_.remaining() / 8) return fail(ErrorCode::Parse, "absurd FIELD array count");
    for (int64_t i = 0; i < narr; ++i) {
      Array a;
      if (Status s = name_token(a.name, "a field array name"); !s) return s;
      int64_t comps = 0, tuples = 0;
      if (Status s = count(comps, "the number of components"); !s) return s;
      if (Status s = count(tuples, "the number of tuples"); !s) return s;
      const std::string_view tt = c_.token();
      const NumType t = legacy_type(tt);
      if (t.bytes == 0) return fail(ErrorCode::Unsupported, "data type '" + shorten(tt) + "' of field array " + a.name);
      if (comps < 1 || comps > 1024) return fail(ErrorCode::Parse, "bad component count for field array " + a.name);
      a.components = static_cast<int>(comps);
      a.integer = t.integer;
      int64_t total = 0;
      if (Status s = product(comps, tuples, total, "field array " + a.name); !s) return s;
      if (Status s = values(total, t, a.values, "field array " + a.name); !s) return s;
      // Field arrays of a data section with one tuple per entity are kept;
      // others are field data of some other kind and are skipped, unless a
      // cell array is named as a ref: skipping that one would write every
      // ref back as 0.
      if (target && tuples != target_n && target == &g_.cell_data && a.components == 1 && is_ref_name(a.name))
        return fail(ErrorCode::Parse, "cell field array " + a.name + " has " + std::to_string(tuples) + " values for " +
                                          std::to_string(target_n) + " cells");
      if (target && tuples == target_n) target->push_back(std::move(a));
      if (upper(c_.peek()) == "METADATA") {
        c_.token();
        if (Status s = skip_metadata(); !s) return s;
      }
    }
    return Status::success();
  }

  /// METADATA blocks (VTK 5.x) end at an empty line.
  Status skip_metadata() {
    c_.rest_of_line();
    while (!c_.eof()) {
      const std::string_view l = c_.rest_of_line();
      if (l.find_first_not_of(" \t") == std::string_view::npos) return Status::success();
    }
    return Status::success();
  }
};

// ---- legacy writer ----

std::string safe_name(const std::string& n) {
  std::string s = n.empty() ? std::string("field") : n;
  for (char& ch : s)
    if (gvscan::is_space(ch)) ch = '_';
  return s;
}

template <class Fn>
void for_each_cell(const TetMesh& m, Format f, Fn fn) {
  int32_t v[4];
  for (int32_t t = 0; t < m.nt(); ++t) {
    detail::file_tet(m, t, f, v);
    fn(10, v, 4, t < static_cast<int32_t>(m.tet_ref.size()) ? m.tet_ref[static_cast<size_t>(t)] : 0);
  }
  for (int32_t i = 0; i < m.ntri(); ++i)
    fn(5, &m.tris[3 * static_cast<size_t>(i)], 3,
       static_cast<size_t>(i) < m.tri_ref.size() ? m.tri_ref[static_cast<size_t>(i)] : 0);
  for (size_t i = 0; i < m.edges.size() / 2; ++i) fn(3, &m.edges[2 * i], 2, i < m.edge_ref.size() ? m.edge_ref[i] : 0);
  for (size_t i = 0; i < m.corners.size(); ++i) fn(1, &m.corners[i], 1, 0);
}

}  // namespace

Status parse_vtk(std::string_view data, const std::string& name, TetMesh& m) {
  m = TetMesh{};
  LegacyReader r(data, name);
  Status s = r.run(m);
  if (!s) m = TetMesh{};
  return s;
}

Status format_vtk(const TetMesh& m, std::string& out, bool binary) {
  out.clear();
  if (m.nt() == 0) return Status::error(ErrorCode::InvalidMesh, "the mesh has no tetrahedra to write");
  const int32_t nv = m.nv();
  const int64_t ncells = static_cast<int64_t>(m.nt()) + m.ntri() + static_cast<int64_t>(m.edges.size() / 2) +
                         static_cast<int64_t>(m.corners.size());
  const int64_t size = 5LL * m.nt() + 4LL * m.ntri() + 3LL * static_cast<int64_t>(m.edges.size() / 2) +
                       2LL * static_cast<int64_t>(m.corners.size());
  out += "# vtk DataFile Version 3.0\ntetopt mesh\n";
  out += binary ? "BINARY\n" : "ASCII\n";
  out += "DATASET UNSTRUCTURED_GRID\nPOINTS ";
  gvscan::put_int(out, nv);
  out += " double\n";
  for (int32_t v = 0; v < nv; ++v) {
    const double* p = m.point(v);
    if (binary) {
      for (int k = 0; k < 3; ++k) gvscan::store<double>(out, p[k], true);
    } else {
      gvscan::put_double(out, p[0]);
      out += ' ';
      gvscan::put_double(out, p[1]);
      out += ' ';
      gvscan::put_double(out, p[2]);
      out += '\n';
    }
  }
  if (binary) out += '\n';
  out += "CELLS ";
  gvscan::put_int(out, ncells);
  out += ' ';
  gvscan::put_int(out, size);
  out += '\n';
  for_each_cell(m, Format::Vtk, [&](int, const int32_t* v, int k, int32_t) {
    if (binary) {
      gvscan::store<int32_t>(out, k, true);
      for (int j = 0; j < k; ++j) gvscan::store<int32_t>(out, v[j], true);
    } else {
      gvscan::put_int(out, k);
      for (int j = 0; j < k; ++j) {
        out += ' ';
        gvscan::put_int(out, v[j]);
      }
      out += '\n';
    }
  });
  if (binary) out += '\n';
  out += "CELL_TYPES ";
  gvscan::put_int(out, ncells);
  out += '\n';
  for_each_cell(m, Format::Vtk, [&](int type, const int32_t*, int, int32_t) {
    if (binary) {
      gvscan::store<int32_t>(out, type, true);
    } else {
      gvscan::put_int(out, type);
      out += '\n';
    }
  });
  if (binary) out += '\n';
  // The refs as a one-component FIELD array: meshio 5.0 reads SCALARS as
  // arrays of shape (n, 1), which tools that look for a 1-D integer cell
  // array (meshcheck among them) do not take as tags: a two-region mesh
  // read back from our .vtk had lost its regions and interface for them.
  out += "CELL_DATA ";
  gvscan::put_int(out, ncells);
  out += "\nFIELD FieldData 1\nref 1 ";
  gvscan::put_int(out, ncells);
  out += " int\n";
  for_each_cell(m, Format::Vtk, [&](int, const int32_t*, int, int32_t ref) {
    if (binary) {
      gvscan::store<int32_t>(out, ref, true);
    } else {
      gvscan::put_int(out, ref);
      out += '\n';
    }
  });
  if (binary) out += '\n';
  if (!m.point_fields.empty()) {
    out += "POINT_DATA ";
    gvscan::put_int(out, nv);
    out += '\n';
    for (const TetMesh::PointField& f : m.point_fields) {
      const int comps = std::max(1, f.components);
      if (f.values.size() != static_cast<size_t>(nv) * static_cast<size_t>(comps))
        return Status::error(ErrorCode::InvalidMesh, "point field " + f.name + " has " + std::to_string(f.values.size()) +
                                                         " values for " + std::to_string(nv) + " vertices");
      const char* type = f.integer ? "int" : "double";
      if (comps <= 4) {
        out += "SCALARS " + safe_name(f.name) + " " + type + " " + std::to_string(comps) + "\nLOOKUP_TABLE default\n";
      } else {
        out += "FIELD FieldData 1\n" + safe_name(f.name) + " " + std::to_string(comps) + " " + std::to_string(nv) +
               " " + type + "\n";
      }
      for (size_t i = 0; i < f.values.size(); ++i) {
        if (binary) {
          if (f.integer) gvscan::store<int32_t>(out, static_cast<int32_t>(f.values[i]), true);
          else gvscan::store<double>(out, f.values[i], true);
        } else {
          if (f.integer) gvscan::put_int(out, static_cast<int64_t>(f.values[i]));
          else gvscan::put_double(out, f.values[i]);
          out += (i + 1) % static_cast<size_t>(comps) == 0 ? '\n' : ' ';
        }
      }
      if (binary) out += '\n';
    }
  }
  return Status::success();
}

// ================================================================ VTU

using detail::ck_add;
using detail::ck_cast;
using detail::ck_mul;
namespace {

struct XmlAttr {
  std::string_view key, value;
};

// An attribute value with its references decoded (XML 1.0, sections 4.1
// and 4.6: the five predefined entities and &#N; / &#xH; as UTF-8).  The
// writer escapes names (xml_escape), so a name with '<', '&' or '"' grew on
// every .vtu round trip before.  A reference that is none of these stays as
// it is.
std::string xml_unescape(std::string_view v) {
  std::string r;
  r.reserve(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    const size_t semi = v[i] == '&' ? v.find(';', i) : std::string_view::npos;
    if (semi == std::string_view::npos || semi - i > 12) {
      r += v[i];
      continue;
    }
    const std::string_view ref = v.substr(i + 1, semi - i - 1);
    const char* named = ref == "lt" ? "<" : ref == "gt" ? ">" : ref == "amp" ? "&" : ref == "quot" ? "\"" :
                        ref == "apos" ? "'" : nullptr;
    uint32_t cp = 0;
    bool num = ref.size() > 1 && ref[0] == '#';
    if (num) {
      const bool hex = ref[1] == 'x';
      const std::string_view digits = ref.substr(hex ? 2 : 1);
      num = !digits.empty();
      for (const char ch : digits) {
        const int d = ch >= '0' && ch <= '9' ? ch - '0'
                    : hex && ch >= 'a' && ch <= 'f' ? ch - 'a' + 10
                    : hex && ch >= 'A' && ch <= 'F' ? ch - 'A' + 10 : -1;
        if (d < 0 || cp > 0x10FFFF) { num = false; break; }
        cp = cp * (hex ? 16 : 10) + static_cast<uint32_t>(d);
      }
      num = num && cp > 0 && cp <= 0x10FFFF && !(cp >= 0xD800 && cp <= 0xDFFF);
    }
    if (named) {
      r += named;
    } else if (num) {  // UTF-8 (RFC 3629)
      if (cp < 0x80) {
        r += static_cast<char>(cp);
      } else if (cp < 0x800) {
        r += static_cast<char>(0xC0 | (cp >> 6));
        r += static_cast<char>(0x80 | (cp & 0x3F));
      } else if (cp < 0x10000) {
        r += static_cast<char>(0xE0 | (cp >> 12));
        r += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        r += static_cast<char>(0x80 | (cp & 0x3F));
      } else {
        r += static_cast<char>(0xF0 | (cp >> 18));
        r += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
        r += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        r += static_cast<char>(0x80 | (cp & 0x3F));
      }
    } else {
      r.append(v.substr(i, semi - i + 1));
    }
    i = semi;
  }
  return r;
}

struct DataArrayInfo {
  std::string section;  // Points, Cells, PointData, CellData
  std::string name, type, format;
  int components = 1;
  int64_t offset = -1;
  size_t tag_pos = 0;               // for messages
  size_t content_begin = 0, content_end = 0;
};

class VtuReader {
 public:
  VtuReader(std::string_view data, const std::string& name) : s_(data), name_(name) {}

  Status run(TetMesh& m) {
    if (Status st = scan(); !st) return st;
    if (npoints_ < 0 || ncells_ < 0) return fail(ErrorCode::Parse, "no <Piece> with NumberOfPoints and NumberOfCells", 0);
    const DataArrayInfo *pts = nullptr, *conn = nullptr, *offs = nullptr, *types = nullptr;
    for (const DataArrayInfo& a : arrays_) {
      if (a.section == "Points" && !pts) pts = &a;
      if (a.section == "Cells") {
        if (a.name == "connectivity") conn = &a;
        else if (a.name == "offsets") offs = &a;
        else if (a.name == "types") types = &a;
      }
    }
    if (!pts) return fail(ErrorCode::Parse, "no <Points> DataArray", 0);
    if (!conn || !offs || !types)
      return fail(ErrorCode::Parse, "<Cells> needs DataArrays named connectivity, offsets and types", 0);
    Grid g;
    Array a;
    int64_t nxyz = 0;
    if (!ck_mul(npoints_, int64_t{3}, nxyz)) return fail(ErrorCode::Parse, "NumberOfPoints overflows", pts->tag_pos);
    if (Status st = decode(*pts, nxyz, a); !st) return st;
    if (pts->components != 3) return fail(ErrorCode::Parse, "Points must have 3 components", pts->tag_pos);
    g.xyz = std::move(a.values);
    if (Status st = decode(*offs, ncells_, a); !st) return st;
    std::vector<int64_t> idx;
    if (size_t bad = 0; !to_indices(a.values, idx, &bad))
      return fail(ErrorCode::Parse, index_range_error("offsets", bad, a.values[bad]), offs->tag_pos);
    g.offsets.reserve(idx.size() + 1);
    g.offsets.push_back(0);
    g.offsets.insert(g.offsets.end(), idx.begin(), idx.end());
    if (Status st = decode(*types, ncells_, a); !st) return st;
    if (size_t bad = 0; !to_indices(a.values, g.types, &bad))
      return fail(ErrorCode::Parse, index_range_error("types", bad, a.values[bad]), types->tag_pos);
    const int64_t nconn = g.offsets.back();
    if (nconn < 0 || static_cast<uint64_t>(nconn) > s_.size())
      return fail(ErrorCode::Parse, "the last cell offset " + std::to_string(nconn) + " is absurd", offs->tag_pos);
    if (Status st = decode(*conn, nconn, a); !st) return st;
    if (size_t bad = 0; !to_indices(a.values, g.conn, &bad))
      return fail(ErrorCode::Parse, index_range_error("connectivity", bad, a.values[bad]), conn->tag_pos);
    for (const DataArrayInfo& d : arrays_) {
      if (d.section != "CellData" && d.section != "PointData") continue;
      int64_t n = 0;
      if (!ck_mul(d.section == "CellData" ? ncells_ : npoints_, int64_t{d.components}, n))
        return fail(ErrorCode::Parse, "DataArray " + array_label(d.name) + ": the value count overflows", d.tag_pos);
      Array x;
      if (Status st = decode(d, n, x); !st) return st;
      (d.section == "CellData" ? g.cell_data : g.point_data).push_back(std::move(x));
    }
    return build_mesh(g, name_, m);
  }

 private:
  std::string_view s_;
  const std::string& name_;
  bool big_ = false;
  int header_bytes_ = 4;
  bool compressed_ = false;
  int64_t npoints_ = -1, ncells_ = -1;
  std::vector<DataArrayInfo> arrays_;
  size_t appended_ = std::string_view::npos;  // first byte after '_'
  size_t appended_end_ = std::string_view::npos;
  bool appended_base64_ = false;

  long line_at(size_t pos) const {
    return 1 + static_cast<long>(std::count(s_.begin(), s_.begin() + static_cast<std::ptrdiff_t>(std::min(pos, s_.size())), '\n'));
  }
  Status fail(ErrorCode code, const std::string& what, size_t pos) const {
    const long l = line_at(pos);
    return Status::error(code, name_ + ":" + std::to_string(l) + ": " + what, l);
  }

  static bool parse_tag(std::string_view s, size_t& pos, std::string_view& tname, std::vector<XmlAttr>& attrs,
                        bool& closing, bool& self_closing) {
    // s[pos] == '<'
    size_t p = pos + 1;
    closing = p < s.size() && s[p] == '/';
    if (closing) ++p;
    const size_t nb = p;
    while (p < s.size() && !gvscan::is_space(s[p]) && s[p] != '>' && s[p] != '/') ++p;
    tname = s.substr(nb, p - nb);
    attrs.clear();
    self_closing = false;
    for (;;) {
      while (p < s.size() && gvscan::is_space(s[p])) ++p;
      if (p >= s.size()) return false;
      if (s[p] == '>') {
        pos = p + 1;
        return true;
      }
      if (s[p] == '/' && p + 1 < s.size() && s[p + 1] == '>') {
        self_closing = true;
        pos = p + 2;
        return true;
      }
      const size_t kb = p;
      while (p < s.size() && s[p] != '=' && !gvscan::is_space(s[p]) && s[p] != '>') ++p;
      const std::string_view key = s.substr(kb, p - kb);
      while (p < s.size() && gvscan::is_space(s[p])) ++p;
      if (p >= s.size() || s[p] != '=') return false;
      ++p;
      while (p < s.size() && gvscan::is_space(s[p])) ++p;
      if (p >= s.size() || (s[p] != '"' && s[p] != '\'')) return false;
      const char q = s[p++];
      const size_t vb = p;
      while (p < s.size() && s[p] != q) ++p;
      if (p >= s.size()) return false;
      attrs.push_back({key, s.substr(vb, p - vb)});
      ++p;
    }
  }
  static std::string_view attr(const std::vector<XmlAttr>& a, std::string_view k) {
    for (const XmlAttr& x : a)
      if (x.key == k) return x.value;
    return {};
  }

  Status scan() {
    size_t pos = 0;
    std::vector<std::string> stack;
    bool saw_vtkfile = false;
    int pieces = 0;
    std::string_view tname;
    std::vector<XmlAttr> attrs;
    while (true) {
      const size_t lt = s_.find('<', pos);
      if (lt == std::string_view::npos) break;
      if (s_.compare(lt, 4, "<!--") == 0) {
        const size_t e = s_.find("-->", lt + 4);
        if (e == std::string_view::npos) return fail(ErrorCode::Parse, "unterminated XML comment", lt);
        pos = e + 3;
        continue;
      }
      if (s_.compare(lt, 2, "<?") == 0 || s_.compare(lt, 2, "<!") == 0) {
        const size_t e = s_.find('>', lt);
        if (e == std::string_view::npos) return fail(ErrorCode::Parse, "unterminated XML declaration", lt);
        pos = e + 1;
        continue;
      }
      bool closing = false, self = false;
      pos = lt;
      if (!parse_tag(s_, pos, tname, attrs, closing, self)) return fail(ErrorCode::Parse, "malformed XML tag", lt);
      if (closing) {
        if (stack.empty() || stack.back() != tname)
          return fail(ErrorCode::Parse, "unexpected closing tag </" + shorten(tname) + ">", lt);
        stack.pop_back();
        continue;
      }
      if (tname == "VTKFile") {
        saw_vtkfile = true;
        if (attr(attrs, "type") != "UnstructuredGrid")
          return fail(ErrorCode::Unsupported,
                      "VTKFile type '" + shorten(attr(attrs, "type")) + "' is not supported (only UnstructuredGrid)", lt);
        big_ = attr(attrs, "byte_order") == "BigEndian";
        const std::string_view ht = attr(attrs, "header_type");
        header_bytes_ = ht == "UInt64" ? 8 : 4;
        if (!ht.empty() && ht != "UInt64" && ht != "UInt32")
          return fail(ErrorCode::Unsupported, "header_type " + shorten(ht), lt);
        const std::string_view comp = attr(attrs, "compressor");
        if (!comp.empty()) {
          if (comp != "vtkZLibDataCompressor")
            return fail(ErrorCode::Unsupported, "compressor " + shorten(comp) + " (only vtkZLibDataCompressor)", lt);
          compressed_ = true;
        }
      } else if (!saw_vtkfile) {
        return fail(ErrorCode::Parse, "not a VTK XML file (no <VTKFile> element)", lt);
      } else if (tname == "Piece") {
        if (++pieces > 1) return fail(ErrorCode::Unsupported, "more than one <Piece>", lt);
        int64_t np = 0, nc = 0;
        if (!gvscan::parse_int(attr(attrs, "NumberOfPoints"), np) || !gvscan::parse_int(attr(attrs, "NumberOfCells"), nc) ||
            np < 0 || nc < 0)
          return fail(ErrorCode::Parse,
                      "<Piece> needs NumberOfPoints and NumberOfCells, whole numbers from 0 on (found '" +
                          shorten(attr(attrs, "NumberOfPoints")) + "' and '" + shorten(attr(attrs, "NumberOfCells")) + "')",
                      lt);
        if (static_cast<uint64_t>(np) > s_.size() || static_cast<uint64_t>(nc) > s_.size())
          return fail(ErrorCode::Parse, "NumberOfPoints / NumberOfCells exceed what the file can hold", lt);
        npoints_ = np;
        ncells_ = nc;
      } else if (tname == "DataArray") {
        DataArrayInfo d;
        d.section = stack.empty() ? std::string() : stack.back();
        // Copies of attribute values are bounded (issue 25: no unbounded
        // token copies): a name up to kMaxNameBytes, the type and format
        // words up to 64 bytes (longer ones match no known word anyway).
        const std::string_view nm = attr(attrs, "Name");
        if (nm.size() > kMaxNameBytes)
          return fail(ErrorCode::Parse, "DataArray Name of " + std::to_string(nm.size()) + " bytes (more than " +
                                            std::to_string(kMaxNameBytes) + ")", lt);
        d.name = xml_unescape(nm);
        d.type = std::string(attr(attrs, "type").substr(0, 64));
        d.format = std::string(attr(attrs, "format").substr(0, 64));
        d.tag_pos = lt;
        if (const std::string_view nc = attr(attrs, "NumberOfComponents"); !nc.empty()) {
          int64_t k = 0;
          if (!gvscan::parse_int(nc, k) || k < 1 || k > 1024)
            return fail(ErrorCode::Parse, "bad NumberOfComponents", lt);
          d.components = static_cast<int>(k);
        }
        if (const std::string_view off = attr(attrs, "offset"); !off.empty())
          if (!gvscan::parse_int(off, d.offset) || d.offset < 0) return fail(ErrorCode::Parse, "bad offset", lt);
        d.content_begin = d.content_end = pos;
        if (!self) {
          const size_t e = s_.find("</DataArray>", pos);
          if (e == std::string_view::npos) return fail(ErrorCode::Parse, "DataArray without </DataArray>", lt);
          d.content_end = e;
          pos = e + 12;
          // Skip nested elements (VTK 9 puts <InformationKey> before the values).
          const size_t gt = s_.substr(0, e).rfind('>');
          if (gt != std::string_view::npos && gt >= d.content_begin) d.content_begin = gt + 1;
        }
        if (d.section == "Points" || d.section == "Cells" || d.section == "PointData" || d.section == "CellData")
          arrays_.push_back(std::move(d));
      } else if (tname == "AppendedData") {
        appended_base64_ = attr(attrs, "encoding") == "base64";
        const size_t us = s_.find('_', pos);
        if (us == std::string_view::npos) return fail(ErrorCode::Parse, "AppendedData without '_'", lt);
        appended_ = us + 1;
        const size_t e = s_.rfind("</AppendedData>");
        appended_end_ = (e == std::string_view::npos || e < appended_) ? s_.size() : e;
        return Status::success();  // raw bytes follow: stop scanning XML here
      }
      if (!self && tname != "DataArray") {
        // VTK's element names are short; a huge one is not copied.
        if (tname.size() > 256)
          return fail(ErrorCode::Parse, "XML element name of " + std::to_string(tname.size()) + " bytes", lt);
        stack.emplace_back(tname);
      }
    }
    if (!saw_vtkfile) return fail(ErrorCode::Parse, "not a VTK XML file (no <VTKFile> element)", 0);
    if (!stack.empty()) return fail(ErrorCode::Parse, "missing </" + stack.back() + "> (truncated file?)", s_.size());
    return Status::success();
  }

  /// Reads a binary header word.
  uint64_t header_word(const char* p) const {
    return header_bytes_ == 8 ? gvscan::load<uint64_t>(p, big_) : gvscan::load<uint32_t>(p, big_);
  }

  /// Decodes one header+data payload (p, n bytes available) into raw bytes;
  /// `count` values of `vbytes` bytes each are expected.  A compressed
  /// payload whose header promises another size is refused before anything
  /// is inflated (a small file of zlib blocks of zeros could otherwise take
  /// gigabytes only to be refused after).
  Status payload(const DataArrayInfo& d, const char* p, size_t n, int64_t count, size_t vbytes,
                 std::string& raw) const {
    const size_t hb = static_cast<size_t>(header_bytes_);
    auto wrong_size = [&](uint64_t bytes) {
      return bytes % vbytes != 0 || bytes / vbytes != static_cast<uint64_t>(count);
    };
    auto size_error = [&](uint64_t bytes) {
      return fail(ErrorCode::Parse, "DataArray " + array_label(d.name) + " holds " + std::to_string(bytes / vbytes) +
                                        " values instead of " + std::to_string(count), d.tag_pos);
    };
    if (!compressed_) {
      if (n < hb) return fail(ErrorCode::Parse, "truncated binary header of " + array_label(d.name), d.tag_pos);
      const uint64_t len = header_word(p);
      if (len > n - hb)
        return fail(ErrorCode::Parse, "binary array " + array_label(d.name) + " claims " + std::to_string(len) + " bytes but " +
                                          std::to_string(n - hb) + " remain (truncated file?)", d.tag_pos);
      if (wrong_size(len)) return size_error(len);
      raw.assign(p + hb, static_cast<size_t>(len));
      return Status::success();
    }
#ifdef TETOPT_VTK_ZLIB
    // VTK's compressed layout: [nb][bs][last][cs_0 .. cs_{nb-1}] then the
    // nb zlib streams; every block inflates to bs bytes but the last, which
    // inflates to `last` (0 meaning a full block).  All arithmetic on these
    // header words is checked (checked.hpp): a wrapped total once sized the
    // buffer at 192 bytes while zlib was allowed 2^63 (issue 25).
    if (n < 3 * hb) return fail(ErrorCode::Parse, "truncated compression header of " + array_label(d.name), d.tag_pos);
    const uint64_t nb = header_word(p), bs = header_word(p + hb), last = header_word(p + 2 * hb);
    if (nb > (n - 3 * hb) / hb) return fail(ErrorCode::Parse, "absurd block count in " + array_label(d.name), d.tag_pos);
    auto bad_header = [&](const std::string& what) {
      return fail(ErrorCode::Parse, what + " in the compression header of " + array_label(d.name), d.tag_pos);
    };
    if (nb > 0 && bs == 0) return bad_header("block size 0");
    if (last > bs) return bad_header("last block (" + std::to_string(last) + " bytes) larger than the block size (" +
                                     std::to_string(bs) + ")");
    size_t at = (3 + static_cast<size_t>(nb)) * hb;  // nb <= n / hb: no overflow
    uint64_t total_c = 0;
    for (uint64_t b = 0; b < nb; ++b)
      if (!ck_add(total_c, header_word(p + (3 + b) * hb), total_c)) return bad_header("compressed sizes that overflow");
    if (total_c > n - at) return fail(ErrorCode::Parse, "truncated compressed data of " + array_label(d.name), d.tag_pos);
    uint64_t total = 0;
    if (nb > 0 && (!ck_mul(nb - 1, bs, total) || !ck_add(total, last == 0 ? bs : last, total)))
      return bad_header("an uncompressed size that overflows");
    // zlib cannot expand more than about 1032:1; a larger claim is a lie.
    uint64_t most = 0;
    if (!ck_mul(uint64_t{1100}, total_c + 64, most) || total > most)
      return fail(ErrorCode::Parse, "absurd uncompressed size in " + array_label(d.name), d.tag_pos);
    // The header's counts bound the size too: count values of vbytes bytes.
    if (wrong_size(total)) return size_error(total);
    size_t total_sz = 0;
    if (!ck_cast(total, total_sz)) return bad_header("an uncompressed size beyond memory");
    raw.resize(total_sz);
    size_t out_at = 0;
    for (uint64_t b = 0; b < nb; ++b) {
      const uint64_t cs = header_word(p + (3 + b) * hb);  // sum checked above: fits in n
      const uint64_t expect = b + 1 == nb ? total - out_at : bs;
      // zlib gets the true capacity left in raw, never the header's word.
      uLongf cap = static_cast<uLongf>(raw.size() - out_at);
      if (expect > cap) return bad_header("blocks that overrun the uncompressed size");
      if (uncompress(reinterpret_cast<Bytef*>(raw.data() + out_at), &cap, reinterpret_cast<const Bytef*>(p + at),
                     static_cast<uLong>(cs)) != Z_OK ||
          cap != expect)
        return fail(ErrorCode::Parse, "corrupt zlib block " + std::to_string(b) + " in " + array_label(d.name), d.tag_pos);
      at += static_cast<size_t>(cs);
      out_at += static_cast<size_t>(cap);
    }
    return Status::success();
#else
    (void)p;
    (void)n;
    (void)count;
    (void)vbytes;
    (void)raw;
    return fail(ErrorCode::Unsupported, "zlib-compressed VTU (tetopt was built without zlib)", d.tag_pos);
#endif
  }

  Status decode(const DataArrayInfo& d, int64_t count, Array& a) const {
    a = Array{};
    a.name = d.name;
    a.components = d.components;
    const NumType t = xml_type(d.type);
    if (t.bytes == 0) return fail(ErrorCode::Unsupported, "DataArray type '" + shorten(d.type) + "'", d.tag_pos);
    a.integer = t.integer;
    if (count < 0) return fail(ErrorCode::Parse, "negative count", d.tag_pos);
    if (d.format == "ascii") {
      Cursor c;
      c.s = s_.substr(0, d.content_end);
      c.pos = d.content_begin;
      c.line = line_at(d.content_begin);
      if (static_cast<uint64_t>(count) > (d.content_end - d.content_begin) / 2 + 1)
        return fail(ErrorCode::Parse, "DataArray " + array_label(d.name) + " holds fewer than the " + std::to_string(count) +
                                          " values it needs", d.tag_pos);
      a.values.resize(static_cast<size_t>(count));
      for (size_t i = 0; i < a.values.size(); ++i) {
        const std::string_view tok = c.token();
        bool ok;
        if (t.integer) {
          int64_t v = 0;
          ok = gvscan::parse_int(tok, v);
          a.values[i] = static_cast<double>(v);
        } else {
          ok = t.is_float32 ? gvscan::parse_float32(tok, a.values[i]) : gvscan::parse_double(tok, a.values[i]);
        }
        if (!ok) {
          const std::string what = tok.empty() ? "DataArray " + array_label(d.name) + " ends after " + std::to_string(i) + " of " +
                                                     std::to_string(count) + " values"
                                               : "bad value '" + shorten(tok) + "' in DataArray " + array_label(d.name);
          return Status::error(ErrorCode::Parse, name_ + ":" + std::to_string(c.line) + ": " + what, c.line);
        }
      }
      if (!c.token().empty())
        return fail(ErrorCode::Parse, "DataArray " + array_label(d.name) + " holds more than the " + std::to_string(count) +
                                          " values it should", d.tag_pos);
      return Status::success();
    }
    std::string raw;
    if (d.format == "binary") {
      std::string bytes;
      if (!gvscan::base64_decode(s_.substr(d.content_begin, d.content_end - d.content_begin), bytes))
        return fail(ErrorCode::Parse, "bad base64 in DataArray " + array_label(d.name), d.tag_pos);
      if (Status st = payload(d, bytes.data(), bytes.size(), count, static_cast<size_t>(t.bytes), raw); !st) return st;
    } else if (d.format == "appended") {
      if (appended_ == std::string_view::npos || d.offset < 0)
        return fail(ErrorCode::Parse, "appended DataArray " + array_label(d.name) + " without AppendedData or offset", d.tag_pos);
      size_t start = 0;
      if (!ck_add(appended_, d.offset, start) || start > appended_end_)
        return fail(ErrorCode::Parse, "offset of DataArray " + array_label(d.name) + " is past the appended data", d.tag_pos);
      if (appended_base64_) {
        size_t stop = appended_end_;
        for (const DataArrayInfo& o : arrays_)
          if (size_t o_start = 0; o.format == "appended" && o.offset > d.offset && ck_add(appended_, o.offset, o_start))
            stop = std::min(stop, o_start);
        std::string bytes;
        if (!gvscan::base64_decode(s_.substr(start, stop - start), bytes))
          return fail(ErrorCode::Parse, "bad base64 in appended DataArray " + array_label(d.name), d.tag_pos);
        if (Status st = payload(d, bytes.data(), bytes.size(), count, static_cast<size_t>(t.bytes), raw); !st) return st;
      } else {
        if (Status st = payload(d, s_.data() + start, appended_end_ - start, count, static_cast<size_t>(t.bytes), raw); !st) return st;
      }
    } else {
      return fail(ErrorCode::Unsupported, "DataArray format '" + shorten(d.format) + "'", d.tag_pos);
    }
    const size_t bytes = static_cast<size_t>(t.bytes);  // raw holds count values (payload checked)
    a.values.resize(static_cast<size_t>(count));
    for (size_t i = 0; i < a.values.size(); ++i) a.values[i] = binary_value(raw.data() + i * bytes, t, big_);
    return Status::success();
  }
};

class VtuWriter {
 public:
  VtuWriter(std::string& out, bool binary) : out_(out), binary_(binary) {}

  template <class T>
  void array(const char* type, const std::string& name, int comps, size_t n, T get) {
    out_ += "        <DataArray type=\"";
    out_ += type;
    out_ += "\" Name=\"" + name + "\"";
    if (comps != 1) out_ += " NumberOfComponents=\"" + std::to_string(comps) + "\"";
    out_ += binary_ ? " format=\"binary\">\n" : " format=\"ascii\">\n";
    using V = decltype(get(size_t{0}));
    if (binary_) {
      std::string raw;
      raw.reserve(n * sizeof(V));
      for (size_t i = 0; i < n; ++i) gvscan::store<V>(raw, get(i), false);
      std::string head;
      gvscan::store<uint64_t>(head, raw.size(), false);
      // Header and data as separate base64 runs, the way VTK writes them.
      gvscan::base64_encode(out_, reinterpret_cast<const unsigned char*>(head.data()), head.size());
      gvscan::base64_encode(out_, reinterpret_cast<const unsigned char*>(raw.data()), raw.size());
      out_ += '\n';
    } else {
      for (size_t i = 0; i < n; ++i) {
        const V v = get(i);
        if constexpr (std::is_floating_point_v<V>) gvscan::put_double(out_, v);
        else gvscan::put_int(out_, static_cast<int64_t>(v));
        out_ += (i + 1) % static_cast<size_t>(comps) == 0 ? '\n' : ' ';
      }
    }
    out_ += "        </DataArray>\n";
  }

 private:
  std::string& out_;
  bool binary_;
};

std::string xml_escape(const std::string& s) {
  std::string r;
  for (char ch : s) {
    if (ch == '"') r += "&quot;";
    else if (ch == '&') r += "&amp;";
    else if (ch == '<') r += "&lt;";
    else if (ch == '>') r += "&gt;";
    else r += ch;
  }
  return r;
}

}  // namespace

Status parse_vtu(std::string_view data, const std::string& name, TetMesh& m) {
  m = TetMesh{};
  VtuReader r(data, name);
  Status s = r.run(m);
  if (!s) m = TetMesh{};
  return s;
}

namespace detail {

Status format_vtu_encoded(const TetMesh& m, std::string& out, bool binary) {
  out.clear();
  if (m.nt() == 0) return Status::error(ErrorCode::InvalidMesh, "the mesh has no tetrahedra to write");
  const int32_t nv = m.nv();
  for (const TetMesh::PointField& f : m.point_fields)
    if (f.values.size() != static_cast<size_t>(nv) * static_cast<size_t>(std::max(1, f.components)))
      return Status::error(ErrorCode::InvalidMesh, "point field " + f.name + " has " + std::to_string(f.values.size()) +
                                                       " values for " + std::to_string(nv) + " vertices");
  // Flatten cells once (tets, triangles, edges, vertices).
  std::vector<int32_t> conn, refs;
  std::vector<int64_t> offsets;
  std::vector<uint8_t> types;
  const size_t ncells = static_cast<size_t>(m.nt()) + static_cast<size_t>(m.ntri()) + m.edges.size() / 2 + m.corners.size();
  conn.reserve(4 * static_cast<size_t>(m.nt()) + m.tris.size() + m.edges.size() + m.corners.size());
  offsets.reserve(ncells);
  types.reserve(ncells);
  refs.reserve(ncells);
  for_each_cell(m, Format::Vtu, [&](int type, const int32_t* v, int k, int32_t ref) {
    conn.insert(conn.end(), v, v + k);
    offsets.push_back(static_cast<int64_t>(conn.size()));
    types.push_back(static_cast<uint8_t>(type));
    refs.push_back(ref);
  });
  out += "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
         "  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"";
  out += std::to_string(nv) + "\" NumberOfCells=\"" + std::to_string(ncells) + "\">\n";
  VtuWriter w(out, binary);
  if (!m.point_fields.empty()) {
    out += "      <PointData>\n";
    for (const TetMesh::PointField& f : m.point_fields) {
      const int comps = std::max(1, f.components);
      const std::string nm = xml_escape(f.name);
      if (f.integer)
        w.array("Int32", nm, comps, f.values.size(), [&](size_t i) { return static_cast<int32_t>(f.values[i]); });
      else
        w.array("Float64", nm, comps, f.values.size(), [&](size_t i) { return f.values[i]; });
    }
    out += "      </PointData>\n";
  }
  out += "      <CellData>\n";
  w.array("Int32", "ref", 1, refs.size(), [&](size_t i) { return refs[i]; });
  out += "      </CellData>\n      <Points>\n";
  w.array("Float64", "Points", 3, m.xyz.size(), [&](size_t i) { return m.xyz[i]; });
  out += "      </Points>\n      <Cells>\n";
  w.array("Int32", "connectivity", 1, conn.size(), [&](size_t i) { return conn[i]; });
  w.array("Int64", "offsets", 1, offsets.size(), [&](size_t i) { return offsets[i]; });
  w.array("UInt8", "types", 1, types.size(), [&](size_t i) { return types[i]; });
  out += "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
  return Status::success();
}

}  // namespace detail

Status format_vtu(const TetMesh& m, std::string& out) { return detail::format_vtu_encoded(m, out, true); }

}  // namespace tetopt
