// Hostile and degenerate input, end to end through read_mesh, build_topology,
// untangle and improve (issue 10), and the regression inputs the fuzzers
// found (tests/regression/, replayed through the fuzz targets' checks).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "tetopt/generate.hpp"
#include "tetopt/improve.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "tetopt/untangle.hpp"

using namespace tetopt;
namespace fs = std::filesystem;

namespace {

class Hostile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("tetopt_hostile_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string put(const std::string& name, const std::string& bytes) {
    const std::string p = (dir_ / name).string();
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }
  fs::path dir_;
};

// Reads path; the error must be one line naming the file.
Status read_err(const std::string& path) {
  TetMesh m;
  Status s = read_mesh(path, m);
  if (s) s = build_topology(m);
  if (!s) {
    EXPECT_EQ(s.message.find('\n'), std::string::npos) << s.message;
  }
  return s;
}

bool mentions(const Status& s, const std::string& what) { return s.message.find(what) != std::string::npos; }

const char* kMeditHead = "MeshVersionFormatted 2\nDimension 3\n";

// Two tets sharing face (1,2,3), both positive.
std::string two_tets_medit(const std::string& extra_vertices = "", int extra_count = 0) {
  std::ostringstream o;
  o << kMeditHead << "Vertices\n" << 5 + extra_count << "\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n1 1 1 0\n"
    << extra_vertices << "Tetrahedra\n2\n1 2 3 4 1\n2 4 3 5 1\nEnd\n";
  return o.str();
}

int run_cli(const std::string& args) {
  const std::string cmd = std::string(TETOPT_CLI) + " " + args + " > /dev/null 2>&1";
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

}  // namespace

// ---------------------------------------------------------------- truncation

TEST_F(Hostile, TruncatedFilesEveryFormat) {
  const TetMesh box = make_box_mesh({.nx = 2, .ny = 2, .nz = 1, .jitter = 0.2});
  for (const char* ext : {".mesh", ".meshb", ".msh", ".vtk", ".vtu"}) {
    const std::string full = (dir_ / (std::string("full") + ext)).string();
    ASSERT_TRUE(write_mesh(full, box)) << ext;
    std::string bytes;
    ASSERT_TRUE(read_file_bytes(full, bytes));
    // Cut at several places: each must give a clean error, never a crash.
    for (double frac : {0.0, 0.1, 0.33, 0.5, 0.77, 0.95}) {
      const size_t cut = static_cast<size_t>(bytes.size() * frac);
      const std::string p = put(std::string("cut") + ext, bytes.substr(0, cut));
      const Status s = read_err(p);
      EXPECT_FALSE(s.ok()) << ext << " cut at " << cut << " of " << bytes.size();
      EXPECT_TRUE(mentions(s, "cut")) << s.message;
    }
  }
}

// A text file that starts with a UTF-8 byte order mark (as some Windows
// editors save it) reads as the same mesh; .meshb is binary and refuses it.
TEST_F(Hostile, Utf8ByteOrderMarkIsSkippedInTextFormats) {
  const TetMesh box = make_box_mesh({.nx = 2, .ny = 2, .nz = 1, .jitter = 0.2, .regions = 2});
  const std::string bom = "\xEF\xBB\xBF";
  for (const char* ext : {".mesh", ".msh", ".vtk", ".vtu", ".node", ".meshb"}) {
    const std::string plain = (dir_ / (std::string("plain") + ext)).string();
    ASSERT_TRUE(write_mesh(plain, box)) << ext;
    TetMesh want, got;
    ASSERT_TRUE(read_mesh(plain, want)) << ext;
    const std::string marked = (dir_ / (std::string("marked") + ext)).string();
    const bool tetgen = std::string(ext) == ".node";
    for (const char* part : tetgen ? std::vector<const char*>{".node", ".ele", ".face"} : std::vector<const char*>{ext}) {
      std::string bytes;
      ASSERT_TRUE(read_file_bytes((dir_ / (std::string("plain") + part)).string(), bytes));
      put(std::string("marked") + part, bom + bytes);
    }
    const Status s = read_mesh(marked, got);
    if (std::string(ext) == ".meshb") {
      EXPECT_FALSE(s.ok());
      continue;
    }
    ASSERT_TRUE(s) << ext << ": " << s.message;
    EXPECT_EQ(got.xyz, want.xyz) << ext;
    EXPECT_EQ(got.tets, want.tets) << ext;
    EXPECT_EQ(got.tet_ref, want.tet_ref) << ext;
    EXPECT_EQ(got.tris, want.tris) << ext;
    EXPECT_EQ(got.tri_ref, want.tri_ref) << ext;
  }
}

