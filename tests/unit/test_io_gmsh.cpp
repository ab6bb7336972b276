// Gmsh .msh reader and writer: round trips of every variant, hostile input,
// and cross-checks against gmsh itself and meshio when they are installed.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <unistd.h>

#include "io/scan_gmsh_vtk.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"
#include "tetopt/predicates.hpp"

using namespace tetopt;
namespace fs = std::filesystem;

namespace {

/// A two-region box with hand-set refs, entity tags, listed edges, corners
/// and physical names.
TetMesh sample_mesh() {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 2, .nz = 2, .regions = 2});
  m.tet_entity.resize(m.tet_ref.size());
  for (size_t t = 0; t < m.tet_ref.size(); ++t) m.tet_entity[t] = m.tet_ref[t] + 10;
  m.tri_entity.resize(m.tri_ref.size());
  for (size_t i = 0; i < m.tri_ref.size(); ++i) {
    m.tri_ref[i] = 100 + static_cast<int32_t>(i % 3);
    m.tri_entity[i] = 200 + static_cast<int32_t>(i % 3);
  }
  m.edges = {0, 1, 1, 2, 4, 5};
  m.edge_ref = {5, 5, 6};
  m.corners = {0, 3};
  m.physical_names = {{3, 1, "left part"}, {3, 2, "right"}, {2, 100, "skin a"}, {1, 5, "wire"}};
  // A coordinate that needs all 17 digits.
  m.xyz[0] = 0.1 + 1e-17;
  m.xyz[3] = std::nextafter(1.0, 2.0);  // vertex 1 is (1, 0, 0)
  return m;
}

void expect_same(const TetMesh& a, const TetMesh& b, bool entities = true) {
  ASSERT_EQ(a.xyz.size(), b.xyz.size());
  EXPECT_EQ(0, std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * sizeof(double))) << "coordinates differ";
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.tet_ref, b.tet_ref);
  EXPECT_EQ(a.tris, b.tris);
  EXPECT_EQ(a.tri_ref, b.tri_ref);
  EXPECT_EQ(a.edges, b.edges);
  EXPECT_EQ(a.edge_ref, b.edge_ref);
  EXPECT_EQ(a.corners, b.corners);
  if (entities) {
    EXPECT_EQ(a.tet_entity, b.tet_entity);
    EXPECT_EQ(a.tri_entity, b.tri_entity);
  }
  ASSERT_EQ(a.physical_names.size(), b.physical_names.size());
  for (size_t i = 0; i < a.physical_names.size(); ++i) {
    EXPECT_EQ(a.physical_names[i].dim, b.physical_names[i].dim);
    EXPECT_EQ(a.physical_names[i].tag, b.physical_names[i].tag);
    EXPECT_EQ(a.physical_names[i].name, b.physical_names[i].name);
  }
}

struct Variant {
  int version;
  bool binary;
};

std::string tmp_dir() {
  const fs::path p = fs::temp_directory_path() / ("tetopt_gmsh_" + std::to_string(::getpid()));
  fs::create_directories(p);
  return p.string();
}

bool have_program(const char* check) { return std::system(check) == 0; }
bool have_gmsh() { return have_program("command -v gmsh >/dev/null 2>&1"); }
bool have_meshio() { return have_program("/usr/bin/python3 -c 'import meshio' >/dev/null 2>&1"); }

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Status parse(const std::string& text, TetMesh& m) { return parse_gmsh(text, "t.msh", m); }

}  // namespace

// ------------------------------------------------------------ round trips

TEST(IoGmsh, RoundTripEveryVariant) {
  const TetMesh m = sample_mesh();
  for (Variant v : {Variant{22, false}, Variant{22, true}, Variant{41, false}, Variant{41, true}}) {
    SCOPED_TRACE("version " + std::to_string(v.version) + (v.binary ? " binary" : " ascii"));
    std::string out;
    ASSERT_TRUE(format_gmsh(m, out, v.version, v.binary));
    TetMesh r;
    const Status s = parse(out, r);
    ASSERT_TRUE(s) << s.message;
    expect_same(m, r);
    // and again: writing what was read gives the same bytes
    std::string out2;
    ASSERT_TRUE(format_gmsh(r, out2, v.version, v.binary));
    EXPECT_EQ(out, out2);
  }
}

TEST(IoGmsh, RoundTripKeepsRefsWhenEntitiesMixRefs) {
  // One entity tag shared by tets of two refs: 4.1 must split the entity so
  // that both refs survive (the entity tag of one group is renumbered).
  TetMesh m = make_box_mesh({.nx = 2, .ny = 2, .nz = 1, .regions = 2});
  m.tet_entity.assign(m.tet_ref.size(), 1);
  for (Variant v : {Variant{22, false}, Variant{41, false}, Variant{41, true}}) {
    std::string out;
    ASSERT_TRUE(format_gmsh(m, out, v.version, v.binary));
    TetMesh r;
    ASSERT_TRUE(parse(out, r));
    EXPECT_EQ(m.tet_ref, r.tet_ref);
    EXPECT_EQ(m.tets, r.tets);
  }
}

