// ANSYS Fluent mesh (.msh) reader and writer, ASCII and binary.
//
// Written from the Fluent User's Guide, Appendix B "Case and Data File
// Formats" (Fluent 6.3: sections B.1 "Guidelines", B.2 "Formatting
// Conventions in Binary and Formatted Files", B.3 "Grid Sections": B.3.1
// Comment (0), B.3.2 Header (1), B.3.3 Dimensions (2), B.3.4 Nodes (10),
// B.3.5 Periodic Shadow Faces (18), B.3.6 Cells (12), B.3.7 Faces (13);
// B.4.1 "Zone" (39 / 45); the same text is in the ANSYS Fluent User's Guide
// 2024 R2, Appendix B).  What it says and this code relies on:
//   - every section is "(index ...)" with a decimal index; grid section
//     headers and ASCII bodies give integers in hexadecimal, coordinates in
//     decimal; zone ids in a zone section (39/45) are decimal;
//   - binary sections carry the index 20xx (single precision) or 30xx
//     (double precision): "(3010 (header)(" raw data ")End of Binary
//     Section 3010)"; integers are 32-bit;
//   - a header with zone-id 0 declares a total (nodes, cells, faces) and
//     has no body; node sections (10 (zone first last type ND)(x y z ...));
//     cell sections (12 (zone first last type element-type)), with a body
//     only for element-type 0 (mixed: one element type per cell);
//     element-type 2 is the tetrahedron; face sections (13 (zone first last
//     bc-type face-type)(...)), each face "n0 n1 n2 c0 c1" (face-type 3,
//     triangular) or "x n0 .. c0 c1" (face-type 0, mixed), node and cell
//     indices 1-based, c1 = 0 on the boundary;
//   - the right-hand normal of n0 n1 n2 points toward c0 (checked on the
//     files Debian OpenFOAM v1912's foamMeshToFluent writes: 3114 of 3114
//     faces, and fluent3DMeshToFoam + checkMesh accept what this writer
//     writes, tests/scripts/test_fluent.sh);
//   - zone sections (39 (id type name [domain])(conditions)) give a zone's
//     type (wall, velocity-inlet, pressure-outlet, interior, fluid, solid,
//     ...) and name.
// A .msh is a Gmsh file when it starts with "$MeshFormat", a Fluent file
// when it starts with '(' (read_mesh looks; io.cpp).
//
// What tetopt keeps: every cell must be a tet (element-type 2, or mixed
// with only 2s) and every face a triangle.  Face zones become listed
// triangles with tri_ref = zone id, in file order, each with the file's
// vertex order: every face of a zone whose type is not `interior`, and the
// faces of an interior zone that separate two cell zones (they are
// constrained anyway); the faces of an interior zone inside one cell zone
// are not listed (listing them would freeze them).  Cell zones give
// tet_ref = zone id.  Zone names are physical names (dim 2 for face zones,
// 3 for cell zones), zone types go to the attachment (fluent_type).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "io/checked.hpp"
#include "io/common.hpp"
#include "io/face_cells.hpp"
#include "tetopt/io.hpp"

namespace tetopt {

namespace {

constexpr int64_t kMaxId = std::numeric_limits<int32_t>::max();

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }

std::string shown_tok(std::string_view t) { return detail::shown_token(t, true); }

/// Face zone bc-type codes of the face section header (Fluent UG B.3.7) and
/// the zone types they stand for, for files without a zone section and for
/// the writer.
struct BcCode {
  int code;
  const char* type;
};
constexpr BcCode kBcCodes[] = {{2, "interior"},         {3, "wall"},           {4, "pressure-inlet"},
                               {5, "pressure-outlet"},  {7, "symmetry"},       {8, "periodic-shadow"},
                               {9, "pressure-far-field"}, {10, "velocity-inlet"}, {12, "periodic"},
                               {14, "fan"},             {20, "mass-flow-inlet"}, {24, "interface"},
                               {31, "parent"},          {36, "outflow"},       {37, "axis"}};
const char* type_of_code(int c) {
  for (const BcCode& b : kBcCodes)
    if (b.code == c) return b.type;
  return nullptr;
}
int code_of_type(const std::string& t) {
  for (const BcCode& b : kBcCodes)
    if (t == b.type) return b.code;
  if (t == "inlet-vent" || t == "intake-fan") return 4;
  if (t == "outlet-vent" || t == "exhaust-fan") return 5;
  if (t == "porous-jump" || t == "radiator") return 14;
  return 3;  // any other boundary: a wall
}

class Reader {
 public:
  Reader(std::string_view d, std::string name) : d_(d), name_(std::move(name)) {}

  Status run(TetMesh& m);

