// TetGen .node / .ele / .face reader and writer.
//
// Format reference: H. Si, "TetGen, a Delaunay-based quality tetrahedral mesh
// generator", ACM TOMS 41(2), 2015, and the TetGen 1.6 user manual, section
// "File formats" (written here from that text):
//   .node  first line: <#points> <dimension (3)> <#attributes> <#boundary markers (0 or 1)>
//          then: <point id> <x> <y> <z> [attributes] [boundary marker]
//   .ele   first line: <#tetrahedra> <nodes per tet (4)> <#attributes>
//          then: <tet id> <n1> <n2> <n3> <n4> [attributes]   (attribute 1 = region)
//   .face  first line: <#faces> <#boundary markers (0 or 1)>
//          then: <face id> <n1> <n2> <n3> [boundary marker]
// One record per line, '#' starts a comment, the first point id (0 or 1)
// fixes the numbering of every file.  Like TetGen's own reader, missing
// trailing attributes / markers read as 0 and extra columns are ignored;
// missing coordinates or vertex ids are errors.  Point ids must be
// consecutive, since the other files refer to points by id.  A record after
// the count of the header is an error (the count would drop it unseen).
//
// Orientation: TetGen 1.5 writes .ele tets with a positive right-hand
// determinant, as conventions.hpp; Stellar's files (e.g. house2) use the
// negative one.  The reader keeps the file's order (read_mesh normalises by
// majority), the writer uses detail::file_tet(Format::TetGen): the file's own
// convention for a mesh read from .node/.ele, positive otherwise.
//
// What tetopt keeps: point markers -> vert_ref, the first tet attribute (the
// region) -> tet_ref, faces -> tris / tri_ref.  Point attributes and further
// tet attributes are not kept.
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <new>
#include <string>
#include <string_view>
#include <vector>

#include "io/checked.hpp"
#include "io/common.hpp"
#include "tetopt/io.hpp"

namespace tetopt {

namespace {

constexpr int64_t kMaxId = std::numeric_limits<int32_t>::max();

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v' || c == ','; }

std::string shorten(std::string_view t) { return detail::shown_token(t, false); }

/// Non-empty lines with '#' comments removed, split into tokens.
class LineReader {
 public:
  explicit LineReader(std::string_view d) : d_(d) {}

  /// Next line holding at least one token; false at the end of the data.
  bool next() {
    while (pos_ < d_.size()) {
      size_t e = d_.find('\n', pos_);
      if (e == std::string_view::npos) e = d_.size();
      std::string_view l = d_.substr(pos_, e - pos_);
      pos_ = e + 1;
      ++line_;
      const size_t h = l.find('#');
      if (h != std::string_view::npos) l = l.substr(0, h);
      tokens_.clear();
      size_t i = 0;
      while (i < l.size()) {
        while (i < l.size() && is_space(l[i])) ++i;
        const size_t b = i;
        while (i < l.size() && !is_space(l[i])) ++i;
        if (i > b) tokens_.push_back(l.substr(b, i - b));
      }
      if (!tokens_.empty()) return true;
    }
    return false;
  }
  long line() const { return line_; }
  size_t remaining() const { return pos_ < d_.size() ? d_.size() - pos_ : 0; }
  size_t size() const { return tokens_.size(); }
  std::string_view tok(size_t i) const { return tokens_[i]; }

  bool integer(size_t i, int64_t& v) const {
    std::string_view t = tokens_[i];
    if (!t.empty() && t[0] == '+') t.remove_prefix(1);
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    return r.ec == std::errc{} && r.ptr == t.data() + t.size();
  }
  bool real(size_t i, double& v) const {
    std::string_view t = tokens_[i];
    if (!t.empty() && t[0] == '+') t.remove_prefix(1);
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ptr != t.data() + t.size() || t.empty()) return false;
    if (r.ec == std::errc::result_out_of_range) {  // underflow reads as 0, overflow fails
      const std::string s(t);
      v = std::strtod(s.c_str(), nullptr);
      return !std::isinf(v);
    }
    return r.ec == std::errc{};
  }