// A text file whose lines end with CR alone (classic Mac OS) reads as the
// same mesh, and an error names its true line: Medit said line 1 for every
// error, VTK and TetGen read an empty header.
TEST_F(Hostile, CarriageReturnLineEndsReadAsLines) {
  const TetMesh box = make_box_mesh({.nx = 2, .ny = 2, .nz = 1, .jitter = 0.2, .regions = 2});
  for (const char* ext : {".mesh", ".msh", ".vtk", ".vtu", ".node"}) {
    SCOPED_TRACE(ext);
    const std::string plain = (dir_ / (std::string("plain") + ext)).string();
    ASSERT_TRUE(write_mesh(plain, box));
    TetMesh want, got;
    ASSERT_TRUE(read_mesh(plain, want));
    const bool tetgen = std::string(ext) == ".node";
    for (const char* part : tetgen ? std::vector<const char*>{".node", ".ele", ".face"} : std::vector<const char*>{ext}) {
      std::string bytes;
      ASSERT_TRUE(read_file_bytes((dir_ / (std::string("plain") + part)).string(), bytes));
      std::replace(bytes.begin(), bytes.end(), '\n', '\r');
      put(std::string("cr") + part, bytes);
    }
    const Status s = read_mesh((dir_ / (std::string("cr") + ext)).string(), got);
    ASSERT_TRUE(s) << s.message;
    EXPECT_EQ(got.xyz, want.xyz);
    EXPECT_EQ(got.tets, want.tets);
    EXPECT_EQ(got.tet_ref, want.tet_ref);
    EXPECT_EQ(got.tris, want.tris);
  }
  // Line 13 of this Medit file (the second tet) names vertex 9 of 5.
  std::string bad = two_tets_medit();
  bad.replace(bad.find("2 4 3 5 1"), 9, "2 4 3 9 1");
  std::replace(bad.begin(), bad.end(), '\n', '\r');
  const Status s = read_err(put("bad.mesh", bad));
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "bad.mesh:13:")) << s.message;
}

TEST_F(Hostile, TruncatedTetGen) {
  const std::string node = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n";  // says 4, gives 3
  put("t.node", node);
  put("t.ele", "1 4 0\n1 1 2 4 3\n");
  const Status s = read_err((dir_ / "t.node").string());
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "t.node")) << s.message;
}

// ------------------------------------------------------------ lying counts

TEST_F(Hostile, CountsThatLie) {
  // Too many tets announced.
  std::string txt = two_tets_medit();
  txt.replace(txt.find("Tetrahedra\n2"), 12, "Tetrahedra\n3");
  Status s = read_err(put("lie_tets.mesh", txt));
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "lie_tets.mesh")) << s.message;
  // Fewer vertices announced than the tets need.
  txt = two_tets_medit();
  txt.replace(txt.find("Vertices\n5"), 10, "Vertices\n4");
  s = read_err(put("lie_verts.mesh", txt));
  EXPECT_FALSE(s.ok());
  // Gmsh: $Nodes announces more nodes than given.
  s = read_err(put("lie.msh",
                   "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n9\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n"
                   "$EndNodes\n$Elements\n1\n1 4 2 1 1 1 2 3 4\n$EndElements\n"));
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "lie.msh")) << s.message;
}

TEST_F(Hostile, AbsurdCountsAllocateNothing) {
  // Each file claims billions of entities but carries a few bytes: the reader
  // must refuse before allocating (under ASan a 100 GB allocation aborts).
  const std::string big = "2000000000";
  const std::vector<std::pair<std::string, std::string>> files = {
      {"a.mesh", std::string(kMeditHead) + "Vertices\n" + big + "\n0 0 0 0\nEnd\n"},
      {"b.mesh", two_tets_medit().replace(two_tets_medit().find("Tetrahedra\n2"), 12, "Tetrahedra\n" + big)},
      {"c.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n" + big + "\n1 0 0 0\n$EndNodes\n"},
      {"d.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 " + big + " 1 " + big + "\n3 1 0 " + big +
                    "\n1\n0 0 0\n$EndNodes\n"},
      {"e.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS " + big +
                    " double\n0 0 0\n"},
      {"f.vtu", "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"" + big +
                    "\" NumberOfCells=\"" + big + "\"><Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" "
                    "format=\"ascii\">0 0 0</DataArray></Points></Piece></UnstructuredGrid></VTKFile>\n"},
  };
  for (const auto& [name, bytes] : files) {
    const auto t0 = std::chrono::steady_clock::now();
    const Status s = read_err(put(name, bytes));
    EXPECT_FALSE(s.ok()) << name;
    EXPECT_TRUE(mentions(s, name)) << s.message;
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0) << name;
  }
  // Binary Medit: a Vertices record claiming 2^31-1 vertices.
  std::string b;
  auto w32 = [&](int32_t x) { b.append(reinterpret_cast<const char*>(&x), 4); };
  w32(1); w32(2);                // magic, version 2
  w32(3); w32(20); w32(3);       // Dimension, next offset, 3
  w32(4); w32(40); w32(0x7fffffff);  // Vertices, next, count
  b.append(16, '\0');
  w32(54);
  const Status s = read_err(put("g.meshb", b));
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "g.meshb")) << s.message;
  // TetGen.
  put("h.node", big + " 3 0 0\n1 0 0 0\n");
  put("h.ele", "1 4 0\n1 1 1 1 1\n");
  EXPECT_FALSE(read_err((dir_ / "h.node").string()).ok());
}

// ----------------------------------------------------- values and indices

TEST_F(Hostile, NanAndInfCoordinates) {
  for (const char* bad : {"nan", "inf", "-inf", "1e999"}) {
    std::string txt = two_tets_medit();
    txt.replace(txt.find("1 1 1 0"), 7, std::string("1 ") + bad + " 1 0");
    const Status s = read_err(put("nan.mesh", txt));
    EXPECT_FALSE(s.ok()) << bad;
    EXPECT_TRUE(mentions(s, "nan.mesh")) << s.message;
    EXPECT_TRUE(mentions(s, "5") || mentions(s, "coordinate") || mentions(s, "number")) << s.message;
  }
  const Status s = read_err(put("nan.vtk",
                                "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n"
                                "0 0 0 1 0 0 0 nan 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n"));
  EXPECT_FALSE(s.ok());
}

