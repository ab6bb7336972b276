// Medit .mesh / .meshb reader and writer: round trips, orientation, hostile
// input, real meshes (when /work/shared/meshes exists) and a meshio cross-check.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cfloat>
#include <climits>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "io/common.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"

using namespace tetopt;
namespace fs = std::filesystem;

namespace {

/// Box mesh with every kind of entity Medit carries and awkward doubles.
TetMesh rich_mesh(bool with_required_lists = true) {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 2, .nz = 2, .jitter = 0.3, .seed = 7, .regions = 2});
  for (double& x : m.xyz) x = x * 0.1 + 1.0 / 3.0;  // affine with positive scale: tets stay positive
  for (int32_t v = 0; v < m.nv(); ++v) m.vert_ref[v] = (v % 5) - 2;
  for (int32_t i = 0; i < m.ntri(); ++i) m.tri_ref[i] = 10 + i % 3;
  // Unused vertices with values that a sloppy printer would not round-trip.
  const double odd[] = {-0.0, 5e-324, DBL_MAX, -DBL_MIN, 0.1, 1e300, 123456789.123456789, -2.5e-310, 1e-7};
  for (size_t i = 0; i + 2 < std::size(odd); i += 3) {
    m.xyz.insert(m.xyz.end(), {odd[i], odd[i + 1], odd[i + 2]});
    m.vert_ref.push_back(static_cast<int32_t>(i) + 100);
  }
  // Edges: the first edge of the first few triangles.
  for (int32_t i = 0; i < 6; ++i) {
    m.edges.push_back(m.tris[3 * i]);
    m.edges.push_back(m.tris[3 * i + 1]);
    m.edge_ref.push_back(i == 2 ? -7 : 20 + i);
  }
  m.corners = {0, 3, 5};
  m.ridges = {1, 4};
  m.required_vertices = {2, 7, 11};
  if (with_required_lists) {
    m.required_edges = {0, 5};
    m.required_tris = {1, 3, 8};
  }
  m.tet_ref[0] = -3;
  m.tet_ref[5] = 123456;
  return m;
}

void expect_same_arrays(const TetMesh& a, const TetMesh& b, bool lists = true) {
  ASSERT_EQ(a.xyz.size(), b.xyz.size());
  EXPECT_EQ(0, std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * sizeof(double))) << "coordinates differ in bits";
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.tet_ref, b.tet_ref);
  EXPECT_EQ(a.vert_ref, b.vert_ref);
  EXPECT_EQ(a.tris, b.tris);
  EXPECT_EQ(a.tri_ref, b.tri_ref);
  if (!lists) return;
  EXPECT_EQ(a.edges, b.edges);
  EXPECT_EQ(a.edge_ref, b.edge_ref);
  EXPECT_EQ(a.corners, b.corners);
  EXPECT_EQ(a.ridges, b.ridges);
  EXPECT_EQ(a.required_vertices, b.required_vertices);
  EXPECT_EQ(a.required_edges, b.required_edges);
  EXPECT_EQ(a.required_tris, b.required_tris);
}

fs::path temp_dir(const std::string& tag) {
  fs::path d = fs::temp_directory_path() / ("tetopt_medit_" + tag + "_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

std::string slurp(const fs::path& p) {
  std::string s;
  EXPECT_TRUE(read_file_bytes(p.string(), s).ok());
  return s;
}

bool all_positive(const TetMesh& m) {
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    if (orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])) != Sign::Positive) return false;
  }
  return true;
}

/// Parses text that must fail; checks code, "name:LINE:" prefix and a phrase.
void expect_ascii_error(const std::string& text, ErrorCode code, long line, const std::string& phrase) {
  TetMesh m;
  const Status s = parse_medit(text, "t.mesh", m);
  ASSERT_FALSE(s.ok()) << "accepted:\n" << text;
  EXPECT_EQ(static_cast<int>(s.code), static_cast<int>(code)) << s.message;
  EXPECT_EQ(s.message.find('\n'), std::string::npos) << s.message;
  if (line > 0) {
    EXPECT_EQ(s.line, line) << s.message;
    EXPECT_EQ(s.message.rfind("t.mesh:" + std::to_string(line) + ": ", 0), 0u) << s.message;
  } else {
    EXPECT_EQ(s.message.rfind("t.mesh", 0), 0u) << s.message;
  }
  EXPECT_NE(s.message.find(phrase), std::string::npos) << s.message;
}

const char* kOneTet =
    "MeshVersionFormatted 2\n"   // 1
    "Dimension 3\n"              // 2
    "Vertices\n"                 // 3
    "4\n"                        // 4
    "0 0 0 1\n"                  // 5
    "1 0 0 2\n"                  // 6
    "0 1 0 3\n"                  // 7
    "0 0 1 4\n"                  // 8
    "Tetrahedra\n"               // 9
    "1\n"                        // 10
    "1 2 3 4 9\n"                // 11
    "End\n";                     // 12

