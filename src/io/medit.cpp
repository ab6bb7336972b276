// Medit .mesh (ASCII) and .meshb (binary GMF) readers and writers.
//
// References for the formats (the code is written here from these texts):
//  - P. J. Frey, "MEDIT: an interactive mesh visualization software",
//    INRIA technical report RT-0253 (2001), appendix "The .mesh file format":
//    keywords, 1-based indices, every entity followed by its reference.
//  - L. Marechal, libMeshb 7 (the GMF library, github.com/LoicMarechal/libMeshb),
//    sources/libmeshb7.c and its documentation: the keyword table GmfKwdFmt
//    (Dimension 3, Vertices 4, Edges 5, Triangles 6, Quadrilaterals 7,
//    Tetrahedra 8, Prisms 9, Hexahedra 10, Corners 13, Ridges 14,
//    RequiredVertices 15, RequiredEdges 16, RequiredTriangles 17, ...,
//    Pyramids 49, End 54) and the binary layout below.
//
// Binary (.meshb) layout, as libMeshb writes it:
//   int32 code word 1 (reads as 16777216 when the file has the other byte order)
//   int32 version: 1 float32 reals / int32 integers / int32 positions
//                  2 float64 reals / int32 integers / int32 positions
//                  3 float64 reals / int32 integers / int64 positions
//                  4 float64 reals / int64 integers / int64 positions
//   then keywords, the first being Dimension:
//     int32 keyword code, position (absolute byte offset of the next keyword,
//     0 after End), for keywords with a count: the count (an "integer"), then
//     the records.  The Dimension value itself is always an int32 word.
// Unknown keywords are skipped by jumping to the next-keyword position, the
// way libMeshb's keyword scan does.
//
// Every count is checked against the bytes that remain before anything is
// allocated, so a lying or absurd count ends in a Parse error.
#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <string>
#include <string_view>
#include <vector>

#include "detail/parallel.hpp"
#include "io/checked.hpp"
#include "io/common.hpp"
#include "tetopt/io.hpp"

namespace tetopt {

namespace {

constexpr int64_t kMaxId = std::numeric_limits<int32_t>::max();

// GMF keyword codes (libMeshb GmfKwdFmt order).
enum GmfKwd : int32_t {
  kGmfDimension = 3,
  kGmfVertices = 4,
  kGmfEdges = 5,
  kGmfTriangles = 6,
  kGmfQuadrilaterals = 7,
  kGmfTetrahedra = 8,
  kGmfPrisms = 9,
  kGmfHexahedra = 10,
  kGmfCorners = 13,
  kGmfRidges = 14,
  kGmfRequiredVertices = 15,
  kGmfRequiredEdges = 16,
  kGmfRequiredTriangles = 17,
  kGmfTetrahedraP2 = 30,
  kGmfHexahedraQ2 = 33,
  kGmfPyramids = 49,
  kGmfEnd = 54,
};

bool is_space(char c) { return c == ' ' || c == '\n' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

std::string shorten(std::string_view t) { return detail::shown_token(t, false); }

// ---------------------------------------------------------------- ASCII ----

/// Whitespace-separated tokens with '#' comments; counts lines as it goes.
class Lexer {
 public:
  explicit Lexer(std::string_view d) : p_(d.data()), end_(d.data() + d.size()) {}

  void skip() {
    while (p_ < end_) {
      const char c = *p_;
      if (c == '\n') {
        ++line_;
        ++p_;
      } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
        ++p_;
      } else if (c == '#') {
        while (p_ < end_ && *p_ != '\n') ++p_;
      } else {
        break;
      }
    }
  }
  long line() const { return line_; }
  size_t remaining() const { return static_cast<size_t>(end_ - p_); }
  const char* pos() const { return p_; }
  const char* end() const { return end_; }
  /// Moves to p, `lines` newlines further on (ParallelRecords).
  void jump(const char* p, long lines) {
    p_ = p;
    line_ += lines;
  }
  bool eof() {
    skip();
    return p_ >= end_;
  }
  /// Next token (not consumed).
  std::string_view peek() {
    skip();
    const char* b = p_;
    const char* e = p_;
    while (e < end_ && !is_space(*e) && *e != '#') ++e;
    return {b, static_cast<size_t>(e - b)};
  }
  std::string_view word() {
    std::string_view w = peek();
    p_ += w.size();
    return w;
  }
  /// Skips the rest of the current line (used for string-valued keywords).
  void skip_quoted_or_token() {
    skip();
    if (p_ < end_ && *p_ == '"') {
      ++p_;
      while (p_ < end_ && *p_ != '"') {
        if (*p_ == '\n') ++line_;
        ++p_;
      }
      if (p_ < end_) ++p_;
    } else {
      word();
    }
  }

  /// Parses an integer token; false (nothing consumed) when the next token is
  /// not exactly an integer.
  bool integer(int64_t& v) {
    skip();
    const char* b = p_;
    if (b < end_ && *b == '+') ++b;
    const auto r = std::from_chars(b, end_, v);
    if (r.ec != std::errc{} || !ends_token(r.ptr)) return false;
    p_ = r.ptr;
    return true;
  }
  /// Parses a real token (non-finite values are returned, the caller decides).
  bool real(double& v) {
    skip();
    const char* b = p_;
    if (b < end_ && *b == '+') ++b;
    const auto r = std::from_chars(b, end_, v);
    if (r.ec == std::errc::result_out_of_range && ends_token(r.ptr)) {
      // Overflow or underflow: strtod tells which (underflow reads as 0).
      const std::string tok(b, r.ptr);
      const double x = std::strtod(tok.c_str(), nullptr);
      if (std::isinf(x)) return false;
      v = x;
      p_ = r.ptr;
      return true;
    }
    if (r.ec != std::errc{} || !ends_token(r.ptr)) return false;
    p_ = r.ptr;
    return true;
  }

 private:
  bool ends_token(const char* q) const { return q == end_ || is_space(*q) || *q == '#'; }
  const char* p_;
  const char* end_;
  long line_ = 1;
};

/// Keywords whose records tetopt does not keep but knows how to skip: tokens
/// per record (the Medit/GMF record layouts, libMeshb GmfKwdFmt), whether a
/// count follows the keyword, and whether a non-empty section makes the mesh
/// unsupported (non-tet volume elements).
struct SkipKwd {
  const char* name;
  int tokens;
  bool counted;
  bool unsupported;
};
constexpr SkipKwd kSkip[] = {
    {"Quadrilaterals", 5, true, false},
    {"RequiredQuadrilaterals", 1, true, false},
    {"Hexahedra", 9, true, true},
    {"Hexaedra", 9, true, true},
    {"Prisms", 7, true, true},
    {"Pyramids", 6, true, true},
    {"TetrahedraP2", 11, true, true},
    {"HexahedraQ2", 28, true, true},
    {"TrianglesP2", 7, true, false},
    {"EdgesP2", 4, true, false},
    {"QuadrilateralsQ2", 10, true, false},
    {"Normals", 3, true, false},
    {"Tangents", 3, true, false},
    {"NormalAtVertices", 2, true, false},
    {"TangentAtVertices", 2, true, false},
    {"NormalAtTriangleVertices", 3, true, false},
    {"NormalAtQuadrilateralVertices", 4, true, false},
    {"TangentAtEdgeVertices", 3, true, false},
    {"SubDomainFromGeom", 3, true, false},
    {"SubDomainFromMesh", 4, true, false},
    {"VerticesOnGeometricVertices", 2, true, false},
    {"VerticesOnGeometricEdges", 4, true, false},
    {"VerticesOnGeometricTriangles", 5, true, false},
    {"VerticesOnGeometricQuadrilaterals", 5, true, false},
    {"EdgesOnGeometricEdges", 2, true, false},
    {"TrianglesOnGeometricTriangles", 2, true, false},
    {"TrianglesOnGeometricQuadrilaterals", 2, true, false},
    {"QuadrilateralsOnGeometricTriangles", 2, true, false},
    {"QuadrilateralsOnGeometricQuadrilaterals", 2, true, false},
    {"VertexOnGeometricVertex", 2, true, false},
    {"VertexOnGeometricEdge", 3, true, false},
    {"EdgeOnGeometricEdge", 2, true, false},
    {"AngleOfCornerBound", 1, false, false},
    {"BoundingBox", 6, false, false},
};

/// Whether a token is a keyword this reader knows (a lying count runs into one).
bool is_keyword(std::string_view w) {
  static constexpr const char* kKnown[] = {"MeshVersionFormatted", "Dimension", "Vertices", "Edges", "Triangles",
                                           "Tetrahedra", "Corners", "Ridges", "RequiredVertices", "RequiredEdges",
                                           "RequiredTriangles", "Identifier", "Geometry", "End"};
  for (const char* k : kKnown)
    if (w == k) return true;
  for (const SkipKwd& k : kSkip)
    if (w == k.name) return true;
  return false;
}

// Parallel fast path for the big sections (Vertices, Triangles, Tetrahedra):
// n records laid out one per line, k tokens each (the first `nreal` reals,
// the others integers), no comment.  The rest of the file is cut into
// 256 KiB chunks (the impeller's 3 MB of vertices were three 1 MiB chunks,
// and the thread with the third parsed it alone); their newlines are
// counted in parallel, which locates the end of record n and the index of
// the first record starting in each chunk; then
// the chunks parse their records in parallel with the same from_chars calls
// as Lexer::real / Lexer::integer.  Anything else (another layout, a comment,
// a bad or non-finite number, an index or ref out of range, a missing last
// newline) makes run() return false with the lexer untouched, and the
// reader's serial loop parses the section again and reports the error as it
// always does.  So the result, and every error message, is the serial one.
class ParallelRecords {
 public:
  struct Spec {
    int k = 0, nreal = 0;       // tokens per record, leading reals
    int64_t id_limit = -1;      // integers before the last: ids 1..limit (-1: 1..kMaxId), stored 0-based
    bool ids = false;           // false: the integers are refs only (Vertices)
  };
  static constexpr int64_t kMinRecords = 20000;
  static constexpr size_t kChunk = size_t{1} << 18;