 private:
  Status fail(const std::string& what, size_t at = std::string::npos) const {
    if (at == std::string::npos) at = pos_;
    at = std::min(at, d_.size());
    const long line = 1 + static_cast<long>(std::count(d_.begin(), d_.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    return Status::error(ErrorCode::Parse, name_ + ":" + std::to_string(line) + ": " + what, line);
  }
  Status unsupported(const std::string& what, size_t at = std::string::npos) const {
    Status s = fail(what, at);
    s.code = ErrorCode::Unsupported;
    return s;
  }
  void skip() {
    while (pos_ < d_.size() && is_space(d_[pos_])) ++pos_;
  }
  char peek() {
    skip();
    return pos_ < d_.size() ? d_[pos_] : '\0';
  }
  Status expect(char c, const char* where) {
    if (peek() != c) {
      if (pos_ >= d_.size()) return fail(std::string("file ends where '") + c + "' was expected " + where);
      return fail(std::string("expected '") + c + "' " + where + ", found '" + shown_tok(d_.substr(pos_, 1)) + "'");
    }
    ++pos_;
    return Status::success();
  }
  /// A token: up to a blank or a parenthesis (a quoted string whole).
  std::string_view token() {
    skip();
    const size_t b = pos_;
    if (pos_ < d_.size() && d_[pos_] == '"') {
      const size_t e = d_.find('"', pos_ + 1);
      pos_ = e == std::string_view::npos ? d_.size() : e + 1;
      return d_.substr(b, pos_ - b);
    }
    while (pos_ < d_.size() && !is_space(d_[pos_]) && d_[pos_] != '(' && d_[pos_] != ')') ++pos_;
    return d_.substr(b, pos_ - b);
  }
  Status number(int base, int64_t& v, const char* what) {
    const size_t at = (skip(), pos_);
    const std::string_view t = token();
    if (t.empty()) return pos_ >= d_.size() ? fail(std::string("file ends where ") + what + " was expected")
                                            : fail(std::string("expected ") + what + ", found '" + shown_tok(d_.substr(pos_, 1)) + "'");
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v, base);
    if (r.ec != std::errc{} || r.ptr != t.data() + t.size())
      return fail(std::string("expected ") + what + (base == 16 ? " (hexadecimal)" : "") + ", found '" + shown_tok(t) + "'", at);
    return Status::success();
  }
  /// Skips to the ')' closing the '(' just read, over nested lists and
  /// strings (text sections only).
  Status skip_balanced(size_t start) {
    int depth = 1;
    while (pos_ < d_.size()) {
      const char c = d_[pos_++];
      if (c == '"') {
        const size_t e = d_.find('"', pos_);
        if (e == std::string_view::npos) break;
        pos_ = e + 1;
      } else if (c == '(') {
        ++depth;
      } else if (c == ')' && --depth == 0) {
        return Status::success();
      }
    }
    return fail("file ends inside a section (no closing ')')", start);
  }
  /// The end of a binary section: ')' then "End of Binary Section NNNN" then ')'.
  Status end_binary(int64_t index) {
    if (Status s = expect(')', "after the binary data"); !s) return s;
    skip();
    static constexpr std::string_view kEnd = "End of Binary Section";
    if (d_.substr(pos_, kEnd.size()) == kEnd) {
      pos_ += kEnd.size();
      int64_t n = 0;
      if (Status s = number(10, n, "the section index"); !s) return s;
      if (n != index) return fail("'End of Binary Section " + std::to_string(n) + "' closes section " + std::to_string(index));
    }
    return expect(')', "at the end of a binary section");
  }
  uint32_t raw32() {
    uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(d_[pos_ + static_cast<size_t>(i)]);
    pos_ += 4;
    return v;
  }
  double raw_real(int bytes) {
    if (bytes == 8) {
      uint64_t u = 0;
      for (int i = 7; i >= 0; --i) u = (u << 8) | static_cast<unsigned char>(d_[pos_ + static_cast<size_t>(i)]);
      pos_ += 8;
      double x;
      std::memcpy(&x, &u, 8);
      return x;
    }
    const uint32_t u = raw32();
    float f;
    std::memcpy(&f, &u, 4);
    return f;
  }
  /// n items of at least `per` bytes each must fit in what is left: exactly
  /// in binary data (read raw, unchecked after this), with a byte of slack
  /// in text (the last item needs no separator; tokens are checked anyway).
  Status room(int64_t n, int64_t per, const char* what, size_t at, bool binary) {
    uint64_t need = 0;
    if (!detail::ck_mul(static_cast<uint64_t>(n), static_cast<uint64_t>(per), need) ||
        need > d_.size() - std::min(pos_, d_.size()) + (binary ? 0 : 1))
      return fail(std::string(what) + ": " + std::to_string(n) + " items are more than the file holds", at);
    return Status::success();
  }

  Status nodes(int64_t index, size_t at);
  Status cells(int64_t index, size_t at);
  Status faces(int64_t index, size_t at);
  Status zone(size_t at);

  std::string_view d_;
  std::string name_;
  size_t pos_ = 0;

  struct NodeZone {
    int64_t first, last;
    std::vector<double> xyz;
  };
  std::vector<NodeZone> node_zones_;
  struct CellZone {
    int64_t id, first, last;
  };
  std::vector<CellZone> cell_zones_;
  struct FaceZone {
    int64_t id, first, last, bc;
    size_t at;
    std::vector<int32_t> v;     // 3 per face, 0-based
    std::vector<int32_t> c;     // c0 c1 per face (1-based, 0 none)
  };
  std::vector<FaceZone> face_zones_;
  struct ZoneInfo {
    std::string type, name;
  };
  std::map<int64_t, ZoneInfo> zone_info_;
};

Status Reader::nodes(int64_t index, size_t at) {
  int64_t zid, first, last, type, nd = 3;
  if (Status s = expect('(', "before the node section header"); !s) return s;
  if (Status s = number(16, zid, "a zone id"); !s) return s;
  if (Status s = number(16, first, "the first index"); !s) return s;
  if (Status s = number(16, last, "the last index"); !s) return s;
  if (Status s = number(16, type, "the node type"); !s) return s;
  if (peek() != ')')
    if (Status s = number(16, nd, "the dimension"); !s) return s;
  if (Status s = expect(')', "after the node section header"); !s) return s;
  if (nd != 3) return unsupported("nodes of dimension " + std::to_string(nd) + " (tetopt reads 3D meshes)", at);
  if (zid == 0) return expect(')', "after a node declaration");  // declaration: the total, no body
  if (first < 1 || last < first || last > kMaxId)
    return fail("node range " + std::to_string(first) + ".." + std::to_string(last) + " (hexadecimal in the file) is not valid", at);
  const int64_t n = last - first + 1;
  const bool binary = index != 10;
  if (Status s = expect('(', "before the node coordinates"); !s) return s;
  const int bytes = index == 2010 ? 4 : 8;
  if (Status s = room(n, 3 * (binary ? bytes : 2), "nodes", at, binary); !s) return s;
  NodeZone z{first, last, {}};
  z.xyz.reserve(detail::ck_size(n, 3));
  for (int64_t i = 0; i < 3 * n; ++i) {
    double x = 0;
    if (binary) {
      x = raw_real(bytes);
    } else {
      const size_t xat = (skip(), pos_);
      const std::string_view t = token();
      std::string_view u = t;
      if (!u.empty() && u[0] == '+') u.remove_prefix(1);
      const auto r = std::from_chars(u.data(), u.data() + u.size(), x);
      if (u.empty() || r.ptr != u.data() + u.size() || r.ec != std::errc{})
        return fail("node " + std::to_string(first + i / 3) + ": expected a finite number, found '" + shown_tok(t) + "'", xat);
    }
    if (!std::isfinite(x)) return fail("node " + std::to_string(first + i / 3) + ": a coordinate that is not a finite number");
    z.xyz.push_back(x);
  }
  node_zones_.push_back(std::move(z));
  if (binary) return end_binary(index);
  if (Status s = expect(')', "after the node coordinates (more than the header's count?)"); !s) return s;
  return expect(')', "at the end of the node section");
}

Status Reader::cells(int64_t index, size_t at) {
  int64_t zid, first, last, type, et = 0;
  if (Status s = expect('(', "before the cell section header"); !s) return s;
  if (Status s = number(16, zid, "a zone id"); !s) return s;
  if (Status s = number(16, first, "the first index"); !s) return s;
  if (Status s = number(16, last, "the last index"); !s) return s;
  if (Status s = number(16, type, "the cell type"); !s) return s;
  if (peek() != ')')
    if (Status s = number(16, et, "the element type"); !s) return s;
  if (Status s = expect(')', "after the cell section header"); !s) return s;
  if (zid == 0) return expect(')', "after a cell declaration");
  if (first < 1 || last < first || last > kMaxId)
    return fail("cell range " + std::to_string(first) + ".." + std::to_string(last) + " is not valid", at);
  if (zid > kMaxId) return fail("cell zone id " + std::to_string(zid) + " out of the 32-bit range", at);
  if (et != 0 && et != 2) {
    static const char* kNames[] = {"mixed", "triangular", "tetrahedral", "quadrilateral", "hexahedral", "pyramid", "wedge", "polyhedral"};
    return unsupported("cell zone " + std::to_string(zid) + " holds " + (et >= 0 && et < 8 ? kNames[et] : "unknown") +
                       " cells (tetopt reads tetrahedra only)", at);
  }
  cell_zones_.push_back(CellZone{zid, first, last});
  if (et == 2) return expect(')', "at the end of a cell section");
  // mixed: one element type per cell, all must be 2
  const int64_t n = last - first + 1;
  const bool binary = index != 12;
  if (Status s = expect('(', "before the cell types"); !s) return s;
  if (Status s = room(n, binary ? 4 : 2, "cell types", at, binary); !s) return s;
  for (int64_t i = 0; i < n; ++i) {
    int64_t t = 0;
    if (binary) t = static_cast<int32_t>(raw32());
    else if (Status s = number(16, t, "a cell type"); !s) return s;
    if (t != 2) return unsupported("cell " + std::to_string(first + i) + " has element type " + std::to_string(t) + " (tetopt reads tetrahedra only)");
  }
  if (binary) return end_binary(index);
  if (Status s = expect(')', "after the cell types"); !s) return s;
  // OpenFOAM's foamMeshToFluent writes an empty "()" after the types.
  while (peek() == '(') {
    const size_t b = pos_++;
    if (Status s = skip_balanced(b); !s) return s;
  }
  return expect(')', "at the end of the cell section");
}

Status Reader::faces(int64_t index, size_t at) {
  int64_t zid, first, last, bc, ft = 0;
  if (Status s = expect('(', "before the face section header"); !s) return s;
  if (Status s = number(16, zid, "a zone id"); !s) return s;
  if (Status s = number(16, first, "the first index"); !s) return s;
  if (Status s = number(16, last, "the last index"); !s) return s;
  if (Status s = number(16, bc, "the boundary condition type"); !s) return s;
  if (peek() != ')')
    if (Status s = number(16, ft, "the face type"); !s) return s;
  if (Status s = expect(')', "after the face section header"); !s) return s;
  if (zid == 0) return expect(')', "after a face declaration");
  if (first < 1 || last < first || last > kMaxId)
    return fail("face range " + std::to_string(first) + ".." + std::to_string(last) + " is not valid", at);
  if (zid > kMaxId) return fail("face zone id " + std::to_string(zid) + " out of the 32-bit range", at);
  if (ft != 0 && ft != 3)
    return unsupported("face zone " + std::to_string(zid) + " has face type " + std::to_string(ft) +
                       " (tetopt reads triangles: face type 3, or 0 with 3-node faces)", at);
  const int64_t n = last - first + 1;
  const bool binary = index != 13;
  if (Status s = expect('(', "before the faces"); !s) return s;
  if (Status s = room(n, (ft == 0 ? 6 : 5) * (binary ? 4 : 2), "faces", at, binary); !s) return s;
  FaceZone z{zid, first, last, bc, at, {}, {}};
  z.v.reserve(detail::ck_size(n, 3));
  z.c.reserve(detail::ck_size(n, 2));
  for (int64_t i = 0; i < n; ++i) {
    if (!binary) skip();  // never in binary data: 0x0a is a node index there
    const size_t fat = pos_;
    int64_t x[6];
    const int k = ft == 0 ? 6 : 5;
    for (int j = 0; j < k; ++j) {
      if (binary) x[j] = static_cast<int32_t>(raw32());
      else if (Status s = number(16, x[j], "a node or cell index"); !s) return s;
      if (ft == 0 && j == 0 && x[0] != 3)
        return unsupported("face " + std::to_string(first + i) + " has " + std::to_string(x[0]) + " nodes (tetopt reads triangles only)", fat);
    }
    const int64_t* p = ft == 0 ? x + 1 : x;
    for (int j = 0; j < 3; ++j) {
      if (p[j] < 1 || p[j] > kMaxId)
        return fail("face " + std::to_string(first + i) + ": node index " + std::to_string(p[j]) + " out of range", fat);
      z.v.push_back(static_cast<int32_t>(p[j] - 1));
    }
    for (int j = 3; j < 5; ++j) {
      if (p[j] < 0 || p[j] > kMaxId)
        return fail("face " + std::to_string(first + i) + ": cell index " + std::to_string(p[j]) + " out of range", fat);
      z.c.push_back(static_cast<int32_t>(p[j]));
    }
  }
  face_zones_.push_back(std::move(z));
  if (binary) return end_binary(index);
  if (Status s = expect(')', "after the faces (more than the header's count?)"); !s) return s;
  return expect(')', "at the end of the face section");
}

Status Reader::zone(size_t at) {
  int64_t id = 0;
  if (Status s = expect('(', "before the zone header"); !s) return s;
  if (Status s = number(10, id, "a zone id (decimal)"); !s) return s;
  const std::string_view type = token();
  const std::string_view nm = token();
  if (type.empty() || nm.empty()) return fail("a zone section needs a type and a name", at);
  // the rest of the header (domain id ...) and the conditions
  while (peek() != ')' && peek() != '\0') {
    if (peek() == '(') {
      const size_t b = pos_++;
      if (Status s = skip_balanced(b); !s) return s;
    } else {
      token();
    }
  }
  if (Status s = expect(')', "after the zone header"); !s) return s;
  if (peek() == '(') {
    const size_t b = pos_++;
    if (Status s = skip_balanced(b); !s) return s;
  }
  if (Status s = expect(')', "at the end of the zone section"); !s) return s;
  std::string name(nm);
  if (name.size() >= 2 && name.front() == '"' && name.back() == '"') name = name.substr(1, name.size() - 2);
  zone_info_[id] = ZoneInfo{std::string(type), name};
  return Status::success();
}

Status Reader::run(TetMesh& m) {
  m = TetMesh{};
  while (peek() != '\0') {
    const size_t at = pos_;
    if (Status s = expect('(', "at the start of a section"); !s) return s;
    int64_t index = 0;
    if (Status s = number(10, index, "a section index"); !s) return s;
    Status s;
    if (index == 10 || index == 2010 || index == 3010) s = nodes(index, at);
    else if (index == 12 || index == 2012 || index == 3012) s = cells(index, at);
    else if (index == 13 || index == 2013 || index == 3013) s = faces(index, at);
    else if (index == 39 || index == 45) s = zone(at);
    else if (index == 2) {
      int64_t nd = 0;
      if (s = number(16, nd, "the dimension"); !s) return s;
      if (nd != 3) return unsupported("a " + std::to_string(nd) + "D mesh (tetopt reads 3D meshes)", at);
      s = expect(')', "after the dimension");
    } else if (index >= 2000) {
      return unsupported("binary section " + std::to_string(index) + " (tetopt reads nodes, cells, faces and zones)", at);
    } else {
      s = skip_balanced(at);  // comments, headers, and sections tetopt does not use
    }
    if (!s) return s;
  }
  // Nodes: the zones together must number 1..N, each once.
  std::sort(node_zones_.begin(), node_zones_.end(), [](const NodeZone& a, const NodeZone& b) { return a.first < b.first; });
  int64_t nv = 0;
  for (const NodeZone& z : node_zones_) {
    if (z.first != nv + 1) return fail("the node zones do not number the nodes 1, 2, ... without gap or overlap (a zone starts at " + std::to_string(z.first) + ")", 0);
    nv = z.last;
  }
  if (nv == 0) return fail("no nodes", 0);
  m.xyz.reserve(detail::ck_size(nv, 3));
  for (const NodeZone& z : node_zones_) m.xyz.insert(m.xyz.end(), z.xyz.begin(), z.xyz.end());
  // Faces: likewise, 1..F.
  std::vector<size_t> order(face_zones_.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return face_zones_[a].first < face_zones_[b].first; });
  int64_t nf = 0;
  for (size_t i : order) {
    if (face_zones_[i].first != nf + 1) return fail("the face zones do not number the faces 1, 2, ... without gap or overlap", face_zones_[i].at);
    nf = face_zones_[i].last;
  }
  // Cells: the zones number 1..C; 4 C <= 2 F before anything per cell.
  std::sort(cell_zones_.begin(), cell_zones_.end(), [](const CellZone& a, const CellZone& b) { return a.first < b.first; });
  int64_t nc = 0;
  for (const CellZone& z : cell_zones_) {
    if (z.first != nc + 1) return fail("the cell zones do not number the cells 1, 2, ... without gap or overlap", 0);
    nc = z.last;
  }
  if (nc == 0) return fail("no cells", 0);
  {
    int64_t need = 0, have = 0;
    if (!detail::ck_mul(nc, int64_t{4}, need) || !detail::ck_mul(nf, int64_t{2}, have) || need > have)
      return fail(std::to_string(nc) + " cells cannot be tetrahedra with " + std::to_string(nf) + " faces", 0);
  }
  std::vector<int32_t> faces, first, second;
  faces.reserve(detail::ck_size(nf, 3));
  first.reserve(detail::ck_size(nf, 1));
  second.reserve(detail::ck_size(nf, 1));
  for (size_t i : order) {
    const FaceZone& z = face_zones_[i];
    for (size_t f = 0; f < z.c.size() / 2; ++f) {
      const int32_t* v = &z.v[3 * f];
      for (int j = 0; j < 3; ++j)
        if (v[j] >= nv) return fail("face " + std::to_string(z.first + static_cast<int64_t>(f)) + ": node " + std::to_string(v[j] + 1) + " out of range 1.." + std::to_string(nv), z.at);
      const int32_t c0 = z.c[2 * f], c1 = z.c[2 * f + 1];
      if (c0 > nc || c1 > nc || (c0 == 0 && c1 == 0) || c0 == c1)
        return fail("face " + std::to_string(z.first + static_cast<int64_t>(f)) + ": cells " + std::to_string(c0) + " and " + std::to_string(c1) +
                        " (each in 1.." + std::to_string(nc) + ", c0 != c1, at most one 0)", z.at);
      // The normal points toward c0: the face points out of c1.
      if (c1 != 0) {
        faces.insert(faces.end(), {v[0], v[1], v[2]});
        first.push_back(c1 - 1);
        second.push_back(c0 - 1);  // -1 when c0 is 0
      } else {
        faces.insert(faces.end(), {v[0], v[2], v[1]});
        first.push_back(c0 - 1);
        second.push_back(-1);
      }
    }
  }
  {
    std::string what;
    int64_t bad = 0;
    if (!detail::tets_from_faces(faces, first, second, nc, m.tets, what, bad)) {
      Status s = fail("cell " + std::to_string(bad + 1) + " " + what, 0);
      if (what.find("supported") != std::string::npos) s.code = ErrorCode::Unsupported;
      return s;
    }
  }
  m.tet_ref.assign(static_cast<size_t>(nc), 0);
  for (const CellZone& z : cell_zones_)
    for (int64_t c = z.first; c <= z.last; ++c) m.tet_ref[c - 1] = static_cast<int32_t>(z.id);
  // Listed triangles: face zones in file order.
  for (const FaceZone& z : face_zones_) {
    const auto it = zone_info_.find(z.id);
    std::string type = it != zone_info_.end() ? it->second.type : "";
    if (type.empty() && type_of_code(static_cast<int>(z.bc))) type = type_of_code(static_cast<int>(z.bc));
    for (size_t f = 0; f < z.c.size() / 2; ++f) {
      const int32_t c0 = z.c[2 * f], c1 = z.c[2 * f + 1];
      if (type == "interior" && c0 && c1 && m.tet_ref[c0 - 1] == m.tet_ref[c1 - 1]) continue;
      m.tris.insert(m.tris.end(), z.v.begin() + 3 * f, z.v.begin() + 3 * f + 3);
      m.tri_ref.push_back(static_cast<int32_t>(z.id));
    }
    GroupAttachment& a = m.attachment.get(2, static_cast<int32_t>(z.id));
    a.fluent_type = type;
    a.fluent_id = static_cast<int32_t>(z.id);
    if (it != zone_info_.end()) m.physical_names.push_back(PhysicalName{2, static_cast<int>(z.id), it->second.name});
  }
  for (const CellZone& z : cell_zones_) {
    const auto it = zone_info_.find(z.id);
    GroupAttachment& a = m.attachment.get(3, static_cast<int32_t>(z.id));
    a.fluent_type = it != zone_info_.end() ? it->second.type : "fluid";
    a.fluent_id = static_cast<int32_t>(z.id);
    if (it != zone_info_.end()) m.physical_names.push_back(PhysicalName{3, static_cast<int>(z.id), it->second.name});
  }
  m.vert_ref.assign(static_cast<size_t>(nv), 0);
  return Status::success();
}

}  // namespace