TEST_F(Hostile, IndicesOutOfRange) {
  for (const char* tet : {"1 2 3 6 1", "0 2 3 4 1", "1 2 3 -4 1", "1 2 3 99999999999 1"}) {
    std::string txt = two_tets_medit();
    txt.replace(txt.find("2 4 3 5 1"), 9, tet);
    const Status s = read_err(put("range.mesh", txt));
    EXPECT_FALSE(s.ok()) << tet;
    EXPECT_TRUE(mentions(s, "range.mesh")) << s.message;
  }
  // A listed triangle naming a vertex that does not exist.
  std::string txt = two_tets_medit();
  txt.replace(txt.find("End"), 3, "Triangles\n1\n1 2 7 3\nEnd");
  EXPECT_FALSE(read_err(put("tri.mesh", txt)).ok());
  // A tet repeating a vertex.
  txt = two_tets_medit();
  txt.replace(txt.find("2 4 3 5 1"), 9, "2 4 4 5 1");
  const Status s = read_err(put("rep.mesh", txt));
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "repeats")) << s.message;
}

// ----------------------------------------------------------- topology

TEST_F(Hostile, DuplicateTets) {
  std::string txt = two_tets_medit();
  txt.replace(txt.find("Tetrahedra\n2\n1 2 3 4 1\n"), 23, "Tetrahedra\n3\n1 2 3 4 1\n2 1 4 3 1\n");
  const Status s = read_err(put("dup.mesh", txt));
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code, ErrorCode::InvalidMesh);
  EXPECT_TRUE(mentions(s, "duplicate")) << s.message;
}

TEST_F(Hostile, FaceSharedByThreeTets) {
  std::string txt = std::string(kMeditHead) +
                    "Vertices\n6\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0.3 0.3 -1 0\n0.2 0.2 1.5 0\n"
                    "Tetrahedra\n3\n1 2 3 4 1\n1 3 2 5 1\n1 2 3 6 1\nEnd\n";
  const Status s = read_err(put("three.mesh", txt));
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code, ErrorCode::InvalidMesh);
  EXPECT_TRUE(mentions(s, "shared by 3")) << s.message;
}

TEST_F(Hostile, TwoDimensionalAndSurfaceOnly) {
  Status s = read_err(put("flat2d.mesh",
                          "MeshVersionFormatted 2\nDimension 2\nVertices\n3\n0 0 0\n1 0 0\n0 1 0\n"
                          "Triangles\n1\n1 2 3 0\nEnd\n"));
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "2-D") || mentions(s, "Dimension 2")) << s.message;
  s = read_err(put("surf.mesh", std::string(kMeditHead) +
                                    "Vertices\n3\n0 0 0 0\n1 0 0 0\n0 1 0 0\nTriangles\n1\n1 2 3 0\nEnd\n"));
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "no tetrahedra")) << s.message;
  s = read_err(put("surf.msh",
                   "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n"
                   "$Elements\n1\n1 2 2 1 1 1 2 3\n$EndElements\n"));
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "no tetrahedra")) << s.message;
  s = read_err(put("surf.vtk",
                   "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 double\n"
                   "0 0 0 1 0 0 0 1 0\nCELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n5\n"));
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(mentions(s, "tetra")) << s.message;
  // Through the CLI: input error, exit 2, nothing written.
  const std::string out = (dir_ / "never.mesh").string();
  EXPECT_EQ(run_cli("improve " + (dir_ / "flat2d.mesh").string() + " -o " + out), 2);
  EXPECT_EQ(run_cli("improve " + (dir_ / "surf.mesh").string() + " -o " + out), 2);
  EXPECT_FALSE(fs::exists(out));
}

// ------------------------------------------- kept: unreferenced, coincident

TEST_F(Hostile, UnreferencedVerticesSurviveImprove) {
  TetMesh box = make_box_mesh({.nx = 3, .ny = 3, .nz = 3, .jitter = 0.4, .seed = 3});
  const int32_t nv0 = box.nv();
  const double extra[] = {7.25, -1.0 / 3.0, 1e-300, 0.1, 0.2, 0.3};
  box.xyz.insert(box.xyz.end(), std::begin(extra), std::end(extra));
  box.vert_ref.insert(box.vert_ref.end(), {41, 42});
  const std::string in = (dir_ / "unref.mesh").string(), out = (dir_ / "unref_out.mesh").string();
  ASSERT_TRUE(write_mesh(in, box));
  TetMesh m;
  ASSERT_TRUE(read_mesh(in, m));
  ASSERT_TRUE(build_topology(m));
  ImproveReport rep;
  ASSERT_TRUE(improve(m, ImproveOptions{}, rep));
  ASSERT_TRUE(write_mesh(out, m));
  TetMesh back;
  ASSERT_TRUE(read_mesh(out, back));
  ASSERT_EQ(back.nv(), nv0 + 2);
  EXPECT_EQ(std::memcmp(back.point(nv0), extra, sizeof extra), 0);
  EXPECT_EQ(back.vert_ref[nv0], 41);
  EXPECT_EQ(back.vert_ref[nv0 + 1], 42);
  // The same through the CLI.
  EXPECT_EQ(run_cli("improve " + in + " -o " + (dir_ / "cli.mesh").string() + " -q"), 0);
  TetMesh cli;
  ASSERT_TRUE(read_mesh((dir_ / "cli.mesh").string(), cli));
  ASSERT_EQ(cli.nv(), nv0 + 2);
  EXPECT_EQ(std::memcmp(cli.point(nv0), extra, sizeof extra), 0);
}

