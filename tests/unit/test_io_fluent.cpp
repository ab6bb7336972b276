// Fluent .msh reader and writer (issue 28): round trips in ASCII and
// binary, zones with names and types, told apart from Gmsh by content, and
// hostile input.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <set>
#include <string>
#include <unistd.h>
#include <vector>

#include "io/common.hpp"
#include "io/face_cells.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"

using namespace tetopt;
namespace fs = std::filesystem;

namespace {

/// Two regions (refs 1, 2), boundary triangles in zones 3, 4, 5, the
/// interface listed with ref 6, names and one zone type.
TetMesh sample_mesh() {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 2, .nz = 2, .jitter = 0.2, .seed = 5, .regions = 2});
  for (int32_t i = 0; i < m.ntri(); ++i) m.tri_ref[i] = 3 + i % 3;
  std::vector<detail::WrittenFace> faces;
  std::string what;
  EXPECT_TRUE(detail::faces_of_tets(m, Format::Fluent, faces, nullptr, what));
  int k = 0;
  for (const detail::WrittenFace& w : faces)
    if (w.second >= 0 && m.tet_ref[w.first] != m.tet_ref[w.second]) {
      const bool flip = k++ % 2;
      m.tris.insert(m.tris.end(), {w.v[0], flip ? w.v[2] : w.v[1], flip ? w.v[1] : w.v[2]});
      m.tri_ref.push_back(6);
    }
  m.xyz[0] = 0.1 + 1e-17;
  m.physical_names = {{2, 3, "inlet"}, {2, 6, "iface"}, {3, 1, "fluid-a"}, {3, 2, "fluid-b"}};
  m.attachment.get(2, 3).fluent_type = "velocity-inlet";
  return m;
}

/// (canonical tet, ref) pairs: a Fluent file groups the cells by zone.
std::multiset<std::pair<std::array<int32_t, 4>, int32_t>> tets_with_refs(const TetMesh& m) {
  std::multiset<std::pair<std::array<int32_t, 4>, int32_t>> s;
  for (int32_t t = 0; t < m.nt(); ++t) {
    int32_t v[4];
    std::copy(m.tet(t), m.tet(t) + 4, v);
    detail::canonical_tet(v);
    s.insert({{v[0], v[1], v[2], v[3]}, m.tet_ref[t]});
  }
  return s;
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
std::string write(const TetMesh& m, bool binary) {
  std::string out;
  const Status s = format_fluent(m, out, binary);
  EXPECT_TRUE(s) << s.message;
  return out;
}

}  // namespace

TEST(Fluent, RoundTripKeepsCoordinatesTetsZonesNamesTypes) {
  const TetMesh m = sample_mesh();
  for (bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    const std::string f = write(m, binary);
    EXPECT_TRUE(detail::looks_like_fluent(f));
    TetMesh b;
    const Status s = parse_fluent(f, "x.msh", b);
    ASSERT_TRUE(s) << s.message;
    ASSERT_EQ(m.xyz.size(), b.xyz.size());
    EXPECT_EQ(0, std::memcmp(m.xyz.data(), b.xyz.data(), m.xyz.size() * sizeof(double)));
    EXPECT_EQ(tets_with_refs(m), tets_with_refs(b));
    EXPECT_EQ(tri_set(m), tri_set(b));
    // Interface triangles keep their vertex order (c0 / c1 say which way).
    std::set<std::array<int32_t, 3>> want, got;
    for (int32_t i = 0; i < m.ntri(); ++i)
      if (m.tri_ref[i] == 6) want.insert({m.tris[3 * i], m.tris[3 * i + 1], m.tris[3 * i + 2]});
    for (int32_t i = 0; i < b.ntri(); ++i)
      if (b.tri_ref[i] == 6) got.insert({b.tris[3 * i], b.tris[3 * i + 1], b.tris[3 * i + 2]});
    EXPECT_EQ(want, got);
    ASSERT_TRUE(name(b, 2, 3) && name(b, 2, 6) && name(b, 3, 2));
    EXPECT_EQ(*name(b, 2, 3), "inlet");
    EXPECT_EQ(*name(b, 3, 2), "fluid-b");
    ASSERT_TRUE(b.attachment.find(2, 3));
    EXPECT_EQ(b.attachment.find(2, 3)->fluent_type, "velocity-inlet");
    EXPECT_EQ(b.attachment.find(2, 4)->fluent_type, "wall");
    EXPECT_EQ(b.attachment.find(2, 6)->fluent_type, "interior");  // between two cell zones
    // Written again from what was read: the same bytes.
    EXPECT_EQ(f, write(b, binary));
  }
}