// --- GMF byte builder for hand-made binary files (either byte order) ---
struct Gmf {
  int ver;
  bool swap;
  std::string b;
  template <typename T>
  void raw(T v) {
    unsigned char t[sizeof(T)];
    std::memcpy(t, &v, sizeof(T));
    if (swap) std::reverse(t, t + sizeof(T));
    b.append(reinterpret_cast<char*>(t), sizeof(T));
  }
  void w32(int32_t v) { raw(v); }
  void pos(int64_t v) {
    if (ver >= 3) raw<int64_t>(v);
    else raw<int32_t>(static_cast<int32_t>(v));
  }
  void integer(int64_t v) {
    if (ver == 4) raw<int64_t>(v);
    else raw<int32_t>(static_cast<int32_t>(v));
  }
  void real(double v) {
    if (ver == 1) raw<float>(static_cast<float>(v));
    else raw<double>(v);
  }
  size_t pos_at = 0;
  void begin(int32_t kwd) {
    w32(kwd);
    pos_at = b.size();
    pos(0);
  }
  void end() {  // patch the next-keyword position
    Gmf tmp{ver, swap, {}};
    tmp.pos(static_cast<int64_t>(b.size()));
    b.replace(pos_at, tmp.b.size(), tmp.b);
  }
};

/// One tet (+ an unknown Normals keyword to skip) in GMF binary.
std::string gmf_one_tet(int ver, bool swap, int64_t vert_count_override = INT64_MIN) {
  Gmf g{ver, swap, {}};
  g.w32(1);
  g.w32(ver);
  g.begin(3);
  g.w32(3);
  g.end();
  g.begin(60);  // Normals: skipped through its next-keyword position
  g.integer(1);
  g.real(0);
  g.real(0);
  g.real(1);
  g.end();
  g.begin(4);
  g.integer(vert_count_override != INT64_MIN ? vert_count_override : 4);
  const double p[4][3] = {{0, 0, 0}, {1.5, 0, 0}, {0, 2.25, 0}, {0, 0, -0.5}};
  for (int i = 0; i < 4; ++i) {
    for (int k = 0; k < 3; ++k) g.real(p[i][k]);
    g.integer(i + 1);
  }
  g.end();
  g.begin(8);
  g.integer(1);
  for (int k : {1, 2, 4, 3}) g.integer(k);
  g.integer(-5);
  g.end();
  g.w32(54);
  g.pos(0);
  return g.b;
}

}  // namespace

// ------------------------------------------------------------ round trips --

TEST(IoMedit, AsciiRoundTripKeepsEverything) {
  const TetMesh m = rich_mesh();
  std::string text;
  ASSERT_TRUE(format_medit(m, text).ok());
  TetMesh r;
  const Status s = parse_medit(text, "rt.mesh", r);
  ASSERT_TRUE(s.ok()) << s.message;
  expect_same_arrays(m, r);
  // Deterministic output.
  std::string again;
  ASSERT_TRUE(format_medit(r, again).ok());
  EXPECT_EQ(text, again);
}

TEST(IoMedit, BinaryRoundTripEveryWrittenVersion) {
  const TetMesh m = rich_mesh();
  for (int ver : {2, 3, 4}) {
    SCOPED_TRACE("version " + std::to_string(ver));
    std::string bytes;
    ASSERT_TRUE(format_meditb(m, bytes, ver).ok());
    int32_t head[2];
    std::memcpy(head, bytes.data(), 8);
    EXPECT_EQ(head[0], 1);
    EXPECT_EQ(head[1], ver);
    TetMesh r;
    const Status s = parse_meditb(bytes, "rt.meshb", r);
    ASSERT_TRUE(s.ok()) << s.message;
    expect_same_arrays(m, r);
  }
  std::string bytes;
  EXPECT_EQ(format_meditb(m, bytes, 1).code, ErrorCode::Unsupported);
  EXPECT_EQ(format_meditb(m, bytes, 5).code, ErrorCode::Unsupported);
}

TEST(IoMedit, BinaryVersionSizesMatchTheGmfLayout) {
  // One tet, no lists: header 8, Dimension 4+P+4, Vertices 4+P+I+4*(24+I),
  // Tetrahedra 4+P+I+5I, End 4+P  (P position size, I integer size).
  TetMesh m;
  m.xyz = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.tets = {0, 1, 2, 3};
  m.tet_ref = {0};
  m.vert_ref.assign(4, 0);
  for (int ver : {2, 3, 4}) {
    const size_t P = ver >= 3 ? 8 : 4, I = ver == 4 ? 8 : 4;
    std::string bytes;
    ASSERT_TRUE(format_meditb(m, bytes, ver).ok());
    EXPECT_EQ(bytes.size(), 8 + (8 + P) + (4 + P + I + 4 * (24 + I)) + (4 + P + I + 5 * I) + (4 + P)) << ver;
  }
}

TEST(IoMedit, HandMadeBinaryBothByteOrdersAndVersion1) {
  for (int ver : {1, 2, 3, 4})
    for (bool swap : {false, true}) {
      SCOPED_TRACE("version " + std::to_string(ver) + (swap ? " swapped" : ""));
      TetMesh r;
      const Status s = parse_meditb(gmf_one_tet(ver, swap), "h.meshb", r);
      ASSERT_TRUE(s.ok()) << s.message;
      EXPECT_EQ(r.xyz, (std::vector<double>{0, 0, 0, 1.5, 0, 0, 0, 2.25, 0, 0, 0, -0.5}));
      EXPECT_EQ(r.vert_ref, (std::vector<int32_t>{1, 2, 3, 4}));
      EXPECT_EQ(r.tets, (std::vector<int32_t>{0, 1, 3, 2}));
      EXPECT_EQ(r.tet_ref, (std::vector<int32_t>{-5}));
    }
}

