// OpenFOAM polyMesh reader and writer (issue 28): round trips in ASCII and
// binary, OpenFOAM's face order, patches / zones / names / types, and
// hostile input (lying counts, truncation, huge numbers, bad ids, cells
// that are no tets, patches that do not tile the boundary).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>
#include <unistd.h>

#include "io/face_cells.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"

using namespace tetopt;
namespace fs = std::filesystem;

namespace {

/// Two regions, boundary triangles in three patches (refs 7, 3, 9), the
/// interface listed as a faceZone (ref 20), vertex refs on two vertices.
TetMesh sample_mesh() {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 2, .nz = 2, .jitter = 0.2, .seed = 3, .regions = 2});
  // make_box_mesh lists the boundary and the interface; give them refs.
  for (int32_t i = 0; i < m.ntri(); ++i) m.tri_ref[i] = i % 3 == 0 ? 7 : (i % 3 == 1 ? 3 : 9);
  m.xyz[0] = 0.1 + 1e-17;  // needs 17 digits
  m.xyz[3 * 1] = std::nextafter(1.0, 2.0);
  m.vert_ref.assign(m.nv(), 0);
  m.vert_ref[0] = 4;
  m.vert_ref[5] = 4;
  m.physical_names = {{2, 7, "inlet"}, {2, 3, "walls"}, {3, 1, "fluid"}, {3, 2, "solid"}, {0, 4, "probe"}};
  m.attachment.get(2, 3).foam_kind = "patch";
  m.attachment.get(2, 3).foam_type = "wall";
  m.attachment.get(2, 3).foam_entries = "inGroups List<word> 1 ( wall );";
  return m;
}

struct Files {
  std::string f[8];
  std::array<std::string_view, 8> views() const {
    std::array<std::string_view, 8> v;
    for (int k = 0; k < 8; ++k) v[k] = f[k];
    return v;
  }
};

Files write(const TetMesh& m, bool binary) {
  Files out;
  const Status s = format_openfoam(m, out.f, binary);
  EXPECT_TRUE(s) << s.message;
  return out;
}

Status read(const Files& f, TetMesh& m) {
  const auto v = f.views();
  return parse_openfoam(v.data(), "case/polyMesh", m);
}

/// A tet as the set of its vertices with its orientation sign.
std::vector<int32_t> canonical_tets(const TetMesh& m) {
  std::vector<int32_t> out;
  for (int32_t t = 0; t < m.nt(); ++t) {
    int32_t v[4];
    std::copy(m.tet(t), m.tet(t) + 4, v);
    detail::canonical_tet(v);
    out.insert(out.end(), v, v + 4);
  }
  return out;
}

std::multiset<std::pair<std::array<int32_t, 3>, int32_t>> tri_set(const TetMesh& m) {
  std::multiset<std::pair<std::array<int32_t, 3>, int32_t>> s;
  for (int32_t i = 0; i < m.ntri(); ++i) s.insert({detail::tri_key(&m.tris[3 * i]), m.tri_ref[i]});
  return s;
}

const std::string* name(const TetMesh& m, int dim, int tag) {
  for (const PhysicalName& p : m.physical_names)
    if (p.dim == dim && p.tag == tag) return &p.name;
  return nullptr;
}

}  // namespace