 private:
  std::string_view d_;
  size_t pos_ = 0;
  long line_ = 0;
  std::vector<std::string_view> tokens_;
};

class TetgenReader {
 public:
  TetgenReader(const std::string& base) : base_(base) {}

  Status run(std::string_view node, std::string_view ele, std::string_view face, TetMesh& out) {
    if (Status s = read_node(node); !s) return s;
    if (Status s = read_ele(ele); !s) return s;
    if (!face.empty())
      if (Status s = read_face(face); !s) return s;
    out = std::move(m_);
    return Status::success();
  }

 private:
  Status fail(ErrorCode c, const char* ext, long line, const std::string& what) const {
    if (line > 0) return Status::error(c, base_ + ext + ":" + std::to_string(line) + ": " + what, line);
    return Status::error(c, base_ + ext + ": " + what);
  }
  Status not_integer(const char* ext, const LineReader& r, size_t i, const char* what) const {
    return fail(ErrorCode::Parse, ext, r.line(), std::string("expected ") + what + ", found '" + shorten(r.tok(i)) + "'");
  }

  /// Reads an integer header field at token i (default when the line is short).
  Status header_int(const char* ext, const LineReader& r, size_t i, int64_t def, const char* what, int64_t& v) const {
    v = def;
    if (i >= r.size()) return Status::success();
    if (!r.integer(i, v)) return not_integer(ext, r, i, what);
    return Status::success();
  }

  /// Checks a record count against the rest of the file (each record is at
  /// least `min_tokens` tokens of 2 bytes) before anything is allocated.
  Status check_count(const char* ext, const LineReader& r, int64_t n, int min_tokens, const char* what) const {
    if (n < 0) return fail(ErrorCode::Parse, ext, r.line(), std::string("negative number of ") + what);
    const uint64_t room = (static_cast<uint64_t>(r.remaining()) + 1) / (2 * static_cast<uint64_t>(min_tokens));
    if (static_cast<uint64_t>(n) > room)
      return fail(ErrorCode::Parse, ext, r.line(),
                  std::to_string(n) + " " + what + " claimed, more than the rest of the file can hold (" +
                      std::to_string(room) + " at most): truncated file or lying count");
    if (n > kMaxId) return fail(ErrorCode::Unsupported, ext, r.line(), std::string("too many ") + what + " for 32-bit ids");
    return Status::success();
  }

  Status truncated(const char* ext, const LineReader& r, int64_t got, int64_t n, const char* what) const {
    return fail(ErrorCode::Parse, ext, r.line(),
                "the header claims " + std::to_string(n) + " " + what + " but the file ends after " +
                    std::to_string(got) + " (truncated file or lying count)");
  }

  /// After the n records the header claims, only comments and blank lines may
  /// follow: a further record means a count that is too small (its records
  /// would be dropped without a word).
  Status no_more(const char* ext, LineReader& r, int64_t n, const char* what) const {
    if (!r.next()) return Status::success();
    return fail(ErrorCode::Parse, ext, r.line(),
                "a record after the " + std::to_string(n) + " " + what +
                    " the header claims (lying count, or two files run together)");
  }

  /// Reads a vertex id at token i into a 0-based index.
  Status vertex_id(const char* ext, const LineReader& r, size_t i, int32_t& v) const {
    int64_t x = 0;
    if (!r.integer(i, x)) return not_integer(ext, r, i, "a vertex id");
    const int64_t nv = m_.nv();
    if (x < base_id_ || x - base_id_ >= nv)
      return fail(ErrorCode::InvalidMesh, ext, r.line(),
                  "vertex id " + std::to_string(x) + " out of range " + std::to_string(base_id_) + ".." +
                      std::to_string(base_id_ + nv - 1));
    v = static_cast<int32_t>(x - base_id_);
    return Status::success();
  }