TEST(IoMedit, FilesThroughReadWriteMesh) {
  const fs::path d = temp_dir("files");
  const TetMesh m = rich_mesh();
  for (const char* ext : {".mesh", ".meshb"})
    for (int ver : {2, 3, 4}) {
      if (std::string(ext) == ".mesh" && ver != 2) continue;
      const std::string p = (d / (std::string("a") + std::to_string(ver) + ext)).string();
      WriteOptions o;
      o.meditb_version = ver;
      Status s = write_mesh(p, m, o);
      ASSERT_TRUE(s.ok()) << s.message;
      TetMesh r;
      OrientationReport rep;
      s = read_mesh(p, r, &rep);
      ASSERT_TRUE(s.ok()) << s.message;
      EXPECT_FALSE(rep.flipped);
      EXPECT_TRUE(rep.inverted.empty());
      expect_same_arrays(m, r);
      EXPECT_TRUE(all_positive(r));
    }
  fs::remove_all(d);
}

TEST(IoMedit, NegativeFileIsNormalisedAndWrittenBackNegative) {
  // A .mesh whose tets all have the opposite orientation.
  TetMesh m = make_box_mesh({.nx = 2, .ny = 2, .nz = 1});
  for (int32_t t = 0; t < m.nt(); ++t) std::swap(m.tets[4 * t + 2], m.tets[4 * t + 3]);
  std::string text;
  ASSERT_TRUE(format_medit(m, text).ok());
  const fs::path d = temp_dir("neg");
  const std::string in = (d / "neg.mesh").string(), out = (d / "out.mesh").string();
  ASSERT_TRUE(write_file_atomic(in, text).ok());
  TetMesh r;
  OrientationReport rep;
  ASSERT_TRUE(read_mesh(in, r, &rep).ok());
  EXPECT_TRUE(rep.flipped);
  EXPECT_TRUE(r.flipped_on_read);
  EXPECT_TRUE(all_positive(r));
  ASSERT_TRUE(write_mesh(out, r).ok());
  EXPECT_EQ(slurp(in), slurp(out));  // the file keeps its own convention
  fs::remove_all(d);
}

// ---------------------------------------------------------- ASCII parsing --

TEST(IoMedit, AsciiToleratesLayoutCommentsAndSkippableKeywords) {
  const std::string text =
      "# a comment\n"
      "MeshVersionFormatted 1 Dimension\n\n 3\n"
      "Vertices 4\n0 0 0 0   1 0 0 0\n0 1 0 0\r\n0 0 1 0 # trailing comment\n"
      "Normals\n2\n0 0 1\n1 0 0\n"
      "NormalAtVertices 1 1 1\n"
      "Quadrilaterals 0\n"
      "Hexahedra\n0\n"
      "Identifier \"a b c\"\n"
      "Tetrahedra 1 1 2 3 4 +7\n"
      "Triangles 1\n1 2 3 5\n"
      "End\n"
      "garbage after End is ignored\n";
  TetMesh m;
  const Status s = parse_medit(text, "t.mesh", m);
  ASSERT_TRUE(s.ok()) << s.message;
  EXPECT_EQ(m.nv(), 4);
  EXPECT_EQ(m.tets, (std::vector<int32_t>{0, 1, 2, 3}));
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{7}));
  EXPECT_EQ(m.tris, (std::vector<int32_t>{0, 1, 2}));
  EXPECT_EQ(m.tri_ref, (std::vector<int32_t>{5}));
}

TEST(IoMedit, AsciiSectionsInAnyOrder) {
  // Lists and elements before the entities they index are range-checked at the end.
  const std::string ok =
      "Dimension 3\nRidges 1 2\nTetrahedra 1 1 2 3 4 0\nEdges 2 1 2 0 2 3 0\n"
      "Vertices 4 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 0\nEnd\n";
  TetMesh m;
  Status s = parse_medit(ok, "t.mesh", m);
  ASSERT_TRUE(s.ok()) << s.message;
  EXPECT_EQ(m.ridges, (std::vector<int32_t>{1}));
  expect_ascii_error("Dimension 3\nRidges 1 3\nTetrahedra 1 1 2 3 4 0\nEdges 2 1 2 0 2 3 0\n"
                     "Vertices 4 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 0\nEnd\n",
                     ErrorCode::InvalidMesh, 2, "edge index 3 out of range 1..2");
  expect_ascii_error("Dimension 3\nTetrahedra 1 1 2 3 5 0\n"
                     "Vertices 4 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 0\nEnd\n",
                     ErrorCode::InvalidMesh, 2, "vertex index 5 out of range 1..4");
}