// A listed triangle whose corners are interior vertices and which is no
// tet's face: its corners stay put (they moved once, and the triangle came
// back elsewhere while the run said "boundary unchanged").
TEST_F(Hostile, ListedTriangleThatIsNoFaceKeepsItsCorners) {
  TetMesh m = make_box_mesh({.nx = 4, .ny = 4, .nz = 4, .jitter = 0.4, .seed = 2});
  ASSERT_TRUE(build_topology(m));
  // Three interior vertices no tet holds together.
  std::vector<int32_t> interior;
  for (int32_t v = 0; v < m.nv(); ++v)
    if (!m.vert_constrained[v]) interior.push_back(v);
  ASSERT_GE(interior.size(), 8u);
  auto share_tet = [&](int32_t a, int32_t b) {
    for (const int32_t* t = m.star_begin(a); t != m.star_end(a); ++t)
      for (int k = 0; k < 4; ++k)
        if (m.tet(*t)[k] == b) return true;
    return false;
  };
  int32_t tri[3] = {interior.front(), -1, interior.back()};
  for (int32_t v : interior)
    if (v != tri[0] && v != tri[2] && !share_tet(v, tri[0]) && !share_tet(v, tri[2])) { tri[1] = v; break; }
  ASSERT_GE(tri[1], 0);
  ASSERT_FALSE(share_tet(tri[0], tri[2]));
  m.tris.insert(m.tris.end(), tri, tri + 3);
  m.tri_ref.push_back(77);
  ASSERT_TRUE(build_topology(m));
  for (int32_t v : tri) EXPECT_TRUE(m.vert_constrained[v]) << v;
  const TetMesh before = m;
  const InvariantSnapshot snap = capture_invariants(m);
  ImproveReport rep;
  ASSERT_TRUE(improve(m, ImproveOptions{}, rep));
  EXPECT_GT(rep.after.alpha_worst, rep.before.alpha_worst);
  for (int32_t v : tri) EXPECT_EQ(std::memcmp(m.point(v), before.point(v), 3 * sizeof(double)), 0) << v;
  EXPECT_EQ(m.tris, before.tris);
  EXPECT_EQ(m.tri_ref, before.tri_ref);
  EXPECT_TRUE(check_invariants(m, snap));
}

TEST_F(Hostile, CoincidentDistinctVerticesKept) {
  // A box and a second box touching it along x = 2 with its own copies of the
  // shared vertices: coincident but distinct vertices, two components.
  TetMesh a = make_box_mesh({.nx = 2, .ny = 2, .nz = 2, .jitter = 0.3, .seed = 4});
  TetMesh b = make_box_mesh({.nx = 2, .ny = 2, .nz = 2, .jitter = 0.3, .seed = 5});
  const int32_t off = a.nv();
  for (int32_t v = 0; v < b.nv(); ++v) b.point(v)[0] += 2.0;
  a.xyz.insert(a.xyz.end(), b.xyz.begin(), b.xyz.end());
  a.vert_ref.insert(a.vert_ref.end(), b.vert_ref.begin(), b.vert_ref.end());
  for (int32_t x : b.tets) a.tets.push_back(x + off);
  a.tet_ref.insert(a.tet_ref.end(), b.tet_ref.begin(), b.tet_ref.end());
  for (int32_t x : b.tris) a.tris.push_back(x + off);
  a.tri_ref.insert(a.tri_ref.end(), b.tri_ref.begin(), b.tri_ref.end());
  int coincident = 0;
  for (int32_t u = 0; u < off; ++u)
    for (int32_t v = off; v < a.nv(); ++v) coincident += std::memcmp(a.point(u), a.point(v), 24) == 0;
  ASSERT_GT(coincident, 0);
  const std::string in = (dir_ / "coinc.mesh").string();
  ASSERT_TRUE(write_mesh(in, a));
  TetMesh m;
  ASSERT_TRUE(read_mesh(in, m));
  ASSERT_TRUE(build_topology(m));
  const int32_t nv = m.nv();
  ImproveReport rep;
  ASSERT_TRUE(improve(m, ImproveOptions{}, rep));
  ASSERT_EQ(m.nv(), nv);
  int after = 0;
  for (int32_t u = 0; u < off; ++u)
    for (int32_t v = off; v < m.nv(); ++v) after += std::memcmp(m.point(u), m.point(v), 24) == 0;
  EXPECT_EQ(after, coincident);
  for (int32_t t = 0; t < m.nt(); ++t) {  // no tet joins the two components
    const int32_t* v = m.tet(t);
    const bool second = v[0] >= off;
    for (int k = 1; k < 4; ++k) EXPECT_EQ(v[k] >= off, second) << "tet " << t;
  }
}