// A point element's tag (its physical tag, or its entity's when it has
// none) is its vertex's ref and comes back as the point's tag in every
// variant, twice over; a robustness probe found them renumbered 1..N.  A
// point in a physical group keeps the group (its entity tag becomes the
// group's), and points in no group get no physical tag back in 4.1.
TEST(IoGmsh, PointElementTagsSurviveEveryVariant) {
  const std::string text =
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 0.1 0.1 0.1\n"
      "$EndNodes\n$Elements\n5\n1 15 2 0 11 1\n2 15 2 0 500 4\n3 15 2 7 12 2\n"
      "4 4 2 0 1 1 2 3 5\n5 4 2 0 1 1 2 5 4\n$EndElements\n";
  TetMesh m;
  ASSERT_TRUE(parse(text, m));
  ASSERT_EQ(m.vert_ref.size(), 5u);
  EXPECT_EQ(m.vert_ref, (std::vector<int32_t>{11, 7, 0, 500, 0}));
  EXPECT_EQ(m.corners, (std::vector<int32_t>{0, 3, 1}));
  for (Variant v : {Variant{22, false}, Variant{22, true}, Variant{41, false}, Variant{41, true}}) {
    SCOPED_TRACE("version " + std::to_string(v.version) + (v.binary ? " binary" : " ascii"));
    std::string out;
    ASSERT_TRUE(format_gmsh(m, out, v.version, v.binary));
    TetMesh r;
    ASSERT_TRUE(parse(out, r));
    EXPECT_EQ(r.corners, m.corners);
    EXPECT_EQ(r.vert_ref, m.vert_ref);
    std::string out2;
    ASSERT_TRUE(format_gmsh(r, out2, v.version, v.binary));
    EXPECT_EQ(out, out2);
    if (v.version == 22 && !v.binary) {
      EXPECT_NE(out.find("\n1 15 2 0 11 1\n"), std::string::npos) << out;
      EXPECT_NE(out.find("\n2 15 2 0 500 4\n"), std::string::npos) << out;
      EXPECT_NE(out.find("\n3 15 2 7 7 2\n"), std::string::npos) << out;
    }
    if (v.version == 41 && !v.binary) {
      // $Entities: points 11 and 500 in no group, 7 in group 7.
      EXPECT_NE(out.find("\n11 0 0 0 0\n"), std::string::npos) << out;
      EXPECT_NE(out.find("\n500 0 0 1 0\n"), std::string::npos) << out;
      EXPECT_NE(out.find("\n7 1 0 0 1 7\n"), std::string::npos) << out;
    }
  }
  // Not dropped: the Gmsh writers carry a corner's vertex ref.
  EXPECT_TRUE(dropped_by_format(m, Format::Gmsh, WriteOptions{}).empty());
  TetMesh other = m;
  other.vert_ref[2] = 3;  // a vertex ref on no point element is still lost
  EXPECT_EQ(dropped_by_format(other, Format::Gmsh, WriteOptions{}),
            (std::vector<std::string>{"vertex refs (1 nonzero)"}));
}

TEST(IoGmsh, WriteReadThroughFilesIsPositive) {
  const std::string dir = tmp_dir();
  TetMesh m = make_box_mesh({.nx = 2, .ny = 2, .nz = 2, .jitter = 0.2, .regions = 2});
  for (Variant v : {Variant{22, false}, Variant{22, true}, Variant{41, false}, Variant{41, true}}) {
    const std::string path = dir + "/f" + std::to_string(v.version) + (v.binary ? "b" : "a") + ".msh";
    ASSERT_TRUE(write_mesh(path, m, {.msh_version = v.version, .binary = v.binary}));
    TetMesh r;
    OrientationReport rep;
    const Status s = read_mesh(path, r, &rep);
    ASSERT_TRUE(s) << s.message;
    EXPECT_EQ(rep.negative, 0);
    EXPECT_FALSE(r.flipped_on_read);
    EXPECT_EQ(r.nt(), m.nt());
    EXPECT_EQ(r.tet_ref, m.tet_ref);
    for (int32_t t = 0; t < r.nt(); ++t) {
      const int32_t* q = r.tet(t);
      ASSERT_EQ(orient3d(r.point(q[0]), r.point(q[1]), r.point(q[2]), r.point(q[3])), Sign::Positive);
    }
  }
  fs::remove_all(dir);
}

TEST(IoGmsh, FlippedFileIsWrittenBackInItsOwnConvention) {
  // A file whose tets are all negative: read_mesh flips them and the Gmsh
  // writer restores the file's order.
  TetMesh m = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  for (int32_t t = 0; t < m.nt(); ++t) std::swap(m.tets[4 * t + 2], m.tets[4 * t + 3]);
  const std::string dir = tmp_dir();
  const std::string path = dir + "/neg.msh";
  std::string out;
  ASSERT_TRUE(format_gmsh(m, out, 41, false));
  ASSERT_TRUE(write_file_atomic(path, out));
  TetMesh r;
  ASSERT_TRUE(read_mesh(path, r));
  EXPECT_TRUE(r.flipped_on_read);
  std::string back;
  ASSERT_TRUE(format_gmsh(r, back, 41, false));
  EXPECT_EQ(out, back);
  fs::remove_all(dir);
}