TEST(IoMedit, AsciiHostileInput) {
  const std::string one = kOneTet;
  // Truncated inside the Tetrahedra record: the byte bound on the count sees it
  // first; with padding the data runs out inside the record.
  expect_ascii_error(one.substr(0, one.find("1 2 3 4 9") + 5), ErrorCode::Parse, 10, "truncated");
  expect_ascii_error(one.substr(0, one.find("1 2 3 4 9") + 5) + "  # padding padding padding", ErrorCode::Parse, 11,
                     "unexpected end of file in Tetrahedra record 1 of 1");
  // Truncated inside Vertices.
  expect_ascii_error(one.substr(0, one.find("0 1 0 3")), ErrorCode::Parse, 4, "truncated");
  // Truncated at a section boundary: End is missing.
  expect_ascii_error(one.substr(0, one.find("End")), ErrorCode::Parse, 12, "missing End keyword");
  // A count that lies.
  {
    std::string t = one;
    t.replace(t.find("Vertices\n4"), 10, "Vertices\n6");
    expect_ascii_error(t, ErrorCode::Parse, 9, "count");
  }
  // An absurd count: rejected before any allocation.
  expect_ascii_error("MeshVersionFormatted 2\nDimension 3\nVertices\n1000000000000000\n0 0 0 0\nEnd\n", ErrorCode::Parse,
                     4, "more than the rest of the file can hold (1 records at most)");
  expect_ascii_error("Dimension 3\nVertices\n99999999999999999999999\n", ErrorCode::Parse, 3, "expected a count");
  expect_ascii_error("Dimension 3\nVertices\n-4\n", ErrorCode::Parse, 3, "negative count");
  // NaN / Inf / overflow coordinates.
  {
    std::string t = one;
    t.replace(t.find("1 0 0 2"), 7, "nan 0 0 2");
    expect_ascii_error(t, ErrorCode::InvalidMesh, 6, "non-finite");
    t = one;
    t.replace(t.find("0 0 1 4"), 7, "0 0 -inf 4");
    expect_ascii_error(t, ErrorCode::InvalidMesh, 8, "non-finite");
    t = one;
    t.replace(t.find("0 0 1 4"), 7, "0 0 1e999 4");
    expect_ascii_error(t, ErrorCode::Parse, 8, "expected a coordinate");
  }
  // A version out of range: its own line and token (not the next ones).
  expect_ascii_error("MeshVersionFormatted 5\nDimension 3\n", ErrorCode::Parse, 1, "found '5'");
  expect_ascii_error("MeshVersionFormatted\n\n  x\nDimension 3\n", ErrorCode::Parse, 3, "found 'x'");
  // Index out of range, zero, negative.
  for (const char* bad : {"1 2 3 5 9", "0 2 3 4 9", "1 -2 3 4 9"}) {
    std::string t = one;
    t.replace(t.find("1 2 3 4 9"), 9, bad);
    expect_ascii_error(t, ErrorCode::InvalidMesh, 11, "out of range 1..4");
  }
  // Non-numeric tokens.
  {
    std::string t = one;
    t.replace(t.find("0 1 0 3"), 7, "0 x1 0 3");
    expect_ascii_error(t, ErrorCode::Parse, 7, "found 'x1'");
    t = one;
    t.replace(t.find("1 2 3 4 9"), 9, "1 2 3 4 9.5");
    expect_ascii_error(t, ErrorCode::Parse, 11, "found '9.5'");
  }
  // Missing / wrong dimension.
  {
    std::string t = one;
    t.replace(t.find("Dimension 3\n"), 12, "");
    expect_ascii_error(t, ErrorCode::Parse, 2, "missing Dimension");
    t = one;
    t.replace(t.find("Dimension 3"), 11, "Dimension 2");
    expect_ascii_error(t, ErrorCode::Unsupported, 2, "2-D mesh");
    t = one;
    t.replace(t.find("Dimension 3"), 11, "Dimension 4");
    expect_ascii_error(t, ErrorCode::Parse, 2, "expected 3");
  }
  // Surface-only mesh.
  expect_ascii_error("MeshVersionFormatted 2\nDimension 3\nVertices 3\n0 0 0 0\n1 0 0 0\n0 1 0 0\n"
                     "Triangles 1\n1 2 3 0\nEnd\n",
                     ErrorCode::InvalidMesh, 0, "no tetrahedra (surface-only mesh?)");
  // Unknown keyword, named with its line.
  {
    std::string t = one;
    t.replace(t.find("Tetrahedra"), 10, "Tetrahedrons");
    expect_ascii_error(t, ErrorCode::Parse, 9, "unknown keyword 'Tetrahedrons'");
  }
  // Mixed elements are refused with a clear message.
  expect_ascii_error(one.substr(0, one.find("End")) + "Hexahedra\n1\n1 2 3 4 1 2 3 4 0\nEnd\n",
                     ErrorCode::Unsupported, 12, "Hexahedra");
  // Duplicate section, number where a keyword belongs, empty file.
  expect_ascii_error(one.substr(0, one.find("End")) + "Tetrahedra\n1\n1 2 3 4 9\nEnd\n", ErrorCode::Parse, 12,
                     "second Tetrahedra");
  expect_ascii_error(one.substr(0, one.find("End")) + "42\nEnd\n", ErrorCode::Parse, 12, "expected a keyword");
  expect_ascii_error("", ErrorCode::Parse, 0, "missing Dimension");
  // Required triangles name triangles, not vertices.
  expect_ascii_error(one.substr(0, one.find("End")) + "Triangles 1 1 2 3 0\nRequiredTriangles 1 2\nEnd\n",
                     ErrorCode::InvalidMesh, 13, "triangle index 2 out of range 1..1");
}