  Status read_node(std::string_view data) {
    const char* ext = ".node";
    LineReader r(data);
    if (!r.next()) return fail(ErrorCode::Parse, ext, 0, "empty file (no header line)");
    int64_t n = 0, dim = 3, nattr = 0, nbm = 0;
    if (!r.integer(0, n)) return not_integer(ext, r, 0, "the number of points");
    if (Status s = header_int(ext, r, 1, 3, "the dimension", dim); !s) return s;
    if (Status s = header_int(ext, r, 2, 0, "the number of attributes", nattr); !s) return s;
    if (Status s = header_int(ext, r, 3, 0, "the number of boundary markers", nbm); !s) return s;
    if (dim == 2) return fail(ErrorCode::Unsupported, ext, r.line(), "2-D mesh (dimension 2): tetopt needs dimension 3");
    if (dim != 3) return fail(ErrorCode::Parse, ext, r.line(), "dimension " + std::to_string(dim) + ": expected 3");
    if (nattr < 0 || nattr > 1000000)
      return fail(ErrorCode::Parse, ext, r.line(), "bad number of attributes " + std::to_string(nattr));
    if (nbm != 0 && nbm != 1)
      return fail(ErrorCode::Parse, ext, r.line(), "bad number of boundary markers " + std::to_string(nbm) + " (0 or 1)");
    if (n == 0)
      return fail(ErrorCode::Unsupported, ext, r.line(),
                  "no points (points listed in a .poly / .smesh file are not supported)");
    if (Status s = check_count(ext, r, n, 4, "points"); !s) return s;
    m_.xyz.reserve(detail::ck_size(n, 3));
    if (nbm) m_.vert_ref.reserve(detail::ck_size(n, 1));
    for (int64_t i = 0; i < n; ++i) {
      if (!r.next()) return truncated(ext, r, i, n, "points");
      int64_t id = 0;
      if (!r.integer(0, id)) return not_integer(ext, r, 0, "a point id");
      if (i == 0) {
        if (id != 0 && id != 1)
          return fail(ErrorCode::Parse, ext, r.line(), "first point id is " + std::to_string(id) + " (must be 0 or 1)");
        base_id_ = id;
      } else if (id != base_id_ + i) {
        return fail(ErrorCode::Parse, ext, r.line(),
                    "point id " + std::to_string(id) + ", expected " + std::to_string(base_id_ + i) +
                        " (ids must be consecutive)");
      }
      if (r.size() < 4)
        return fail(ErrorCode::Parse, ext, r.line(), "point " + std::to_string(id) + " has fewer than 3 coordinates");
      for (size_t k = 1; k <= 3; ++k) {
        double x = 0;
        if (!r.real(k, x)) return not_integer(ext, r, k, "a coordinate");
        if (!std::isfinite(x))
          return fail(ErrorCode::InvalidMesh, ext, r.line(), "point " + std::to_string(id) + " has a non-finite coordinate");
        m_.xyz.push_back(x);
      }
      if (nbm) {
        const size_t k = 4 + static_cast<size_t>(nattr);
        int64_t mark = 0;
        if (k < r.size() && !r.integer(k, mark)) return not_integer(ext, r, k, "an integer boundary marker");
        if (mark < std::numeric_limits<int32_t>::min() || mark > kMaxId)
          return fail(ErrorCode::Parse, ext, r.line(), "boundary marker does not fit in 32 bits");
        m_.vert_ref.push_back(static_cast<int32_t>(mark));
      }
    }
    return no_more(ext, r, n, "points");
  }