  /// reals: n * nreal; ids: n * (k - nreal - 1) when spec.ids; refs: n.
  static bool run(Lexer& lx, int64_t n, const Spec& sp, int threads, size_t chunk, double* reals, int32_t* ids,
                  int32_t* refs) {
    if (chunk == 0) return false;
    lx.skip();
    const char* p0 = lx.pos();
    const char* e = lx.end();
    const size_t len = static_cast<size_t>(e - p0);
    const int64_t nc_all = static_cast<int64_t>((len + chunk - 1) / chunk);
    if (n <= 0 || nc_all == 0) return false;
    auto chunk_begin = [&](int64_t c) { return p0 + std::min(len, static_cast<size_t>(c) * chunk); };
    // Newlines are counted in waves of chunks, each wave twice the last,
    // until the n-th is passed, so a section is not scanned to the end of the
    // file (three sections used to scan the rest of the file three times).
    int64_t wave = std::max<int64_t>(4, 2 * static_cast<int64_t>(detail::resolve_threads(threads)));
    std::vector<int64_t> nl(1, 0);  // nl[c]: newlines in [p0, chunk_begin(c))
    int64_t nc = 0;
    for (; nc < nc_all && nl[static_cast<size_t>(nc)] < n; wave *= 2) {
      const int64_t c0 = nc, c1 = std::min(nc_all, nc + wave);
      nl.resize(static_cast<size_t>(c1) + 1, 0);
      detail::parallel_items(c1 - c0, threads, [&](int64_t j) {
        const int64_t c = c0 + j;
        nl[static_cast<size_t>(c) + 1] = std::count(chunk_begin(c), chunk_begin(c + 1), '\n');
      });
      for (int64_t c = c0; c < c1; ++c) nl[c + 1] += nl[c];
      nc = c1;
    }
    if (nl[nc] < n) return false;  // the last record has no newline (or the count lies): serial
    // The n-th newline ends record n-1.
    int64_t cn = 0;
    while (nl[cn + 1] < n) ++cn;
    const char* stop = chunk_begin(cn);
    for (int64_t seen = nl[cn];;) {
      stop = static_cast<const char*>(std::memchr(stop, '\n', chunk_begin(cn + 1) - stop));
      if (++seen == n) break;
      ++stop;
    }
    std::atomic<bool> bad{false};
    const int nint = sp.k - sp.nreal;  // ids then the ref
    detail::parallel_items(cn + 1, threads, [&](int64_t c) {
      const char* b = chunk_begin(c);
      const char* cend = std::min(chunk_begin(c + 1), stop + 1);
      int64_t i;
      const char* r;
      if (c == 0) {
        i = 0;
        r = p0;
      } else {  // the first record starting in [b, cend): after a newline at b-1 or later
        const char* q = static_cast<const char*>(std::memchr(b - 1, '\n', cend - (b - 1)));
        if (!q || q >= stop) return;
        i = nl[c] - (b[-1] == '\n' ? 1 : 0) + 1;  // newlines in [p0, q] = index of the record after q
        r = q + 1;
      }
      while (i < n && r < cend && !bad.load(std::memory_order_relaxed)) {
        const char* eol = static_cast<const char*>(std::memchr(r, '\n', stop + 1 - r));
        if (!parse_record(r, eol, sp, nint, i, reals, ids, refs)) {
          bad = true;
          return;
        }
        r = eol + 1;
        ++i;
      }
    });
    if (bad) return false;
    lx.jump(stop, static_cast<long>(n - 1));
    return true;
  }