TEST(IoGmsh, SparseUnorderedNodeTags) {
  const std::string text =
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
      "$Nodes\n5\n"
      "1000 0 0 0\n7 1 0 0\n123456789 0 1 0\n3 0 0 1\n42 1 1 1\n"
      "$EndNodes\n$Elements\n3\n"
      "1 4 2 9 4 1000 7 123456789 3\n"
      "2 2 2 5 6 1000 7 123456789\n"
      "3 4 0 7 123456789 3 42\n"
      "$EndElements\n";
  TetMesh m;
  const Status s = parse(text, m);
  ASSERT_TRUE(s) << s.message;
  ASSERT_EQ(m.nv(), 5);
  EXPECT_EQ(m.tets, (std::vector<int32_t>{0, 1, 2, 3, 1, 2, 3, 4}));
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{9, 0}));
  EXPECT_EQ(m.tet_entity, (std::vector<int32_t>{4, 0}));
  EXPECT_EQ(m.tri_ref, (std::vector<int32_t>{5}));
  EXPECT_EQ(m.point(4)[2], 1.0);
}

TEST(IoGmsh, PhysicalTagZeroFallsBackToElementary) {
  const std::string text =
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n"
      "$Elements\n1\n1 4 2 0 17 1 2 3 4\n$EndElements\n";
  TetMesh m;
  ASSERT_TRUE(parse(text, m));
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{17}));
}

TEST(IoGmsh, Msh41EntityPhysicalTagsAndParametricNodes) {
  const std::string text =
      "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
      "$PhysicalNames\n1\n3 33 \"solid body\"\n$EndPhysicalNames\n"
      "$Entities\n0 0 0 2\n5 0 0 0 1 1 1 1 33 0\n6 0 0 0 1 1 1 0 0\n$EndEntities\n"
      "$Nodes\n2 5 1 5\n"
      "3 5 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
      "2 9 1 1\n5\n1 1 1 0.5 0.5\n"
      "$EndNodes\n"
      "$Elements\n2 2 1 2\n3 5 4 1\n1 1 2 3 4\n3 6 4 1\n2 2 3 4 5\n$EndElements\n"
      "$NodeData\n1\n\"junk\"\n$EndNodeData\n";
  TetMesh m;
  const Status s = parse(text, m);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(m.nv(), 5);
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{33, 6}));
  EXPECT_EQ(m.tet_entity, (std::vector<int32_t>{5, 6}));
  ASSERT_EQ(m.physical_names.size(), 1u);
  EXPECT_EQ(m.physical_names[0].name, "solid body");
  // An entity's physical or own tag beyond 32 bits is refused (a physical tag
  // of 2^31 once became every tet's ref -2^31).
  struct Bad {
    std::string from, to, line;
  };
  for (const auto& [from, to, line] : std::vector<Bad>{
           {"5 0 0 0 1 1 1 1 33 0", "5 0 0 0 1 1 1 1 2147483648 0", "t.msh:10:"},
           {"5 0 0 0 1 1 1 1 33 0", "5 0 0 0 1 1 1 1 -2147483649 0", "t.msh:10:"},
           {"6 0 0 0 1 1 1 0 0", "4294967302 0 0 0 1 1 1 0 0", "t.msh:11:"}}) {
    std::string bad = text;
    bad.replace(bad.find(from), from.size(), to);
    TetMesh b;
    const Status e = parse(bad, b);
    ASSERT_FALSE(e) << to;
    EXPECT_NE(e.message.find("does not fit in 32 bits"), std::string::npos) << e.message;
    EXPECT_EQ(e.message.rfind(line, 0), 0u) << e.message;
  }
}