TEST(Fluent, BoundaryFacesPointIntoTheDomainAndTheTurnIsSaid) {
  TetMesh m = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  m.tri_ref.assign(m.ntri(), 1);
  // make_box_mesh lists its boundary triangles facing out.
  bool said = false;
  for (const std::string& x : dropped_by_format(m, Format::Fluent)) said = said || x.find("written facing in") != std::string::npos;
  EXPECT_TRUE(said);
  TetMesh b;
  ASSERT_TRUE(parse_fluent(write(m, false), "x.msh", b));
  std::vector<detail::WrittenFace> faces;
  std::vector<std::array<int32_t, 3>> keys;
  std::string what;
  ASSERT_TRUE(detail::faces_of_tets(b, Format::Fluent, faces, &keys, what));
  for (int32_t i = 0; i < b.ntri(); ++i) {
    const auto k = detail::tri_key(&b.tris[3 * i]);
    const size_t f = std::lower_bound(keys.begin(), keys.end(), k) - keys.begin();
    EXPECT_FALSE(detail::same_rotation(&b.tris[3 * i], faces[f].v)) << "triangle " << i << " faces out";
  }
}

TEST(Fluent, ToldApartFromGmshAndChosenOnWrite) {
  const fs::path dir = fs::temp_directory_path() / ("tetopt_fluent_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const TetMesh m = sample_mesh();
  WriteOptions fl;
  fl.msh = WriteOptions::Msh::Fluent;
  ASSERT_TRUE(write_mesh((dir / "a.msh").string(), m, fl));
  TetMesh b;
  ASSERT_TRUE(read_mesh((dir / "a.msh").string(), b));
  EXPECT_EQ(b.source_format, static_cast<int>(Format::Fluent));
  EXPECT_TRUE(msh_is_fluent(b, {}));
  ASSERT_TRUE(write_mesh((dir / "b.msh").string(), b, {}));  // Auto: Fluent again
  TetMesh c;
  ASSERT_TRUE(read_mesh((dir / "b.msh").string(), c));
  EXPECT_EQ(c.source_format, static_cast<int>(Format::Fluent));
  WriteOptions gm;
  gm.msh = WriteOptions::Msh::Gmsh;
  ASSERT_TRUE(write_mesh((dir / "c.msh").string(), b, gm));
  TetMesh d;
  ASSERT_TRUE(read_mesh((dir / "c.msh").string(), d));
  EXPECT_EQ(d.source_format, static_cast<int>(Format::Gmsh));
  EXPECT_EQ(tri_set(b), tri_set(d));
  EXPECT_EQ(*name(d, 2, 3), "inlet");  // Fluent zone names become Gmsh physical names
  fs::remove_all(dir);
}

// ---- hostile input ----

namespace {
const char* kSmall =
    "(0 \"hand written\")\n(2 3)\n(10 (0 1 4 0 3))\n(12 (0 1 1 0 0))\n(13 (0 1 4 0 0))\n"
    "(10 (1 1 4 1 3)(\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n))\n"
    "(12 (2 1 1 1 2))\n"
    "(13 (3 1 4 3 3)(\n1 2 3 1 0\n1 4 2 1 0\n2 4 3 1 0\n1 3 4 1 0\n))\n"
    "(39 (2 fluid body 1)())\n(39 (3 wall skin 1)())\n";
std::string with(std::string s, const std::string& from, const std::string& to) {
  const size_t p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  if (p != std::string::npos) s.replace(p, from.size(), to);
  return s;
}
Status read(const std::string& s) {
  TetMesh m;
  return parse_fluent(s, "h.msh", m);
}
}  // namespace

TEST(FluentHostile, TheHandWrittenTetIsRead) {
  TetMesh m;
  const Status s = parse_fluent(kSmall, "h.msh", m);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(m.nt(), 1);
  EXPECT_EQ(m.ntri(), 4);
  EXPECT_EQ(m.tet_ref[0], 2);
  ASSERT_TRUE(name(m, 2, 3));
  EXPECT_EQ(*name(m, 2, 3), "skin");
  // positive: the faces point into the cell (toward c0)
  const double* a = m.point(m.tet(0)[0]);
  const double *b = m.point(m.tet(0)[1]), *c = m.point(m.tet(0)[2]), *d = m.point(m.tet(0)[3]);
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]},
               w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  EXPECT_GT(u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]), 0);
}