 private:
  static bool horizontal_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
  static bool parse_record(const char* p, const char* eol, const ParallelRecords::Spec& sp, int nint, int64_t i,
                           double* reals, int32_t* ids, int32_t* refs) {
    auto next = [&]() -> bool {
      while (p < eol && horizontal_space(*p)) ++p;
      if (p < eol && *p == '+') ++p;
      return p < eol && *p != '#';
    };
    auto ends = [&](const char* q) { return q == eol || horizontal_space(*q); };
    for (int t = 0; t < sp.nreal; ++t) {
      double v = 0;
      if (!next()) return false;
      const auto res = std::from_chars(p, eol, v);
      if (res.ec != std::errc{} || !ends(res.ptr) || !std::isfinite(v)) return false;
      reals[i * sp.nreal + t] = v;
      p = res.ptr;
    }
    for (int t = 0; t < nint; ++t) {
      int64_t v = 0;
      if (!next()) return false;
      const auto res = std::from_chars(p, eol, v);
      if (res.ec != std::errc{} || !ends(res.ptr)) return false;
      p = res.ptr;
      if (t + 1 < nint) {  // an id
        if (v < 1 || v > kMaxId || (sp.id_limit >= 0 && v > sp.id_limit)) return false;
        ids[i * (nint - 1) + t] = static_cast<int32_t>(v - 1);
      } else {  // the ref
        if (v < std::numeric_limits<int32_t>::min() || v > kMaxId) return false;
        refs[i] = static_cast<int32_t>(v);
      }
    }
    while (p < eol && horizontal_space(*p)) ++p;
    return p == eol;
  }
};

class MeditAsciiReader {
 public:
  MeditAsciiReader(std::string_view data, const std::string& name, int threads, int64_t min_records, size_t chunk)
      : lx_(data), name_(name), threads_(threads), min_records_(min_records), chunk_(chunk) {}

  Status run(TetMesh& out) {
    bool have_dim = false, have_vertices = false, have_tets = false, ended = false;
    std::vector<std::string> seen;
    if (lx_.eof()) return fail(ErrorCode::Parse, 0, "empty file (missing Dimension)");
    while (!lx_.eof()) {
      const long kw_line = lx_.line();
      const std::string_view kw = lx_.word();
      if (kw.empty() || !std::isalpha(static_cast<unsigned char>(kw[0])))
        return fail(ErrorCode::Parse, kw_line, "expected a keyword, found '" + shorten(kw) + "'");
      if (kw == "End") {
        ended = true;
        break;
      }
      if (kw != "MeshVersionFormatted" && kw != "Dimension") {
        if (std::find(seen.begin(), seen.end(), kw) != seen.end())
          return fail(ErrorCode::Parse, kw_line, "second " + std::string(kw) + " section");
        seen.emplace_back(kw);
      }
      Status s;
      if (kw == "MeshVersionFormatted") {
        int64_t ver = 0;
        const std::string found = shorten(lx_.peek());  // the token and its line, before it is consumed
        const long at = lx_.line();
        if (!lx_.integer(ver) || ver < 0 || ver > 4)
          return fail(ErrorCode::Parse, at, "MeshVersionFormatted: expected a version 0..4, found '" + found + "'");
      } else if (kw == "Dimension") {
        int64_t d = 0;
        if (!lx_.integer(d))
          return fail(ErrorCode::Parse, lx_.line(),
                      "Dimension: expected 3, found '" + shorten(lx_.peek()) + "'");
        if (d == 2)
          return fail(ErrorCode::Unsupported, kw_line, "2-D mesh (Dimension 2): tetopt needs Dimension 3");
        if (d != 3) return fail(ErrorCode::Parse, kw_line, "Dimension " + std::to_string(d) + ": expected 3");
        have_dim = true;
      } else if (kw == "Vertices") {
        if (!have_dim)
          return fail(ErrorCode::Parse, kw_line, "missing Dimension (it must come before Vertices)");
        s = read_vertices();
        have_vertices = true;
      } else if (kw == "Edges") {
        s = read_elements("Edges", 2, m_.edges, m_.edge_ref);
        have_edges_ = true;
      } else if (kw == "Triangles") {
        s = read_elements("Triangles", 3, m_.tris, m_.tri_ref);
        have_tris_ = true;
      } else if (kw == "Tetrahedra") {
        s = read_elements("Tetrahedra", 4, m_.tets, m_.tet_ref);
        have_tets = true;
      } else if (kw == "Corners") {
        s = read_list("Corners", m_.corners, Target::Vertex);
      } else if (kw == "RequiredVertices") {
        s = read_list("RequiredVertices", m_.required_vertices, Target::Vertex);
      } else if (kw == "Ridges") {
        s = read_list("Ridges", m_.ridges, Target::Edge);
      } else if (kw == "RequiredEdges") {
        s = read_list("RequiredEdges", m_.required_edges, Target::Edge);
      } else if (kw == "RequiredTriangles") {
        s = read_list("RequiredTriangles", m_.required_tris, Target::Triangle);
      } else if (kw == "Identifier" || kw == "Geometry") {
        lx_.skip_quoted_or_token();
      } else {
        const SkipKwd* k = nullptr;
        for (const SkipKwd& e : kSkip)
          if (kw == e.name) k = &e;
        if (!k) return fail(ErrorCode::Parse, kw_line, "unknown keyword '" + shorten(kw) + "'");
        s = skip_section(*k, kw_line);
      }
      if (!s) return s;
    }
    // libMeshb tolerates a missing End, but every writer emits it and without
    // it a file cut at a record boundary would read as a smaller mesh.
    if (!ended) return fail(ErrorCode::Parse, lx_.line(), "missing End keyword (truncated file?)");
    if (!have_dim) return fail(ErrorCode::Parse, 0, "missing Dimension");
    if (!have_vertices) return fail(ErrorCode::Parse, 0, "no Vertices section");
    if (!have_tets || m_.tets.empty())
      return fail(ErrorCode::InvalidMesh, 0, "no tetrahedra (surface-only mesh?)");
    for (const Pending& p : pending_)
      if (Status s = check_pending(p); !s) return s;
    out = std::move(m_);
    return Status::success();
  }

 private:
  enum class Target { Vertex, Edge, Triangle };
  struct Pending {
    const char* kw;
    long line;
    const std::vector<int32_t>* arr;
    int per;
    Target target;
  };

  Status fail(ErrorCode c, long line, const std::string& what) const {
    if (line > 0) return Status::error(c, name_ + ":" + std::to_string(line) + ": " + what, line);
    return Status::error(c, name_ + ": " + what);
  }

  /// Reads the count after a keyword and checks that the remaining bytes can
  /// hold that many records of `tokens` tokens (each at least 2 bytes).
  Status read_count(const char* kw, int tokens, int64_t& n) {
    const long ln = lx_.line();
    if (!lx_.integer(n)) {
      if (lx_.eof()) return fail(ErrorCode::Parse, ln, std::string(kw) + ": missing count (truncated file?)");
      return fail(ErrorCode::Parse, lx_.line(),
                  std::string(kw) + ": expected a count, found '" + shorten(lx_.peek()) + "'");
    }
    if (n < 0) return fail(ErrorCode::Parse, lx_.line(), std::string(kw) + ": negative count " + std::to_string(n));
    const uint64_t room = (static_cast<uint64_t>(lx_.remaining()) + 1) / (2 * static_cast<uint64_t>(tokens));
    if (static_cast<uint64_t>(n) > room)
      return fail(ErrorCode::Parse, lx_.line(),
                  std::string(kw) + ": count " + std::to_string(n) + " is more than the rest of the file can hold (" +
                      std::to_string(room) + " records at most): truncated file or lying count");
    if (n > kMaxId)
      return fail(ErrorCode::Unsupported, lx_.line(),
                  std::string(kw) + ": count " + std::to_string(n) + " exceeds the 32-bit index range");
    return Status::success();
  }