// A 4.1 entity in two physical groups, and one in none, stay so through a
// read and a write (ASCII and binary): the writer listed only the ref, so
// the second group lost its tets and the entity without a group got one.
// An entity whose tets the writer gives another ref lists that ref.
// A model without physical groups: Gmsh writes physical tag 0 (2.2) or no
// physical tags (4.1) on every element.  The refs are then the elementary
// tags, and the writers made them physical groups (0 -> 1..6 on a box's
// faces: meshcheck saw every boundary triangle lose its tag, and meshio could
// not read the 4.1 output, some blocks having a physical tag and some not).
TEST(IoGmsh, FileWithoutPhysicalGroupsGetsNoneBack) {
  const std::string v22 =
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
      "$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n$EndNodes\n"
      "$Elements\n6\n1 15 2 0 1 1\n2 1 2 0 3 1 2\n3 2 2 0 4 1 2 3\n4 2 2 0 5 2 3 4\n"
      "5 4 2 0 1 1 2 3 4\n6 4 2 0 2 2 3 4 5\n$EndElements\n";
  TetMesh m;
  Status s = parse(v22, m);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{1, 2}));  // regions: the elementary volumes
  EXPECT_EQ(m.tri_ref, (std::vector<int32_t>{4, 5}));
  for (bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    std::string o22, o41;
    ASSERT_TRUE(format_gmsh(m, o22, 22, binary));
    ASSERT_TRUE(format_gmsh(m, o41, 41, binary));
    if (!binary) {
      EXPECT_EQ(o22, v22);  // physical 0 and the elementary tags, as read
    }
    for (const std::string* out : {&o22, &o41}) {
      TetMesh r;
      s = parse(*out, r);
      ASSERT_TRUE(s) << s.message;
      EXPECT_EQ(r.tet_ref, m.tet_ref);
      EXPECT_EQ(r.tri_ref, m.tri_ref);
      EXPECT_EQ(r.edge_ref, m.edge_ref);
      for (const TetMesh::GmshEntity& e : r.gmsh_entities)
        EXPECT_TRUE(e.physicals.empty()) << "dim " << e.dim << " tag " << e.tag;
    }
    // From 4.1 back to 4.1: points and curves without a physical tag too.
    TetMesh r41;
    ASSERT_TRUE(parse(o41, r41));
    std::string again;
    ASSERT_TRUE(format_gmsh(r41, again, 41, binary));
    TetMesh r2;
    ASSERT_TRUE(parse(again, r2));
    ASSERT_FALSE(r2.gmsh_entities.empty());
    for (const TetMesh::GmshEntity& e : r2.gmsh_entities)
      EXPECT_TRUE(e.physicals.empty()) << "dim " << e.dim << " tag " << e.tag;
  }
  // Elements of one entity with and without a physical tag: not listed as
  // "in none"; the ref is written as before.
  std::string mixed = v22;
  mixed.replace(mixed.find("\n4 2 2 0 5"), 10, "\n4 2 2 9 4");
  TetMesh mx;
  ASSERT_TRUE(parse(mixed, mx));
  for (const TetMesh::GmshEntity& e : mx.gmsh_entities) EXPECT_FALSE(e.dim == 2 && e.tag == 4);
}

TEST(IoGmsh, Msh41EntityPhysicalListsSurviveARoundTrip) {
  const std::string text =
      "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
      "$Entities\n0 0 0 2\n5 0 0 0 1 1 1 2 33 44 0\n6 0 0 0 1 1 1 0 0\n$EndEntities\n"
      "$Nodes\n1 5 1 5\n3 5 0 5\n1\n2\n3\n4\n5\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n"
      "$Elements\n2 2 1 2\n3 5 4 1\n1 1 2 3 4\n3 6 4 1\n2 2 3 4 5\n$EndElements\n";
  TetMesh m;
  Status s = parse(text, m);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{33, 6}));
  ASSERT_EQ(m.gmsh_entities.size(), 2u);
  EXPECT_EQ(m.gmsh_entities[0].physicals, (std::vector<int32_t>{33, 44}));
  EXPECT_TRUE(m.gmsh_entities[1].physicals.empty());
  for (bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    std::string out;
    ASSERT_TRUE(format_gmsh(m, out, 41, binary));
    if (!binary) {
      EXPECT_NE(out.find("\n5 0 0 0 1 1 1 2 33 44 0\n"), std::string::npos) << out;
      EXPECT_NE(out.find("\n6 0 0 0 1 1 1 0 0\n"), std::string::npos) << out;
    }
    TetMesh r;
    s = parse(out, r);
    ASSERT_TRUE(s) << s.message;
    EXPECT_EQ(r.tet_ref, m.tet_ref);
    EXPECT_EQ(r.tet_entity, m.tet_entity);
    std::map<int, std::vector<int32_t>> vol;
    for (const TetMesh::GmshEntity& e : r.gmsh_entities)
      if (e.dim == 3) vol[e.tag] = e.physicals;
    EXPECT_EQ(vol, (std::map<int, std::vector<int32_t>>{{5, {33, 44}}, {6, {}}}));
  }
  // Listed edges carry no entity tag: an edge of line entity 1 (physical
  // 5) is written in an entity tagged by its ref, 5, which must list 5, not
  // the empty list of the file's line entity 5 (its group would be lost).
  {
    const std::string lines =
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
        "$Entities\n0 2 0 1\n1 0 0 0 1 0 0 1 5 0\n5 0 0 0 0 1 0 0 0\n1 0 0 0 1 1 1 1 9 0\n$EndEntities\n"
        "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n"
        "$Elements\n3 3 1 3\n1 1 1 1\n1 1 2\n1 5 1 1\n2 1 3\n3 1 4 1\n3 1 2 3 4\n$EndElements\n";
    TetMesh e;
    s = parse(lines, e);
    ASSERT_TRUE(s) << s.message;
    EXPECT_EQ(e.edge_ref, (std::vector<int32_t>{5, 5}));
    std::string o;
    ASSERT_TRUE(format_gmsh(e, o, 41, false));
    TetMesh back;
    ASSERT_TRUE(parse(o, back));
    bool group5 = false;
    for (const TetMesh::GmshEntity& g : back.gmsh_entities)
      if (g.dim == 1 && std::find(g.physicals.begin(), g.physicals.end(), 5) != g.physicals.end()) group5 = true;
    EXPECT_TRUE(group5) << o;
  }
  // An element block in an entity that $Entities does not list: refused
  // (Gmsh refuses it too), naming the line; without $Entities it is read.
  {
    std::string bad = text;
    bad.replace(bad.find("3 6 4 1\n"), 8, "3 7 4 1\n");
    TetMesh b;
    const Status e = parse(bad, b);
    ASSERT_FALSE(e);
    EXPECT_NE(e.message.find("t.msh:27: element block 2 is in entity 7 of dimension 3, which $Entities does not list"),
              std::string::npos)
        << e.message;
    std::string none = bad;
    none.erase(none.find("$Entities"), none.find("$Nodes") - none.find("$Entities"));
    TetMesh c;
    const Status ok = parse(none, c);
    ASSERT_TRUE(ok) << ok.message;
    EXPECT_EQ(c.tet_ref, (std::vector<int32_t>{5, 7}));
  }
  // The second tet moved to ref 7 (not entity 6's own tag): its entity lists 7.
  m.tet_ref[1] = 7;
  std::string out;
  ASSERT_TRUE(format_gmsh(m, out, 41, false));
  TetMesh r;
  ASSERT_TRUE(parse(out, r));
  EXPECT_EQ(r.tet_ref, (std::vector<int32_t>{33, 7}));
}