TEST_F(Hostile, TireCoincidentPairsSurvive) {
  const fs::path dir = fs::path(TETOPT_SOURCE_DIR) / ".." / "shared" / "meshes" / "tire";
  fs::path file;
  if (fs::exists(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (format_from_path(e.path().string()) != Format::Unknown &&
          format_from_path(e.path().string()) != Format::TetGen)
        if (file.empty() || e.path().extension() == ".mesh") file = e.path();
  if (file.empty()) GTEST_SKIP() << "shared tire mesh not available";
  TetMesh m;
  ASSERT_TRUE(read_mesh(file.string(), m));
  ASSERT_TRUE(build_topology(m));
  auto pairs = [](const TetMesh& x) {
    std::vector<int32_t> id(x.nv());
    for (int32_t v = 0; v < x.nv(); ++v) id[v] = v;
    std::sort(id.begin(), id.end(), [&](int32_t a, int32_t b) {
      return std::lexicographical_compare(x.point(a), x.point(a) + 3, x.point(b), x.point(b) + 3);
    });
    std::vector<std::pair<int32_t, int32_t>> p;
    for (size_t i = 1; i < id.size(); ++i)
      if (std::memcmp(x.point(id[i - 1]), x.point(id[i]), 24) == 0)
        p.emplace_back(std::min(id[i - 1], id[i]), std::max(id[i - 1], id[i]));
    std::sort(p.begin(), p.end());
    return p;
  };
  const auto before = pairs(m);
  EXPECT_GE(before.size(), 10u);
  ImproveOptions o;
  o.iterations = 2;
  ImproveReport rep;
  ASSERT_TRUE(improve(m, o, rep));
  EXPECT_EQ(pairs(m), before);
}

// ------------------------------------------------ zero-volume and inverted

namespace {

// Box mesh whose free vertex nearest the centre is dragged by `d`.
TetMesh tangled_box(const double d[3], int32_t* moved = nullptr) {
  TetMesh m = make_box_mesh({.nx = 4, .ny = 4, .nz = 4, .jitter = 0.2, .seed = 9});
  EXPECT_TRUE(build_topology(m));
  int32_t best = -1;
  double bd = 1e300;
  for (int32_t v = 0; v < m.nv(); ++v) {
    if (m.vert_constrained[v]) continue;
    const double* p = m.point(v);
    const double q = (p[0] - 2) * (p[0] - 2) + (p[1] - 2) * (p[1] - 2) + (p[2] - 2) * (p[2] - 2);
    if (q < bd) { bd = q; best = v; }
  }
  for (int k = 0; k < 3; ++k) m.point(best)[k] += d[k];
  if (moved) *moved = best;
  return m;
}

}  // namespace

TEST(Untangle, RepairsAnInvertedInteriorVertexAndImproveAccepts) {
  const double d[3] = {1.3, 0.9, -1.1};
  TetMesh m = tangled_box(d);
  const InvariantSnapshot snap = capture_invariants(m);
  ASSERT_GT(snap.nonpositive, 0);
  const auto vol0 = region_volumes(m);
  std::vector<std::string> lines;
  UntangleStats st = untangle(m, [&](LogLevel, const std::string& s) { lines.push_back(s); });
  ASSERT_TRUE(st.status);
  EXPECT_EQ(st.nonpositive_before, snap.nonpositive);
  EXPECT_EQ(st.nonpositive_after, 0);
  EXPECT_TRUE(st.remaining.empty());
  EXPECT_GT(st.moves, 0);
  EXPECT_TRUE(nonpositive_tets(m).empty());
  ASSERT_FALSE(lines.empty());
  EXPECT_TRUE(validate(m)) << validate(m).message;
  EXPECT_TRUE(check_invariants(m, snap)) << check_invariants(m, snap).message;
  const auto vol1 = region_volumes(m);
  ASSERT_EQ(vol0.size(), vol1.size());
  EXPECT_NEAR(vol0[0].second, vol1[0].second, 1e-9 * std::fabs(vol0[0].second));
  // improve after untangling: ok, and the whole mesh stays positive.
  ImproveReport rep;
  ASSERT_TRUE(improve(m, ImproveOptions{}, rep));
  EXPECT_TRUE(validate(m));
  EXPECT_GT(rep.after.alpha_worst, 0);
}

TEST(Untangle, FlatTetIsRepaired) {
  // Put a free vertex exactly on the plane of an opposite face: a flat tet.
  TetMesh m = make_box_mesh({.nx = 3, .ny = 3, .nz = 3});
  ASSERT_TRUE(build_topology(m));
  int32_t v = -1;
  for (int32_t x = 0; x < m.nv() && v < 0; ++x)
    if (!m.vert_constrained[x]) v = x;
  ASSERT_GE(v, 0);
  const int32_t t = *m.star_begin(v);
  const int32_t* tv = m.tet(t);
  int k = 0;
  while (tv[k] != v) ++k;
  const double* a = m.point(tv[kFaceVertex[k][0]]);
  const double* b = m.point(tv[kFaceVertex[k][1]]);
  // Midpoint of an edge of the opposite face: exactly coplanar (grid values).
  for (int i = 0; i < 3; ++i) m.point(v)[i] = 0.5 * (a[i] + b[i]);
  const auto bad = nonpositive_tets(m);
  ASSERT_FALSE(bad.empty());
  const InvariantSnapshot snap = capture_invariants(m);
  UntangleStats st = untangle(m);
  EXPECT_EQ(st.nonpositive_after, 0);
  EXPECT_TRUE(check_invariants(m, snap));
  EXPECT_TRUE(validate(m));
}

TEST(Untangle, NeverMovesConstrainedAndReportsAllConstrained) {
  // Two tets on one face, the second folded over the first: all vertices lie
  // on the boundary, so nothing may move; the inverted tet is reported and
  // improve must neither fail the invariant nor touch anything.
  TetMesh m;
  m.xyz = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0.2, 0.2, 0.3, 1, 1, 1};
  m.tets = {0, 1, 2, 3, 0, 2, 1, 4, 1, 2, 3, 5};  // second: folded onto the first, negative
  m.tet_ref = {1, 1, 1};
  m.vert_ref.assign(6, 0);
  OrientationReport r = normalize_orientation(m);
  ASSERT_EQ(r.inverted.size(), 1u);
  ASSERT_TRUE(build_topology(m));
  const std::vector<double> xyz0 = m.xyz;
  UntangleStats st = untangle(m);
  ASSERT_EQ(st.remaining.size(), 1u);
  EXPECT_EQ(st.remaining[0].tet, r.inverted[0]);
  EXPECT_EQ(st.remaining[0].reason, UntangleReason::AllConstrained);
  EXPECT_STREQ(to_string(st.remaining[0].reason), "all four vertices constrained");
  EXPECT_EQ(std::memcmp(m.xyz.data(), xyz0.data(), xyz0.size() * 8), 0);
  ImproveReport rep;
  const Status s = improve(m, ImproveOptions{}, rep);
  EXPECT_TRUE(s) << s.message;
  // Topological operations may remove the fold (every new tet is positive
  // and the constrained faces stay), but no vertex moves and it never gets worse.
  EXPECT_LE(nonpositive_tets(m).size(), 1u);
  EXPECT_EQ(std::memcmp(m.xyz.data(), xyz0.data(), xyz0.size() * 8), 0);
}

TEST(Untangle, SingleFreeVertexAmongFixedIsRepaired) {
  // Every vertex but one is listed as required (constrained); the free one
  // is dragged so that tets invert.  Its old position was valid, so a
  // positive position exists and untangle must find it, moving nothing else;
  // reasons given for any remaining tet must be consistent.
  const double d[3] = {0.6, 0.7, 0.8};
  int32_t moved = -1;
  TetMesh m = tangled_box(d, &moved);
  for (int32_t v = 0; v < m.nv(); ++v)
    if (v != moved) m.required_vertices.push_back(v);
  ASSERT_TRUE(build_topology(m));
  ASSERT_FALSE(nonpositive_tets(m).empty());
  const InvariantSnapshot snap = capture_invariants(m);
  const std::vector<double> xyz0 = m.xyz;
  UntangleStats st = untangle(m);
  for (int32_t v = 0; v < m.nv(); ++v) {
    if (v != moved) {
      EXPECT_EQ(std::memcmp(m.point(v), &xyz0[3 * v], 24), 0) << v;
    }
  }
  EXPECT_TRUE(check_invariants(m, snap)) << check_invariants(m, snap).message;
  EXPECT_LE(st.nonpositive_after, st.nonpositive_before);
  for (const auto& r : st.remaining) {
    const int32_t* v = m.tet(r.tet);
    const bool all = m.vert_constrained[v[0]] && m.vert_constrained[v[1]] && m.vert_constrained[v[2]] &&
                     m.vert_constrained[v[3]];
    EXPECT_EQ(r.reason == UntangleReason::AllConstrained, all);
  }
  EXPECT_EQ(st.nonpositive_after, 0);
}

TEST(Untangle, HopelessTangleNeverWorsens) {
  // Two free vertices swapped: stars overlap heavily.  Whatever untangle
  // manages, the number of non-positive tets must not grow, no positive tet
  // may become non-positive, and the invariant check must accept the result.
  TetMesh m = make_box_mesh({.nx = 4, .ny = 4, .nz = 4, .jitter = 0.3, .seed = 2});
  ASSERT_TRUE(build_topology(m));
  std::vector<int32_t> freev;
  for (int32_t v = 0; v < m.nv(); ++v)
    if (!m.vert_constrained[v]) freev.push_back(v);
  ASSERT_GE(freev.size(), 4u);
  for (int k = 0; k < 3; ++k) std::swap(m.point(freev[0])[k], m.point(freev.back())[k]);
  const InvariantSnapshot snap = capture_invariants(m);
  ASSERT_GT(snap.nonpositive, 0);
  const auto bad0 = nonpositive_tets(m);
  UntangleStats st = untangle(m);
  EXPECT_LE(st.nonpositive_after, st.nonpositive_before);
  for (int32_t t : nonpositive_tets(m)) EXPECT_TRUE(std::binary_search(bad0.begin(), bad0.end(), t)) << t;
  EXPECT_TRUE(check_invariants(m, snap)) << check_invariants(m, snap).message;
  ImproveReport rep;
  const Status s = improve(m, ImproveOptions{}, rep);
  EXPECT_TRUE(s) << s.message;
  EXPECT_LE(static_cast<int64_t>(nonpositive_tets(m).size()), st.nonpositive_after);
}

TEST(Untangle, NeedsTopology) {
  TetMesh m = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  UntangleStats st = untangle(m);
  EXPECT_FALSE(st.status);
  EXPECT_EQ(st.status.code, ErrorCode::Invariant);
}

TEST(Untangle, DeterministicAcrossRuns) {
  const double d[3] = {1.1, -1.2, 0.7};
  TetMesh a = tangled_box(d), b = tangled_box(d);
  untangle(a);
  untangle(b);
  EXPECT_EQ(std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * 8), 0);
}