  /// Error for a token that should have been a number.
  Status bad_number(const char* kw, int64_t rec, int64_t count, const char* what) {
    if (lx_.eof())
      return fail(ErrorCode::Parse, lx_.line(),
                  std::string("unexpected end of file in ") + kw + " record " + std::to_string(rec) + " of " +
                      std::to_string(count) + " (truncated file?)");
    const std::string_view tok = lx_.peek();
    if (is_keyword(tok))
      return fail(ErrorCode::Parse, lx_.line(),
                  std::string(kw) + ": the count says " + std::to_string(count) + " records but record " +
                      std::to_string(rec) + " starts at '" + shorten(tok) + "' (count too large?)");
    return fail(ErrorCode::Parse, lx_.line(),
                std::string("expected ") + what + " in " + kw + " record " + std::to_string(rec) + ", found '" +
                    shorten(tok) + "'");
  }

  Status read_ref(const char* kw, int64_t rec, int64_t count, int32_t& ref) {
    int64_t r = 0;
    if (!lx_.integer(r)) return bad_number(kw, rec, count, "an integer reference");
    if (r < std::numeric_limits<int32_t>::min() || r > kMaxId)
      return fail(ErrorCode::Parse, lx_.line(),
                  std::string(kw) + " record " + std::to_string(rec) + ": reference " + std::to_string(r) +
                      " does not fit in 32 bits");
    ref = static_cast<int32_t>(r);
    return Status::success();
  }

  Status read_vertices() {
    int64_t n = 0;
    if (Status s = read_count("Vertices", 4, n); !s) return s;
    if (n >= min_records_) {
      m_.xyz.resize(detail::ck_size(n, 3));
      m_.vert_ref.resize(detail::ck_size(n, 1));
      if (ParallelRecords::run(lx_, n, {4, 3, -1, false}, threads_, chunk_, m_.xyz.data(), nullptr,
                               m_.vert_ref.data())) {
        nv_ = n;
        return Status::success();
      }
      m_.xyz.clear();
      m_.vert_ref.clear();
    }
    m_.xyz.reserve(detail::ck_size(n, 3));
    m_.vert_ref.reserve(detail::ck_size(n, 1));
    for (int64_t i = 1; i <= n; ++i) {
      for (int k = 0; k < 3; ++k) {
        double x = 0;
        if (!lx_.real(x)) return bad_number("Vertices", i, n, "a coordinate");
        if (!std::isfinite(x))
          return fail(ErrorCode::InvalidMesh, lx_.line(),
                      "vertex " + std::to_string(i) + " has a non-finite coordinate");
        m_.xyz.push_back(x);
      }
      int32_t ref = 0;
      if (Status s = read_ref("Vertices", i, n, ref); !s) return s;
      m_.vert_ref.push_back(ref);
    }
    nv_ = n;
    return Status::success();
  }

  /// Reads a 1-based id and stores it 0-based; checks it against `limit`
  /// when known (limit >= 0), otherwise leaves it to check_pending.
  Status read_id(const char* kw, int64_t rec, int64_t count, int64_t limit, const char* what, int32_t& id) {
    int64_t v = 0;
    if (!lx_.integer(v)) return bad_number(kw, rec, count, "an integer index");
    if (v < 1 || v > kMaxId || (limit >= 0 && v > limit))
      return fail(ErrorCode::InvalidMesh, lx_.line(),
                  std::string(kw) + " record " + std::to_string(rec) + ": " + what + " index " +
                      std::to_string(v) + " out of range 1.." + (limit >= 0 ? std::to_string(limit) : "N"));
    id = static_cast<int32_t>(v - 1);
    return Status::success();
  }

  Status read_elements(const char* kw, int nper, std::vector<int32_t>& ids, std::vector<int32_t>& refs) {
    const long kw_line = lx_.line();
    int64_t n = 0;
    if (Status s = read_count(kw, nper + 1, n); !s) return s;
    if (n >= min_records_) {
      ids.resize(detail::ck_size(n, static_cast<uint64_t>(nper)));
      refs.resize(detail::ck_size(n, 1));
      if (ParallelRecords::run(lx_, n, {nper + 1, 0, nv_, true}, threads_, chunk_, nullptr, ids.data(),
                               refs.data())) {
        if (nv_ < 0) pending_.push_back({kw, kw_line, &ids, nper, Target::Vertex});
        return Status::success();
      }
      ids.clear();
      refs.clear();
    }
    ids.reserve(detail::ck_size(n, static_cast<uint64_t>(nper)));
    refs.reserve(detail::ck_size(n, 1));
    for (int64_t i = 1; i <= n; ++i) {
      for (int k = 0; k < nper; ++k) {
        int32_t id = 0;
        if (Status s = read_id(kw, i, n, nv_, "vertex", id); !s) return s;
        ids.push_back(id);
      }
      int32_t ref = 0;
      if (Status s = read_ref(kw, i, n, ref); !s) return s;
      refs.push_back(ref);
    }
    if (nv_ < 0) pending_.push_back({kw, kw_line, &ids, nper, Target::Vertex});
    return Status::success();
  }

  Status read_list(const char* kw, std::vector<int32_t>& ids, Target target) {
    const long kw_line = lx_.line();
    int64_t n = 0;
    if (Status s = read_count(kw, 1, n); !s) return s;
    const int64_t limit = target == Target::Vertex ? nv_
                          : target == Target::Edge  ? (have_edges() ? int64_t(m_.edge_ref.size()) : -1)
                                                    : (have_tris() ? int64_t(m_.tri_ref.size()) : -1);
    const char* what = target == Target::Vertex ? "vertex" : target == Target::Edge ? "edge" : "triangle";
    ids.reserve(detail::ck_size(n, 1));
    for (int64_t i = 1; i <= n; ++i) {
      int32_t id = 0;
      if (Status s = read_id(kw, i, n, limit, what, id); !s) return s;
      ids.push_back(id);
    }
    if (limit < 0) pending_.push_back({kw, kw_line, &ids, 1, target});
    return Status::success();
  }

  bool have_edges() const { return have_edges_; }
  bool have_tris() const { return have_tris_; }

  Status check_pending(const Pending& p) const {
    const int64_t limit = p.target == Target::Vertex ? nv_
                          : p.target == Target::Edge ? static_cast<int64_t>(m_.edge_ref.size())
                                                     : static_cast<int64_t>(m_.tri_ref.size());
    const char* what = p.target == Target::Vertex ? "vertex" : p.target == Target::Edge ? "edge" : "triangle";
    for (size_t i = 0; i < p.arr->size(); ++i)
      if ((*p.arr)[i] >= limit)
        return fail(ErrorCode::InvalidMesh, p.line,
                    std::string(p.kw) + " record " + std::to_string(i / p.per + 1) + ": " + what + " index " +
                        std::to_string((*p.arr)[i] + 1) + " out of range 1.." + std::to_string(limit));
    return Status::success();
  }