Status parse_fluent(std::string_view data, const std::string& name, TetMesh& m) {
  Reader r(data, name);
  return r.run(m);
}

bool detail::looks_like_fluent(std::string_view data) {
  size_t i = 0;
  if (data.substr(0, 3) == "\xEF\xBB\xBF") i = 3;
  while (i < data.size() && is_space(data[i])) ++i;
  return i < data.size() && data[i] == '(';
}

// ---------------------------------------------------------------- writer ----

namespace {

void put_hex(std::string& out, int64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, 16);
  out.append(buf, r.ptr);
}
using detail::put_raw_le;
void put_double(std::string& out, double v) { detail::put_real(out, v); }

/// A zone name as Fluent's syntax takes it: no blanks or parentheses.
std::string fluent_word(const std::string& s, bool& changed) {
  std::string w = s.empty() ? std::string("zone") : s;
  for (char& c : w) {
    const auto u = static_cast<unsigned char>(c);
    if (u <= 32 || u == 127 || c == '(' || c == ')' || c == '"') c = '_';
  }
  changed = w != s;
  return w;
}

struct FZone {
  int32_t id = 0, ref = 0;
  bool has_ref = false;  // a ref of the mesh (listed triangles)
  std::string type, name;
  std::vector<std::pair<int32_t, int32_t>> faces;  // (face, tri or -1)
};