// ------------------------------------------------------------ hostile input

namespace {
const std::string kHead = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
const std::string kNodes = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";

void expect_error(const std::string& text, ErrorCode code, long line, const std::string& needle) {
  TetMesh m;
  const Status s = parse(text, m);
  ASSERT_FALSE(s) << "accepted: " << text.substr(0, 200);
  EXPECT_EQ(s.code, code) << s.message;
  if (line > 0) {
    EXPECT_EQ(s.line, line) << s.message;
    EXPECT_EQ(s.message.rfind("t.msh:" + std::to_string(line) + ": ", 0), 0u) << s.message;
  }
  EXPECT_NE(s.message.find(needle), std::string::npos) << s.message;
  EXPECT_EQ(s.message.find('\n'), std::string::npos) << "message is not one line: " << s.message;
  EXPECT_EQ(m.nt(), 0);
}
}  // namespace

TEST(IoGmshHostile, TruncatedFile) {
  const std::string full = kHead + kNodes + "$Elements\n1\n1 4 2 1 1 1 2 3 4\n$EndElements\n";
  expect_error(full.substr(0, full.size() - 25), ErrorCode::Parse, 0, "end of file");
  // every prefix fails cleanly (no crash, no exception)
  for (size_t n = 0; n + 1 < full.size(); ++n) {
    TetMesh m;
    EXPECT_FALSE(parse(full.substr(0, n), m)) << n;
  }
}

TEST(IoGmshHostile, CountsThatLie) {
  // more nodes promised than present
  expect_error(kHead + "$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n", ErrorCode::Parse, 10, "$EndNodes");
  // fewer promised than present
  expect_error(kHead + "$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n", ErrorCode::Parse, 9,
               "expected $EndNodes");
  // element count too large
  expect_error(kHead + kNodes + "$Elements\n2\n1 4 2 1 1 1 2 3 4\n$EndElements\n", ErrorCode::Parse, 0, "");
}

TEST(IoGmshHostile, AbsurdCountsAllocateNothing) {
  expect_error(kHead + "$Nodes\n900000000000\n1 0 0 0\n$EndNodes\n", ErrorCode::Parse, 5, "exceeds");
  expect_error(kHead + kNodes + "$Elements\n99999999999\n$EndElements\n", ErrorCode::Parse, 12, "exceeds");
  expect_error(kHead + "$Nodes\n-3\n$EndNodes\n", ErrorCode::Parse, 5, "negative");
  // A 4.1 block's negative minimum tag, named with its article in place.
  expect_error("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 -5 4\n", ErrorCode::Parse, 5,
               "the minimum node tag is negative (-5)");
  // binary 4.1 header with a huge size_t count
  std::string b = "$MeshFormat\n4.1 1 8\n";
  gvscan::store<int32_t>(b, 1, false);
  b += "\n$EndMeshFormat\n$Nodes\n";
  for (uint64_t x : {uint64_t{1}, uint64_t{1} << 40, uint64_t{1}, uint64_t{1} << 40}) gvscan::store<uint64_t>(b, x, false);
  b += "\n$EndNodes\n";
  TetMesh m;
  const Status s = parse(b, m);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message.find("exceeds"), std::string::npos) << s.message;
}

TEST(IoGmshHostile, NanAndInfCoordinates) {
  expect_error(kHead + "$Nodes\n2\n1 0 0 0\n2 nan 0 0\n$EndNodes\n", ErrorCode::InvalidMesh, 7, "NaN");
  expect_error(kHead + "$Nodes\n2\n1 0 inf 0\n2 0 0 0\n$EndNodes\n", ErrorCode::InvalidMesh, 6, "infinite");
  expect_error(kHead + "$Nodes\n1\n1 0 1e999 0\n$EndNodes\n", ErrorCode::Parse, 6, "coordinate");
}