TEST(IoMedit, AsciiEveryPrefixFailsCleanlyOrParses) {
  std::string text;
  ASSERT_TRUE(format_medit(rich_mesh(), text).ok());
  // End is required, so every cut before it is reported, never read as a smaller mesh.
  const size_t cut_end = text.rfind("End") + 3;
  for (size_t n = 0; n < cut_end; n += (n < 400 || n + 400 > cut_end ? 1 : 7)) {
    TetMesh m;
    const Status s = parse_medit(std::string_view(text).substr(0, n), "p.mesh", m);
    ASSERT_FALSE(s.ok()) << "prefix of " << n << " bytes accepted";
    EXPECT_EQ(s.message.find('\n'), std::string::npos);
  }
  TetMesh m;
  EXPECT_TRUE(parse_medit(std::string_view(text).substr(0, cut_end), "p.mesh", m).ok());
}

// --------------------------------------------------------- binary parsing --

TEST(IoMedit, BinaryHostileInput) {
  auto expect_err = [](const std::string& bytes, ErrorCode code, const std::string& phrase) {
    TetMesh m;
    const Status s = parse_meditb(bytes, "b.meshb", m);
    ASSERT_FALSE(s.ok()) << "expected: " << phrase;
    EXPECT_EQ(static_cast<int>(s.code), static_cast<int>(code)) << s.message;
    EXPECT_EQ(s.message.rfind("b.meshb: ", 0), 0u) << s.message;
    EXPECT_NE(s.message.find(phrase), std::string::npos) << s.message;
  };
  // Absurd counts (2^31-1 in version 2, 10^15 in version 4) and a lying one.
  expect_err(gmf_one_tet(2, false, 0x7fffffff), ErrorCode::Parse, "remain");
  expect_err(gmf_one_tet(4, false, 1000000000000000LL), ErrorCode::Parse, "remain");
  expect_err(gmf_one_tet(3, true, 5), ErrorCode::Parse, "remain");
  expect_err(gmf_one_tet(3, false, -1), ErrorCode::Parse, "negative count");
  // Header problems.
  expect_err("", ErrorCode::Parse, "too short");
  {
    std::string b = gmf_one_tet(2, false);
    b[0] = 7;
    expect_err(b, ErrorCode::Parse, "not a GMF binary mesh");
    b = gmf_one_tet(2, false);
    b[4] = 9;
    expect_err(b, ErrorCode::Unsupported, "GMF version 9");
    b = gmf_one_tet(2, false);
    b[16] = 2;  // Dimension value (8 header + 4 code + 4 position)
    expect_err(b, ErrorCode::Unsupported, "2-D mesh");
    b = gmf_one_tet(2, false);
    b[8] = 4;  // first keyword is not Dimension
    expect_err(b, ErrorCode::Parse, "missing Dimension");
  }
  // Index out of range / zero, NaN coordinate: patch a hand-made file.
  {
    Gmf g{2, false, {}};
    g.w32(1); g.w32(2);
    g.begin(3); g.w32(3); g.end();
    g.begin(4); g.integer(4);
    for (int i = 0; i < 4; ++i) { g.real(i == 2 ? std::nan("") : i); g.real(0); g.real(i == 3); g.integer(0); }
    g.end();
    g.begin(8); g.integer(1); for (int k : {1, 2, 3, 4}) g.integer(k); g.integer(0); g.end();
    g.w32(54); g.pos(0);
    TetMesh m;
    Status s = parse_meditb(g.b, "b.meshb", m);
    EXPECT_EQ(s.code, ErrorCode::InvalidMesh);
    EXPECT_NE(s.message.find("b.meshb: record 3: Vertices: vertex 3 has a non-finite"), std::string::npos) << s.message;
    EXPECT_EQ(s.line, 3);
  }
  {
    std::string b = gmf_one_tet(2, false);
    // Tetrahedra record: last 4+4 bytes are End; before them ref, then ids 1 2 4 3.
    const size_t ids = b.size() - 8 - 4 - 16;
    int32_t bad = 5;
    std::memcpy(&b[ids + 4], &bad, 4);
    expect_err(b, ErrorCode::InvalidMesh, "vertex index 5 out of range 1..4");
    bad = 0;
    std::memcpy(&b[ids], &bad, 4);
    expect_err(b, ErrorCode::InvalidMesh, "vertex index 0 is below 1 (indices count from 1)");
  }
  // A negative count of an unsupported element (as the ASCII reader says),
  // and Vertices claiming to be the last keyword before the Tetrahedra
  // (it said "no tetrahedra").
  for (const bool last : {false, true}) {
    Gmf g{2, false, {}};
    g.w32(1); g.w32(2);
    g.begin(3); g.w32(3); g.end();
    g.begin(4); g.integer(4);
    for (int i = 0; i < 4; ++i) { g.real(i == 1); g.real(i == 2); g.real(i == 3); g.integer(0); }
    if (!last) g.end();  // else its next-keyword position stays 0
    g.begin(10); g.integer(last ? 0 : -5); g.end();
    g.begin(8); g.integer(1); for (int k : {1, 2, 3, 4}) g.integer(k); g.integer(0); g.end();
    g.w32(54); g.pos(0);
    if (last) expect_err(g.b, ErrorCode::Parse, "Vertices at byte 20 has next-keyword position 0");
    else expect_err(g.b, ErrorCode::Parse, "Hexahedra: negative count -5");
  }
  // Missing End.
  {
    std::string b = gmf_one_tet(3, false);
    expect_err(b.substr(0, b.size() - 12), ErrorCode::Parse, "without the End keyword");
  }
}