// ------------------------------------------------ the relaxed invariant

TEST(Invariants, TangledInputMayKeepItsTanglesButNotGrowThem) {
  const double d[3] = {1.3, 0.9, -1.1};
  int32_t moved = -1;
  TetMesh m = tangled_box(d, &moved);
  const InvariantSnapshot snap = capture_invariants(m);
  ASSERT_GT(snap.nonpositive, 0);
  EXPECT_TRUE(check_invariants(m, snap));  // unchanged tangled mesh passes
  // Inverting a tet elsewhere (a free vertex far from the tangle) fails.
  int32_t far = -1;
  for (int32_t v = 0; v < m.nv(); ++v)
    if (!m.vert_constrained[v] &&
        !std::binary_search(snap.tangled_vertices.begin(), snap.tangled_vertices.end(), v)) {
      far = v;
      break;
    }
  ASSERT_GE(far, 0);
  TetMesh w = m;
  w.point(far)[0] += 3.0;
  Status s = check_invariants(w, snap);
  EXPECT_FALSE(s);
  EXPECT_EQ(s.code, ErrorCode::Invariant);
  EXPECT_TRUE(mentions(s, "inverted or flat")) << s.message;
  // A positive mesh: any non-positive tet fails.
  TetMesh p = make_box_mesh({.nx = 2, .ny = 2, .nz = 2});
  ASSERT_TRUE(build_topology(p));
  const InvariantSnapshot ps = capture_invariants(p);
  EXPECT_EQ(ps.nonpositive, 0);
  int32_t v = 0;
  while (p.vert_constrained[v]) ++v;
  p.point(v)[2] += 5;
  EXPECT_FALSE(check_invariants(p, ps));
}