TEST(IoGmshHostile, UnknownNodeTagAndDuplicateTag) {
  expect_error(kHead + kNodes + "$Elements\n1\n1 4 2 1 1 1 2 3 99\n$EndElements\n", ErrorCode::InvalidMesh, 13,
               "node tag 99");
  expect_error(kHead + "$Nodes\n2\n1 0 0 0\n1 1 0 0\n$EndNodes\n", ErrorCode::InvalidMesh, 7, "appears twice");
}

TEST(IoGmshHostile, NonNumericTokens) {
  expect_error(kHead + "$Nodes\n2\n1 0 0 0\n2 1 x 0\n$EndNodes\n", ErrorCode::Parse, 7, "'x'");
  expect_error(kHead + kNodes + "$Elements\n1\n1 4 2 1 1 1 2 3 4z\n$EndElements\n", ErrorCode::Parse, 13, "'4z'");
  expect_error("$MeshFormat\n2.2 zero 8\n$EndMeshFormat\n", ErrorCode::Parse, 2, "file type");
}

TEST(IoGmshHostile, SectionOrderAndMissingEnd) {
  expect_error(kHead + "$Elements\n0\n$EndElements\n" + kNodes, ErrorCode::Parse, 4, "before $Nodes");
  expect_error(kHead + "$Nodes\n1\n1 0 0 0\n$Elements\n0\n$EndElements\n", ErrorCode::Parse, 7, "expected $EndNodes");
  expect_error("$Nodes\n1\n1 0 0 0\n$EndNodes\n", ErrorCode::Parse, 1, "$MeshFormat");
  expect_error(kHead + kNodes + "$Periodic\n1 2 3\n", ErrorCode::Parse, 0, "$EndPeriodic");
  expect_error(kHead + kNodes, ErrorCode::Parse, 0, "no $Elements");
}

TEST(IoGmshHostile, SurfaceOnlyMeshAndUnsupportedTypes) {
  expect_error(kHead + kNodes + "$Elements\n1\n1 2 2 1 1 1 2 3\n$EndElements\n", ErrorCode::InvalidMesh, 0,
               "no tetrahedra");
  expect_error(kHead + kNodes + "$Elements\n1\n1 11 2 1 1 1 2 3 4 1 2 3 4 1 2\n$EndElements\n", ErrorCode::Unsupported,
               13, "10-node second-order tetrahedron");
  expect_error(kHead + kNodes + "$Elements\n1\n1 6 2 1 1 1 2 3 4 1 2\n$EndElements\n", ErrorCode::Unsupported, 13,
               "prism");
  expect_error("$MeshFormat\n4 0 8\n$EndMeshFormat\n", ErrorCode::Unsupported, 2, "version 4");
}

TEST(IoGmshHostile, BinaryTruncatedAndCorrupted) {
  const TetMesh m = sample_mesh();
  for (int version : {22, 41}) {
    std::string out;
    ASSERT_TRUE(format_gmsh(m, out, version, true));
    for (size_t cut : {out.size() / 2, out.size() - 20, out.size() / 3, size_t{30}}) {
      TetMesh r;
      const Status s = parse(out.substr(0, cut), r);
      EXPECT_FALSE(s) << version << " cut " << cut;
      EXPECT_EQ(s.message.find('\n'), std::string::npos);
    }
    // wrong endianness check
    std::string bad = out;
    const size_t at = bad.find("8\n") + 2;
    bad[at] = 2;
    TetMesh r;
    EXPECT_FALSE(parse(bad, r));
    // flip bytes all over the binary part: never a crash
    for (size_t i = 60; i < out.size(); i += 7) {
      std::string c = out;
      c[i] = static_cast<char>(c[i] ^ 0x5a);
      TetMesh x;
      (void)parse(c, x);
    }
  }
}

// ------------------------------------------------------------ gmsh / meshio

TEST(IoGmshCross, GmshAcceptsOurFiles) {
  if (!have_gmsh()) GTEST_SKIP() << "gmsh not installed";
  const std::string dir = tmp_dir();
  const TetMesh m = sample_mesh();
  for (Variant v : {Variant{22, false}, Variant{22, true}, Variant{41, false}, Variant{41, true}}) {
    SCOPED_TRACE("version " + std::to_string(v.version) + (v.binary ? " binary" : " ascii"));
    std::string out;
    ASSERT_TRUE(format_gmsh(m, out, v.version, v.binary));
    const std::string in = dir + "/ours.msh", back = dir + "/back.msh";
    ASSERT_TRUE(write_file_atomic(in, out));
    fs::remove(back);
    const std::string cmd = "gmsh " + in + " -0 -format msh41 -o " + back + " > " + dir + "/log.txt 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(dir + "/log.txt");
    const std::string log = slurp(dir + "/log.txt");
    EXPECT_EQ(log.find("Error"), std::string::npos) << log;
    TetMesh r;
    const Status s = read_mesh(back, r);
    ASSERT_TRUE(s) << s.message;
    EXPECT_EQ(r.nt(), m.nt());
    EXPECT_EQ(r.ntri(), m.ntri());
    EXPECT_EQ(r.edges.size(), m.edges.size());
    // Gmsh may renumber elements inside an entity; compare refs as multisets.
    std::vector<int32_t> a = m.tet_ref, b = r.tet_ref, c = m.tri_ref, d = r.tri_ref;
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    std::sort(c.begin(), c.end());
    std::sort(d.begin(), d.end());
    EXPECT_EQ(a, b);
    EXPECT_EQ(c, d);
    EXPECT_EQ(r.physical_names.size(), m.physical_names.size());
  }
  fs::remove_all(dir);
}