TEST(OpenFoam, RoundTripKeepsCoordinatesTetsRefsNamesTypes) {
  const TetMesh m = sample_mesh();
  for (bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    const Files f = write(m, binary);
    TetMesh b;
    const Status s = read(f, b);
    ASSERT_TRUE(s) << s.message;
    ASSERT_EQ(m.xyz.size(), b.xyz.size());
    EXPECT_EQ(0, std::memcmp(m.xyz.data(), b.xyz.data(), m.xyz.size() * sizeof(double)));
    EXPECT_EQ(canonical_tets(m), b.tets);  // same tets, same orientation, canonical order
    EXPECT_EQ(m.tet_ref, b.tet_ref);
    EXPECT_EQ(m.vert_ref, b.vert_ref);
    // Boundary triangles come back with their refs (a listed triangle that
    // faces out keeps its vertex order too).
    EXPECT_EQ(tri_set(m), tri_set(b));
    ASSERT_TRUE(name(b, 2, 7) && name(b, 2, 3) && name(b, 3, 1) && name(b, 3, 2) && name(b, 0, 4));
    EXPECT_EQ(*name(b, 2, 7), "inlet");
    EXPECT_EQ(*name(b, 2, 3), "walls");
    EXPECT_EQ(*name(b, 3, 2), "solid");
    EXPECT_EQ(*name(b, 0, 4), "probe");
    const GroupAttachment* a = b.attachment.find(2, 3);
    ASSERT_TRUE(a);
    EXPECT_EQ(a->foam_type, "wall");
    EXPECT_EQ(a->foam_entries, "inGroups List<word> 1 ( wall );");
    // Patch order: the attachment's patch (walls, ref 3) first, then 7, 9.
    EXPECT_LT(f.f[4].find("walls"), f.f[4].find("inlet"));
    // Written again: the same bytes.
    const Files g = write(b, binary);
    for (int k = 0; k < 8; ++k) EXPECT_EQ(f.f[k], g.f[k]) << kFoamFileNames[k];
  }
}

TEST(OpenFoam, AsciiAndBinaryReadTheSame) {
  const TetMesh m = sample_mesh();
  TetMesh a, b;
  ASSERT_TRUE(read(write(m, false), a));
  ASSERT_TRUE(read(write(m, true), b));
  EXPECT_EQ(0, std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * sizeof(double)));
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.tris, b.tris);
  EXPECT_EQ(a.tri_ref, b.tri_ref);
  EXPECT_EQ(a.tet_ref, b.tet_ref);
}