struct FPlan {
  std::vector<detail::WrittenFace> faces;
  std::vector<int32_t> cell_order;  // new cell -> tet
  std::vector<int32_t> cell_of;     // tet -> new cell (0-based)
  struct CZ {
    int32_t id, first, last;
    std::string type, name;
  };
  std::vector<CZ> cell_zones;
  std::vector<FZone> zones;
  int32_t node_zone = 0;
  int64_t unmatched = 0, turned = 0, renamed = 0, merged_interior = 0, ref_changed = 0;
};

const std::string* name_of(const TetMesh& m, int dim, int32_t ref) {
  for (const PhysicalName& p : m.physical_names)
    if (p.dim == dim && p.tag == ref) return &p.name;
  return nullptr;
}

Status make_plan(const TetMesh& m, FPlan& plan) {
  std::vector<detail::WrittenFace> faces;
  std::vector<std::array<int32_t, 3>> keys;
  std::string what;
  if (!detail::faces_of_tets(m, Format::Fluent, faces, &keys, what)) return Status::error(ErrorCode::InvalidMesh, what);
  // Cells grouped by ref, the refs in order of first appearance, the tets
  // of one ref in their order (a cell zone is a range of cells).
  const int32_t nt = m.nt();
  std::vector<int32_t> refs;
  std::map<int32_t, size_t> ref_index;
  for (int32_t t = 0; t < nt; ++t)
    if (ref_index.emplace(m.tet_ref[t], refs.size()).second) refs.push_back(m.tet_ref[t]);
  std::vector<std::vector<int32_t>> by_ref(refs.size());
  for (int32_t t = 0; t < nt; ++t) by_ref[ref_index[m.tet_ref[t]]].push_back(t);
  plan.cell_of.assign(static_cast<size_t>(nt), -1);
  std::set<int32_t> used_ids;
  // Zone ids: a ref that is a valid id (1..) and not taken is its own id.
  auto take_id = [&](int32_t want) {
    int32_t id = want;
    if (id < 1 || used_ids.count(id)) {
      id = 1;
      while (used_ids.count(id)) ++id;
    }
    used_ids.insert(id);
    return id;
  };
  // Reserve the refs first so generated ids avoid them.
  std::vector<int32_t> cell_ids(refs.size());
  for (size_t i = 0; i < refs.size(); ++i) cell_ids[i] = take_id(refs[i]);
  for (size_t i = 0; i < refs.size(); ++i) {
    FPlan::CZ z;
    z.id = cell_ids[i];
    plan.ref_changed += z.id != refs[i];
    z.first = static_cast<int32_t>(plan.cell_order.size()) + 1;
    for (int32_t t : by_ref[i]) {
      plan.cell_of[t] = static_cast<int32_t>(plan.cell_order.size());
      plan.cell_order.push_back(t);
    }
    z.last = static_cast<int32_t>(plan.cell_order.size());
    const GroupAttachment* a = m.attachment.find(3, refs[i]);
    z.type = a && !a->fluent_type.empty() ? a->fluent_type : "fluid";
    const std::string* n = name_of(m, 3, refs[i]);
    bool changed = false;
    z.name = n ? fluent_word(*n, changed) : z.type + "-" + std::to_string(z.id);
    plan.renamed += changed;
    plan.cell_zones.push_back(std::move(z));
  }
  // Listed triangles onto faces.
  const size_t nf = faces.size();
  std::vector<int32_t> listed(nf, -1);
  std::vector<int32_t> zone_refs;
  std::map<int32_t, std::vector<std::pair<int32_t, int32_t>>> ref_faces;
  for (int32_t t = 0; t < m.ntri(); ++t) {
    const int32_t* p = &m.tris[3 * static_cast<size_t>(t)];
    const auto k = detail::tri_key(p);
    const auto it = std::lower_bound(keys.begin(), keys.end(), k);
    if (it == keys.end() || *it != k || listed[static_cast<size_t>(it - keys.begin())] >= 0) {
      ++plan.unmatched;  // no tet's face, or listed a second time
      continue;
    }
    const auto f = static_cast<int32_t>(it - keys.begin());
    listed[f] = t;
    auto& v = ref_faces[m.tri_ref[t]];
    if (v.empty()) zone_refs.push_back(m.tri_ref[t]);
    v.emplace_back(f, t);
  }
  // Zone order: interior (unlisted internal faces), then the attachment's
  // face zones in file order, then the other refs in order of appearance,
  // then the unlisted boundary faces.
  std::vector<int32_t> ordered;
  std::set<int32_t> seen;
  for (const GroupAttachment& g : m.attachment.groups)
    if (g.dim == 2 && ref_faces.count(g.ref) && seen.insert(g.ref).second) ordered.push_back(g.ref);
  for (int32_t r : zone_refs)
    if (seen.insert(r).second) ordered.push_back(r);
  std::map<int32_t, int32_t> face_id;
  for (int32_t r : ordered) {
    face_id[r] = take_id(r);
    plan.ref_changed += face_id[r] != r;
  }
  // The unlisted internal faces go to one interior zone: the attachment's
  // first interior zone (with its id and name; when some of its faces are
  // listed, as interfaces between cell zones, they share the zone), else a
  // new one.  Further interior zones without listed faces merge into it.
  int32_t interior_ref = 0;
  bool have_interior = false;
  for (const GroupAttachment& g : m.attachment.groups)
    if (g.dim == 2 && g.fluent_type == "interior") {
      if (!have_interior) {
        interior_ref = g.ref;
        have_interior = true;
      } else if (!ref_faces.count(g.ref)) {
        ++plan.merged_interior;
      }
    }
  std::vector<std::pair<int32_t, int32_t>> bulk;
  for (size_t f = 0; f < nf; ++f)
    if (faces[f].second >= 0 && listed[f] < 0) bulk.emplace_back(static_cast<int32_t>(f), -1);
  const bool bulk_joins = have_interior && ref_faces.count(interior_ref);
  std::vector<FZone> zs;
  if (!bulk_joins && (!bulk.empty() || have_interior)) {
    FZone z;
    z.type = "interior";
    z.ref = interior_ref;
    z.has_ref = have_interior;
    z.id = have_interior && !used_ids.count(interior_ref) ? take_id(interior_ref) : take_id(0);
    const std::string* n = have_interior ? name_of(m, 2, interior_ref) : nullptr;
    bool changed = false;
    z.name = n ? fluent_word(*n, changed) : "interior-" + std::to_string(z.id);
    plan.renamed += changed;
    z.faces = std::move(bulk);
    zs.push_back(std::move(z));
  }
  for (int32_t r : ordered) {
    FZone z;
    z.ref = r;
    z.has_ref = true;
    z.id = face_id[r];
    z.faces = ref_faces[r];
    const GroupAttachment* a = m.attachment.find(2, r);
    bool inside_one = false;  // some listed face inside one cell zone
    bool any_internal = false;
    for (const auto& ft : z.faces) {
      const detail::WrittenFace& w = faces[ft.first];
      if (w.second >= 0) {
        any_internal = true;
        inside_one = inside_one || m.tet_ref[w.first] == m.tet_ref[w.second];
      }
    }
    z.type = a && !a->fluent_type.empty() ? a->fluent_type : (any_internal ? "interior" : "wall");
    // an OpenFOAM patch's type where Fluent has the same one
    if (a && a->fluent_type.empty() && !any_internal && (a->foam_type == "symmetryPlane" || a->foam_type == "symmetry"))
      z.type = "symmetry";
    // An interior zone is listed back only where it separates two cell
    // zones; one with a listed face inside a cell zone is written as a wall.
    if (z.type == "interior" && inside_one) z.type = "wall";
    if (bulk_joins && r == interior_ref && z.type == "interior") z.faces.insert(z.faces.end(), bulk.begin(), bulk.end());
    const std::string* n = name_of(m, 2, r);
    bool changed = false;
    z.name = n ? fluent_word(*n, changed) : z.type + "-" + std::to_string(z.id);
    plan.renamed += changed;
    zs.push_back(std::move(z));
  }
  if (bulk_joins && zs.size() == ordered.size() && !bulk.empty()) {
    // the interior zone turned out a wall: the bulk gets its own zone
    bool placed = false;
    for (const FZone& z : zs) placed = placed || (z.ref == interior_ref && z.type == "interior");
    if (!placed) {
      FZone z;
      z.type = "interior";
      z.id = take_id(0);
      z.name = "interior-" + std::to_string(z.id);
      z.faces = bulk;
      zs.insert(zs.begin(), std::move(z));
    }
  }
  FZone rest;
  rest.type = "wall";
  for (size_t f = 0; f < nf; ++f)
    if (faces[f].second < 0 && listed[f] < 0) rest.faces.emplace_back(static_cast<int32_t>(f), -1);
  if (!rest.faces.empty()) {
    rest.id = take_id(0);
    rest.name = "wall-" + std::to_string(rest.id);
    zs.push_back(std::move(rest));
  }
  plan.node_zone = take_id(0);
  // Faces in zone order, each oriented toward c0: a listed triangle keeps
  // its vertex order (c0 is then the cell it points into); otherwise the
  // face points into its first tet for a boundary face (turned) and into
  // the second tet for an internal one.
  for (FZone& z : zs) {
    for (auto& ft : z.faces) {
      detail::WrittenFace w = faces[ft.first];  // oriented out of w.first
      detail::WrittenFace o;
      if (ft.second >= 0) {
        const int32_t* p = &m.tris[3 * static_cast<size_t>(ft.second)];
        o.v[0] = p[0]; o.v[1] = p[1]; o.v[2] = p[2];
        const bool out_of_first = detail::same_rotation(p, w.v);
        if (w.second < 0) {
          if (out_of_first) ++plan.turned, o.v[1] = p[2], o.v[2] = p[1];
          o.first = w.first;  // c0
          o.second = -1;
        } else {
          o.first = out_of_first ? w.second : w.first;   // c0: the cell it points into
          o.second = out_of_first ? w.first : w.second;  // c1
        }
      } else if (w.second < 0) {
        o.v[0] = w.v[0]; o.v[1] = w.v[2]; o.v[2] = w.v[1];
        o.first = w.first;
        o.second = -1;
      } else {
        o.v[0] = w.v[0]; o.v[1] = w.v[1]; o.v[2] = w.v[2];
        o.first = w.second;
        o.second = w.first;
      }
      ft.first = static_cast<int32_t>(plan.faces.size());
      plan.faces.push_back(o);
    }
  }
  plan.zones = std::move(zs);
  return Status::success();
}

}  // namespace