TEST(IoGmshCross, ReadsWhatGmshWrote) {
  if (!have_gmsh()) GTEST_SKIP() << "gmsh not installed";
  const std::string dir = tmp_dir();
  const std::string geo = std::string(TETOPT_SOURCE_DIR) + "/tests/data/gmsh/two_boxes.geo";
  int32_t nt_first = -1;
  for (const char* fmt : {"msh22", "msh41"})
    for (const char* bin : {"", " -bin"}) {
      SCOPED_TRACE(std::string(fmt) + bin);
      const std::string out = dir + "/g.msh";
      fs::remove(out);
      const std::string cmd = "gmsh " + geo + " -3 -format " + fmt + bin + " -o " + out + " > /dev/null 2>&1";
      ASSERT_EQ(std::system(cmd.c_str()), 0);
      TetMesh r;
      OrientationReport rep;
      const Status s = read_mesh(out, r, &rep);
      ASSERT_TRUE(s) << s.message;
      EXPECT_GT(r.nt(), 0);
      EXPECT_EQ(rep.negative, 0);
      EXPECT_EQ(rep.flat, 0);
      if (nt_first < 0) nt_first = r.nt();
      EXPECT_EQ(r.nt(), nt_first);  // same mesh in every encoding
      for (int32_t ref : r.tet_ref) EXPECT_TRUE(ref == 7 || ref == 8) << ref;
      EXPECT_GT(std::count(r.tet_ref.begin(), r.tet_ref.end(), 7), 0);
      EXPECT_GT(std::count(r.tet_ref.begin(), r.tet_ref.end(), 8), 0);
      for (int32_t ref : r.tri_ref) EXPECT_EQ(ref, 3);
      EXPECT_EQ(r.physical_names.size(), 3u);
      // total volume of the two unit cubes
      double vol = 0;
      for (int32_t t = 0; t < r.nt(); ++t) vol += tet_volume(r, t);
      EXPECT_NEAR(vol, 2.0, 1e-12);
    }
  fs::remove_all(dir);
}

TEST(IoGmshCross, MeshioReadsOurFiles) {
  if (!have_meshio()) GTEST_SKIP() << "meshio not importable by /usr/bin/python3";
  const std::string dir = tmp_dir();
  const TetMesh m = sample_mesh();
  int64_t want_sum = 0;
  for (int32_t r : m.tet_ref) want_sum += r;
  for (Variant v : {Variant{22, false}, Variant{22, true}, Variant{41, false}, Variant{41, true}}) {
    SCOPED_TRACE("version " + std::to_string(v.version) + (v.binary ? " binary" : " ascii"));
    std::string out;
    ASSERT_TRUE(format_gmsh(m, out, v.version, v.binary));
    const std::string in = dir + "/ours.msh", res = dir + "/res.txt";
    ASSERT_TRUE(write_file_atomic(in, out));
    const std::string cmd =
        "/usr/bin/python3 -c 'import meshio,sys\n"
        "m=meshio.read(sys.argv[1])\n"
        "nt=sum(len(c.data) for c in m.cells if c.type==\"tetra\")\n"
        "s=sum(int(m.cell_data[\"gmsh:physical\"][i].sum()) for i,c in enumerate(m.cells) if c.type==\"tetra\")\n"
        "print(len(m.points), nt, s, repr(float(m.points[0][0])))' " +
        in + " > " + res + " 2>" + dir + "/err.txt";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(dir + "/err.txt");
    std::istringstream ss(slurp(res));
    int64_t np = 0, nt = 0, sum = 0;
    std::string x0;
    ss >> np >> nt >> sum >> x0;
    EXPECT_EQ(np, m.nv());
    EXPECT_EQ(nt, m.nt());
    EXPECT_EQ(sum, want_sum);
    double x = 0;
    ASSERT_TRUE(gvscan::parse_double(x0, x));
    EXPECT_EQ(x, m.xyz[0]);
  }
  fs::remove_all(dir);
}