TEST(OpenFoam, FaceOrderIsUpperTriangularAndFacesPointOutOfTheOwner) {
  const TetMesh m = sample_mesh();
  const Files f = write(m, false);
  TetMesh b;
  ASSERT_TRUE(read(f, b));
  // Re-parse owner and neighbour through the reader's own lists: every
  // internal face has owner < neighbour, sorted by (owner, neighbour).
  std::vector<detail::WrittenFace> faces;
  std::string what;
  ASSERT_TRUE(detail::faces_of_tets(b, Format::OpenFoam, faces, nullptr, what));
  // From the text: the owner and neighbour lists.
  auto list = [](const std::string& text) {
    std::vector<long> v;
    size_t p = text.find("\n(\n");
    EXPECT_NE(p, std::string::npos);
    p += 3;
    while (text[p] != ')') {
      const size_t e = text.find('\n', p);
      v.push_back(std::stol(text.substr(p, e - p)));
      p = e + 1;
    }
    return v;
  };
  const std::vector<long> own = list(f.f[2]), nei = list(f.f[3]);
  ASSERT_GT(nei.size(), 0u);
  for (size_t i = 0; i < nei.size(); ++i) {
    EXPECT_LT(own[i], nei[i]) << i;
    if (i) {
      EXPECT_TRUE(own[i - 1] < own[i] || (own[i - 1] == own[i] && nei[i - 1] < nei[i])) << i;
    }
  }
  // Face orientation: the normal of face i points away from its owner's
  // fourth vertex (positive tets).
  size_t p = f.f[1].find("\n(\n") + 3;
  for (size_t i = 0; i < own.size(); ++i) {
    int32_t v[3];
    ASSERT_EQ(3, std::sscanf(f.f[1].c_str() + p, "3(%d %d %d)", &v[0], &v[1], &v[2]));
    p = f.f[1].find('\n', p) + 1;
    const int32_t* t = b.tet(static_cast<int32_t>(own[i]));
    int32_t d = -1;
    for (int k = 0; k < 4; ++k)
      if (t[k] != v[0] && t[k] != v[1] && t[k] != v[2]) d = t[k];
    ASSERT_GE(d, 0);
    const double *a = b.point(v[0]), *bb = b.point(v[1]), *c = b.point(v[2]), *x = b.point(d);
    const double u[3] = {bb[0] - a[0], bb[1] - a[1], bb[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    EXPECT_LT(n[0] * (x[0] - a[0]) + n[1] * (x[1] - a[1]) + n[2] * (x[2] - a[2]), 0) << "face " << i;
  }
}

TEST(OpenFoam, InterfaceTrianglesBecomeAFaceZoneAndComeBack) {
  TetMesh m = make_box_mesh({.nx = 2, .ny = 1, .nz = 1, .regions = 2});
  m.tri_ref.assign(m.ntri(), 1);
  // List the interface triangles (a tet on each side, different refs) with
  // ref 50, every other one turned over (a faceZone's flipMap).
  std::vector<detail::WrittenFace> faces;
  std::string what;
  ASSERT_TRUE(detail::faces_of_tets(m, Format::OpenFoam, faces, nullptr, what));
  int internal = 0;
  for (const detail::WrittenFace& w : faces)
    if (w.second >= 0 && m.tet_ref[w.first] != m.tet_ref[w.second]) {
      const bool flip = internal++ % 2;
      m.tris.insert(m.tris.end(), {w.v[0], flip ? w.v[2] : w.v[1], flip ? w.v[1] : w.v[2]});
      m.tri_ref.push_back(50);
    }
  ASSERT_GT(internal, 1);
  m.physical_names = {{2, 50, "iface"}};
  const Files f = write(m, false);
  EXPECT_NE(f.f[6].find("iface"), std::string::npos);
  EXPECT_NE(f.f[6].find("type faceZone"), std::string::npos);
  TetMesh b;
  ASSERT_TRUE(read(f, b));
  EXPECT_EQ(tri_set(m), tri_set(b));
  // Each listed interface triangle keeps its vertex order (flipMap).
  std::set<std::array<int32_t, 3>> want, got;
  for (int32_t i = 0; i < m.ntri(); ++i)
    if (m.tri_ref[i] == 50) want.insert({m.tris[3 * i], m.tris[3 * i + 1], m.tris[3 * i + 2]});
  for (int32_t i = 0; i < b.ntri(); ++i)
    if (b.tri_ref[i] == 50) got.insert({b.tris[3 * i], b.tris[3 * i + 1], b.tris[3 * i + 2]});
  EXPECT_EQ(want, got);
}

TEST(OpenFoam, UnlistedBoundaryFacesGoToDefaultFacesAndDroppedNamesAreSaid) {
  TetMesh m = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  m.tris.clear();
  m.tri_ref.clear();
  m.edges = {0, 1};
  m.edge_ref = {1};
  m.physical_names = {{1, 1, "wire"}};
  const Files f = write(m, false);
  EXPECT_NE(f.f[4].find("defaultFaces"), std::string::npos);
  TetMesh b;
  ASSERT_TRUE(read(f, b));
  EXPECT_EQ(b.ntri(), 12);  // the 12 boundary triangles of a cube, now listed
  const std::vector<std::string> lost = dropped_by_format(m, Format::OpenFoam);
  std::string all;
  for (const std::string& x : lost) all += x + ";";
  EXPECT_NE(all.find("listed edges (1)"), std::string::npos) << all;
  EXPECT_NE(all.find("physical names of groups with no patch or zone (1)"), std::string::npos) << all;
}

TEST(OpenFoam, NamesThatAreNoWordAreMadeOneAndSaid) {
  TetMesh m = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  m.tri_ref.assign(m.ntri(), 1);
  m.physical_names = {{2, 1, "my wall (left)"}};
  const Files f = write(m, false);
  EXPECT_NE(f.f[4].find("my_wall__left_"), std::string::npos) << f.f[4];
  bool said = false;
  for (const std::string& x : dropped_by_format(m, Format::OpenFoam)) said = said || x.find("no OpenFOAM word") != std::string::npos;
  EXPECT_TRUE(said);
}

// ---- hostile input ----

namespace {
Files small_files(bool binary = false) {
  TetMesh m = make_box_mesh({.nx = 1, .ny = 1, .nz = 1, .regions = 1});
  m.tri_ref.assign(m.ntri(), 1);
  m.tet_ref.assign(m.nt(), 0);  // no cellZones: tests add their own
  return write(m, binary);
}
/// Replaces the first occurrence of `from` in file k.
Files with(Files f, int k, const std::string& from, const std::string& to) {
  const size_t p = f.f[k].find(from);
  EXPECT_NE(p, std::string::npos) << from;
  if (p != std::string::npos) f.f[k].replace(p, from.size(), to);
  return f;
}
std::string error_of(const Files& f) {
  TetMesh m;
  const Status s = read(f, m);
  EXPECT_FALSE(s) << "accepted";
  return s.message;
}
}  // namespace

TEST(OpenFoamHostile, ErrorsAreOneLineNamingFileAndLine) {
  const Files f = small_files();
  const std::string e = error_of(with(f, 0, "(0 0 0)", "(0 zero 0)"));
  EXPECT_EQ(e.find('\n'), std::string::npos);
  EXPECT_EQ(e.rfind("case/polyMesh/points:", 0), 0u) << e;
  EXPECT_NE(e.find("expected a finite number, found 'zero'"), std::string::npos) << e;
}

TEST(OpenFoamHostile, LyingCountsAreRefusedBeforeAllocating) {
  const Files f = small_files();
  EXPECT_NE(error_of(with(f, 0, "\n8\n(", "\n800000000000\n(")).find("more than the file holds"), std::string::npos);
  EXPECT_NE(error_of(with(f, 1, "\n18\n(", "\n9223372036854775807\n(")).find("more than the file holds"), std::string::npos);
  EXPECT_NE(error_of(with(f, 2, "\n18\n(", "\n99999999999999999999\n(")).find("expected the count"), std::string::npos);
  // A count smaller than the items: the list does not end where it says.
  EXPECT_NE(error_of(with(f, 0, "\n8\n(", "\n7\n(")).find("expected ')'"), std::string::npos);
  // A uniform list whose count is larger than the mesh allows.
  const Files b = small_files();
  std::string e = error_of(with(b, 5, "0\n(\n)", "1\n(\nz\n{\n    type cellZone;\ncellLabels List<label> 1000000000000{0};\n}\n)"));
  EXPECT_NE(e.find("is larger than"), std::string::npos) << e;
  // Binary: a count past the bytes left.
  const Files bin = small_files(true);
  e = error_of(with(bin, 0, "\n8\n(", "\n100\n("));
  EXPECT_NE(e.find("more than the file holds"), std::string::npos) << e;
}

TEST(OpenFoamHostile, TruncatedFilesAreRefused) {
  for (bool binary : {false, true}) {
    const Files f = small_files(binary);
    for (int k = 0; k < 5; ++k) {
      Files t = f;
      t.f[k].resize(t.f[k].size() * 2 / 3);
      TetMesh m;
      EXPECT_FALSE(read(t, m)) << kFoamFileNames[k] << (binary ? " binary" : " ascii");
    }
  }
}

TEST(OpenFoamHostile, BadIdsAndHugeNumbers) {
  const Files f = small_files();
  std::string e = error_of(with(f, 1, "3(", "3(99 "));
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
  e = error_of(with(f, 2, "\n(\n0\n", "\n(\n-1\n"));
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
  e = error_of(with(f, 0, "(0 0 0)", "(1e999 0 0)"));
  EXPECT_NE(e.find("finite number"), std::string::npos) << e;
  e = error_of(with(f, 1, "3(", "3(4294967296 "));
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
  // An owner far past the cells the faces can make.
  e = error_of(with(f, 2, "\n(\n0\n", "\n(\n2000000000\n"));
  EXPECT_NE(e.find("cannot be tetrahedra"), std::string::npos) << e;
}

TEST(OpenFoamHostile, CellsThatAreNoTetsAreUnsupported) {
  const Files f = small_files();
  // A quadrilateral face.
  TetMesh m;
  Files q = with(f, 1, "3(", "4(7 ");
  Status s = read(q, m);
  EXPECT_EQ(s.code, ErrorCode::Unsupported) << s.message;
  EXPECT_NE(s.message.find("only tetrahedral"), std::string::npos) << s.message;
  // Face 0 given to another cell: one cell with 5 faces, one with 3.
  s = read(with(f, 2, "\n(\n0\n", "\n(\n5\n"), m);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message.find("faces"), std::string::npos) << s.message;
  const size_t p = f.f[2].find("\n(\n") + 3;
  // A face with the same cell on both sides.
  const std::string own0 = f.f[2].substr(p, f.f[2].find('\n', p) - p);
  const size_t pn = f.f[3].find("\n(\n") + 3;
  Files h = f;
  h.f[3].replace(pn, h.f[3].find('\n', pn) - pn, own0);
  s = read(h, m);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message.find("same cell"), std::string::npos) << s.message;
}

