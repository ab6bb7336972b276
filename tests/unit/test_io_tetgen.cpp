// TetGen .node / .ele / .face reader and writer: round trips, orientation,
// .mesh -> TetGen -> .mesh identity, hostile input, house2 (when present).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cctype>
#include <cfloat>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"

using namespace tetopt;
namespace fs = std::filesystem;

namespace {

TetMesh tg_mesh(bool regions) {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 2, .nz = 2, .jitter = 0.35, .seed = 11, .regions = regions ? 2 : 1});
  for (double& x : m.xyz) x = x * 0.7 - 1.0 / 7.0;
  for (int32_t v = 0; v < m.nv(); ++v) m.vert_ref[v] = v % 3 == 0 ? 0 : v % 4 - 1;
  for (int32_t i = 0; i < m.ntri(); ++i) m.tri_ref[i] = i % 4;
  if (!regions) m.tet_ref.assign(m.nt(), 0);
  // An unused vertex with awkward values.
  m.xyz.insert(m.xyz.end(), {5e-324, -0.0, DBL_MAX});
  m.vert_ref.push_back(-9);
  return m;
}

fs::path temp_dir(const std::string& tag) {
  fs::path d = fs::temp_directory_path() / ("tetopt_tetgen_" + tag + "_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

std::string slurp(const fs::path& p) {
  std::string s;
  EXPECT_TRUE(read_file_bytes(p.string(), s).ok());
  return s;
}

int count_sign(const TetMesh& m, Sign want) {
  int n = 0;
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = m.tet(t);
    n += orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])) == want;
  }
  return n;
}

void expect_bits_equal(const std::vector<double>& a, const std::vector<double>& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(double)));
}

const char* kNode = "4 3 0 1\n1 0 0 0 5\n2 1 0 0 0\n3 0 1 0 0\n4 0 0 1 6\n";     // lines 1-5
const char* kEle = "1 4 1\n1 1 2 4 3 7\n";                                        // negative (as Stellar's files)
const char* kFace = "2 1\n1 1 2 3 3\n2 1 2 4 4\n";

void expect_tg_error(const std::string& node, const std::string& ele, const std::string& face, ErrorCode code,
                     const std::string& prefix, const std::string& phrase) {
  TetMesh m;
  const Status s = parse_tetgen(node, ele, face, "dir/t", m);
  ASSERT_FALSE(s.ok()) << "accepted";
  EXPECT_EQ(static_cast<int>(s.code), static_cast<int>(code)) << s.message;
  EXPECT_EQ(s.message.rfind(prefix, 0), 0u) << s.message;
  EXPECT_NE(s.message.find(phrase), std::string::npos) << s.message;
  EXPECT_EQ(s.message.find('\n'), std::string::npos) << s.message;
  const size_t colon = prefix.find(':');
  if (colon != std::string::npos && colon + 1 < prefix.size() && std::isdigit(static_cast<unsigned char>(prefix[colon + 1])))
    EXPECT_EQ(s.line, std::stol(prefix.substr(colon + 1))) << s.message;
  else
    EXPECT_EQ(s.line, 0) << s.message;
}

}  // namespace

TEST(IoTetgen, RoundTripKeepsCoordinatesRefsAndFaces) {
  for (bool regions : {false, true}) {
    SCOPED_TRACE(regions ? "regions" : "no regions");
    const TetMesh m = tg_mesh(regions);
    std::string node, ele, face;
    ASSERT_TRUE(format_tetgen(m, node, ele, face).ok());
    EXPECT_EQ(ele.substr(0, ele.find('\n')), std::to_string(m.nt()) + (regions ? " 4 1" : " 4 0"));
    TetMesh r;
    const Status s = parse_tetgen(node, ele, face, "rt", r);
    ASSERT_TRUE(s.ok()) << s.message;
    expect_bits_equal(m.xyz, r.xyz);
    EXPECT_EQ(r.vert_ref, m.vert_ref);
    EXPECT_EQ(r.tris, m.tris);
    EXPECT_EQ(r.tri_ref, m.tri_ref);
    EXPECT_EQ(r.tet_ref, m.tet_ref);
    // The file holds positive tets, as TetGen 1.5 writes them: ours, unchanged.
    ASSERT_EQ(r.tets.size(), m.tets.size());
    EXPECT_EQ(count_sign(r, Sign::Positive), r.nt());
    EXPECT_EQ(r.tets, m.tets);
  }
}