TEST(IoGmshCross, MeshioWrittenFilesRead) {
  if (!have_meshio()) GTEST_SKIP() << "meshio not importable by /usr/bin/python3";
  const std::string dir = tmp_dir();
  for (const char* fmt : {"gmsh22", "gmsh"})
    for (const char* binary : {"False", "True"}) {
      SCOPED_TRACE(std::string(fmt) + " binary=" + binary);
      const std::string out = dir + "/mio.msh";
      const std::string cmd =
          std::string("/usr/bin/python3 -c 'import meshio,numpy as np\n"
                      "p=np.array([[0,0,0],[1,0,0],[0,1,0],[0,0,1],[1,1,1]],dtype=float)\n"
                      "c=[(\"tetra\",np.array([[0,1,2,3],[1,2,3,4]]))]\n"
                      "cd={\"gmsh:physical\":[np.array([4,9])],\"gmsh:geometrical\":[np.array([1,2])]}\n"
                      "meshio.write(\"") +
          out + "\",meshio.Mesh(p,c,cell_data=cd),file_format=\"" + fmt + "\",binary=" + binary +
          ")' > /dev/null 2>&1";
      ASSERT_EQ(std::system(cmd.c_str()), 0);
      TetMesh r;
      const Status s = read_mesh(out, r);
      ASSERT_TRUE(s) << s.message;
      EXPECT_EQ(r.nv(), 5);
      EXPECT_EQ(r.nt(), 2);
      // meshio's 4.1 writer drops physical tags (no $Entities, one block in
      // entity 1): the file itself says ref = entity tag 1 there.
      if (std::string(fmt) == "gmsh22") EXPECT_EQ(r.tet_ref, (std::vector<int32_t>{4, 9}));
      else EXPECT_EQ(r.tet_ref, (std::vector<int32_t>{1, 1}));
    }
  fs::remove_all(dir);
}

TEST(IoGmshPerf, LargeAsciiParsesQuickly) {
  // 45 x 45 x 40 cells x 6 = 486k tets: must parse in well under 5 s.
  TetMesh m = make_box_mesh({.nx = 45, .ny = 45, .nz = 40});
  std::string out;
  ASSERT_TRUE(format_gmsh(m, out, 41, false));
  const auto t0 = std::chrono::steady_clock::now();
  TetMesh r;
  ASSERT_TRUE(parse(out, r));
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(r.nt(), m.nt());
  EXPECT_LT(secs, 5.0) << r.nt() << " tets took " << secs << " s";
}

TEST(IoFormats, DroppedByFormatNamesExactlyWhatTheFileLoses) {
  // Every kind of data one format or another cannot hold, written to each
  // format and read back: a kind is named by dropped_by_format exactly when
  // it does not come back.
  TetMesh m = sample_mesh();
  m.vert_ref.assign(m.nv(), 0);
  m.vert_ref[2] = 7;
  m.vert_ref[5] = -1;
  m.required_vertices = {1};
  m.required_edges = {0};
  m.required_tris = {0, 1};
  m.ridges = {2};
  m.point_fields.push_back({"fixed", 1, true, std::vector<double>(m.nv(), 1.0)});
  // Names a syntax cannot hold as they are (written with '_' instead).
  m.point_fields.push_back({"a b", 1, false, std::vector<double>(m.nv(), 0.5)});
  ASSERT_FALSE(m.physical_names.empty());
  m.physical_names[0].name = "say \"hi\"";
  const fs::path d = fs::temp_directory_path() / ("tetopt_dropped_" + std::to_string(::getpid()));
  fs::create_directories(d);
  struct Case {
    const char* name;
    int msh_version;
  };
  for (const Case c : {Case{"a.mesh", 41}, Case{"a.meshb", 41}, Case{"a.msh", 41}, Case{"b.msh", 22},
                       Case{"a.vtk", 41}, Case{"a.vtu", 41}, Case{"a.node", 41}}) {
    SCOPED_TRACE(c.name);
    const std::string path = (d / c.name).string();
    WriteOptions wo;
    wo.msh_version = c.msh_version;
    const std::vector<std::string> lost = dropped_by_format(m, format_from_path(path), wo);
    auto named = [&](const std::string& what) {
      return std::any_of(lost.begin(), lost.end(), [&](const std::string& s) { return s.rfind(what, 0) == 0; });
    };
    ASSERT_TRUE(write_mesh(path, m, wo).ok());
    TetMesh r;
    const Status s = read_mesh(path, r);
    ASSERT_TRUE(s.ok()) << s.message;
    // Tets may come back reordered by nothing here: same ids expected.
    EXPECT_EQ(r.tet_ref, m.tet_ref);
    EXPECT_EQ(r.tri_ref, m.tri_ref);
    EXPECT_EQ(named("vertex refs"), r.vert_ref != m.vert_ref);
    EXPECT_EQ(named("listed edges"), r.edges.empty());
    EXPECT_EQ(named("corners"), r.corners.empty());
    EXPECT_EQ(named("required vertices"), r.required_vertices.empty());
    EXPECT_EQ(named("required edges"), r.required_edges.empty());
    EXPECT_EQ(named("required triangles"), r.required_tris.empty());
    EXPECT_EQ(named("ridges"), r.ridges.empty());
    EXPECT_EQ(named("physical names ("), r.physical_names.empty());
    EXPECT_EQ(named("physical names with"), !r.physical_names.empty() && r.physical_names[0].name != m.physical_names[0].name);
    EXPECT_EQ(named("Gmsh elementary entity tags"), r.tet_entity != m.tet_entity || r.tri_entity != m.tri_entity);
    EXPECT_EQ(named("point data arrays (fixed, a b)"), r.point_fields.empty());
    EXPECT_EQ(named("point data names with blanks"), r.point_fields.size() == 2 && r.point_fields[1].name != "a b");
  }
  fs::remove_all(d);
}