TEST(OpenFoamHostile, PatchesMustTileTheBoundary) {
  const Files f = small_files();
  std::string e = error_of(with(f, 4, "startFace       ", "startFace       1"));
  EXPECT_NE(e.find("starts at face"), std::string::npos) << e;
  e = error_of(with(f, 4, "nFaces          12;", "nFaces          11;"));
  EXPECT_NE(e.find("the patches hold faces"), std::string::npos) << e;
  e = error_of(with(f, 4, "nFaces          12;", "nFaces          1200;"));
  EXPECT_NE(e.find("only 12 are left"), std::string::npos) << e;
  Files nob = f;
  nob.f[4].clear();
  e = error_of(nob);
  EXPECT_NE(e.find("boundary: missing"), std::string::npos) << e;
}

TEST(OpenFoamHostile, ACellInTwoZonesAndCommentsAndArch) {
  Files f = small_files();
  f = with(f, 5, "0\n(\n)", "2\n(\na\n{\n    type cellZone;\ncellLabels List<label> 1(0);\n}\nb\n{\n    type cellZone;\ncellLabels List<label> 2(1 0);\n}\n)");
  TetMesh m;
  Status s = read(f, m);
  EXPECT_EQ(s.code, ErrorCode::Unsupported) << s.message;
  EXPECT_NE(s.message.find("cell 0 is in two cellZones"), std::string::npos) << s.message;
  // Comments anywhere, a uniform list and an unknown arch entry.
  Files c = small_files();
  c = with(c, 0, "\n8\n(", "\n/* eight */ 8 // points\n(");
  ASSERT_TRUE(read(c, m)) << read(c, m).message;
  Files u = small_files();
  u = with(u, 5, "0\n(\n)", "1\n(\nall\n{\n    type cellZone;\ncellLabels List<label> 6{0};\n}\n)");
  s = read(u, m);
  EXPECT_FALSE(s);  // six times cell 0: in the zone twice
  Files a = small_files(true);
  a = with(a, 0, "LSB;label=32;scalar=64", "LSB;label=16;scalar=64");
  s = read(a, m);
  EXPECT_EQ(s.code, ErrorCode::Unsupported) << s.message;
}