TEST(IoMedit, BinaryEveryPrefixAndCorruptionFailsCleanly) {
  const TetMesh m = rich_mesh();
  std::mt19937 rng(12345);
  for (int ver : {2, 3, 4}) {
    std::string bytes;
    ASSERT_TRUE(format_meditb(m, bytes, ver).ok());
    for (size_t n = 0; n < bytes.size(); ++n) {
      TetMesh r;
      const Status s = parse_meditb(std::string_view(bytes).substr(0, n), "p.meshb", r);
      EXPECT_FALSE(s.ok()) << "prefix of " << n << " bytes accepted (version " << ver << ")";
    }
    // Random corruption: anything may happen except a crash or an escape.
    for (int trial = 0; trial < 300; ++trial) {
      std::string c = bytes;
      for (int k = 0; k < 3; ++k) c[rng() % c.size()] = static_cast<char>(rng());
      TetMesh r;
      const Status s = parse_meditb(c, "c.meshb", r);
      if (s.ok()) {
        EXPECT_GT(r.nt(), 0);
      } else {
        EXPECT_EQ(s.message.find('\n'), std::string::npos);
      }
    }
  }
}

// ------------------------------------------------------------ real meshes --

namespace {
std::string shared_meshes() {
  for (const std::string& d : {std::string("/work/shared/meshes"), std::string(TETOPT_SOURCE_DIR "/../shared/meshes")})
    if (fs::is_directory(d)) return d;
  return {};
}
}  // namespace

TEST(IoMeditReal, HingeAndFlangeCountsAndOrientation) {
  const std::string dir = shared_meshes();
  if (dir.empty()) GTEST_SKIP() << "no shared meshes";
  struct Case { const char* file; int32_t nv, nt; };
  for (const Case c : {Case{"hinge_raw/hinge_raw.mesh", 605, 1339}, Case{"flange/flange.mesh", 11345, 48967}}) {
    SCOPED_TRACE(c.file);
    TetMesh m;
    OrientationReport rep;
    const Status s = read_mesh(dir + "/" + c.file, m, &rep);
    ASSERT_TRUE(s.ok()) << s.message;
    EXPECT_EQ(m.nv(), c.nv);
    EXPECT_EQ(m.nt(), c.nt);
    EXPECT_GT(m.ntri(), 0);
    EXPECT_TRUE(rep.inverted.empty());
    EXPECT_TRUE(rep.flat_tets.empty());
    EXPECT_TRUE(all_positive(m));
    // And back through the binary format, bit for bit.
    std::string b;
    ASSERT_TRUE(format_meditb(m, b, 3).ok());
    TetMesh r;
    ASSERT_TRUE(parse_meditb(b, "x.meshb", r).ok());
    expect_same_arrays(m, r);
  }
}

// ---------------------------------------------------------------- meshio --

namespace {
bool have_meshio() {
  static const int rc = std::system("/usr/bin/python3 -c 'import meshio' >/dev/null 2>&1");
  return rc == 0;
}

double checksum(const TetMesh& m) {
  // Rows with a huge coordinate (the DBL_MAX test vertex) are left out, as in the script.
  double s = 0;
  for (int32_t v = 0; v < m.nv(); ++v) {
    const double* p = m.point(v);
    if (std::fabs(p[0]) < 1e200 && std::fabs(p[1]) < 1e200 && std::fabs(p[2]) < 1e200) s += p[0] + 2 * p[1] + 3 * p[2];
  }
  return s;
}
}  // namespace

TEST(IoMeditMeshio, MeshioReadsWhatWeWrite) {
  if (!have_meshio()) GTEST_SKIP() << "/usr/bin/python3 cannot import meshio";
  const fs::path d = temp_dir("meshio_w");
  // meshio's ASCII reader knows neither RequiredEdges nor RequiredTriangles.
  const TetMesh m = rich_mesh(false);
  int64_t idsum = 0;
  for (int32_t v : m.tets) idsum += v;
  const std::string py = (d / "check.py").string();
  {
    std::ofstream f(py);
    f << "import sys, warnings\nwarnings.simplefilter('ignore')\nimport meshio\n"
         "m = meshio.read(sys.argv[1])\n"
         "tets = [c.data for c in m.cells if c.type == 'tetra']\n"
         "tris = [c.data for c in m.cells if c.type == 'triangle']\n"
         "p = m.points\n"
         "q = p[(abs(p) < 1e200).all(axis=1)]\n"
         "cs = float((q[:,0] + 2*q[:,1] + 3*q[:,2]).sum())\n"
         "open(sys.argv[2], 'w').write('%d %d %d %d %r\\n' % (len(p), sum(len(t) for t in tets),"
         " sum(len(t) for t in tris), int(sum(int(t.sum()) for t in tets)), cs))\n";
  }
  for (const char* name : {"w.mesh", "w2.meshb", "w3.meshb", "w4.meshb"}) {
    SCOPED_TRACE(name);
    const std::string p = (d / name).string(), res = (d / "res.txt").string();
    WriteOptions o;
    o.meditb_version = name[1] - '0';
    ASSERT_TRUE(write_mesh(p, m, o).ok());
    const std::string cmd = "/usr/bin/python3 " + py + " " + p + " " + res + " >/dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    std::ifstream in(res);
    int64_t nv = -1, nt = -1, ntri = -1, ids = -1;
    double cs = 0;
    in >> nv >> nt >> ntri >> ids >> cs;
    EXPECT_EQ(nv, m.nv());
    EXPECT_EQ(nt, m.nt());
    EXPECT_EQ(ntri, m.ntri());
    EXPECT_EQ(ids, idsum);
    const double mine = checksum(m);
    ASSERT_TRUE(std::isfinite(mine));
    EXPECT_NEAR(cs, mine, 1e-12 * std::fabs(mine));
  }
  fs::remove_all(d);
}