TEST(Invariants, CountOfTanglesMayNotGrowInsideTheTangle) {
  // Moving a tangled vertex further can invert more tets among the tangled
  // vertices only: condition (1) catches it when the count grows.
  const double d[3] = {0.9, 0.0, 0.0};
  int32_t moved = -1;
  TetMesh m = tangled_box(d, &moved);
  const InvariantSnapshot snap = capture_invariants(m);
  ASSERT_GT(snap.nonpositive, 0);
  // Drag back and forth until some position gives more non-positive tets
  // all within the tangled vertex set; such a configuration must fail.
  bool found = false;
  const std::vector<double> xyz0 = m.xyz;
  for (int i = 1; i <= 40 && !found; ++i) {
    m.xyz = xyz0;
    m.point(moved)[0] += 0.05 * i;
    const auto bad = nonpositive_tets(m);
    if (static_cast<int64_t>(bad.size()) <= snap.nonpositive) continue;
    found = true;
    EXPECT_FALSE(check_invariants(m, snap));
  }
  EXPECT_TRUE(found);
}

// ------------------------------------------------------------- exit codes

TEST_F(Hostile, CliExitCodes) {
  std::string help;
  {
    const std::string p = (dir_ / "help.txt").string();
    ASSERT_EQ(std::system((std::string(TETOPT_CLI) + " --help > " + p + " 2>&1").c_str()), 0);
    ASSERT_TRUE(read_file_bytes(p, help));
  }
  for (const char* line : {"0  success", "2  input error", "3  invariant failure", "130 interrupted"})
    EXPECT_NE(help.find(line), std::string::npos) << line;
  // Input error: 2, nothing written.
  const std::string out = (dir_ / "o.mesh").string();
  EXPECT_EQ(run_cli("improve " + put("trunc.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0") +
                    " -o " + out),
            2);
  EXPECT_FALSE(fs::exists(out));
  // Success: 0.
  const std::string gen = (dir_ / "g.mesh").string();
  ASSERT_EQ(run_cli("generate " + gen + " --cells 2 2 2 --jitter 0.3"), 0);
  EXPECT_EQ(run_cli("improve " + gen + " -o " + out + " -q"), 0);
  EXPECT_TRUE(fs::exists(out));
}

TEST_F(Hostile, CliTangledInputIsNotAnInvariantFailure) {
  // A tangled input must not exit 3 (invariant failure means a bug).
  const double d[3] = {1.3, 0.9, -1.1};
  TetMesh m = tangled_box(d);
  const std::string in = (dir_ / "tangled.mesh").string(), out = (dir_ / "tangled_out.mesh").string();
  ASSERT_TRUE(write_mesh(in, m));
  const int rc = run_cli("improve " + in + " -o " + out + " -q");
  EXPECT_EQ(rc, 0);
  if (rc == 0) {
    TetMesh back;
    ASSERT_TRUE(read_mesh(out, back));
    EXPECT_LE(nonpositive_tets(back).size(), nonpositive_tets(m).size());
  }
}

// ------------------------------------------------- fuzz findings replayed