TEST(IoTetgen, WrittenEleReadsBackAsTheSamePositiveTets) {
  const fs::path d = temp_dir("orient");
  const TetMesh m = tg_mesh(true);
  const std::string ele = (d / "o.ele").string();
  ASSERT_TRUE(write_mesh(ele, m).ok());
  EXPECT_TRUE(fs::exists(d / "o.node"));
  EXPECT_TRUE(fs::exists(d / "o.face"));
  TetMesh r;
  OrientationReport rep;
  const Status s = read_mesh(ele, r, &rep);
  ASSERT_TRUE(s.ok()) << s.message;
  EXPECT_FALSE(rep.flipped);  // written positive, as TetGen 1.5 writes
  EXPECT_FALSE(r.flipped_on_read);
  EXPECT_TRUE(rep.inverted.empty());
  EXPECT_EQ(count_sign(r, Sign::Positive), r.nt());
  EXPECT_EQ(r.tets, m.tets);
  // Written again as TetGen: byte-identical files (the convention survives).
  const std::string again = (d / "p.node").string();
  ASSERT_TRUE(write_mesh(again, r).ok());
  EXPECT_EQ(slurp(d / "o.node"), slurp(d / "p.node"));
  EXPECT_EQ(slurp(d / "o.ele"), slurp(d / "p.ele"));
  EXPECT_EQ(slurp(d / "o.face"), slurp(d / "p.face"));
  fs::remove_all(d);
}

TEST(IoTetgen, MeshToTetgenToMeshIsBitIdentical) {
  const fs::path d = temp_dir("mtm");
  TetMesh m = tg_mesh(true);
  const std::string a = (d / "a.mesh").string(), b = (d / "b.mesh").string(), tg = (d / "t.node").string();
  ASSERT_TRUE(write_mesh(a, m).ok());
  TetMesh first;
  ASSERT_TRUE(read_mesh(a, first).ok());
  ASSERT_TRUE(write_mesh(tg, first).ok());
  TetMesh second;
  const Status s = read_mesh(tg, second);
  ASSERT_TRUE(s.ok()) << s.message;
  expect_bits_equal(first.xyz, second.xyz);
  EXPECT_EQ(first.tets, second.tets);
  EXPECT_EQ(first.tet_ref, second.tet_ref);
  EXPECT_EQ(first.vert_ref, second.vert_ref);
  EXPECT_EQ(first.tris, second.tris);
  EXPECT_EQ(first.tri_ref, second.tri_ref);
  ASSERT_TRUE(write_mesh(b, second).ok());
  EXPECT_EQ(slurp(a), slurp(b));
  fs::remove_all(d);
}

TEST(IoTetgen, ZeroBasedCommentsAttributesAndShortLines) {
  const std::string node =
      "# header follows\n"
      "5 3 2 1  # two attributes, one marker\n"
      "0 0 0 0  0.5 7  3\n"
      "1 1 0 0  1 1\n"          // marker missing: 0, like TetGen
      "2 0 1 0  1 1 -4 extra\n"  // extra column ignored
      "\n"
      "3 0 0 1  1 1 2\n"
      "4 1 1 1  1 1 9\n";
  const std::string ele = "2 4 2\n0 0 1 3 2 -3 99\n1 1 2 3 4\n";  // 2nd tet: no attributes -> region 0
  const std::string face = "1\n0 0 1 2\n";                          // no marker column
  TetMesh m;
  const Status s = parse_tetgen(node, ele, face, "z", m);
  ASSERT_TRUE(s.ok()) << s.message;
  EXPECT_EQ(m.nv(), 5);
  EXPECT_EQ(m.vert_ref, (std::vector<int32_t>{3, 0, -4, 2, 9}));
  EXPECT_EQ(m.tets, (std::vector<int32_t>{0, 1, 3, 2, 1, 2, 3, 4}));
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{-3, 0}));
  EXPECT_EQ(m.tris, (std::vector<int32_t>{0, 1, 2}));
  EXPECT_EQ(m.tri_ref, (std::vector<int32_t>{0}));
  // Region attributes written as reals by other tools.
  TetMesh r;
  ASSERT_TRUE(parse_tetgen(node, "1 4 1\n0 0 1 3 2 2.0\n", "", "z", r).ok());
  EXPECT_EQ(r.tet_ref, (std::vector<int32_t>{2}));
  EXPECT_TRUE(r.tris.empty());
}

