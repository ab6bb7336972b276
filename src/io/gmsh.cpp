// Gmsh .msh reader and writer: formats 2.2 and 4.1, ASCII and binary.
//
// Format references: the Gmsh reference manual, section "MSH file format"
// (version 4.1) and its "Legacy formats" appendix (version 2.2).
//
// Mapping into TetMesh:
//   4-node tets (type 4)       -> tets, tet_ref, tet_entity
//   3-node triangles (type 2)  -> tris, tri_ref, tri_entity
//   2-node lines (type 1)      -> edges, edge_ref
//   points (type 15)           -> corners (vertex ids)
// A ref is the element's physical tag (2.2: the first tag; 4.1: the first
// physical tag of the element's entity), or its elementary (entity) tag when
// it has none.  Node tags may be sparse or unordered: vertices are numbered
// in order of appearance.  Any other element type is an Unsupported error.
//
// Errors: "FILE:LINE: what" for text, "FILE: byte N: what" inside binary
// data (Status::line then holds the byte offset).  Counts are bounded by the
// bytes that remain before anything is allocated.
#include <algorithm>
#include <map>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

#include "io/checked.hpp"
#include "io/common.hpp"
#include "io/scan_gmsh_vtk.hpp"
#include "tetopt/io.hpp"

namespace tetopt {

namespace {

using gvscan::Cursor;

const char* element_type_name(int64_t t) {
  switch (t) {
    case 1: return "2-node line";
    case 2: return "3-node triangle";
    case 3: return "4-node quadrangle";
    case 4: return "4-node tetrahedron";
    case 5: return "8-node hexahedron";
    case 6: return "6-node prism";
    case 7: return "5-node pyramid";
    case 8: return "3-node second-order line";
    case 9: return "6-node second-order triangle";
    case 10: return "9-node second-order quadrangle";
    case 11: return "10-node second-order tetrahedron";
    case 12: return "27-node second-order hexahedron";
    case 13: return "18-node second-order prism";
    case 14: return "14-node second-order pyramid";
    case 15: return "1-node point";
    case 16: return "8-node second-order quadrangle";
    case 17: return "20-node second-order hexahedron";
    default: return "unknown type";
  }
}

/// Nodes of the element types tetopt reads; 0 for every other type.
int supported_nodes(int64_t t) {
  switch (t) {
    case 1: return 2;
    case 2: return 3;
    case 4: return 4;
    case 15: return 1;
    default: return 0;
  }
}

std::string shorten(std::string_view t) { return detail::shown_token(t, true); }

class GmshReader {
 public:
  GmshReader(std::string_view data, const std::string& name, TetMesh& m) : name_(name), m_(m) { c_.s = data; }

  Status run() {
    if (Status s = read_format(); !s) return s;
    for (;;) {
      const std::string_view t = c_.token();
      if (t.empty()) break;
      Status s;
      if (t == "$PhysicalNames") s = read_physical_names();
      else if (t == "$Entities") s = version_ == 41 ? read_entities() : skip_section(t);
      else if (t == "$Nodes") s = version_ == 41 ? read_nodes41() : read_nodes22();
      else if (t == "$Elements") s = version_ == 41 ? read_elements41() : read_elements22();
      else if (t == "$MeshFormat") s = fail(ErrorCode::Parse, "a second $MeshFormat section");
      else if (t.size() > 1 && t[0] == '$' && t.substr(0, 4) != "$End") s = skip_section(t);
      else
        s = fail(ErrorCode::Parse, "unexpected '" + shorten(t) +
                                       "' between sections (a count that does not match the data, or a missing $End line?)");
      if (!s) return s;
    }
    if (!have_nodes_) return fail(ErrorCode::Parse, "no $Nodes section");
    if (!have_elements_) return fail(ErrorCode::Parse, "no $Elements section");
    if (m_.tets.empty())
      return fail(ErrorCode::InvalidMesh, "no tetrahedra (a surface-only mesh? tetopt needs 4-node tets)");
    // A 2.2 file's elements with physical tag 0 (in no physical group: what
    // Gmsh writes when a model defines none) took their elementary tag as
    // ref; their entities are listed without physical tags, so that the
    // writers give them physical 0 (2.2) or none (4.1) back instead of
    // making their ref a new physical group.  An entity whose elements
    // disagree is not listed (the writers then write the ref).
    for (const auto& [key, seen] : phys22_)
      if (seen.zero && !seen.nonzero) m_.gmsh_entities.push_back({key.first, key.second, {}});
    return Status::success();
  }

 private:
  const std::string& name_;
  TetMesh& m_;
  Cursor c_;
  int version_ = 0;  // 22 or 41
  bool binary_ = false;
  int dsize_ = 8;    // size_t width in 4.1 binary files
  bool have_nodes_ = false, have_elements_ = false;
  size_t dense_limit_ = 0;
  std::vector<int32_t> dense_;  // tag -> vertex id + 1 (0: unknown)
  std::unordered_map<int64_t, int32_t> sparse_;
  std::map<std::pair<int, int>, int32_t> entity_phys_;  // (dim, tag) -> first physical tag
  // 2.2: whether the elements of (dim, elementary tag) had physical tag 0
  // and / or another one (see run()).
  struct Seen22 {
    bool zero = false, nonzero = false;
  };
  std::map<std::pair<int, int>, Seen22> phys22_;
  std::pair<int, int> last22_{-1, 0};
  Seen22* last_seen22_ = nullptr;
  void note22(int64_t type, int64_t phys, int64_t elem) {
    if (elem < INT32_MIN || elem > INT32_MAX) return;  // add_element refuses it
    const int dim = type == 15 ? 0 : type == 1 ? 1 : type == 2 ? 2 : 3;
    const std::pair<int, int> key{dim, static_cast<int>(elem)};
    if (!last_seen22_ || key != last22_) {
      last_seen22_ = &phys22_[key];
      last22_ = key;
    }
    (phys == 0 ? last_seen22_->zero : last_seen22_->nonzero) = true;
  }
  std::set<std::pair<int, int>> entities_;              // (dim, tag) listed in $Entities
  bool have_entities_ = false;                          // a $Entities section was read

  Status fail(ErrorCode code, const std::string& what) const {
    return Status::error(code, name_ + ":" + std::to_string(c_.line) + ": " + what, c_.line);
  }
  Status fail_bin(const std::string& what) const {
    return Status::error(ErrorCode::Parse, name_ + ": byte " + std::to_string(c_.pos) + ": " + what,
                         static_cast<long>(c_.pos));
  }
  Status bad_token(std::string_view t, const std::string& what) const {
    if (t.empty()) return fail(ErrorCode::Parse, "unexpected end of file while reading " + what + " (truncated file?)");
    return fail(ErrorCode::Parse, "expected " + what + ", found '" + shorten(t) + "'");
  }