namespace {

// What read_mesh does after a parse (fuzz/fuzz_common.hpp mirrors this).
bool finish_read(TetMesh& m, Format f) {
  m.source_format = static_cast<int>(f);
  if (m.vert_ref.empty()) m.vert_ref.assign(m.nv(), 0);
  if (m.tet_ref.empty()) m.tet_ref.assign(m.nt(), 0);
  if (m.tri_ref.size() < static_cast<size_t>(m.ntri())) m.tri_ref.resize(m.ntri(), 0);
  if (m.edge_ref.size() < m.edges.size() / 2) m.edge_ref.resize(m.edges.size() / 2, 0);
  if (!check_arrays(m, "replay")) return false;
  normalize_orientation(m);
  return true;
}

Status parse_as(Format f, std::string_view bytes, TetMesh& m) {
  switch (f) {
    case Format::Medit: return parse_medit(bytes, "replay", m);
    case Format::MeditBinary: return parse_meditb(bytes, "replay", m);
    case Format::Gmsh: return parse_gmsh(bytes, "replay", m);
    case Format::Vtk: return parse_vtk(bytes, "replay", m);
    case Format::Vtu: return parse_vtu(bytes, "replay", m);
    case Format::Abaqus: return parse_abaqus(bytes, "replay", m);
    case Format::Fluent: return parse_fluent(bytes, "replay", m);
    case Format::TetGen: {
      const size_t a = bytes.find('\0');
      if (a == std::string_view::npos) return Status::error(ErrorCode::Parse, "no NUL separator");
      const size_t b = bytes.find('\0', a + 1);
      const std::string_view node = bytes.substr(0, a);
      const std::string_view ele = bytes.substr(a + 1, b == std::string_view::npos ? std::string_view::npos : b - a - 1);
      const std::string_view face = b == std::string_view::npos ? std::string_view{} : bytes.substr(b + 1);
      return parse_tetgen(node, ele, face, "replay", m);
    }
    default: return Status::error(ErrorCode::Unsupported, "format");
  }
}

Status format_as(Format f, const TetMesh& m, std::string& out) {
  switch (f) {
    case Format::Medit: return format_medit(m, out);
    case Format::MeditBinary: return format_meditb(m, out, 3);
    case Format::Gmsh: return format_gmsh(m, out, 41, false);
    case Format::Vtk: return format_vtk(m, out, false);
    case Format::Vtu: return format_vtu(m, out);
    case Format::Abaqus: return format_abaqus(m, out);
    case Format::Fluent: return format_fluent(m, out, true);
    case Format::TetGen: {
      std::string node, ele, face;
      Status s = format_tetgen(m, node, ele, face);
      out = node + std::string(1, '\0') + ele + std::string(1, '\0') + face;
      return s;
    }
    default: return Status::error(ErrorCode::Unsupported, "format");
  }
}

void replay(Format f, const std::string& bytes, const std::string& what) {
  SCOPED_TRACE(what);
  TetMesh m;
  if (!parse_as(f, bytes, m)) return;  // a clean refusal is fine
  if (!finish_read(m, f)) return;
  {
    TetMesh t = m;
    const OrientationReport r = normalize_orientation(t);
    if (build_topology(t)) {
      EXPECT_TRUE(validate(t, ValidateLevel::Cheap));
      if (r.inverted.empty() && r.flat_tets.empty()) {
        EXPECT_TRUE(validate(t, ValidateLevel::Full));
      }
      EXPECT_TRUE(check_invariants(t, capture_invariants(t)));
    }
  }
  std::string out;
  ASSERT_TRUE(format_as(f, m, out));
  TetMesh back;
  ASSERT_TRUE(parse_as(f, out, back));
  ASSERT_TRUE(finish_read(back, f));
  ASSERT_EQ(m.xyz.size(), back.xyz.size());
  EXPECT_EQ(std::memcmp(m.xyz.data(), back.xyz.data(), m.xyz.size() * sizeof(double)), 0);
  EXPECT_EQ(m.tets, back.tets);
  EXPECT_EQ(m.tet_ref, back.tet_ref);
}

}  // namespace

TEST(Regression, FuzzFindingsReplay) {
  const fs::path root = fs::path(TETOPT_SOURCE_DIR) / "tests" / "regression";
  const std::pair<const char*, Format> dirs[] = {{"medit", Format::Medit}, {"meditb", Format::MeditBinary},
                                                 {"gmsh", Format::Gmsh},   {"vtk", Format::Vtk},
                                                 {"vtu", Format::Vtu},     {"tetgen", Format::TetGen},
                                                 {"abaqus", Format::Abaqus}, {"fluent", Format::Fluent}};
  int files = 0;
  for (const auto& [name, f] : dirs) {
    if (!fs::exists(root / name)) continue;
    for (const auto& e : fs::directory_iterator(root / name)) {
      std::string bytes;
      ASSERT_TRUE(read_file_bytes(e.path().string(), bytes));
      replay(f, bytes, e.path().string());
      ++files;
    }
  }
  EXPECT_GT(files, 0);
}

TEST(Regression, TetGenOrientationTieRoundTrip) {
  // Three positive and three negative tets: normalize_orientation keeps the
  // tie as is, and a TetGen write / re-read must give the same tets back.
  const std::string node = "8 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 1 1 0\n5 0 0 1\n6 1 3 4\n7 3 7 8\n8 1 1 10\n";
  const std::string ele = "6 4 0\n1 1 2 8 4\n2 1 2 6 8\n3 2 3 8 4\n4 1 3 7 8\n5 1 5 6 8\n6 1 5 8 7\n";
  replay(Format::TetGen, node + std::string(1, '\0') + ele, "tie");
  TetMesh m;
  ASSERT_TRUE(parse_tetgen(node, ele, "", "tie", m));
  ASSERT_TRUE(finish_read(m, Format::TetGen));
  const OrientationReport r = normalize_orientation(m);
  EXPECT_EQ(r.positive, r.negative);
}