TEST(IoMeditMeshio, WeReadWhatMeshioWrites) {
  if (!have_meshio()) GTEST_SKIP() << "/usr/bin/python3 cannot import meshio";
  const fs::path d = temp_dir("meshio_r");
  const TetMesh m = make_box_mesh({.nx = 3, .ny = 2, .nz = 2, .jitter = 0.2, .seed = 3, .regions = 2});
  // Hand meshio a .vtk-free description: a small Python script with the arrays.
  const std::string py = (d / "write.py").string();
  {
    std::ofstream f(py);
    f.precision(17);
    f << "import sys, warnings\nwarnings.simplefilter('ignore')\nimport numpy as np, meshio\npts = np.array([";
    for (int32_t v = 0; v < m.nv(); ++v) f << "[" << m.point(v)[0] << "," << m.point(v)[1] << "," << m.point(v)[2] << "],";
    f << "])\ntets = np.array([";
    for (int32_t t = 0; t < m.nt(); ++t) f << "[" << m.tet(t)[0] << "," << m.tet(t)[1] << "," << m.tet(t)[2] << "," << m.tet(t)[3] << "],";
    f << "])\nrefs = np.array([";
    for (int32_t r : m.tet_ref) f << r << ",";
    f << "])\nmeshio.write(sys.argv[1], meshio.Mesh(pts, [('tetra', tets)], cell_data={'medit:ref': [refs]}))\n";
  }
  for (const char* name : {"r.mesh", "r.meshb"}) {
    SCOPED_TRACE(name);
    const std::string p = (d / name).string();
    const std::string cmd = "/usr/bin/python3 " + py + " " + p + " >/dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    TetMesh r;
    const Status s = read_mesh(p, r);
    ASSERT_TRUE(s.ok()) << s.message;
    EXPECT_EQ(r.xyz, m.xyz);
    EXPECT_EQ(r.tets, m.tets);
    EXPECT_EQ(r.tet_ref, m.tet_ref);
  }
  fs::remove_all(d);
}

// ------------------------------------------------------------- performance --

TEST(IoMedit, LargeAsciiParsesQuickly) {
  // ~300k tets: a sanity bound far above the expected time (~0.1 s).
  const TetMesh m = make_box_mesh({.nx = 40, .ny = 40, .nz = 32});
  std::string text;
  ASSERT_TRUE(format_medit(m, text).ok());
  TetMesh r;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(parse_medit(text, "big.mesh", r).ok());
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(r.nt(), m.nt());
  EXPECT_LT(sec, 5.0);
}

