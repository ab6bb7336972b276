// Abaqus / CalculiX .inp reader and writer (issue 28): round trip, sets and
// surfaces, the C3D4 face numbering, hostile input.
#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "io/face_cells.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"

using namespace tetopt;

namespace {

TetMesh sample_mesh() {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 2, .nz = 2, .jitter = 0.2, .seed = 9, .regions = 2});
  for (int32_t i = 0; i < m.ntri(); ++i) m.tri_ref[i] = i % 2 ? 5 : 12;
  m.tet_ref[0] = 0;  // a tet in no set
  m.vert_ref.assign(m.nv(), 0);
  m.vert_ref[2] = 7;
  m.vert_ref[3] = 7;
  m.xyz[0] = 0.1 + 1e-17;
  m.physical_names = {{3, 1, "left"}, {3, 2, "right"}, {2, 12, "skin"}, {0, 7, "probe"}};
  return m;
}
const std::string* name(const TetMesh& m, int dim, int tag) {
  for (const PhysicalName& p : m.physical_names)
    if (p.dim == dim && p.tag == tag) return &p.name;
  return nullptr;
}
std::multiset<std::pair<std::array<int32_t, 3>, int32_t>> tri_set(const TetMesh& m) {
  std::multiset<std::pair<std::array<int32_t, 3>, int32_t>> s;
  for (int32_t i = 0; i < m.ntri(); ++i) s.insert({detail::tri_key(&m.tris[3 * i]), m.tri_ref[i]});
  return s;
}
Status read(const std::string& s, TetMesh& m) { return parse_abaqus(s, "a.inp", m); }
Status read(const std::string& s) {
  TetMesh m;
  return read(s, m);
}
std::string with(std::string s, const std::string& from, const std::string& to) {
  const size_t p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  if (p != std::string::npos) s.replace(p, from.size(), to);
  return s;
}

}  // namespace

TEST(Abaqus, RoundTripKeepsEverythingItCanHold) {
  const TetMesh m = sample_mesh();
  std::string f;
  ASSERT_TRUE(format_abaqus(m, f));
  TetMesh b;
  const Status s = read(f, b);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(0, std::memcmp(m.xyz.data(), b.xyz.data(), m.xyz.size() * sizeof(double)));
  EXPECT_EQ(m.tets, b.tets);  // the element order and each element's node order
  EXPECT_EQ(m.tet_ref, b.tet_ref);
  EXPECT_EQ(m.vert_ref, b.vert_ref);
  EXPECT_EQ(tri_set(m), tri_set(b));
  ASSERT_TRUE(name(b, 3, 2) && name(b, 2, 12) && name(b, 0, 7));
  EXPECT_EQ(*name(b, 3, 2), "right");
  EXPECT_EQ(*name(b, 2, 12), "skin");
  EXPECT_EQ(*name(b, 2, 5), "SURF5");  // generated, stable
  EXPECT_NE(f.find("**tetopt ref=12"), std::string::npos);  // ref 12 is the second surface
  std::string g;
  ASSERT_TRUE(format_abaqus(b, g));
  EXPECT_EQ(f, g);
}