  Status skip_section(const SkipKwd& k, long kw_line) {
    int64_t n = 1;
    if (k.counted)
      if (Status s = read_count(k.name, k.tokens, n); !s) return s;
    if (k.unsupported && n > 0)
      return fail(ErrorCode::Unsupported, kw_line,
                  std::string(k.name) + " (" + std::to_string(n) +
                      "): mixed-element and high-order meshes are not supported, only linear tetrahedra");
    for (int64_t i = 1; i <= n; ++i)
      for (int t = 0; t < k.tokens; ++t) {
        double x = 0;
        if (!lx_.real(x)) return bad_number(k.name, i, n, "a number");
      }
    return Status::success();
  }

  Lexer lx_;
  const std::string& name_;
  int threads_ = 1;
  int64_t min_records_ = 0;  // sections this long take ParallelRecords
  size_t chunk_ = 0;
  TetMesh m_;
  int64_t nv_ = -1;
  bool have_edges_ = false, have_tris_ = false;
  std::vector<Pending> pending_;
};

// --------------------------------------------------------------- binary ----

// Why a 1-based index read from a .meshb file is refused.
const char* bad_index(int64_t v) {
  return v < 1 ? " is below 1 (indices count from 1)" : " exceeds the 32-bit index range";
}

class MeditBinaryReader {
 public:
  MeditBinaryReader(std::string_view data, const std::string& name)
      : b_(reinterpret_cast<const unsigned char*>(data.data())), n_(data.size()), name_(name) {}

  Status run(TetMesh& out) {
    size_t off = 0;
    int32_t code = 0;
    if (!word32(off, code)) return fail(ErrorCode::Parse, 0, "file too short for a GMF header (truncated?)");
    if (code == 16777216) {
      swap_ = true;
    } else if (code != 1) {
      return fail(ErrorCode::Parse, 0, "not a GMF binary mesh (code word " + std::to_string(code) + ", expected 1)");
    }
    int32_t ver = 0;
    if (!word32(off, ver)) return fail(ErrorCode::Parse, 0, "file too short for a GMF header (truncated?)");
    if (ver < 1 || ver > 4) return fail(ErrorCode::Unsupported, 0, "GMF version " + std::to_string(ver) + " (1..4 known)");
    ver_ = ver;
    int32_t kwd = 0;
    int64_t pos = 0;
    if (!word32(off, kwd) || !position(off, pos))
      return fail(ErrorCode::Parse, 0, "file ends inside the header (truncated?)");
    if (kwd != kGmfDimension)
      return fail(ErrorCode::Parse, 0, "missing Dimension (first keyword is " + std::to_string(kwd) + ", expected 3)");
    int32_t dim = 0;
    if (!word32(off, dim)) return fail(ErrorCode::Parse, 0, "file ends inside Dimension (truncated?)");
    if (dim == 2) return fail(ErrorCode::Unsupported, 0, "2-D mesh (Dimension 2): tetopt needs Dimension 3");
    if (dim != 3) return fail(ErrorCode::Parse, 0, "Dimension " + std::to_string(dim) + ": expected 3");

    bool have_vertices = false, have_tets = false;
    std::vector<int32_t> seen;
    for (;;) {
      const size_t kw_start = off;
      if (off == n_) return fail(ErrorCode::Parse, 0, "file ends without the End keyword (truncated?)");
      if (!word32(off, kwd) || !position(off, pos))
        return fail(ErrorCode::Parse, 0, "file ends inside a keyword header at byte " + std::to_string(kw_start) +
                                             " (truncated?)");
      if (kwd == kGmfEnd) break;
      if (pos != 0 && (pos <= static_cast<int64_t>(kw_start) || static_cast<uint64_t>(pos) > n_))
        return fail(ErrorCode::Parse, 0,
                    "keyword " + std::to_string(kwd) + " at byte " + std::to_string(kw_start) +
                        ": next-keyword position " + std::to_string(pos) + " outside " +
                        std::to_string(kw_start + 1) + ".." + std::to_string(n_) + " (truncated or corrupt file?)");
      limit_ = pos != 0 ? static_cast<size_t>(pos) : n_;
      const bool known = kwd == kGmfVertices || kwd == kGmfEdges || kwd == kGmfTriangles || kwd == kGmfTetrahedra ||
                         kwd == kGmfCorners || kwd == kGmfRidges || kwd == kGmfRequiredVertices ||
                         kwd == kGmfRequiredEdges || kwd == kGmfRequiredTriangles;
      if (known) {
        if (std::find(seen.begin(), seen.end(), kwd) != seen.end())
          return fail(ErrorCode::Parse, 0, "second " + std::string(kwd_name(kwd)) + " section");
        seen.push_back(kwd);
      }
      Status s;
      switch (kwd) {
        case kGmfVertices: s = read_vertices(off); have_vertices = true; break;
        case kGmfEdges: s = read_elements(off, "Edges", 2, m_.edges, m_.edge_ref); break;
        case kGmfTriangles: s = read_elements(off, "Triangles", 3, m_.tris, m_.tri_ref); break;
        case kGmfTetrahedra: s = read_elements(off, "Tetrahedra", 4, m_.tets, m_.tet_ref); have_tets = true; break;
        case kGmfCorners: s = read_list(off, "Corners", m_.corners); break;
        case kGmfRidges: s = read_list(off, "Ridges", m_.ridges); break;
        case kGmfRequiredVertices: s = read_list(off, "RequiredVertices", m_.required_vertices); break;
        case kGmfRequiredEdges: s = read_list(off, "RequiredEdges", m_.required_edges); break;
        case kGmfRequiredTriangles: s = read_list(off, "RequiredTriangles", m_.required_tris); break;
        case kGmfHexahedra:
        case kGmfPrisms:
        case kGmfPyramids:
        case kGmfTetrahedraP2:
        case kGmfHexahedraQ2: {
          int64_t cnt = 0;
          if (!integer(off, cnt)) return fail(ErrorCode::Parse, 0, "file ends inside a keyword header (truncated?)");
          if (cnt < 0)  // as the ASCII reader says
            return fail(ErrorCode::Parse, 0, std::string(kwd_name(kwd)) + ": negative count " + std::to_string(cnt));
          if (cnt > 0)
            return fail(ErrorCode::Unsupported, 0,
                        std::string(kwd_name(kwd)) + " (" + std::to_string(cnt) +
                            "): mixed-element and high-order meshes are not supported, only linear tetrahedra");
          break;
        }
        default: break;  // skipped through the next-keyword position
      }
      if (!s) return s;
      if (pos == 0) {
        // The last keyword by its header, yet no End: say so rather than
        // "no tetrahedra" when the Tetrahedra come after it.
        if (kwd != kGmfEnd && (!have_vertices || !have_tets))
          return fail(ErrorCode::Parse, 0,
                      std::string(kwd_name(kwd)) + " at byte " + std::to_string(kw_start) +
                          " has next-keyword position 0 (the last keyword) but the mesh is not complete (" +
                          (have_vertices ? "no Tetrahedra" : "no Vertices") + " before it); corrupt file?");
        break;
      }
      off = static_cast<size_t>(pos);
    }
    if (!have_vertices) return fail(ErrorCode::Parse, 0, "no Vertices keyword");
    if (!have_tets || m_.tets.empty()) return fail(ErrorCode::InvalidMesh, 0, "no tetrahedra (surface-only mesh?)");
    // Range checks once every count is known (keywords may come in any order).
    if (Status s = check_ids("Edges", m_.edges, 2, m_.nv(), "vertex"); !s) return s;
    if (Status s = check_ids("Triangles", m_.tris, 3, m_.nv(), "vertex"); !s) return s;
    if (Status s = check_ids("Tetrahedra", m_.tets, 4, m_.nv(), "vertex"); !s) return s;
    if (Status s = check_ids("Corners", m_.corners, 1, m_.nv(), "vertex"); !s) return s;
    if (Status s = check_ids("RequiredVertices", m_.required_vertices, 1, m_.nv(), "vertex"); !s) return s;
    const int64_t ne = static_cast<int64_t>(m_.edge_ref.size());
    if (Status s = check_ids("Ridges", m_.ridges, 1, ne, "edge"); !s) return s;
    if (Status s = check_ids("RequiredEdges", m_.required_edges, 1, ne, "edge"); !s) return s;
    const int64_t ntr = static_cast<int64_t>(m_.tri_ref.size());
    if (Status s = check_ids("RequiredTriangles", m_.required_tris, 1, ntr, "triangle"); !s) return s;
    out = std::move(m_);
    return Status::success();
  }