  Status read_ele(std::string_view data) {
    const char* ext = ".ele";
    LineReader r(data);
    if (!r.next()) return fail(ErrorCode::Parse, ext, 0, "empty file (no header line)");
    int64_t n = 0, npe = 4, nattr = 0;
    if (!r.integer(0, n)) return not_integer(ext, r, 0, "the number of tetrahedra");
    if (Status s = header_int(ext, r, 1, 4, "the number of nodes per tetrahedron", npe); !s) return s;
    if (Status s = header_int(ext, r, 2, 0, "the number of attributes", nattr); !s) return s;
    if (npe == 10) return fail(ErrorCode::Unsupported, ext, r.line(), "second-order tetrahedra (10 nodes) are not supported");
    if (npe != 4) return fail(ErrorCode::Parse, ext, r.line(), "nodes per tetrahedron " + std::to_string(npe) + ": expected 4");
    if (nattr < 0 || nattr > 1000000)
      return fail(ErrorCode::Parse, ext, r.line(), "bad number of attributes " + std::to_string(nattr));
    if (n == 0) return fail(ErrorCode::InvalidMesh, ext, r.line(), "no tetrahedra (surface-only mesh?)");
    if (Status s = check_count(ext, r, n, 5, "tetrahedra"); !s) return s;
    m_.tets.reserve(detail::ck_size(n, 4));
    m_.tet_ref.reserve(detail::ck_size(n, 1));
    for (int64_t i = 0; i < n; ++i) {
      if (!r.next()) return truncated(ext, r, i, n, "tetrahedra");
      int64_t id = 0;
      if (!r.integer(0, id)) return not_integer(ext, r, 0, "a tetrahedron id");
      if (r.size() < 5)
        return fail(ErrorCode::Parse, ext, r.line(), "tetrahedron " + std::to_string(id) + " has fewer than 4 vertices");
      for (size_t k = 1; k <= 4; ++k) {
        int32_t v = 0;
        if (Status s = vertex_id(ext, r, k, v); !s) return s;
        m_.tets.push_back(v);
      }
      int32_t region = 0;
      if (nattr > 0 && r.size() > 5) {
        double a = 0;
        if (!r.real(5, a)) return not_integer(ext, r, 5, "a region attribute");
        if (!(a == std::floor(a)) || a < std::numeric_limits<int32_t>::min() || a > static_cast<double>(kMaxId))
          return fail(ErrorCode::Unsupported, ext, r.line(),
                      "region attribute '" + shorten(r.tok(5)) + "' is not a 32-bit integer");
        region = static_cast<int32_t>(a);
      }
      m_.tet_ref.push_back(region);
    }
    return no_more(ext, r, n, "tetrahedra");
  }

  Status read_face(std::string_view data) {
    const char* ext = ".face";
    LineReader r(data);
    if (!r.next()) return Status::success();  // an empty .face lists nothing
    int64_t n = 0, nbm = 0;
    if (!r.integer(0, n)) return not_integer(ext, r, 0, "the number of faces");
    if (Status s = header_int(ext, r, 1, 0, "the number of boundary markers", nbm); !s) return s;
    if (nbm != 0 && nbm != 1)
      return fail(ErrorCode::Parse, ext, r.line(), "bad number of boundary markers " + std::to_string(nbm) + " (0 or 1)");
    if (Status s = check_count(ext, r, n, 4, "faces"); !s) return s;
    m_.tris.reserve(detail::ck_size(n, 3));
    m_.tri_ref.reserve(detail::ck_size(n, 1));
    for (int64_t i = 0; i < n; ++i) {
      if (!r.next()) return truncated(ext, r, i, n, "faces");
      int64_t id = 0;
      if (!r.integer(0, id)) return not_integer(ext, r, 0, "a face id");
      if (r.size() < 4)
        return fail(ErrorCode::Parse, ext, r.line(), "face " + std::to_string(id) + " has fewer than 3 vertices");
      for (size_t k = 1; k <= 3; ++k) {
        int32_t v = 0;
        if (Status s = vertex_id(ext, r, k, v); !s) return s;
        m_.tris.push_back(v);
      }
      int64_t mark = 0;
      if (nbm && r.size() > 4 && !r.integer(4, mark)) return not_integer(ext, r, 4, "an integer boundary marker");
      if (mark < std::numeric_limits<int32_t>::min() || mark > kMaxId)
        return fail(ErrorCode::Parse, ext, r.line(), "boundary marker does not fit in 32 bits");
      m_.tri_ref.push_back(static_cast<int32_t>(mark));
    }
    return no_more(ext, r, n, "faces");
  }