Status format_fluent(const TetMesh& m, std::string& out, bool binary) {
  FPlan plan;
  if (Status s = make_plan(m, plan); !s) return s;
  const int64_t nv = m.nv(), nc = m.nt(), nf = static_cast<int64_t>(plan.faces.size());
  out += "(0 \"Fluent mesh written by tetopt\")\n(1 \"tetopt\")\n(0 \"Dimensions:\")\n(2 3)\n\n(10 (0 1 ";
  put_hex(out, nv);
  out += " 0 3))\n(12 (0 1 ";
  put_hex(out, nc);
  out += " 0 0))\n(13 (0 1 ";
  put_hex(out, nf);
  out += " 0 0))\n\n";
  // nodes
  out += binary ? "(3010 (" : "(10 (";
  put_hex(out, plan.node_zone);
  out += " 1 ";
  put_hex(out, nv);
  out += " 1 3)(";
  out += binary ? "" : "\n";
  for (int32_t v = 0; v < m.nv(); ++v) {
    const double* x = m.point(v);
    for (int k = 0; k < 3; ++k) {
      if (binary) {
        put_raw_le(out, x[k]);
      } else {
        if (k) out += ' ';
        put_double(out, x[k]);
      }
    }
    if (!binary) out += '\n';
  }
  out += binary ? ")\nEnd of Binary Section 3010)\n\n" : "))\n\n";
  // cells: one section per zone, element type 2
  for (const FPlan::CZ& z : plan.cell_zones) {
    out += "(12 (";
    put_hex(out, z.id);
    out += ' ';
    put_hex(out, z.first);
    out += ' ';
    put_hex(out, z.last);
    out += " 1 2))\n";
  }
  out += '\n';
  // faces
  int64_t next = 1;
  for (const FZone& z : plan.zones) {
    if (z.faces.empty()) continue;  // a section needs first <= last
    out += binary ? "(3013 (" : "(13 (";
    put_hex(out, z.id);
    out += ' ';
    put_hex(out, next);
    out += ' ';
    put_hex(out, next + static_cast<int64_t>(z.faces.size()) - 1);
    out += ' ';
    put_hex(out, z.type == "interior" ? 2 : code_of_type(z.type));
    out += " 3)(";
    out += binary ? "" : "\n";
    for (const auto& ft : z.faces) {
      const detail::WrittenFace& w = plan.faces[ft.first];
      const int64_t vals[5] = {w.v[0] + 1, w.v[1] + 1, w.v[2] + 1, plan.cell_of[w.first] + 1,
                               w.second >= 0 ? plan.cell_of[w.second] + 1 : 0};
      for (int k = 0; k < 5; ++k) {
        if (binary) {
          put_raw_le(out, static_cast<int32_t>(vals[k]));
        } else {
          if (k) out += ' ';
          put_hex(out, vals[k]);
        }
      }
      if (!binary) out += '\n';
    }
    out += binary ? ")\nEnd of Binary Section 3013)\n\n" : "))\n\n";
    next += static_cast<int64_t>(z.faces.size());
  }
  // zones
  for (const FPlan::CZ& z : plan.cell_zones) out += "(39 (" + std::to_string(z.id) + " " + z.type + " " + z.name + " 1)())\n";
  for (const FZone& z : plan.zones)
    if (!z.faces.empty()) out += "(39 (" + std::to_string(z.id) + " " + z.type + " " + z.name + " 1)())\n";
  return Status::success();
}