TEST(IoTetgen, HostileInput) {
  const std::string node = kNode, ele = kEle, face = kFace;
  {
    TetMesh m;
    const Status s = parse_tetgen(node, ele, face, "dir/t", m);
    ASSERT_TRUE(s.ok()) << s.message;
    EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{7}));
    EXPECT_EQ(m.vert_ref, (std::vector<int32_t>{5, 0, 0, 6}));
  }
  // Truncated files / lying counts.
  // (a short lie is caught by the byte bound, a padded one when the data runs out)
  expect_tg_error(node.substr(0, node.find("3 0 1 0")), ele, face, ErrorCode::Parse, "dir/t.node:1:",
                  "4 points claimed, more than the rest of the file can hold (2 at most)");
  expect_tg_error(node.substr(0, node.find("3 0 1 0")) + "# padding padding padding padding padding\n", ele, face,
                  ErrorCode::Parse, "dir/t.node:4:", "claims 4 points but the file ends after 2");
  expect_tg_error(node, "2 4 1\n1 1 2 4 3 7\n", face, ErrorCode::Parse, "dir/t.ele:1:", "more than the rest");
  expect_tg_error(node, "2 4 1\n1 1 2 4 3 7      # padding padding\n", face, ErrorCode::Parse, "dir/t.ele:2:",
                  "truncated");
  expect_tg_error(node, ele, "3 1\n1 1 2 3 3                                   \n", ErrorCode::Parse, "dir/t.face:2:",
                  "claims 3 faces");
  expect_tg_error(node.substr(0, node.size() - 5), ele, face, ErrorCode::Parse, "dir/t.node:5:", "fewer than 3 coordinates");
  expect_tg_error(node, "1 4 1\n1 1 2 4            \n", face, ErrorCode::Parse, "dir/t.ele:2:", "fewer than 4 vertices");
  // Counts smaller than the data: the records past them would be dropped.
  expect_tg_error(node, "1 4 1\n1 1 2 4 3 7\n# a comment\n2 1 2 4 3 7\n", face, ErrorCode::Parse, "dir/t.ele:4:",
                  "a record after the 1 tetrahedra the header claims");
  expect_tg_error("3" + node.substr(1), ele, face, ErrorCode::Parse, "dir/t.node:5:",
                  "a record after the 3 points the header claims");
  expect_tg_error(node, ele, "1 1\n1 1 2 3 3\n2 1 2 4 4\n", ErrorCode::Parse, "dir/t.face:3:",
                  "a record after the 1 faces");
  {  // comments and blank lines after the records are fine
    TetMesh m;
    EXPECT_TRUE(parse_tetgen(node + "\n# tail\n\n", ele + "# Generated by tetgen\n", face + "\n", "dir/t", m).ok());
  }
  // Absurd counts: no allocation.
  expect_tg_error("1000000000000000 3 0 1\n1 0 0 0 0\n", ele, face, ErrorCode::Parse, "dir/t.node:1:",
                  "more than the rest of the file can hold");
  expect_tg_error(node, "4000000000 4 0\n1 1 2 3 4\n", face, ErrorCode::Parse, "dir/t.ele:1:", "more than the rest");
  expect_tg_error(node, ele, "-1 0\n", ErrorCode::Parse, "dir/t.face:1:", "negative");
  // NaN / Inf / overflow.
  {
    std::string n = node;
    n.replace(n.find("2 1 0 0"), 7, "2 nan 0 0");
    expect_tg_error(n, ele, face, ErrorCode::InvalidMesh, "dir/t.node:3:", "non-finite");
    n = node;
    n.replace(n.find("3 0 1 0"), 7, "3 0 inf 0");
    expect_tg_error(n, ele, face, ErrorCode::InvalidMesh, "dir/t.node:4:", "non-finite");
    n = node;
    n.replace(n.find("3 0 1 0"), 7, "3 0 1e400 0");
    expect_tg_error(n, ele, face, ErrorCode::Parse, "dir/t.node:4:", "found '1e400'");
  }
  // Index out of range, zero (1-based file), negative.
  expect_tg_error(node, "1 4 0\n1 1 2 4 5\n", face, ErrorCode::InvalidMesh, "dir/t.ele:2:", "vertex id 5 out of range 1..4");
  expect_tg_error(node, "1 4 0\n1 0 2 4 3\n", face, ErrorCode::InvalidMesh, "dir/t.ele:2:", "vertex id 0 out of range 1..4");
  expect_tg_error(node, "1 4 0\n1 -1 2 4 3\n", face, ErrorCode::InvalidMesh, "dir/t.ele:2:", "vertex id -1");
  expect_tg_error(node, ele, "1 1\n1 1 2 9 0\n", ErrorCode::InvalidMesh, "dir/t.face:2:", "vertex id 9 out of range");
  // Non-numeric tokens.
  expect_tg_error(node, "1 4 0\n1 1 two 4 3\n", face, ErrorCode::Parse, "dir/t.ele:2:", "found 'two'");
  expect_tg_error("four 3 0 0\n", ele, face, ErrorCode::Parse, "dir/t.node:1:", "found 'four'");
  expect_tg_error(node, "1 4 1\n1 1 2 4 3 1.5\n", face, ErrorCode::Unsupported, "dir/t.ele:2:", "not a 32-bit integer");
  {
    std::string n = node;
    n.replace(n.find("4 0 0 1 6"), 9, "4 0 0 1 x6");
    expect_tg_error(n, ele, face, ErrorCode::Parse, "dir/t.node:5:", "boundary marker");
  }
  // Wrong / missing dimension, numbering.
  expect_tg_error("4 2 0 0\n1 0 0\n2 1 0\n3 0 1\n4 1 1\n", ele, face, ErrorCode::Unsupported, "dir/t.node:1:", "2-D mesh");
  expect_tg_error("4 5 0 0\n", ele, face, ErrorCode::Parse, "dir/t.node:1:", "expected 3");
  expect_tg_error("4 3 0 0\n2 0 0 0\n3 1 0 0\n4 0 1 0\n5 0 0 1\n", ele, face, ErrorCode::Parse, "dir/t.node:2:",
                  "must be 0 or 1");
  expect_tg_error("4 3 0 0\n1 0 0 0\n2 1 0 0\n4 0 1 0\n5 0 0 1\n", ele, face, ErrorCode::Parse, "dir/t.node:4:",
                  "consecutive");
  expect_tg_error("", ele, face, ErrorCode::Parse, "dir/t.node: ", "empty file");
  expect_tg_error("0 3 0 0\n", ele, face, ErrorCode::Unsupported, "dir/t.node:1:", "no points");
  // No tets, second-order tets.
  expect_tg_error(node, "0 4 0\n", face, ErrorCode::InvalidMesh, "dir/t.ele:1:", "no tetrahedra");
  expect_tg_error(node, "", face, ErrorCode::Parse, "dir/t.ele: ", "empty file");
  expect_tg_error(node, "1 10 0\n1 1 2 3 4 5 6 7 8 9 10\n", face, ErrorCode::Unsupported, "dir/t.ele:1:", "second-order");
}