 private:
  static const char* kwd_name(int32_t k) {
    switch (k) {
      case kGmfVertices: return "Vertices";
      case kGmfEdges: return "Edges";
      case kGmfTriangles: return "Triangles";
      case kGmfTetrahedra: return "Tetrahedra";
      case kGmfCorners: return "Corners";
      case kGmfRidges: return "Ridges";
      case kGmfRequiredVertices: return "RequiredVertices";
      case kGmfRequiredEdges: return "RequiredEdges";
      case kGmfRequiredTriangles: return "RequiredTriangles";
      case kGmfHexahedra: return "Hexahedra";
      case kGmfPrisms: return "Prisms";
      case kGmfPyramids: return "Pyramids";
      case kGmfTetrahedraP2: return "TetrahedraP2";
      case kGmfHexahedraQ2: return "HexahedraQ2";
      default: return "keyword";
    }
  }

  Status fail(ErrorCode c, long record, const std::string& what) const {
    if (record > 0) return Status::error(c, name_ + ": record " + std::to_string(record) + ": " + what, record);
    return Status::error(c, name_ + ": " + what);
  }

  template <typename T>
  T load(size_t off) const {
    unsigned char tmp[sizeof(T)];
    std::memcpy(tmp, b_ + off, sizeof(T));
    if (swap_) std::reverse(tmp, tmp + sizeof(T));
    T v;
    std::memcpy(&v, tmp, sizeof(T));
    return v;
  }
  bool word32(size_t& off, int32_t& v) const {
    if (n_ - off < 4 || off > n_) return false;
    v = load<int32_t>(off);
    off += 4;
    return true;
  }
  bool position(size_t& off, int64_t& v) const {
    if (ver_ >= 3) {
      if (off > n_ || n_ - off < 8) return false;
      v = load<int64_t>(off);
      off += 8;
      return true;
    }
    int32_t w = 0;
    if (!word32(off, w)) return false;
    v = w;
    return true;
  }
  size_t int_size() const { return ver_ == 4 ? 8 : 4; }
  size_t real_size() const { return ver_ == 1 ? 4 : 8; }
  bool integer(size_t& off, int64_t& v) const {
    if (ver_ == 4) {
      if (off > limit_ || limit_ - off < 8) return false;
      v = load<int64_t>(off);
      off += 8;
      return true;
    }
    if (off > limit_ || limit_ - off < 4) return false;
    v = load<int32_t>(off);
    off += 4;
    return true;
  }
  int64_t int_at(size_t off) const { return ver_ == 4 ? load<int64_t>(off) : load<int32_t>(off); }
  double real_at(size_t off) const {
    return ver_ == 1 ? static_cast<double>(load<float>(off)) : load<double>(off);
  }

  /// Count of a keyword, checked against the bytes before the next keyword.
  Status read_count(size_t& off, const char* kw, size_t rec_size, int64_t& n) {
    if (!integer(off, n)) return fail(ErrorCode::Parse, 0, std::string(kw) + ": file ends before the count (truncated?)");
    if (n < 0) return fail(ErrorCode::Parse, 0, std::string(kw) + ": negative count " + std::to_string(n));
    const uint64_t room = (limit_ - off) / rec_size;
    if (static_cast<uint64_t>(n) > room)
      return fail(ErrorCode::Parse, 0,
                  std::string(kw) + ": count " + std::to_string(n) + " needs more than the " +
                      std::to_string(limit_ - off) + " bytes that remain (" + std::to_string(rec_size) +
                      " per record; truncated file or lying count)");
    if (n > kMaxId)
      return fail(ErrorCode::Unsupported, 0, std::string(kw) + ": count exceeds the 32-bit index range");
    return Status::success();
  }

  Status ref_at(size_t off, const char* kw, int64_t rec, int32_t& ref) const {
    const int64_t r = int_at(off);
    if (r < std::numeric_limits<int32_t>::min() || r > kMaxId)
      return fail(ErrorCode::Parse, static_cast<long>(rec),
                  std::string(kw) + ": reference " + std::to_string(r) + " does not fit in 32 bits");
    ref = static_cast<int32_t>(r);
    return Status::success();
  }

  Status read_vertices(size_t off) {
    const size_t rs = 3 * real_size() + int_size();
    int64_t n = 0;
    if (Status s = read_count(off, "Vertices", rs, n); !s) return s;
    m_.xyz.resize(detail::ck_size(n, 3));
    m_.vert_ref.resize(detail::ck_size(n, 1));
    for (int64_t i = 0; i < n; ++i, off += rs) {
      for (int k = 0; k < 3; ++k) {
        const double x = real_at(off + k * real_size());
        if (!std::isfinite(x))
          return fail(ErrorCode::InvalidMesh, static_cast<long>(i + 1),
                      "Vertices: vertex " + std::to_string(i + 1) + " has a non-finite coordinate");
        m_.xyz[3 * static_cast<size_t>(i) + k] = x;
      }
      if (Status s = ref_at(off + 3 * real_size(), "Vertices", i + 1, m_.vert_ref[static_cast<size_t>(i)]); !s)
        return s;
    }
    return Status::success();
  }

  Status read_elements(size_t off, const char* kw, int nper, std::vector<int32_t>& ids, std::vector<int32_t>& refs) {
    const size_t is = int_size();
    const size_t rs = (nper + 1) * is;
    int64_t n = 0;
    if (Status s = read_count(off, kw, rs, n); !s) return s;
    ids.resize(detail::ck_size(n, static_cast<uint64_t>(nper)));
    refs.resize(detail::ck_size(n, 1));
    for (int64_t i = 0; i < n; ++i, off += rs) {
      for (int k = 0; k < nper; ++k) {
        const int64_t v = int_at(off + k * is);
        if (v < 1 || v > kMaxId)
          return fail(ErrorCode::InvalidMesh, static_cast<long>(i + 1),
                      std::string(kw) + ": vertex index " + std::to_string(v) +
                          bad_index(v));
        ids[static_cast<size_t>(i) * nper + k] = static_cast<int32_t>(v - 1);
      }
      if (Status s = ref_at(off + nper * is, kw, i + 1, refs[static_cast<size_t>(i)]); !s) return s;
    }
    return Status::success();
  }