  // ---- text tokens ----
  Status int_tok(int64_t& v, const char* what) {
    const std::string_view t = c_.token();
    if (!gvscan::parse_int(t, v)) return bad_token(t, what);
    return Status::success();
  }
  Status real_tok(double& v, const char* what) {
    const std::string_view t = c_.token();
    if (!gvscan::parse_double(t, v)) return bad_token(t, what);
    return Status::success();
  }
  Status expect(std::string_view want, const std::string& hint) {
    const std::string_view t = c_.token();
    if (t != want)
      return fail(ErrorCode::Parse, "expected " + std::string(want) + ", found '" +
                                        (t.empty() ? std::string("end of file") : shorten(t)) + "'" + hint);
    return Status::success();
  }
  /// Bounds a count by the bytes left (each item needs at least min_bytes).
  Status check_count(int64_t n, size_t min_bytes, const char* what) {
    if (n < 0) return fail(ErrorCode::Parse, std::string("negative ") + what + " count " + std::to_string(n));
    if (static_cast<uint64_t>(n) > c_.remaining() / min_bytes)
      return fail(ErrorCode::Parse, std::string(what) + " count " + std::to_string(n) + " exceeds what the remaining " +
                                        std::to_string(c_.remaining()) + " bytes can hold (truncated file or lying count)");
    return Status::success();
  }

  // ---- binary values (little-endian, checked by the caller with need) ----
  bool need(size_t n) const { return c_.remaining() >= n; }
  /// Whether `count` records of `each` bytes remain, the product checked
  /// (checked.hpp): a count from the file never wraps into a small size.
  bool need_n(int64_t count, size_t each) const {
    size_t total = 0;
    return count >= 0 && detail::ck_mul(static_cast<uint64_t>(count), each, total) && need(total);
  }
  int32_t i32() {
    const int32_t v = gvscan::load<int32_t>(c_.s.data() + c_.pos, false);
    c_.pos += 4;
    return v;
  }
  double f64() {
    const double v = gvscan::load<double>(c_.s.data() + c_.pos, false);
    c_.pos += 8;
    return v;
  }
  int64_t size_val() {  // a 4.1 size_t field (dsize_ bytes)
    if (dsize_ == 8) {
      const uint64_t v = gvscan::load<uint64_t>(c_.s.data() + c_.pos, false);
      c_.pos += 8;
      return v > static_cast<uint64_t>(INT64_MAX) ? -1 : static_cast<int64_t>(v);
    }
    const uint32_t v = gvscan::load<uint32_t>(c_.s.data() + c_.pos, false);
    c_.pos += 4;
    return v;
  }
  /// A size_t field in binary, an integer token in text.
  /// A count or tag: never negative (a negative block size once slipped past
  /// the "more than declared" check and reached vector::resize).
  Status count_val(int64_t& v, const char* what) {
    if (!binary_) {
      if (Status s = int_tok(v, what); !s) return s;
      // `what` has its article ("the minimum element tag"): "... is negative".
      if (v < 0) return fail(ErrorCode::Parse, std::string(what) + " is negative (" + std::to_string(v) + ")");
      return Status::success();
    }
    if (!need(static_cast<size_t>(dsize_))) return fail_bin(std::string("truncated data while reading ") + what);
    v = size_val();
    // Unsigned in the file: past 2^63 it reads negative here.
    if (v < 0)
      return fail_bin(std::string(what) + " is absurd (" + std::to_string(static_cast<uint64_t>(v)) + ")");
    return Status::success();
  }
  Status int_val(int64_t& v, const char* what) {
    if (!binary_) return int_tok(v, what);
    if (!need(4)) return fail_bin(std::string("truncated data while reading ") + what);
    v = i32();
    return Status::success();
  }
  /// After an ASCII count line, binary data starts right after its newline.
  void start_binary() {
    if (binary_) c_.rest_of_line();
  }

  // ---- node tags ----
  Status add_node_tag(int64_t tag) {
    const int32_t id = static_cast<int32_t>(m_.xyz.size() / 3);
    if (tag < 0) return fail(ErrorCode::Parse, "negative node tag " + std::to_string(tag));
    if (static_cast<uint64_t>(tag) < dense_limit_) {
      const size_t k = static_cast<size_t>(tag);
      if (k >= dense_.size()) dense_.resize(std::min(dense_limit_, std::max(k + 1, 2 * dense_.size())), 0);
      if (dense_[k] != 0) return fail(ErrorCode::InvalidMesh, "node tag " + std::to_string(tag) + " appears twice");
      dense_[k] = id + 1;
    } else if (!sparse_.emplace(tag, id).second) {
      return fail(ErrorCode::InvalidMesh, "node tag " + std::to_string(tag) + " appears twice");
    }
    return Status::success();
  }
  int32_t lookup(int64_t tag) const {
    if (tag < 0) return -1;
    if (static_cast<uint64_t>(tag) < dense_.size()) return dense_[static_cast<size_t>(tag)] - 1;
    if (static_cast<uint64_t>(tag) < dense_limit_) return -1;
    const auto it = sparse_.find(tag);
    return it == sparse_.end() ? -1 : it->second;
  }
  Status add_point(double x, double y, double z) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      return binary_ ? fail_bin("node " + std::to_string(m_.xyz.size() / 3 + 1) + " has a NaN or infinite coordinate")
                     : fail(ErrorCode::InvalidMesh,
                            "node " + std::to_string(m_.xyz.size() / 3 + 1) + " has a NaN or infinite coordinate");
    m_.xyz.push_back(x);
    m_.xyz.push_back(y);
    m_.xyz.push_back(z);
    return Status::success();
  }

  Status unsupported_type(int64_t type) const {
    return fail(ErrorCode::Unsupported, "element type " + std::to_string(type) + " (" + element_type_name(type) +
                                            ") is not supported: tetopt reads 4-node tetrahedra, 3-node "
                                            "triangles, 2-node lines and points");
  }

  /// Stores one element; nodes are file tags.
  Status add_element(int64_t etag, int64_t type, const int64_t* nodes, int64_t ref, int64_t entity) {
    const int k = supported_nodes(type);
    int32_t v[4];
    for (int j = 0; j < k; ++j) {
      v[j] = lookup(nodes[j]);
      if (v[j] < 0) {
        const std::string what = "element " + std::to_string(etag) + " names node tag " + std::to_string(nodes[j]) +
                                 ", which $Nodes does not define";
        return binary_ ? fail_bin(what) : fail(ErrorCode::InvalidMesh, what);
      }
    }
    if (ref < INT32_MIN || ref > INT32_MAX || entity < INT32_MIN || entity > INT32_MAX)
      return fail(ErrorCode::Parse, "element " + std::to_string(etag) + " has a tag outside the 32-bit range");
    switch (type) {
      case 4:
        m_.tets.insert(m_.tets.end(), v, v + 4);
        m_.tet_ref.push_back(static_cast<int32_t>(ref));
        m_.tet_entity.push_back(static_cast<int32_t>(entity));
        break;
      case 2:
        m_.tris.insert(m_.tris.end(), v, v + 3);
        m_.tri_ref.push_back(static_cast<int32_t>(ref));
        m_.tri_entity.push_back(static_cast<int32_t>(entity));
        break;
      case 1:
        m_.edges.insert(m_.edges.end(), v, v + 2);
        m_.edge_ref.push_back(static_cast<int32_t>(ref));
        break;
      case 15:
        // A point element's ref (its physical tag, or its entity's tag when
        // it has none) becomes its vertex's ref, which the writers give the
        // point back (and the other formats write as a vertex ref).
        m_.corners.push_back(v[0]);
        if (m_.vert_ref.size() != static_cast<size_t>(m_.nv())) m_.vert_ref.assign(static_cast<size_t>(m_.nv()), 0);
        m_.vert_ref[static_cast<size_t>(v[0])] = static_cast<int32_t>(ref);
        break;
      default: return unsupported_type(type);
    }
    return Status::success();
  }