TEST(IoTetgen, WriteIsAllThreeFilesOrNone) {
  // A .face that cannot be written (a folder of that name) fails the write
  // before .node and .ele are in place: no file of the set, no temporary.
  const fs::path d = temp_dir("atomic");
  fs::create_directories(d / "x.face");
  const TetMesh m = tg_mesh(true);
  const Status s = write_mesh((d / "x.node").string(), m);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message.find("x.face"), std::string::npos) << s.message;
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(d)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"x.face"});
  // The old set stays whole when the new one cannot be written.
  fs::remove_all(d / "x.face");
  ASSERT_TRUE(write_mesh((d / "x.node").string(), m).ok());
  const std::string node = slurp(d / "x.node"), ele = slurp(d / "x.ele");
  fs::remove(d / "x.face");
  fs::create_directories(d / "x.face");
  EXPECT_FALSE(write_mesh((d / "x.ele").string(), m).ok());
  EXPECT_EQ(slurp(d / "x.node"), node);
  EXPECT_EQ(slurp(d / "x.ele"), ele);
  fs::remove_all(d);
}

TEST(IoTetgen, ReadMeshErrorsNameTheFile) {
  const fs::path d = temp_dir("err");
  ASSERT_TRUE(write_file_atomic((d / "e.node").string(), kNode).ok());
  ASSERT_TRUE(write_file_atomic((d / "e.ele").string(), "1 4 0\n1 1 2 4 9\n").ok());
  TetMesh m;
  const Status s = read_mesh((d / "e.ele").string(), m);
  EXPECT_EQ(s.code, ErrorCode::InvalidMesh);
  EXPECT_EQ(s.message.rfind((d / "e.ele:2: ").string(), 0), 0u) << s.message;
  fs::remove_all(d);
}

TEST(IoTetgenReal, House2) {
  std::string dir;
  for (const std::string& c : {std::string("/work/shared/meshes"), std::string(TETOPT_SOURCE_DIR "/../shared/meshes")})
    if (fs::is_directory(c)) {
      dir = c;
      break;
    }
  if (dir.empty() || !fs::exists(dir + "/house2/house2.node")) GTEST_SKIP() << "no shared meshes";
  TetMesh m;
  OrientationReport rep;
  const Status s = read_mesh(dir + "/house2/house2.node", m, &rep);
  ASSERT_TRUE(s.ok()) << s.message;
  EXPECT_EQ(m.nv(), 400);
  EXPECT_EQ(m.nt(), 1389);
  EXPECT_TRUE(rep.flipped);  // Stellar's negative orientation
  EXPECT_TRUE(rep.inverted.empty());
  EXPECT_TRUE(rep.flat_tets.empty());
  EXPECT_EQ(count_sign(m, Sign::Positive), m.nt());
  int marked = 0;
  for (int32_t r : m.vert_ref) marked += r != 0;
  EXPECT_GT(marked, 0);  // the boundary-marker column became vert_ref
  EXPECT_LT(marked, m.nv());
  // TetGen -> TetGen keeps the coordinates bit for bit.
  std::string node, ele, face;
  ASSERT_TRUE(format_tetgen(m, node, ele, face).ok());
  TetMesh r;
  ASSERT_TRUE(parse_tetgen(node, ele, face, "h", r).ok());
  expect_bits_equal(m.xyz, r.xyz);
}