  Status read_list(size_t off, const char* kw, std::vector<int32_t>& ids) {
    const size_t is = int_size();
    int64_t n = 0;
    if (Status s = read_count(off, kw, is, n); !s) return s;
    ids.resize(detail::ck_size(n, 1));
    for (int64_t i = 0; i < n; ++i, off += is) {
      const int64_t v = int_at(off);
      if (v < 1 || v > kMaxId)
        return fail(ErrorCode::InvalidMesh, static_cast<long>(i + 1),
                    std::string(kw) + ": index " + std::to_string(v) +
                        bad_index(v));
      ids[static_cast<size_t>(i)] = static_cast<int32_t>(v - 1);
    }
    return Status::success();
  }

  Status check_ids(const char* kw, const std::vector<int32_t>& ids, int per, int64_t limit, const char* what) const {
    for (size_t i = 0; i < ids.size(); ++i)
      if (ids[i] >= limit)
        return fail(ErrorCode::InvalidMesh, static_cast<long>(i / per + 1),
                    std::string(kw) + ": " + what + " index " + std::to_string(ids[i] + 1) + " out of range 1.." +
                        std::to_string(limit));
    return Status::success();
  }

  const unsigned char* b_;
  size_t n_;
  const std::string& name_;
  bool swap_ = false;
  int ver_ = 2;
  size_t limit_ = 0;
  TetMesh m_;
};

// --------------------------------------------------------------- writers ---

/// Cheap consistency check before writing (a bug, not bad input, if it fails).
Status check_for_write(const TetMesh& m) {
  if (m.xyz.size() % 3 || m.tets.size() % 4 || m.tris.size() % 3 || m.edges.size() % 2)
    return Status::error(ErrorCode::Invariant, "inconsistent array sizes");
  const int64_t nv = m.nv();
  for (const auto* a : {&m.tets, &m.tris, &m.edges, &m.corners, &m.required_vertices})
    for (int32_t v : *a)
      if (v < 0 || v >= nv) return Status::error(ErrorCode::Invariant, "a vertex index is out of range");
  for (int32_t i : m.required_tris)
    if (i < 0 || i >= m.ntri()) return Status::error(ErrorCode::Invariant, "a required triangle index is out of range");
  const int64_t ne = static_cast<int64_t>(m.edges.size() / 2);
  for (const auto* a : {&m.ridges, &m.required_edges})
    for (int32_t i : *a)
      if (i < 0 || i >= ne) return Status::error(ErrorCode::Invariant, "a ridge or required edge index is out of range");
  return Status::success();
}

int32_t ref_of(const std::vector<int32_t>& r, size_t i) { return i < r.size() ? r[i] : 0; }

using detail::put_int;
using detail::put_real;

void put_list(std::string& out, const char* kw, const std::vector<int32_t>& ids) {
  if (ids.empty()) return;
  out += kw;
  out += '\n';
  put_int(out, static_cast<int64_t>(ids.size()));
  out += '\n';
  for (int32_t i : ids) {
    put_int(out, int64_t(i) + 1);
    out += '\n';
  }
  out += '\n';
}

template <typename T>
void put_raw(std::string& out, T v) {
  char buf[sizeof(T)];
  std::memcpy(buf, &v, sizeof(T));
  out.append(buf, sizeof(T));
}

/// Writes GMF keyword blocks, back-patching each next-keyword position.
class GmfWriter {
 public:
  GmfWriter(std::string& out, int ver) : out_(out), ver_(ver) {}
  void begin(int32_t kwd) {
    put_raw<int32_t>(out_, kwd);
    pos_at_ = out_.size();
    if (ver_ >= 3) put_raw<int64_t>(out_, 0);
    else put_raw<int32_t>(out_, 0);
  }
  void end() {  // the next keyword starts here
    const uint64_t p = out_.size();
    if (ver_ >= 3) {
      const int64_t v = static_cast<int64_t>(p);
      std::memcpy(&out_[pos_at_], &v, 8);
    } else {
      const int32_t v = static_cast<int32_t>(p);
      std::memcpy(&out_[pos_at_], &v, 4);
    }
  }
  void integer(int64_t v) {
    if (ver_ == 4) put_raw<int64_t>(out_, v);
    else put_raw<int32_t>(out_, static_cast<int32_t>(v));
  }
  void real(double v) { put_raw<double>(out_, v); }
  void list(int32_t kwd, const std::vector<int32_t>& ids) {
    if (ids.empty()) return;
    begin(kwd);
    integer(static_cast<int64_t>(ids.size()));
    for (int32_t i : ids) integer(int64_t(i) + 1);
    end();
  }

 private:
  std::string& out_;
  int ver_;
  size_t pos_at_ = 0;
};

template <typename F>
Status guarded(const std::string& name, F&& f) {
  try {
    return f();
  } catch (const std::bad_alloc&) {
    return Status::error(ErrorCode::OutOfMemory, name + ": out of memory");
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::Invariant, name + ": unexpected error: " + e.what());
  }
}

}  // namespace

Status parse_medit(std::string_view data, const std::string& name, TetMesh& m, int threads) {
  return detail::parse_medit_tuned(data, name, m, threads,
                                   threads == 1 ? std::numeric_limits<int64_t>::max() : ParallelRecords::kMinRecords,
                                   ParallelRecords::kChunk);
}

Status detail::parse_medit_tuned(std::string_view data, const std::string& name, TetMesh& m, int threads,
                                 int64_t min_records, size_t chunk) {
  return guarded(name, [&] {
    TetMesh tmp;
    MeditAsciiReader r(data, name, threads, std::max<int64_t>(1, min_records), chunk);
    Status s = r.run(tmp);
    if (s) m = std::move(tmp);
    return s;
  });
}

Status parse_meditb(std::string_view data, const std::string& name, TetMesh& m) {
  return guarded(name, [&] {
    TetMesh tmp;
    MeditBinaryReader r(data, name);
    Status s = r.run(tmp);
    if (s) m = std::move(tmp);
    return s;
  });
}