// The parallel fast path of the ASCII reader (sections of >= 20,000 records,
// one per line) gives the serial reader's mesh bit for bit, and on any
// irregular or broken file the serial reader's exact error (it falls back).
TEST(IoMedit, AsciiParallelSectionsEqualSerial) {
  BoxMeshOptions bo;
  bo.nx = 24;
  bo.ny = 20;
  bo.nz = 14;  // 40,320 tets, 7,875 vertices
  bo.jitter = 0.3;
  bo.seed = 3;
  bo.regions = 2;
  const TetMesh box = make_box_mesh(bo);
  std::string text;
  ASSERT_TRUE(format_medit(box, text).ok());
  auto same = [](const TetMesh& a, const TetMesh& b) {
    return a.xyz.size() == b.xyz.size() &&
           std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * sizeof(double)) == 0 && a.tets == b.tets &&
           a.tet_ref == b.tet_ref && a.vert_ref == b.vert_ref && a.tris == b.tris && a.tri_ref == b.tri_ref;
  };
  auto parse = [](const std::string& t, int threads, TetMesh& m) { return parse_medit(t, "p.mesh", m, threads); };
  TetMesh serial, par;
  ASSERT_TRUE(parse(text, 1, serial).ok());
  ASSERT_TRUE(parse(text, 2, par).ok());
  ASSERT_EQ(serial.nt(), box.nt());
  EXPECT_TRUE(same(serial, par));
  // Variants: each is parsed with 1 and 2 threads; both must agree (same
  // mesh, or the same error message and line).
  const size_t tet_kw = text.find("Tetrahedra");
  ASSERT_NE(tet_kw, std::string::npos);
  const size_t deep = text.find('\n', tet_kw + (text.size() - tet_kw) / 2) + 1;  // a record start mid-section
  std::vector<std::pair<std::string, std::string>> variants;
  auto edit = [&](const std::string& name, size_t at, size_t len, const std::string& with) {
    std::string t = text;
    t.replace(at, len, with);
    variants.emplace_back(name, t);
  };
  const size_t sp = text.find(' ', deep);
  edit("bad number", deep, 1, "x");
  edit("id out of range", deep, sp - deep, "99999999");
  edit("zero id", deep, sp - deep, "0");
  edit("comment in a record", sp, 1, " # c\n");
  edit("record split over two lines", sp, 1, "\n");
  edit("tabs and CR", sp, 1, "\t\r ");
  edit("plus sign", deep, 0, "+");
  edit("nan coordinate", text.find('\n', text.find("Vertices") + 20) + 1, 1, "nan");
  edit("huge coordinate (underflow reads as 0)", text.find('\n', text.find("Vertices") + 20) + 1, 1, "1e-400 ");
  edit("missing End and last newline", text.rfind("End"), std::string::npos, "");
  {
    std::string t = text;  // the Tetrahedra count one too large
    const size_t c = t.find('\n', tet_kw) + 1;
    const size_t ce = t.find('\n', c);
    t.replace(c, ce - c, std::to_string(box.nt() + 1));
    variants.emplace_back("count too large", t);
  }
  variants.emplace_back("unchanged", text);
  for (const auto& [name, t] : variants) {
    SCOPED_TRACE(name);
    TetMesh a, b;
    const Status sa = parse(t, 1, a), sb = parse(t, 2, b);
    EXPECT_EQ(sa.ok(), sb.ok());
    EXPECT_EQ(sa.message, sb.message);
    EXPECT_EQ(sa.line, sb.line);
    if (sa.ok()) {
      EXPECT_TRUE(same(a, b));
    }
    // Every section through the fast path, in chunks of a few bytes (records
    // straddle many chunk borders), on 1 and 3 threads.
    for (int th : {1, 3})
      for (size_t chunk : {size_t{7}, size_t{64}, size_t{4099}}) {
        TetMesh c;
        const Status sc = detail::parse_medit_tuned(t, "p.mesh", c, th, 1, chunk);
        EXPECT_EQ(sa.message, sc.message) << "threads " << th << " chunk " << chunk;
        EXPECT_EQ(sa.line, sc.line);
        if (sa.ok() && sc.ok()) {
          EXPECT_TRUE(same(a, c)) << "threads " << th << " chunk " << chunk;
        }
      }
  }
  // At least one variant must parse and several must fail, or the list tests nothing.
  int ok = 0;
  for (const auto& v : variants) {
    TetMesh m;
    ok += parse(v.second, 2, m).ok();
  }
  EXPECT_GE(ok, 2);
  EXPECT_LE(ok, static_cast<int>(variants.size()) - 4);
}

// write_mesh streams .mesh text to its temporary file in pieces of about
// 4 MiB (on a helper thread with threads > 1): the file holds exactly what
// format_medit gives, and a write that fails after some pieces (a file size
// limit, as a full disk would) leaves neither the file nor a temporary.
TEST(IoMedit, StreamedWriteIsTheFormattedTextAndFailsCleanly) {
  BoxMeshOptions bo;
  bo.nx = bo.ny = bo.nz = 36;  // 279,936 tets: about 9.7 MB of text, two pieces and a rest
  bo.jitter = 0.2;
  bo.regions = 2;
  const TetMesh m = make_box_mesh(bo);
  std::string text;
  ASSERT_TRUE(format_medit(m, text).ok());
  ASSERT_GT(text.size(), size_t{8} << 20);
  const fs::path d = temp_dir("stream");
  for (int threads : {1, 2, 0}) {
    WriteOptions wo;
    wo.threads = threads;
    const std::string tag = std::to_string(threads);
    const fs::path out = d / (tag + "w.mesh");
    ASSERT_TRUE(write_mesh(out.string(), m, wo).ok()) << threads;
    EXPECT_TRUE(slurp(out) == text) << threads << " threads: the file is not format_medit's text";
    // Limits inside the first piece, inside the second and inside the rest.
    for (const rlim_t limit : {rlim_t{1} << 20, rlim_t{6} << 20, static_cast<rlim_t>(text.size() - 100)}) {
      const fs::path bad = d / (tag + "_" + std::to_string(limit) + ".mesh");
      const pid_t pid = ::fork();
      ASSERT_GE(pid, 0);
      if (pid == 0) {
        std::signal(SIGXFSZ, SIG_IGN);  // write() then fails with EFBIG
        const rlimit rl{limit, limit};
        if (::setrlimit(RLIMIT_FSIZE, &rl) != 0) ::_exit(20);
        const Status s = write_mesh(bad.string(), m, wo);
        ::_exit(s.ok() ? 0 : s.code == ErrorCode::Io && s.message.find("write failed") != std::string::npos ? 10 : 11);
      }
      int status = 0;
      ASSERT_EQ(::waitpid(pid, &status, 0), pid);
      ASSERT_TRUE(WIFEXITED(status)) << threads << " threads, limit " << limit;
      EXPECT_EQ(WEXITSTATUS(status), 10) << threads << " threads, limit " << limit;
      EXPECT_FALSE(fs::exists(bad)) << bad;
    }
  }
  for (const auto& e : fs::directory_iterator(d))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << "left behind: " << e.path();
  fs::remove_all(d);
}