  const std::string& base_;
  int64_t base_id_ = 1;
  TetMesh m_;
};

using detail::put_int;
using detail::put_real;
int32_t ref_of(const std::vector<int32_t>& r, size_t i) { return i < r.size() ? r[i] : 0; }

}  // namespace

Status parse_tetgen(std::string_view node, std::string_view ele, std::string_view face, const std::string& name,
                    TetMesh& m) {
  try {
    TetMesh tmp;
    TetgenReader r(name);
    Status s = r.run(node, ele, face, tmp);
    if (s) m = std::move(tmp);
    return s;
  } catch (const std::bad_alloc&) {
    return Status::error(ErrorCode::OutOfMemory, name + ".node/.ele: out of memory while reading");
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::Invariant, name + ": unexpected error: " + e.what());
  }
}

Status format_tetgen(const TetMesh& m, std::string& node, std::string& ele, std::string& face) {
  try {
    if (m.xyz.size() % 3 || m.tets.size() % 4 || m.tris.size() % 3)
      return Status::error(ErrorCode::Invariant, "inconsistent array sizes");
    const int32_t nv = m.nv();
    for (const auto* a : {&m.tets, &m.tris})
      for (int32_t v : *a)
        if (v < 0 || v >= nv) return Status::error(ErrorCode::Invariant, "a vertex index is out of range");
    node.clear();
    ele.clear();
    face.clear();
    node.reserve(static_cast<size_t>(nv) * 72 + 64);
    ele.reserve(m.tets.size() * 10 + 64);
    face.reserve(m.tris.size() * 10 + 64);
    // Ids start at 1 (TetGen's default numbering).
    put_int(node, nv);
    node += " 3 0 1\n";
    for (int32_t v = 0; v < nv; ++v) {
      const double* p = m.point(v);
      put_int(node, int64_t(v) + 1);
      for (int k = 0; k < 3; ++k) {
        node += ' ';
        put_real(node, p[k]);
      }
      node += ' ';
      put_int(node, ref_of(m.vert_ref, v));
      node += '\n';
    }
    bool regions = false;
    for (int32_t r : m.tet_ref) regions = regions || r != 0;
    put_int(ele, m.nt());
    ele += regions ? " 4 1\n" : " 4 0\n";
    for (int32_t t = 0; t < m.nt(); ++t) {
      int32_t v[4];
      detail::file_tet(m, t, Format::TetGen, v);
      put_int(ele, int64_t(t) + 1);
      for (int k = 0; k < 4; ++k) {
        ele += ' ';
        put_int(ele, int64_t(v[k]) + 1);
      }
      if (regions) {
        ele += ' ';
        put_int(ele, ref_of(m.tet_ref, static_cast<size_t>(t)));
      }
      ele += '\n';
    }
    // Always written (even with no faces) so a stale .face beside the
    // output is replaced rather than read back with the new mesh.
    put_int(face, m.ntri());
    face += " 1\n";
    for (int32_t f = 0; f < m.ntri(); ++f) {
      put_int(face, int64_t(f) + 1);
      for (int k = 0; k < 3; ++k) {
        face += ' ';
        put_int(face, int64_t(m.tris[3 * static_cast<size_t>(f) + k]) + 1);
      }
      face += ' ';
      put_int(face, ref_of(m.tri_ref, static_cast<size_t>(f)));
      face += '\n';
    }
    return Status::success();
  } catch (const std::bad_alloc&) {
    return Status::error(ErrorCode::OutOfMemory, "TetGen writer: out of memory");
  }
}

}  // namespace tetopt