Status format_medit(const TetMesh& m, std::string& out, int threads, const TextFlush& flush) {
  return guarded("Medit writer", [&] {
    if (Status s = check_for_write(m); !s) return s;
    out.clear();
    constexpr size_t kFlushAt = size_t{4} << 20;
    const size_t whole = static_cast<size_t>(m.nv()) * 64 + m.tets.size() * 10 + m.tris.size() * 10 + 256;
    // Streamed, `out` holds at most kFlushAt plus one block of lines.
    out.reserve(flush ? std::min(whole, kFlushAt + (size_t{1} << 20)) : whole);
    auto maybe_flush = [&] {
      if (flush && out.size() >= kFlushAt) {
        flush(out);
        out.clear();
      }
    };
    out += "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n";
    put_int(out, m.nv());
    out += '\n';
    // Vertex and tet lines are formatted in fixed blocks (in parallel with
    // threads > 1) and appended in order: the same bytes for any count.  The
    // blocks go in batches through buffers kept from batch to batch: a fresh
    // buffer per block was a fresh mapping of zeroed pages per block, the
    // largest part of the writer's time.
    // Blocks per batch: 16, or when streamed 2 per thread (at least 4), so
    // that the batch's buffers (about 0.5 MB a block) stay small beside the
    // pieces; the bytes do not depend on it.
    const int64_t kBatch = flush ? std::clamp<int64_t>(2 * detail::resolve_threads(threads), 4, 16) : 16;
    std::vector<std::string> buf(static_cast<size_t>(kBatch));
    auto blocks = [&](int64_t n, auto&& line) {
      for (int64_t b0 = 0; b0 < n; b0 += kBatch * detail::kBlock) {
        const int64_t len = std::min(n - b0, kBatch * detail::kBlock);
        detail::parallel_blocks(len, threads, [&](int64_t b, int64_t e) {
          std::string& o = buf[static_cast<size_t>(b / detail::kBlock)];
          o.clear();
          for (int64_t i = b; i < e; ++i) line(o, b0 + i);
        });
        for (int64_t k = 0; k < detail::block_count(len); ++k) {
          out += buf[static_cast<size_t>(k)];
          maybe_flush();
        }
      }
    };
    blocks(m.nv(), [&](std::string& o, int64_t i) {
      const auto v = static_cast<int32_t>(i);
      const double* p = m.point(v);
      for (int k = 0; k < 3; ++k) {
        put_real(o, p[k]);
        o += ' ';
      }
      put_int(o, ref_of(m.vert_ref, v));
      o += '\n';
    });
    out += '\n';
    auto elements = [&](const char* kw, const std::vector<int32_t>& ids, int per, const std::vector<int32_t>& refs) {
      if (ids.empty()) return;
      const size_t n = ids.size() / per;
      out += kw;
      out += '\n';
      put_int(out, static_cast<int64_t>(n));
      out += '\n';
      for (size_t i = 0; i < n; ++i) {
        for (int k = 0; k < per; ++k) {
          put_int(out, int64_t(ids[i * per + k]) + 1);
          out += ' ';
        }
        put_int(out, ref_of(refs, i));
        out += '\n';
      }
      out += '\n';
    };
    elements("Edges", m.edges, 2, m.edge_ref);
    elements("Triangles", m.tris, 3, m.tri_ref);
    maybe_flush();
    out += "Tetrahedra\n";
    put_int(out, m.nt());
    out += '\n';
    blocks(m.nt(), [&](std::string& o, int64_t i) {
      const auto t = static_cast<int32_t>(i);
      int32_t v[4];
      detail::file_tet(m, t, Format::Medit, v);
      for (int k = 0; k < 4; ++k) {
        put_int(o, int64_t(v[k]) + 1);
        o += ' ';
      }
      put_int(o, ref_of(m.tet_ref, static_cast<size_t>(t)));
      o += '\n';
    });
    out += '\n';
    put_list(out, "Corners", m.corners);
    put_list(out, "RequiredVertices", m.required_vertices);
    put_list(out, "Ridges", m.ridges);
    put_list(out, "RequiredEdges", m.required_edges);
    put_list(out, "RequiredTriangles", m.required_tris);
    out += "End\n";
    return Status::success();
  });
}

Status format_meditb(const TetMesh& m, std::string& out, int version) {
  return guarded("Medit binary writer", [&] {
    if (version < 2 || version > 4)
      return Status::error(ErrorCode::Unsupported,
                           "GMF version " + std::to_string(version) + " is not written (use 2, 3 or 4)");
    if (Status s = check_for_write(m); !s) return s;
    out.clear();
    const size_t is = version == 4 ? 8 : 4;
    const size_t est = 64 + static_cast<size_t>(m.nv()) * (24 + is) + (m.tets.size() + m.tet_ref.size()) * is +
                       (m.tris.size() + m.tri_ref.size() + m.edges.size() + m.edge_ref.size()) * is +
                       (m.corners.size() + m.ridges.size() + m.required_vertices.size() + m.required_edges.size() +
                        m.required_tris.size()) * is + 7 * 20;
    if (version == 2 && est > static_cast<size_t>(std::numeric_limits<int32_t>::max()))
      return Status::error(ErrorCode::Unsupported, "the mesh needs more than 2 GiB: GMF version 2 cannot address it (use 3 or 4)");
    out.reserve(est);
    put_raw<int32_t>(out, 1);
    put_raw<int32_t>(out, version);
    GmfWriter w(out, version);
    w.begin(kGmfDimension);
    put_raw<int32_t>(out, 3);
    w.end();
    w.begin(kGmfVertices);
    w.integer(m.nv());
    for (int32_t v = 0; v < m.nv(); ++v) {
      const double* p = m.point(v);
      w.real(p[0]);
      w.real(p[1]);
      w.real(p[2]);
      w.integer(ref_of(m.vert_ref, v));
    }
    w.end();
    auto elements = [&](int32_t kwd, const std::vector<int32_t>& ids, int per, const std::vector<int32_t>& refs) {
      if (ids.empty()) return;
      const size_t n = ids.size() / per;
      w.begin(kwd);
      w.integer(static_cast<int64_t>(n));
      for (size_t i = 0; i < n; ++i) {
        for (int k = 0; k < per; ++k) w.integer(int64_t(ids[i * per + k]) + 1);
        w.integer(ref_of(refs, i));
      }
      w.end();
    };
    elements(kGmfEdges, m.edges, 2, m.edge_ref);
    elements(kGmfTriangles, m.tris, 3, m.tri_ref);
    w.begin(kGmfTetrahedra);
    w.integer(m.nt());
    for (int32_t t = 0; t < m.nt(); ++t) {
      int32_t v[4];
      detail::file_tet(m, t, Format::MeditBinary, v);
      for (int k = 0; k < 4; ++k) w.integer(int64_t(v[k]) + 1);
      w.integer(ref_of(m.tet_ref, static_cast<size_t>(t)));
    }
    w.end();
    w.list(kGmfCorners, m.corners);
    w.list(kGmfRequiredVertices, m.required_vertices);
    w.list(kGmfRidges, m.ridges);
    w.list(kGmfRequiredEdges, m.required_edges);
    w.list(kGmfRequiredTriangles, m.required_tris);
    put_raw<int32_t>(out, kGmfEnd);  // End: next-keyword position 0
    if (version >= 3) put_raw<int64_t>(out, 0);
    else put_raw<int32_t>(out, 0);
    if (version == 2 && out.size() > static_cast<size_t>(std::numeric_limits<int32_t>::max()))
      return Status::error(ErrorCode::Unsupported, "the mesh needs more than 2 GiB: GMF version 2 cannot address it (use 3 or 4)");
    return Status::success();
  });
}

}  // namespace tetopt