TEST(FluentHostile, LyingCountsAndTruncation) {
  Status s = read(with(kSmall, "(10 (1 1 4 1 3)", "(10 (1 1 fffffff 1 3)"));
  EXPECT_NE(s.message.find("more than the file holds"), std::string::npos) << s.message;
  s = read(with(kSmall, "(13 (3 1 4 3 3)", "(13 (3 1 7fffffff 3 3)"));
  EXPECT_NE(s.message.find("more than the file holds"), std::string::npos) << s.message;
  s = read(with(kSmall, "(12 (2 1 1 1 2))", "(12 (2 1 7fffffff 1 2))"));
  EXPECT_NE(s.message.find("cannot be tetrahedra"), std::string::npos) << s.message;
  s = read(with(kSmall, "(10 (1 1 4 1 3)", "(10 (1 1 3 1 3)"));  // fewer nodes than listed
  EXPECT_FALSE(s);
  s = read(with(kSmall, "(10 (1 1 4 1 3)", "(10 (1 1 ffffffffffffffffffff 1 3)"));
  EXPECT_FALSE(s);
  for (size_t cut : {size_t{30}, size_t{120}, size_t{200}, std::string(kSmall).size() - 30}) {
    s = read(std::string(kSmall).substr(0, cut));
    EXPECT_FALSE(s) << cut;
    EXPECT_EQ(s.message.find('\n'), std::string::npos);
    EXPECT_EQ(s.message.rfind("h.msh:", 0), 0u) << s.message;
  }
}

TEST(FluentHostile, BadIndicesAndCells) {
  Status s = read(with(kSmall, "1 2 3 1 0", "1 2 9 1 0"));
  EXPECT_NE(s.message.find("out of range"), std::string::npos) << s.message;
  s = read(with(kSmall, "1 2 3 1 0", "1 2 3 5 0"));
  EXPECT_NE(s.message.find("cells 5 and 0"), std::string::npos) << s.message;
  s = read(with(kSmall, "1 2 3 1 0", "1 2 3 1 1"));
  EXPECT_FALSE(s);
  s = read(with(kSmall, "1 2 3 1 0", "1 2 zz 1 0"));
  EXPECT_NE(s.message.find("hexadecimal"), std::string::npos) << s.message;
  s = read(with(kSmall, "(12 (2 1 1 1 2))", "(12 (2 1 1 1 4))"));
  EXPECT_EQ(s.code, ErrorCode::Unsupported) << s.message;
  EXPECT_NE(s.message.find("hexahedral"), std::string::npos) << s.message;
  s = read(with(kSmall, "(13 (3 1 4 3 3)", "(13 (3 1 4 3 4)"));
  EXPECT_EQ(s.code, ErrorCode::Unsupported) << s.message;
  s = read(with(kSmall, "(2 3)", "(2 2)"));
  EXPECT_EQ(s.code, ErrorCode::Unsupported) << s.message;
  s = read(with(kSmall, "(39 (2 fluid body 1)())", "(2059 (1 1 1 1)(\x01\x02))"));
  EXPECT_EQ(s.code, ErrorCode::Unsupported) << s.message;
  // a cell whose faces do not close up (face 3 moved to another vertex)
  s = read(with(kSmall, "2 4 3 1 0", "2 4 1 1 0"));
  EXPECT_FALSE(s);
  // an unclosed comment section
  s = read(std::string("(0 \"never closed") + kSmall);
  EXPECT_FALSE(s);
}