TEST(OpenFoamHostile, BigEndianAndSinglePrecisionBinaryAreRead) {
  // The same mesh written by hand as MSB with 64-bit labels and 32-bit scalars.
  TetMesh m = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  m.tri_ref.assign(m.ntri(), 1);
  Files f = write(m, false);  // text of boundary etc.
  TetMesh want;
  ASSERT_TRUE(read(f, want));
  auto be = [](std::string& out, uint64_t v, int bytes) {
    for (int i = bytes - 1; i >= 0; --i) out += static_cast<char>((v >> (8 * i)) & 0xff);
  };
  auto hdr = [](const char* cls, const char* obj) {
    return std::string("FoamFile\n{\n version 2.0;\n format binary;\n arch \"MSB;label=64;scalar=32\";\n class ") + cls +
           ";\n object " + obj + ";\n}\n";
  };
  Files g = f;
  g.f[0] = hdr("vectorField", "points") + std::to_string(m.nv()) + "\n(";
  for (double x : m.xyz) {
    const float fl = static_cast<float>(x);
    uint32_t u;
    std::memcpy(&u, &fl, 4);
    be(g.f[0], u, 4);
  }
  g.f[0] += ")\n";
  // faces, owner, neighbour from the ASCII text, as 64-bit MSB labels.
  auto numbers = [](const std::string& text, bool faces) {
    std::vector<int64_t> v;
    size_t p = text.find("\n(\n") + 3;
    while (text[p] != ')') {
      const size_t e = text.find('\n', p);
      std::string line = text.substr(p, e - p);
      if (faces) {
        int a, b, c;
        std::sscanf(line.c_str(), "3(%d %d %d)", &a, &b, &c);
        v.insert(v.end(), {a, b, c});
      } else {
        v.push_back(std::stoll(line));
      }
      p = e + 1;
    }
    return v;
  };
  auto list = [&](const std::vector<int64_t>& v) {
    std::string s = std::to_string(v.size()) + "\n(";
    for (int64_t x : v) be(s, static_cast<uint64_t>(x), 8);
    return s + ")\n";
  };
  const std::vector<int64_t> fl = numbers(f.f[1], true);
  std::vector<int64_t> off;
  for (size_t i = 0; i <= fl.size() / 3; ++i) off.push_back(static_cast<int64_t>(3 * i));
  g.f[1] = hdr("faceCompactList", "faces") + list(off) + list(fl);
  g.f[2] = hdr("labelList", "owner") + list(numbers(f.f[2], false));
  g.f[3] = hdr("labelList", "neighbour") + list(numbers(f.f[3], false));
  TetMesh got;
  const Status s = read(g, got);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(got.tets, want.tets);
  EXPECT_EQ(got.tris, want.tris);
  EXPECT_EQ(got.xyz, want.xyz);  // the box's coordinates are exact in float
}

TEST(OpenFoam, ReadMeshAndWriteMeshThroughTheFolder) {
  const fs::path dir = fs::temp_directory_path() / ("tetopt_foam_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const TetMesh m = sample_mesh();
  const std::string out = (dir / "case/constant/polyMesh").string();
  EXPECT_EQ(format_from_path(out), Format::OpenFoam);
  ASSERT_TRUE(check_output_path(out)) << check_output_path(out).message;
  ASSERT_TRUE(write_mesh(out, m, {}));
  for (const char* f : kFoamFileNames) EXPECT_TRUE(fs::exists(dir / "case/constant/polyMesh" / f)) << f;
  TetMesh b;
  Status s = read_mesh((dir / "case").string(), b);  // the case folder finds constant/polyMesh
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(b.source_format, static_cast<int>(Format::OpenFoam));
  EXPECT_EQ(canonical_tets(m), b.tets);
  // A file where the folder should be is refused before any work.
  fs::create_directories(dir / "x");
  { FILE* fp = std::fopen((dir / "x/polyMesh").c_str(), "w"); std::fclose(fp); }
  EXPECT_FALSE(check_output_path((dir / "x/polyMesh").string()));
  fs::remove_all(dir);
}