  // ---- sections ----
  Status read_format() {
    if (const std::string_view t = c_.token(); t != "$MeshFormat")
      return fail(ErrorCode::Parse, "not a Gmsh file: expected $MeshFormat, found '" + shorten(t) + "'");
    const std::string_view ver = c_.token();
    if (ver == "2.2" || ver == "2.1" || ver == "2" || ver == "2.0") version_ = 22;
    else if (ver == "4.1") version_ = 41;
    else if (ver.empty()) return bad_token(ver, "a version number");
    else
      return fail(ErrorCode::Unsupported,
                  "Gmsh format version " + shorten(ver) + " is not supported (tetopt reads 2.2 and 4.1)");
    int64_t ft = 0, ds = 0;
    if (Status s = int_tok(ft, "the file type (0 ASCII, 1 binary)"); !s) return s;
    if (Status s = int_tok(ds, "the data size"); !s) return s;
    if (ft != 0 && ft != 1) return fail(ErrorCode::Parse, "file type " + std::to_string(ft) + " is neither 0 nor 1");
    binary_ = ft == 1;
    if (binary_) {
      if (version_ == 22 && ds != 8)
        return fail(ErrorCode::Unsupported, "binary data size " + std::to_string(ds) + " (only 8-byte doubles)");
      if (version_ == 41 && ds != 8 && ds != 4)
        return fail(ErrorCode::Unsupported, "binary size_t width " + std::to_string(ds) + " (4 or 8 expected)");
      dsize_ = static_cast<int>(ds);
      c_.rest_of_line();
      if (!need(4)) return fail_bin("truncated endianness check");
      const int32_t one = i32();
      if (one == 0x01000000) return fail(ErrorCode::Unsupported, "big-endian binary .msh files are not supported");
      if (one != 1) return fail_bin("bad endianness check (expected the integer 1)");
    }
    return expect("$EndMeshFormat", "");
  }