TEST(FluentHostile, BinarySectionsAreRead) {
  // The hand-written tet with its nodes and faces as binary sections.
  std::string b = "(2 3)\n(3010 (1 1 4 1 3)(";
  for (double x : {0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.}) b.append(reinterpret_cast<const char*>(&x), 8);
  b += ")\nEnd of Binary Section 3010)\n(12 (2 1 1 1 2))\n(3013 (3 1 4 3 3)(";
  for (int32_t x : {1, 2, 3, 1, 0, 1, 4, 2, 1, 0, 2, 4, 3, 1, 0, 1, 3, 4, 1, 0}) b.append(reinterpret_cast<const char*>(&x), 4);
  b += ")\nEnd of Binary Section 3013)\n";
  TetMesh m;
  Status s = parse_fluent(b, "b.msh", m);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(m.nt(), 1);
  // A wrong section number after the data.
  s = read(with(b, "End of Binary Section 3013", "End of Binary Section 3010"));
  EXPECT_FALSE(s);
  // Cut inside the binary data.
  s = read(b.substr(0, b.find("(3013") + 40));
  EXPECT_FALSE(s);
}

TEST(Fluent, ZoneTypesMapToOpenFoamAndWhatCannotIsSaid) {
  TetMesh m = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  for (int32_t i = 0; i < m.ntri(); ++i) m.tri_ref[i] = 1 + i % 2;
  m.attachment.get(2, 1).fluent_type = "wall";
  m.attachment.get(2, 2).fluent_type = "velocity-inlet";
  std::string files[8];
  ASSERT_TRUE(format_openfoam(m, files, false));
  EXPECT_NE(files[4].find("type            wall;"), std::string::npos) << files[4];
  std::string lost;
  for (const std::string& x : dropped_by_format(m, Format::OpenFoam)) lost += x + ";";
  EXPECT_NE(lost.find("Fluent zone types (1 zones)"), std::string::npos) << lost;  // velocity-inlet only
  EXPECT_EQ(lost.find("OpenFOAM"), std::string::npos) << lost;
  // And back: an OpenFOAM wall with inGroups entries written as Fluent.
  TetMesh f = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  f.tri_ref.assign(f.ntri(), 4);
  f.attachment.get(2, 4).foam_kind = "patch";
  f.attachment.get(2, 4).foam_type = "symmetryPlane";
  std::string out;
  ASSERT_TRUE(format_fluent(f, out, false));
  EXPECT_NE(out.find("(39 (4 symmetry "), std::string::npos) << out.substr(out.rfind("(39"));
  lost.clear();
  for (const std::string& x : dropped_by_format(f, Format::Fluent)) lost += x + ";";
  EXPECT_EQ(lost.find("OpenFOAM patch types"), std::string::npos) << lost;
  f.attachment.get(2, 4).foam_entries = "inGroups List<word> 1 ( sym );";
  lost.clear();
  for (const std::string& x : dropped_by_format(f, Format::Gmsh)) lost += x + ";";
  EXPECT_NE(lost.find("OpenFOAM patch types and entries (1 patches)"), std::string::npos) << lost;
}