std::vector<std::string> detail::fluent_dropped(const TetMesh& m) {
  std::vector<std::string> out;
  FPlan plan;
  if (!make_plan(m, plan)) return out;
  auto add = [&](int64_t n, const std::string& what) {
    if (n > 0) out.push_back(what + " (" + std::to_string(n) + ")");
  };
  add(plan.unmatched, "listed triangles that are no tet's face or list one twice");
  add(plan.turned, "boundary triangles listed facing out; written facing in, as Fluent orders them");
  add(plan.renamed, "names with blanks, quotes or parentheses; written with '_'");
  add(plan.ref_changed, "refs below 1 or taken by another zone; written with other zone ids");
  add(plan.merged_interior, "interior face zones; written as one");
  if (m.vert_ref.size() == static_cast<size_t>(m.nv()))
    add(std::count_if(m.vert_ref.begin(), m.vert_ref.end(), [](int32_t r) { return r != 0; }), "vertex refs");
  int64_t unused = 0;
  for (const PhysicalName& pn : m.physical_names) {
    bool used = false;
    for (const FPlan::CZ& z : plan.cell_zones) used = used || (pn.dim == 3 && z.id == pn.tag);
    for (const FZone& z : plan.zones) used = used || (pn.dim == 2 && z.has_ref && z.ref == pn.tag && !z.faces.empty());
    unused += !used;
  }
  add(unused, "physical names of groups with no zone");
  return out;
}

}  // namespace tetopt