TEST(Abaqus, HandWrittenDeckWithSparseIdsGenerateAndSurfaces) {
  // Nodes numbered 10.., elements 100 and 200, sets by GENERATE and by
  // name, a surface on faces S1 and S4 of element 100 (C3D4 faces: S1 =
  // 1-2-3, S4 = 3-4-1), comments, lower-case keywords, a skipped *MATERIAL.
  const std::string deck =
      "** a comment\n*Heading\n two tets\n*NODE, NSET=ALLN\n10, 0, 0, 0\n11, 1, 0, 0\n12, 0, 1, 0\n13, 0, 0, 1\n14, 1, 1, 1\n"
      "*element, type=C3D4, elset=A\n100, 10, 11, 12, 13\n*ELEMENT, TYPE=C3D4\n200, 11, 14, 12, 13\n"
      "*ELSET, ELSET=B, GENERATE\n100, 200, 100\n*ELSET, ELSET=C\nA, 200\n"
      "*NSET, NSET=TIP\n14\n*SURFACE, NAME=BOTTOM, TYPE=ELEMENT\n100, S1\nA, S4\n"
      "*MATERIAL, NAME=X\n*ELASTIC\n1., 0.3\n";
  TetMesh m;
  const Status s = read(deck, m);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(m.nt(), 2);
  EXPECT_EQ(m.nv(), 5);
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{1, 2}));   // A first, then B (element 200 is only in B, C)
  EXPECT_EQ(m.vert_ref, (std::vector<int32_t>{1, 1, 1, 1, 1}));  // ALLN first for every node
  ASSERT_EQ(m.ntri(), 2);
  EXPECT_EQ(std::vector<int32_t>(m.tris.begin(), m.tris.begin() + 3), (std::vector<int32_t>{0, 1, 2}));  // S1 = 1-2-3
  EXPECT_EQ(std::vector<int32_t>(m.tris.begin() + 3, m.tris.end()), (std::vector<int32_t>{2, 3, 0}));  // S4 = 3-4-1
  EXPECT_EQ(m.tri_ref, (std::vector<int32_t>{1, 1}));
  ASSERT_TRUE(name(m, 2, 1));
  EXPECT_EQ(*name(m, 2, 1), "BOTTOM");
}

TEST(AbaqusHostile, BadDecksAreRefusedWithFileAndLine) {
  const std::string ok = "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1\n*ELEMENT, TYPE=C3D4, ELSET=E\n1, 1, 2, 3, 4\n";
  ASSERT_TRUE(read(ok));
  Status s = read(with(ok, "TYPE=C3D4", "TYPE=C3D8"));
  EXPECT_EQ(s.code, ErrorCode::Unsupported);
  EXPECT_NE(s.message.find("C3D8"), std::string::npos) << s.message;
  s = read(with(ok, "1, 1, 2, 3, 4", "1, 1, 2, 3, 9"));
  EXPECT_NE(s.message.find("node 9 is not defined"), std::string::npos) << s.message;
  EXPECT_EQ(s.message.rfind("a.inp:7:", 0), 0u) << s.message;
  s = read(with(ok, "4, 0, 0, 1", "4, 0, 0, 1e999"));
  EXPECT_NE(s.message.find("finite number"), std::string::npos) << s.message;
  s = read(with(ok, "4, 0, 0, 1", "99999999999, 0, 0, 1"));
  EXPECT_NE(s.message.find("node id"), std::string::npos) << s.message;
  s = read(with(ok, "2, 1, 0, 0", "1, 1, 0, 0"));
  EXPECT_NE(s.message.find("defined twice"), std::string::npos) << s.message;
  s = read(with(ok, "1, 1, 2, 3, 4", "1, 1, 2, 3"));
  EXPECT_NE(s.message.find("4 nodes"), std::string::npos) << s.message;
  // GENERATE with a lying range; a set naming itself or an unknown set (no cycle can form).
  s = read(ok + "*ELSET, ELSET=G, GENERATE\n1, 2000000000, 1\n");
  EXPECT_NE(s.message.find("more ids than are defined"), std::string::npos) << s.message;
  s = read(ok + "*ELSET, ELSET=S\nS\n");
  EXPECT_NE(s.message.find("neither an id nor"), std::string::npos) << s.message;
  s = read(ok + "*ELSET, ELSET=S\nT\n*ELSET, ELSET=T\nS\n");
  EXPECT_FALSE(s);
  s = read(ok + "*SURFACE, NAME=X\n1, S5\n");
  EXPECT_NE(s.message.find("S5"), std::string::npos) << s.message;
  s = read(ok + "*SURFACE, NAME=X\n7, S1\n");
  EXPECT_NE(s.message.find("element 7 is not defined"), std::string::npos) << s.message;
  s = read(ok + "*INCLUDE, INPUT=x.inp\n");
  EXPECT_EQ(s.code, ErrorCode::Unsupported);
  s = read(ok.substr(0, ok.find("*ELEMENT")));
  EXPECT_NE(s.message.find("no C3D4"), std::string::npos) << s.message;
  s = read("");
  EXPECT_FALSE(s);
  // A continuation line: the element's nodes over two lines.
  EXPECT_TRUE(read(with(ok, "1, 1, 2, 3, 4", "1, 1, 2,\n3, 4")));
}