  Status skip_section(std::string_view t) {
    const std::string end = "$End" + std::string(t.substr(1));
    const size_t at = c_.s.find(end, c_.pos);
    if (at == std::string_view::npos)
      return fail(ErrorCode::Parse, "section " + shorten(t) + " has no " + shorten(end) + " (truncated file?)");
    c_.line += static_cast<long>(std::count(c_.s.begin() + static_cast<std::ptrdiff_t>(c_.pos),
                                            c_.s.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    c_.pos = at + end.size();
    return Status::success();
  }

  Status read_physical_names() {
    int64_t n = 0;
    if (Status s = int_tok(n, "the number of physical names"); !s) return s;
    if (Status s = check_count(n, 6, "physical name"); !s) return s;
    for (int64_t i = 0; i < n; ++i) {
      int64_t dim = 0, tag = 0;
      if (Status s = int_tok(dim, "a physical dimension"); !s) return s;
      if (Status s = int_tok(tag, "a physical tag"); !s) return s;
      if (dim < 0 || dim > 3 || tag < INT32_MIN || tag > INT32_MAX)
        return fail(ErrorCode::Parse, "bad physical group dimension or tag");
      const std::string_view rest = c_.rest_of_line();
      const size_t a = rest.find('"'), b = rest.rfind('"');
      if (a == std::string_view::npos || b == a)
        return fail(ErrorCode::Parse, "physical name without double quotes");
      m_.physical_names.push_back({static_cast<int>(dim), static_cast<int>(tag), std::string(rest.substr(a + 1, b - a - 1))});
    }
    return expect("$EndPhysicalNames", " (does the count match the names?)");
  }

  Status read_entities() {
    have_entities_ = true;
    start_binary();
    int64_t cnt[4];
    for (int d = 0; d < 4; ++d)
      if (Status s = count_val(cnt[d], "an entity count"); !s) return s;
    for (int d = 0; d < 4; ++d) {
      if (Status s = binary_ ? (cnt[d] > static_cast<int64_t>(c_.remaining() / 36) ? fail_bin("absurd entity count")
                                                                                  : Status::success())
                             : check_count(cnt[d], 8, "entity");
          !s)
        return s;
      for (int64_t i = 0; i < cnt[d]; ++i) {
        int64_t tag = 0, nphys = 0;
        if (Status s = int_val(tag, "an entity tag"); !s) return s;
        if (tag < INT32_MIN || tag > INT32_MAX)
          return fail(ErrorCode::Parse, "entity tag " + std::to_string(tag) + " does not fit in 32 bits");
        const int nbox = d == 0 ? 3 : 6;
        for (int k = 0; k < nbox; ++k) {
          if (binary_) {
            if (!need(8)) return fail_bin("truncated $Entities");
            f64();
          } else {
            double x;
            if (Status s = real_tok(x, "an entity coordinate"); !s) return s;
          }
        }
        if (Status s = count_val(nphys, "a physical tag count"); !s) return s;
        if (nphys > static_cast<int64_t>(c_.remaining() / 2))
          return fail(ErrorCode::Parse, "absurd physical tag count " + std::to_string(nphys));
        TetMesh::GmshEntity ge;
        ge.dim = d;
        ge.tag = static_cast<int>(tag);
        entities_.insert({d, static_cast<int>(tag)});
        for (int64_t k = 0; k < nphys; ++k) {
          int64_t p = 0;
          if (Status s = int_val(p, "a physical tag"); !s) return s;
          // A physical tag becomes a ref (int32); 2^31 wrapped to -2^31 once.
          if (p < INT32_MIN || p > INT32_MAX)
            return fail(ErrorCode::Parse, "physical tag " + std::to_string(p) + " does not fit in 32 bits");
          if (k == 0) entity_phys_[{d, static_cast<int>(tag)}] = static_cast<int32_t>(p);
          ge.physicals.push_back(static_cast<int32_t>(p));
        }
        m_.gmsh_entities.push_back(std::move(ge));
        if (d > 0) {
          int64_t nb = 0;
          if (Status s = count_val(nb, "a bounding entity count"); !s) return s;
          if (nb > static_cast<int64_t>(c_.remaining() / 2))
            return fail(ErrorCode::Parse, "absurd bounding entity count " + std::to_string(nb));
          for (int64_t k = 0; k < nb; ++k) {
            int64_t b = 0;
            if (Status s = int_val(b, "a bounding entity tag"); !s) return s;
          }
        }
      }
    }
    return expect("$EndEntities", " (do the entity counts match the data?)");
  }

  Status begin_nodes(int64_t n) {
    if (have_nodes_) return fail(ErrorCode::Parse, "a second $Nodes section");
    if (have_elements_) return fail(ErrorCode::Parse, "$Nodes after $Elements");
    have_nodes_ = true;
    const size_t min_bytes = binary_ ? (version_ == 41 ? static_cast<size_t>(dsize_) + 24 : 28) : 8;
    if (Status s = check_count(n, min_bytes, "node"); !s) return s;
    if (n > INT32_MAX / 4) return fail(ErrorCode::Unsupported, "more than 2^29 nodes");
    size_t xyz = 0;
    if (!detail::ck_mul(static_cast<uint64_t>(n), uint64_t{4}, dense_limit_) || !detail::ck_add(dense_limit_, 1024, dense_limit_) ||
        !detail::ck_bytes(static_cast<uint64_t>(n), 3, 1, xyz))
      return fail(ErrorCode::Parse, "node count " + std::to_string(n) + " overflows");
    m_.xyz.reserve(xyz);
    return Status::success();
  }

  Status read_nodes22() {
    int64_t n = 0;
    if (Status s = int_tok(n, "the number of nodes"); !s) return s;
    if (Status s = begin_nodes(n); !s) return s;
    start_binary();
    for (int64_t i = 0; i < n; ++i) {
      int64_t tag = 0;
      double x, y, z;
      if (binary_) {
        if (!need(28)) return fail_bin("truncated $Nodes data (node " + std::to_string(i + 1) + ")");
        tag = i32();
        x = f64();
        y = f64();
        z = f64();
      } else {
        if (Status s = int_tok(tag, "a node tag"); !s) return s;
        if (Status s = real_tok(x, "a coordinate"); !s) return s;
        if (Status s = real_tok(y, "a coordinate"); !s) return s;
        if (Status s = real_tok(z, "a coordinate"); !s) return s;
      }
      if (Status s = add_node_tag(tag); !s) return s;
      if (Status s = add_point(x, y, z); !s) return s;
    }
    return expect("$EndNodes", " (does the node count match the data?)");
  }

  Status read_nodes41() {
    start_binary();
    int64_t nblocks = 0, n = 0, mn = 0, mx = 0;
    if (Status s = count_val(nblocks, "the number of node blocks"); !s) return s;
    if (Status s = count_val(n, "the number of nodes"); !s) return s;
    if (Status s = count_val(mn, "the minimum node tag"); !s) return s;
    if (Status s = count_val(mx, "the maximum node tag"); !s) return s;
    if (Status s = begin_nodes(n); !s) return s;
    if (Status s = check_count(nblocks, 8, "node block"); !s) return s;
    int64_t seen = 0;
    std::vector<int64_t> tags;
    for (int64_t b = 0; b < nblocks; ++b) {
      int64_t dim = 0, etag = 0, param = 0, cnt = 0;
      if (Status s = int_val(dim, "an entity dimension"); !s) return s;
      if (Status s = int_val(etag, "an entity tag"); !s) return s;
      if (Status s = int_val(param, "the parametric flag"); !s) return s;
      if (Status s = count_val(cnt, "the number of nodes in a block"); !s) return s;
      if (dim < 0 || dim > 3) return fail(ErrorCode::Parse, "entity dimension " + std::to_string(dim) + " in $Nodes");
      if (cnt > n - seen)
        return fail(ErrorCode::Parse, "node blocks hold more nodes than the declared " + std::to_string(n));
      const int per = 3 + (param ? static_cast<int>(dim) : 0);
      tags.resize(static_cast<size_t>(cnt));
      if (binary_) {
        if (!need_n(cnt, static_cast<size_t>(dsize_) + 8 * static_cast<size_t>(per)))
          return fail_bin("truncated $Nodes block " + std::to_string(b + 1));
        for (auto& t : tags) t = size_val();
        for (int64_t i = 0; i < cnt; ++i) {
          if (Status s = add_node_tag(tags[static_cast<size_t>(i)]); !s) return s;
          const double x = f64(), y = f64(), z = f64();
          for (int k = 3; k < per; ++k) f64();
          if (Status s = add_point(x, y, z); !s) return s;
        }
      } else {
        for (auto& t : tags)
          if (Status s = int_tok(t, "a node tag"); !s) return s;
        for (int64_t i = 0; i < cnt; ++i) {
          if (Status s = add_node_tag(tags[static_cast<size_t>(i)]); !s) return s;
          double x[6];
          for (int k = 0; k < per; ++k)
            if (Status s = real_tok(x[k], "a coordinate"); !s) return s;
          if (Status s = add_point(x[0], x[1], x[2]); !s) return s;
        }
      }
      seen += cnt;
    }
    if (seen != n)
      return fail(ErrorCode::Parse, "$Nodes declares " + std::to_string(n) + " nodes but its blocks hold " +
                                        std::to_string(seen));
    return expect("$EndNodes", " (do the node counts match the data?)");
  }

  Status begin_elements(int64_t n) {
    if (!have_nodes_) return fail(ErrorCode::Parse, "$Elements before $Nodes");
    if (have_elements_) return fail(ErrorCode::Parse, "a second $Elements section");
    have_elements_ = true;
    const size_t min_bytes = binary_ ? (version_ == 41 ? 2 * static_cast<size_t>(dsize_) : 8) : 6;
    return check_count(n, min_bytes, "element");
  }

  Status read_elements22() {
    if (!have_nodes_) return fail(ErrorCode::Parse, "$Elements before $Nodes");
    int64_t n = 0;
    if (Status s = int_tok(n, "the number of elements"); !s) return s;
    if (Status s = begin_elements(n); !s) return s;
    start_binary();
    int64_t tags[64], nodes[4];
    if (!binary_) {
      for (int64_t i = 0; i < n; ++i) {
        int64_t etag = 0, type = 0, ntags = 0;
        if (Status s = int_tok(etag, "an element tag"); !s) return s;
        if (Status s = int_tok(type, "an element type"); !s) return s;
        if (Status s = int_tok(ntags, "the number of element tags"); !s) return s;
        const int k = supported_nodes(type);
        if (k == 0) return unsupported_type(type);
        if (ntags < 0 || ntags > 64) return fail(ErrorCode::Parse, "absurd element tag count " + std::to_string(ntags));
        for (int64_t j = 0; j < ntags; ++j)
          if (Status s = int_tok(tags[j], "an element tag"); !s) return s;
        for (int j = 0; j < k; ++j)
          if (Status s = int_tok(nodes[j], "a node tag"); !s) return s;
        const int64_t phys = ntags >= 1 ? tags[0] : 0, elem = ntags >= 2 ? tags[1] : 0;
        if (Status s = add_element(etag, type, nodes, phys != 0 ? phys : elem, elem); !s) return s;
        if (ntags >= 2) note22(type, phys, elem);
      }
    } else {
      int64_t done = 0;
      while (done < n) {
        if (!need(12)) return fail_bin("truncated $Elements header");
        const int64_t type = i32(), cnt = i32(), ntags = i32();
        const int k = supported_nodes(type);
        if (k == 0) return unsupported_type(type);
        if (cnt <= 0 || cnt > n - done) return fail_bin("element block count " + std::to_string(cnt) + " is out of range");
        if (ntags < 0 || ntags > 64) return fail_bin("absurd element tag count " + std::to_string(ntags));
        const size_t per = 4 * static_cast<size_t>(1 + ntags + k);
        if (!need_n(cnt, per)) return fail_bin("truncated $Elements data");
        for (int64_t e = 0; e < cnt; ++e) {
          const int64_t etag = i32();
          for (int64_t j = 0; j < ntags; ++j) tags[j] = i32();
          for (int j = 0; j < k; ++j) nodes[j] = i32();
          const int64_t phys = ntags >= 1 ? tags[0] : 0, elem = ntags >= 2 ? tags[1] : 0;
          if (Status s = add_element(etag, type, nodes, phys != 0 ? phys : elem, elem); !s) return s;
          if (ntags >= 2) note22(type, phys, elem);
        }
        done += cnt;
      }
    }
    return expect("$EndElements", " (does the element count match the data?)");
  }

  Status read_elements41() {
    if (!have_nodes_) return fail(ErrorCode::Parse, "$Elements before $Nodes");
    start_binary();
    int64_t nblocks = 0, n = 0, mn = 0, mx = 0;
    if (Status s = count_val(nblocks, "the number of element blocks"); !s) return s;
    if (Status s = count_val(n, "the number of elements"); !s) return s;
    if (Status s = count_val(mn, "the minimum element tag"); !s) return s;
    if (Status s = count_val(mx, "the maximum element tag"); !s) return s;
    if (Status s = begin_elements(n); !s) return s;
    if (Status s = check_count(nblocks, 8, "element block"); !s) return s;
    int64_t seen = 0;
    int64_t rec[5];
    for (int64_t b = 0; b < nblocks; ++b) {
      int64_t dim = 0, etag = 0, type = 0, cnt = 0;
      if (Status s = int_val(dim, "an entity dimension"); !s) return s;
      if (Status s = int_val(etag, "an entity tag"); !s) return s;
      if (Status s = int_val(type, "an element type"); !s) return s;
      if (Status s = count_val(cnt, "the number of elements in a block"); !s) return s;
      const int k = supported_nodes(type);
      if (k == 0) return unsupported_type(type);
      if (cnt > n - seen)
        return fail(ErrorCode::Parse, "element blocks hold more elements than the declared " + std::to_string(n));
      // An element block in an entity that $Entities does not list: Gmsh
      // refuses the file ("Unknown entity"); its physical groups are unknown.
      if (have_entities_ && (dim < 0 || dim > 3 || etag < INT32_MIN || etag > INT32_MAX ||
                             !entities_.count({static_cast<int>(dim), static_cast<int>(etag)})))
        return fail(ErrorCode::Parse, "element block " + std::to_string(b + 1) + " is in entity " +
                                          std::to_string(etag) + " of dimension " + std::to_string(dim) +
                                          ", which $Entities does not list");
      int64_t ref = etag;
      if (const auto it = entity_phys_.find({static_cast<int>(dim), static_cast<int>(etag)}); it != entity_phys_.end())
        ref = it->second;
      if (binary_) {
        if (!need_n(cnt, static_cast<size_t>(dsize_) * static_cast<size_t>(k + 1)))
          return fail_bin("truncated $Elements block " + std::to_string(b + 1));
        for (int64_t e = 0; e < cnt; ++e) {
          for (int j = 0; j <= k; ++j) rec[j] = size_val();
          if (Status s = add_element(rec[0], type, rec + 1, ref, etag); !s) return s;
        }
      } else {
        for (int64_t e = 0; e < cnt; ++e) {
          for (int j = 0; j <= k; ++j)
            if (Status s = int_tok(rec[j], j == 0 ? "an element tag" : "a node tag"); !s) return s;
          if (Status s = add_element(rec[0], type, rec + 1, ref, etag); !s) return s;
        }
      }
      seen += cnt;
    }
    if (seen != n)
      return fail(ErrorCode::Parse, "$Elements declares " + std::to_string(n) + " elements but its blocks hold " +
                                        std::to_string(seen));
    return expect("$EndElements", " (do the element counts match the data?)");
  }
};

// ---------------------------------------------------------------- writer

/// One run of consecutive elements of the same type and entity: a 4.1 block.
struct Block {
  int dim = 3, type = 4, entity = 0;
  int32_t first = 0, count = 0;  // into the per-type element list
};

/// A geometric entity of the 4.1 $Entities section.
struct Entity {
  int dim = 3, tag = 0;
  std::vector<int32_t> phys;  // physical tags written (usually one: the ref)
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  bool box_set = false;
};

class GmshWriter {
 public:
  GmshWriter(const TetMesh& m, std::string& out, bool binary) : m_(m), out_(out), binary_(binary) {}

  Status write22() {
    out_ += binary_ ? "$MeshFormat\n2.2 1 8\n" : "$MeshFormat\n2.2 0 8\n";
    if (binary_) {
      gvscan::store<int32_t>(out_, 1, false);
      out_ += '\n';
    }
    out_ += "$EndMeshFormat\n";
    write_physical_names();
    const int32_t nv = m_.nv();
    out_ += "$Nodes\n";
    gvscan::put_int(out_, nv);
    out_ += '\n';
    for (int32_t v = 0; v < nv; ++v) {
      const double* p = m_.point(v);
      if (binary_) {
        gvscan::store<int32_t>(out_, v + 1, false);
        for (int k = 0; k < 3; ++k) gvscan::store<double>(out_, p[k], false);
      } else {
        gvscan::put_int(out_, v + 1);
        for (int k = 0; k < 3; ++k) {
          out_ += ' ';
          gvscan::put_double(out_, p[k]);
        }
        out_ += '\n';
      }
    }
    if (binary_) out_ += '\n';
    out_ += "$EndNodes\n$Elements\n";
    const size_t nc = m_.corners.size(), ne = m_.edges.size() / 2;
    const int32_t ntri = m_.ntri(), nt = m_.nt();
    gvscan::put_int(out_, static_cast<int64_t>(nc + ne) + ntri + nt);
    out_ += '\n';
    int64_t id = 0;
    // Binary 2.2: one header (type, count, 2 tags) per element type.
    auto header = [&](int type, int64_t count) {
      if (!binary_ || count == 0) return;
      gvscan::store<int32_t>(out_, type, false);
      gvscan::store<int32_t>(out_, static_cast<int32_t>(count), false);
      gvscan::store<int32_t>(out_, 2, false);
    };
    auto element = [&](int type, int32_t phys, int32_t elem, const int32_t* v, int k) {
      ++id;
      if (binary_) {
        gvscan::store<int32_t>(out_, static_cast<int32_t>(id), false);
        gvscan::store<int32_t>(out_, phys, false);
        gvscan::store<int32_t>(out_, elem, false);
        for (int j = 0; j < k; ++j) gvscan::store<int32_t>(out_, v[j] + 1, false);
      } else {
        gvscan::put_int(out_, id);
        out_ += ' ';
        gvscan::put_int(out_, type);
        out_ += " 2 ";
        gvscan::put_int(out_, phys);
        out_ += ' ';
        gvscan::put_int(out_, elem);
        for (int j = 0; j < k; ++j) {
          out_ += ' ';
          gvscan::put_int(out_, v[j] + 1);
        }
        out_ += '\n';
      }
    };
    header(15, static_cast<int64_t>(nc));
    for (size_t i = 0; i < nc; ++i) {
      const int32_t r = corner_ref(i);
      if (r > 0) element(15, phys22(0, r, r), r, &m_.corners[i], 1);
      else element(15, 0, static_cast<int32_t>(i + 1), &m_.corners[i], 1);
    }
    header(1, static_cast<int64_t>(ne));
    for (size_t i = 0; i < ne; ++i) {
      const int32_t r = edge_ref(i);
      element(1, phys22(1, std::max(r, 0), r), std::max(r, 0), &m_.edges[2 * i], 2);
    }
    header(2, ntri);
    for (int32_t i = 0; i < ntri; ++i) {
      const int32_t r = tri_ref(i), e = elementary(m_.tri_entity, ntri, i, r);
      element(2, phys22(2, e, r), e, &m_.tris[3 * static_cast<size_t>(i)], 3);
    }
    header(4, nt);
    for (int32_t t = 0; t < nt; ++t) {
      int32_t v[4];
      detail::file_tet(m_, t, Format::Gmsh, v);
      const int32_t r = tet_ref(t), e = elementary(m_.tet_entity, nt, t, r);
      element(4, phys22(3, e, r), e, v, 4);
    }
    if (binary_) out_ += '\n';
    out_ += "$EndElements\n";
    return Status::success();
  }

  Status write41() {
    out_ += binary_ ? "$MeshFormat\n4.1 1 8\n" : "$MeshFormat\n4.1 0 8\n";
    if (binary_) {
      gvscan::store<int32_t>(out_, 1, false);
      out_ += '\n';
    }
    out_ += "$EndMeshFormat\n";
    write_physical_names();

    // Entities: one per distinct (dim, entity tag, ref); element runs of the
    // same entity become blocks, so the element order survives.  Every
    // entity lists exactly one physical tag, its ref (0 included: gmsh keeps
    // physical 0 in 4.1, and meshio needs a physical tag on every block),
    // except where the file read said otherwise (physicals_of): an entity in
    // two groups, or in none; a file with no physical tag at all gets none
    // back, points included (meshio reads a file where no block has one).
    const int32_t nt = m_.nt(), ntri = m_.ntri();
    const int32_t ne = static_cast<int32_t>(m_.edges.size() / 2), nc = static_cast<int32_t>(m_.corners.size());
    std::vector<Entity> ents;
    std::vector<Block> blocks;
    // One point entity per corner, tagged with its ref where that is
    // positive and not taken by an earlier corner (with the physical tags
    // physicals_of gives), else with a fresh tag above every corner ref.
    int32_t fresh = 1;
    for (int32_t i = 0; i < nc; ++i) fresh = std::max(fresh, corner_ref(static_cast<size_t>(i)) + 1);
    std::set<int32_t> point_tags;
    for (int32_t i = 0; i < nc; ++i) {
      Entity e;
      e.dim = 0;
      const int32_t r = corner_ref(static_cast<size_t>(i));
      if (r > 0 && point_tags.insert(r).second) {
        e.tag = r;
        e.phys = physicals_of(0, r, r);
      } else {
        e.tag = fresh++;
        if (!no_physicals_read()) e.phys = {std::max(r, 0)};
      }
      grow(e, m_.corners[static_cast<size_t>(i)]);
      ents.push_back(e);
      blocks.push_back({0, 15, e.tag, i, 1});
    }
    assign(1, 1, ne, [&](int32_t i) { return edge_ref(static_cast<size_t>(i)); }, nullptr,
           [&](int32_t i, Entity& e) { grow(e, m_.edges[2 * static_cast<size_t>(i)]); grow(e, m_.edges[2 * static_cast<size_t>(i) + 1]); },
           ents, blocks);
    assign(2, 2, ntri, [&](int32_t i) { return tri_ref(i); }, &m_.tri_entity,
           [&](int32_t i, Entity& e) { for (int k = 0; k < 3; ++k) grow(e, m_.tris[3 * static_cast<size_t>(i) + k]); },
           ents, blocks);
    assign(3, 4, nt, [&](int32_t i) { return tet_ref(i); }, &m_.tet_entity,
           [&](int32_t i, Entity& e) { for (int k = 0; k < 4; ++k) grow(e, m_.tets[4 * static_cast<size_t>(i) + k]); },
           ents, blocks);
    int vol_tag = -1;
    for (const Entity& e : ents)
      if (e.dim == 3) {
        vol_tag = e.tag;
        break;
      }
    if (vol_tag < 0) return Status::error(ErrorCode::InvalidMesh, "the mesh has no tetrahedra to write");

    // $Entities
    out_ += "$Entities\n";
    int64_t cnt[4] = {0, 0, 0, 0};
    for (const Entity& e : ents) ++cnt[e.dim];
    if (binary_) {
      for (int d = 0; d < 4; ++d) gvscan::store<uint64_t>(out_, static_cast<uint64_t>(cnt[d]), false);
    } else {
      for (int d = 0; d < 4; ++d) {
        gvscan::put_int(out_, cnt[d]);
        out_ += d < 3 ? ' ' : '\n';
      }
    }
    for (int d = 0; d < 4; ++d)
      for (const Entity& e : ents) {
        if (e.dim != d) continue;
        if (binary_) {
          gvscan::store<int32_t>(out_, e.tag, false);
          for (int k = 0; k < 3; ++k) gvscan::store<double>(out_, e.lo[k], false);
          if (d > 0)
            for (int k = 0; k < 3; ++k) gvscan::store<double>(out_, e.hi[k], false);
          gvscan::store<uint64_t>(out_, e.phys.size(), false);
          for (const int32_t p : e.phys) gvscan::store<int32_t>(out_, p, false);
          if (d > 0) gvscan::store<uint64_t>(out_, 0, false);
        } else {
          gvscan::put_int(out_, e.tag);
          for (int k = 0; k < 3; ++k) {
            out_ += ' ';
            gvscan::put_double(out_, e.lo[k]);
          }
          if (d > 0)
            for (int k = 0; k < 3; ++k) {
              out_ += ' ';
              gvscan::put_double(out_, e.hi[k]);
            }
          out_ += ' ';
          gvscan::put_int(out_, static_cast<int64_t>(e.phys.size()));
          for (const int32_t p : e.phys) {
            out_ += ' ';
            gvscan::put_int(out_, p);
          }
          out_ += d == 0 ? "\n" : " 0\n";
        }
      }
    if (binary_) out_ += '\n';
    out_ += "$EndEntities\n";

    // $Nodes: one block in the first volume entity.
    const int32_t nv = m_.nv();
    out_ += "$Nodes\n";
    if (binary_) {
      gvscan::store<uint64_t>(out_, nv > 0 ? 1 : 0, false);
      gvscan::store<uint64_t>(out_, static_cast<uint64_t>(nv), false);
      gvscan::store<uint64_t>(out_, nv > 0 ? 1 : 0, false);
      gvscan::store<uint64_t>(out_, static_cast<uint64_t>(nv), false);
      if (nv > 0) {
        gvscan::store<int32_t>(out_, 3, false);
        gvscan::store<int32_t>(out_, vol_tag, false);
        gvscan::store<int32_t>(out_, 0, false);
        gvscan::store<uint64_t>(out_, static_cast<uint64_t>(nv), false);
        for (int32_t v = 0; v < nv; ++v) gvscan::store<uint64_t>(out_, static_cast<uint64_t>(v) + 1, false);
        for (int32_t v = 0; v < nv; ++v)
          for (int k = 0; k < 3; ++k) gvscan::store<double>(out_, m_.point(v)[k], false);
      }
      out_ += '\n';
    } else {
      out_ += nv > 0 ? "1 " : "0 ";
      gvscan::put_int(out_, nv);
      out_ += nv > 0 ? " 1 " : " 0 ";
      gvscan::put_int(out_, nv);
      out_ += '\n';
      if (nv > 0) {
        out_ += "3 ";
        gvscan::put_int(out_, vol_tag);
        out_ += " 0 ";
        gvscan::put_int(out_, nv);
        out_ += '\n';
        for (int32_t v = 0; v < nv; ++v) {
          gvscan::put_int(out_, v + 1);
          out_ += '\n';
        }
        for (int32_t v = 0; v < nv; ++v) {
          const double* p = m_.point(v);
          gvscan::put_double(out_, p[0]);
          out_ += ' ';
          gvscan::put_double(out_, p[1]);
          out_ += ' ';
          gvscan::put_double(out_, p[2]);
          out_ += '\n';
        }
      }
    }
    out_ += "$EndNodes\n";

    // $Elements
    const int64_t total = static_cast<int64_t>(nc) + ne + ntri + nt;
    out_ += "$Elements\n";
    if (binary_) {
      gvscan::store<uint64_t>(out_, blocks.size(), false);
      gvscan::store<uint64_t>(out_, static_cast<uint64_t>(total), false);
      gvscan::store<uint64_t>(out_, total > 0 ? 1 : 0, false);
      gvscan::store<uint64_t>(out_, static_cast<uint64_t>(total), false);
    } else {
      gvscan::put_int(out_, static_cast<int64_t>(blocks.size()));
      out_ += ' ';
      gvscan::put_int(out_, total);
      out_ += total > 0 ? " 1 " : " 0 ";
      gvscan::put_int(out_, total);
      out_ += '\n';
    }
    int64_t id = 0;
    for (const Block& b : blocks) {
      if (binary_) {
        gvscan::store<int32_t>(out_, b.dim, false);
        gvscan::store<int32_t>(out_, b.entity, false);
        gvscan::store<int32_t>(out_, b.type, false);
        gvscan::store<uint64_t>(out_, static_cast<uint64_t>(b.count), false);
      } else {
        gvscan::put_int(out_, b.dim);
        out_ += ' ';
        gvscan::put_int(out_, b.entity);
        out_ += ' ';
        gvscan::put_int(out_, b.type);
        out_ += ' ';
        gvscan::put_int(out_, b.count);
        out_ += '\n';
      }
      for (int32_t i = b.first; i < b.first + b.count; ++i) {
        int32_t v[4];
        int k = 0;
        switch (b.type) {
          case 15: v[0] = m_.corners[static_cast<size_t>(i)]; k = 1; break;
          case 1: v[0] = m_.edges[2 * static_cast<size_t>(i)]; v[1] = m_.edges[2 * static_cast<size_t>(i) + 1]; k = 2; break;
          case 2: for (int j = 0; j < 3; ++j) v[j] = m_.tris[3 * static_cast<size_t>(i) + j]; k = 3; break;
          default: detail::file_tet(m_, i, Format::Gmsh, v); k = 4; break;
        }
        ++id;
        if (binary_) {
          gvscan::store<uint64_t>(out_, static_cast<uint64_t>(id), false);
          for (int j = 0; j < k; ++j) gvscan::store<uint64_t>(out_, static_cast<uint64_t>(v[j]) + 1, false);
        } else {
          gvscan::put_int(out_, id);
          for (int j = 0; j < k; ++j) {
            out_ += ' ';
            gvscan::put_int(out_, v[j] + 1);
          }
          out_ += '\n';
        }
      }
    }
    if (binary_) out_ += '\n';
    out_ += "$EndElements\n";
    return Status::success();
  }

 private:
  const TetMesh& m_;
  std::string& out_;
  bool binary_;

  int32_t tet_ref(int32_t t) const { return static_cast<size_t>(t) < m_.tet_ref.size() ? m_.tet_ref[static_cast<size_t>(t)] : 0; }
  int32_t tri_ref(int32_t i) const { return static_cast<size_t>(i) < m_.tri_ref.size() ? m_.tri_ref[static_cast<size_t>(i)] : 0; }
  int32_t edge_ref(size_t i) const { return i < m_.edge_ref.size() ? m_.edge_ref[i] : 0; }
  static int32_t elementary(const std::vector<int32_t>& ent, int32_t n, int32_t i, int32_t ref) {
    if (ent.size() == static_cast<size_t>(n)) return ent[static_cast<size_t>(i)];
    return std::max(ref, 0);
  }

  void grow(Entity& e, int32_t v) const {
    const double* p = m_.point(v);
    for (int k = 0; k < 3; ++k) {
      if (!e.box_set || p[k] < e.lo[k]) e.lo[k] = p[k];
      if (!e.box_set || p[k] > e.hi[k]) e.hi[k] = p[k];
    }
    e.box_set = true;
  }

  void write_physical_names() {
    if (m_.physical_names.empty()) return;
    out_ += "$PhysicalNames\n";
    gvscan::put_int(out_, static_cast<int64_t>(m_.physical_names.size()));
    out_ += '\n';
    for (const PhysicalName& p : m_.physical_names) {
      gvscan::put_int(out_, p.dim);
      out_ += ' ';
      gvscan::put_int(out_, p.tag);
      out_ += " \"";
      for (char ch : p.name) out_ += (ch == '"' || ch == '\n' || ch == '\r') ? '_' : ch;
      out_ += "\"\n";
    }
    out_ += "$EndPhysicalNames\n";
  }

  /// The physical tags of an entity written with (dim, tag) and ref r: those
  /// of the same entity in the file read, when r is theirs (the first of
  /// them, or the entity tag when it had none: the reader's refs), so an
  /// entity in two physical groups, or in none, stays so; otherwise {r}.
  std::vector<int32_t> physicals_of(int dim, int tag, int32_t r) {
    if (read_ents_.empty() && !m_.gmsh_entities.empty())
      for (const TetMesh::GmshEntity& g : m_.gmsh_entities) read_ents_.emplace(std::make_pair(g.dim, g.tag), &g.physicals);
    if (const auto it = read_ents_.find({dim, tag}); it != read_ents_.end()) {
      const std::vector<int32_t>& p = *it->second;
      if (p.empty() ? r == tag : p[0] == r) return p;
    }
    return {r};
  }
  std::map<std::pair<int, int>, const std::vector<int32_t>*> read_ents_;
  /// A corner's ref: its vertex's (a point element's tag when read from
  /// Gmsh), 0 when the mesh has no vertex refs.
  int32_t corner_ref(size_t i) const {
    const int32_t v = m_.corners[i];
    return m_.vert_ref.size() == static_cast<size_t>(m_.nv()) ? m_.vert_ref[static_cast<size_t>(v)] : 0;
  }
  /// 2.2: the physical tag of an element with ref r in entity (dim, tag):
  /// 0 when the file read had that entity in no physical group and r is its
  /// tag (the reader's ref), else r.
  int32_t phys22(int dim, int tag, int32_t r) {
    if (m_.gmsh_entities.empty()) return r;
    if (dim != p22_dim_ || tag != p22_tag_) {  // runs of one entity: one lookup
      p22_dim_ = dim;
      p22_tag_ = tag;
      p22_none_ = physicals_of(dim, tag, tag).empty();
    }
    return p22_none_ && r == tag ? 0 : r;
  }
  int p22_dim_ = -1, p22_tag_ = 0;
  bool p22_none_ = false;
  /// Whether an entity of dimension dim in the file read was in physical
  /// group p.
  bool physical_read(int dim, int32_t p) const {
    return std::any_of(m_.gmsh_entities.begin(), m_.gmsh_entities.end(), [&](const TetMesh::GmshEntity& g) {
      return g.dim == dim && std::find(g.physicals.begin(), g.physicals.end(), p) != g.physicals.end();
    });
  }
  /// Whether the file read listed entities and none of them had a physical
  /// tag (4.1: its points then get none either).
  bool no_physicals_read() const {
    return !m_.gmsh_entities.empty() &&
           std::all_of(m_.gmsh_entities.begin(), m_.gmsh_entities.end(),
                       [](const TetMesh::GmshEntity& g) { return g.physicals.empty(); });
  }

  /// Gives each element of one dimension an entity tag: its own entity tag
  /// when it has one (else its ref when positive), unless that tag already
  /// names an entity with a different ref, in which case a fresh tag is used.
  /// Each entity carries its ref as its one physical tag, or the physical
  /// tags the file gave it (physicals_of).
  template <class RefFn, class GrowFn>
  void assign(int dim, int type, int32_t n, RefFn ref_of, const std::vector<int32_t>* given, GrowFn grow_fn,
              std::vector<Entity>& ents, std::vector<Block>& blocks) {
    if (n == 0) return;
    const bool have_given = given && given->size() == static_cast<size_t>(n);
    auto desired = [&](int32_t i, int32_t r) -> int32_t {
      if (have_given && (*given)[static_cast<size_t>(i)] > 0) return (*given)[static_cast<size_t>(i)];
      return r > 0 ? r : 0;
    };
    // Fresh tags start above every wanted one; in 64 bits, since a wanted
    // tag may be INT32_MAX (a fuzzed file: desired + 1 overflowed int32).
    // Past INT32_MAX, a fresh tag is the smallest positive one that no
    // element wants and none uses yet.
    int64_t next = 1;
    for (int32_t i = 0; i < n; ++i) next = std::max<int64_t>(next, int64_t{desired(i, ref_of(i))} + 1);
    std::set<int32_t> wanted;
    int32_t low = 1;
    if (next > INT32_MAX)
      for (int32_t i = 0; i < n; ++i) wanted.insert(desired(i, ref_of(i)));
    std::map<std::pair<int32_t, int32_t>, size_t> key_to_ent;  // (desired, ref) -> index in ents
    std::map<int32_t, bool> used;
    std::pair<int32_t, int32_t> last_key{-1, -1};
    size_t last_ent = 0;
    for (int32_t i = 0; i < n; ++i) {
      const int32_t r = ref_of(i);
      const std::pair<int32_t, int32_t> key{desired(i, r), r};
      size_t ei;
      if (i > 0 && key == last_key) {
        ei = last_ent;
      } else if (const auto it = key_to_ent.find(key); it != key_to_ent.end()) {
        ei = it->second;
      } else {
        int32_t tag = key.first;
        if (tag <= 0 || used.count(tag)) {
          if (next <= INT32_MAX) {
            tag = static_cast<int32_t>(next++);
          } else {
            while (wanted.count(low) || used.count(low)) ++low;
            tag = low++;
          }
        }
        used[tag] = true;
        Entity e;
        e.dim = dim;
        e.tag = tag;
        // Only an element that carries this entity tag from the file (tets,
        // listed triangles) is in the file's entity: a listed edge's entity
        // tag is its ref, which may be another line entity's tag, whose list
        // would drop the edge's group.
        e.phys = have_given && (*given)[static_cast<size_t>(i)] == tag ? physicals_of(dim, tag, r)
                                                                        : std::vector<int32_t>{r};
        // An edge (no entity tags kept: its entity tag is its ref) whose
        // curve the file read had in no physical group keeps none, unless
        // another curve of that file was in physical group r (the ref may
        // be that group's: both read as r).
        if (!given && tag == r && physicals_of(dim, tag, r).empty() && !physical_read(dim, r)) e.phys.clear();
        ents.push_back(e);
        ei = ents.size() - 1;
        key_to_ent[key] = ei;
      }
      grow_fn(i, ents[ei]);
      if (!blocks.empty() && blocks.back().dim == dim && blocks.back().entity == ents[ei].tag &&
          blocks.back().first + blocks.back().count == i) {
        ++blocks.back().count;
      } else {
        blocks.push_back({dim, type, ents[ei].tag, i, 1});
      }
      last_key = key;
      last_ent = ei;
    }
  }
};

}  // namespace

Status parse_gmsh(std::string_view data, const std::string& name, TetMesh& m) {
  m = TetMesh{};
  GmshReader r(data, name, m);
  Status s = r.run();
  if (!s) m = TetMesh{};
  return s;
}

Status format_gmsh(const TetMesh& m, std::string& out, int version, bool binary) {
  out.clear();
  if (m.nt() == 0) return Status::error(ErrorCode::InvalidMesh, "the mesh has no tetrahedra to write");
  GmshWriter w(m, out, binary);
  if (version == 22) return w.write22();
  if (version == 41) return w.write41();
  return Status::error(ErrorCode::Unsupported,
                       "Gmsh version " + std::to_string(version) + " cannot be written (use 22 or 41)");
}

}  // namespace tetopt
