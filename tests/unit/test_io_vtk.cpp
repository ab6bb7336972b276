// VTK legacy (.vtk) and XML (.vtu) readers and writers: round trips of every
// variant, the 5.x legacy layout, appended and compressed VTU, hostile
// input, meshio cross-checks and the shared real meshes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <sys/resource.h>
#include <unistd.h>
#include <zlib.h>

#include "io/scan_gmsh_vtk.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"
#include "tetopt/predicates.hpp"

using namespace tetopt;
namespace fs = std::filesystem;

namespace {

TetMesh sample_mesh() {
  TetMesh m = make_box_mesh({.nx = 3, .ny = 2, .nz = 2, .jitter = 0.3, .seed = 7, .regions = 2});
  for (size_t i = 0; i < m.tri_ref.size(); ++i) m.tri_ref[i] = 100 + static_cast<int32_t>(i % 3);
  // Negative refs and the int32 extremes (binary Int32 was once read unsigned).
  m.tet_ref[0] = -1;
  m.tet_ref[1] = INT32_MIN;
  m.tri_ref[0] = INT32_MAX;
  m.edges = {0, 1, 1, 2, 4, 5};
  m.edge_ref = {5, -7, 6};
  m.corners = {0, 3};
  m.xyz[0] = 0.1 + 1e-17;
  m.xyz[3] = std::nextafter(1.0, 2.0);  // vertex 1 is (1, 0, 0)
  const size_t nv = static_cast<size_t>(m.nv());
  TetMesh::PointField fixed{"fixed", 1, true, {}}, disp{"disp", 3, false, {}}, big{"six", 6, false, {}};
  for (size_t v = 0; v < nv; ++v) {
    fixed.values.push_back(static_cast<double>(v % 2));
    for (int k = 0; k < 3; ++k) disp.values.push_back(std::sqrt(static_cast<double>(v + k)) / 3.0);
    for (int k = 0; k < 6; ++k) big.values.push_back(-1.0 / static_cast<double>(v + k + 1));
  }
  m.point_fields = {fixed, disp, big};
  return m;
}

void expect_same(const TetMesh& a, const TetMesh& b) {
  ASSERT_EQ(a.xyz.size(), b.xyz.size());
  EXPECT_EQ(0, std::memcmp(a.xyz.data(), b.xyz.data(), a.xyz.size() * sizeof(double))) << "coordinates differ";
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.tet_ref, b.tet_ref);
  EXPECT_EQ(a.tris, b.tris);
  EXPECT_EQ(a.tri_ref, b.tri_ref);
  EXPECT_EQ(a.edges, b.edges);
  EXPECT_EQ(a.edge_ref, b.edge_ref);
  EXPECT_EQ(a.corners, b.corners);
  ASSERT_EQ(a.point_fields.size(), b.point_fields.size());
  for (size_t i = 0; i < a.point_fields.size(); ++i) {
    EXPECT_EQ(a.point_fields[i].name, b.point_fields[i].name);
    EXPECT_EQ(a.point_fields[i].components, b.point_fields[i].components);
    EXPECT_EQ(a.point_fields[i].integer, b.point_fields[i].integer);
    ASSERT_EQ(a.point_fields[i].values.size(), b.point_fields[i].values.size());
    EXPECT_EQ(0, std::memcmp(a.point_fields[i].values.data(), b.point_fields[i].values.data(),
                             a.point_fields[i].values.size() * sizeof(double)))
        << a.point_fields[i].name;
  }
}

enum class Kind { VtkAscii, VtkBinary, VtuBinary, VtuAscii };
const char* kind_name(Kind k) {
  switch (k) {
    case Kind::VtkAscii: return "vtk ascii";
    case Kind::VtkBinary: return "vtk binary";
    case Kind::VtuBinary: return "vtu binary";
    default: return "vtu ascii";
  }
}
constexpr Kind kKinds[] = {Kind::VtkAscii, Kind::VtkBinary, Kind::VtuBinary, Kind::VtuAscii};

Status format_kind(const TetMesh& m, std::string& out, Kind k) {
  switch (k) {
    case Kind::VtkAscii: return format_vtk(m, out, false);
    case Kind::VtkBinary: return format_vtk(m, out, true);
    case Kind::VtuBinary: return format_vtu(m, out);
    default: return detail::format_vtu_encoded(m, out, false);
  }
}
Status parse_kind(const std::string& in, TetMesh& m, Kind k) {
  return (k == Kind::VtkAscii || k == Kind::VtkBinary) ? parse_vtk(in, "t.vtk", m) : parse_vtu(in, "t.vtu", m);
}

std::string tmp_dir() {
  const fs::path p = fs::temp_directory_path() / ("tetopt_vtk_" + std::to_string(::getpid()));
  fs::create_directories(p);
  return p.string();
}
bool have_meshio() { return std::system("/usr/bin/python3 -c 'import meshio' >/dev/null 2>&1") == 0; }
std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
std::string shared_meshes() {
  for (const std::string& p : {std::string(TETOPT_SOURCE_DIR) + "/../shared/meshes", std::string("/work/shared/meshes")})
    if (fs::is_directory(p)) return p;
  return {};
}

}  // namespace

// ------------------------------------------------------------ round trips

TEST(IoVtk, RoundTripEveryVariant) {
  const TetMesh m = sample_mesh();
  for (Kind k : kKinds) {
    SCOPED_TRACE(kind_name(k));
    std::string out;
    ASSERT_TRUE(format_kind(m, out, k));
    TetMesh r;
    const Status s = parse_kind(out, r, k);
    ASSERT_TRUE(s) << s.message;
    expect_same(m, r);
    std::string again;
    ASSERT_TRUE(format_kind(r, again, k));
    EXPECT_EQ(out, again);
  }
}

TEST(IoVtk, VtuNamesWithXmlSpecialCharactersRoundTrip) {
  // The writer escapes '<', '>', '&' and '"' in Name="..."; the reader took
  // the escaped text as the name, so "T<1&x" became "T&lt;1&amp;x" and grew
  // on every .vtu -> .vtu conversion.
  TetMesh m = sample_mesh();
  ASSERT_FALSE(m.point_fields.empty());
  m.point_fields[0].name = "T<1&x>\"q\"";
  for (Kind k : {Kind::VtuBinary, Kind::VtuAscii}) {
    SCOPED_TRACE(kind_name(k));
    std::string out, again;
    ASSERT_TRUE(format_kind(m, out, k));
    TetMesh r;
    ASSERT_TRUE(parse_kind(out, r, k));
    ASSERT_FALSE(r.point_fields.empty());
    EXPECT_EQ(r.point_fields[0].name, m.point_fields[0].name);
    ASSERT_TRUE(format_kind(r, again, k));
    EXPECT_EQ(out, again);
  }
  // Character references and &apos; are decoded too; an unknown or broken
  // reference stays as written.
  std::string out;
  ASSERT_TRUE(format_kind(m, out, Kind::VtuAscii));
  const std::string escaped = "T&lt;1&amp;x&gt;&quot;q&quot;";
  const size_t at = out.find(escaped);
  ASSERT_NE(at, std::string::npos);
  out.replace(at, escaped.size(), "&#65;&#x42;&apos;&#xE9;&#x1F600;&bogus;&#xD800;&;end&");
  TetMesh r;
  ASSERT_TRUE(parse_kind(out, r, Kind::VtuAscii));
  EXPECT_EQ(r.point_fields[0].name, "AB'\xC3\xA9\xF0\x9F\x98\x80&bogus;&#xD800;&;end&");
}

TEST(IoVtk, WriteReadThroughFilesIsPositive) {
  const std::string dir = tmp_dir();
  const TetMesh m = sample_mesh();
  for (const auto& [ext, bin] : {std::pair{".vtk", false}, std::pair{".vtk", true}, std::pair{".vtu", false}}) {
    const std::string path = dir + "/f" + (bin ? "b" : "a") + ext;
    ASSERT_TRUE(write_mesh(path, m, {.binary = bin}));
    TetMesh r;
    OrientationReport rep;
    const Status s = read_mesh(path, r, &rep);
    ASSERT_TRUE(s) << s.message;
    EXPECT_EQ(rep.negative, 0);
    EXPECT_EQ(r.tet_ref, m.tet_ref);
    for (int32_t t = 0; t < r.nt(); ++t) {
      const int32_t* q = r.tet(t);
      ASSERT_EQ(orient3d(r.point(q[0]), r.point(q[1]), r.point(q[2]), r.point(q[3])), Sign::Positive);
    }
  }
  fs::remove_all(dir);
}

TEST(IoVtk, Legacy51OffsetsConnectivityAndFieldData) {
  TetMesh m;
  const std::string path = std::string(TETOPT_SOURCE_DIR) + "/tests/data/vtk/two_tets_51.vtk";
  std::string bytes;
  ASSERT_TRUE(read_file_bytes(path, bytes));
  const Status s = parse_vtk(bytes, "two_tets_51.vtk", m);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(m.nv(), 5);
  EXPECT_EQ(m.tets, (std::vector<int32_t>{0, 1, 2, 3, 1, 2, 3, 4}));
  EXPECT_EQ(m.tris, (std::vector<int32_t>{0, 1, 2}));
  EXPECT_EQ(m.edges, (std::vector<int32_t>{0, 4}));
  // GLOBAL_ID is an id numbering, not a region: MaterialIds wins.
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{7, 8}));
  EXPECT_EQ(m.tri_ref, (std::vector<int32_t>{9}));
  EXPECT_EQ(m.edge_ref, (std::vector<int32_t>{10}));
  ASSERT_EQ(m.point_fields.size(), 2u);
  EXPECT_EQ(m.point_fields[0].name, "fixed");
  EXPECT_TRUE(m.point_fields[0].integer);
  EXPECT_EQ(m.point_fields[1].name, "velocity");
  EXPECT_EQ(m.point_fields[1].components, 3);
  EXPECT_EQ(m.point_fields[1].values[12], 0.5);
}

TEST(IoVtk, RefArrayChoice) {
  const std::string head =
      "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
      "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nCELL_DATA 1\n";
  TetMesh m;
  ASSERT_TRUE(parse_vtk(head + "SCALARS GLOBAL_ID int 1\nLOOKUP_TABLE default\n5\n", "t.vtk", m));
  EXPECT_TRUE(m.tet_ref.empty());  // read_mesh fills 0
  ASSERT_TRUE(parse_vtk(head + "SCALARS q int\nLOOKUP_TABLE default\n5\nSCALARS region int 1\nLOOKUP_TABLE default\n6\n",
                        "t.vtk", m));
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{6}));
  ASSERT_TRUE(parse_vtk(head + "SCALARS w float\nLOOKUP_TABLE default\n0.5\nSCALARS q int\nLOOKUP_TABLE default\n5\n",
                        "t.vtk", m));
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{5}));
  // A ref array with a value no ref can be is an error, not refs of 0.
  for (const char* bad : {"7.5", "1e10", "-3000000000"}) {
    const Status s = parse_vtk(head + "SCALARS ref float 1\nLOOKUP_TABLE default\n" + bad + "\n", "t.vtk", m);
    ASSERT_FALSE(s) << bad;
    EXPECT_NE(s.message.find("cell array ref holds"), std::string::npos) << s.message;
    EXPECT_NE(s.message.find("at cell 0"), std::string::npos) << s.message;
  }
  EXPECT_FALSE(parse_vtk(head + "SCALARS gmsh:geometrical double 1\nLOOKUP_TABLE default\n2.25\n", "t.vtk", m));
  // A FIELD ref array of the wrong length is an error too; another FIELD
  // array of another length is field data and is skipped.
  {
    const Status s = parse_vtk(head + "FIELD FieldData 1\nref 1 2 int\n3 4\n", "t.vtk", m);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message.find("cell field array ref has 2 values for 1 cells"), std::string::npos) << s.message;
  }
  ASSERT_TRUE(parse_vtk(head + "FIELD FieldData 2\nTimeValue 1 2 double\n0.5 1\nref 1 1 int\n9\n", "t.vtk", m));
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{9}));
  // A float ref array holding whole numbers is read.
  ASSERT_TRUE(parse_vtk(head + "SCALARS MaterialIds double 1\nLOOKUP_TABLE default\n-4\n", "t.vtk", m));
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{-4}));
}

namespace {
/// A one-tet VTU with appended data (raw or base64), optionally with a
/// UInt32 header and a BigEndian byte order.
std::string appended_vtu(bool base64, bool header64, bool big) {
  struct Arr {
    const char* name;
    const char* type;
    int comps;
    std::string bytes;
  };
  std::vector<Arr> arrs;
  std::string b;
  for (double x : {0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.}) gvscan::store<double>(b, x, big);
  arrs.push_back({"Points", "Float64", 3, b});
  b.clear();
  for (int32_t x : {0, 1, 2, 3}) gvscan::store<int32_t>(b, x, big);
  arrs.push_back({"connectivity", "Int32", 1, b});
  b.clear();
  gvscan::store<int64_t>(b, 4, big);
  arrs.push_back({"offsets", "Int64", 1, b});
  arrs.push_back({"types", "UInt8", 1, std::string(1, '\x0a')});
  b.clear();
  gvscan::store<int16_t>(b, 42, big);
  arrs.push_back({"CellEntityIds", "Int16", 1, b});
  std::string data, xml_arrays[5];
  for (size_t i = 0; i < arrs.size(); ++i) {
    std::string chunk;
    if (header64) gvscan::store<uint64_t>(chunk, arrs[i].bytes.size(), big);
    else gvscan::store<uint32_t>(chunk, static_cast<uint32_t>(arrs[i].bytes.size()), big);
    chunk += arrs[i].bytes;
    if (base64) {
      std::string enc;
      gvscan::base64_encode(enc, reinterpret_cast<const unsigned char*>(chunk.data()), chunk.size());
      chunk = enc;
    }
    xml_arrays[i] = std::string("<DataArray type=\"") + arrs[i].type + "\" Name=\"" + arrs[i].name +
                    "\" NumberOfComponents=\"" + std::to_string(arrs[i].comps) +
                    "\" format=\"appended\" offset=\"" + std::to_string(data.size()) + "\"/>\n";
    data += chunk;
  }
  std::string s = std::string("<?xml version=\"1.0\"?>\n<!-- hand-made -->\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"") +
                  (big ? "BigEndian" : "LittleEndian") + "\" header_type=\"" + (header64 ? "UInt64" : "UInt32") +
                  "\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n"
                  "<CellData>" + xml_arrays[4] + "</CellData>\n<Points>" + xml_arrays[0] +
                  "</Points>\n<Cells>" + xml_arrays[1] + xml_arrays[2] + xml_arrays[3] +
                  "</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"" + (base64 ? "base64" : "raw") +
                  "\">\n   _" + data + "\n</AppendedData>\n</VTKFile>\n";
  return s;
}
}  // namespace

TEST(IoVtk, VtuAppendedRawAndBase64) {
  for (bool b64 : {false, true})
    for (bool h64 : {false, true})
      for (bool big : {false, true}) {
        SCOPED_TRACE(std::to_string(b64) + std::to_string(h64) + std::to_string(big));
        TetMesh m;
        const Status s = parse_vtu(appended_vtu(b64, h64, big), "a.vtu", m);
        ASSERT_TRUE(s) << s.message;
        EXPECT_EQ(m.tets, (std::vector<int32_t>{0, 1, 2, 3}));
        EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{42}));
        EXPECT_EQ(m.point(3)[2], 1.0);
      }
}

// ------------------------------------------------------------ hostile input

namespace {
const std::string kVtkHead = "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\n";
const std::string kPts = "POINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n";  // lines 5..9
const std::string kCells = "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n";     // lines 10..13

void expect_error(const std::string& text, ErrorCode code, long line, const std::string& needle, bool vtu = false) {
  TetMesh m;
  const std::string name = vtu ? "t.vtu" : "t.vtk";
  const Status s = vtu ? parse_vtu(text, name, m) : parse_vtk(text, name, m);
  ASSERT_FALSE(s) << "accepted: " << text.substr(0, 200);
  EXPECT_EQ(s.code, code) << s.message;
  if (line > 0) {
    EXPECT_EQ(s.line, line) << s.message;
    EXPECT_EQ(s.message.rfind(name + ":" + std::to_string(line) + ": ", 0), 0u) << s.message;
  }
  EXPECT_NE(s.message.find(needle), std::string::npos) << s.message;
  EXPECT_EQ(s.message.find('\n'), std::string::npos) << "message is not one line: " << s.message;
  EXPECT_EQ(m.nt(), 0);
}
}  // namespace

TEST(IoVtkHostile, ValidBaseIsAccepted) {
  TetMesh m;
  const Status s = parse_vtk(kVtkHead + kPts + kCells, "t.vtk", m);
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(m.nt(), 1);
}

TEST(IoVtkHostile, TruncatedFile) {
  const std::string full = kVtkHead + kPts + kCells;
  expect_error(full.substr(0, 80), ErrorCode::Parse, 0, "truncated");
  for (size_t n = 0; n + 1 < full.size(); ++n) {
    TetMesh m;
    EXPECT_FALSE(parse_vtk(full.substr(0, n), "t.vtk", m)) << n;
  }
  std::string vtu;
  ASSERT_TRUE(format_vtu(sample_mesh(), vtu));
  for (size_t n = 0; n + 1 < vtu.size(); n += 97) {
    TetMesh m;
    EXPECT_FALSE(parse_vtu(vtu.substr(0, n), "t.vtu", m)) << n;
  }
}

TEST(IoVtkHostile, CountsThatLie) {
  expect_error(kVtkHead + "POINTS 5 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n" + kCells, ErrorCode::Parse, 10, "'CELLS'");
  expect_error(kVtkHead + kPts + "CELLS 1 6\n4 0 1 2 3\nCELL_TYPES 1\n10\n", ErrorCode::Parse, 12, "'CELL_TYPES'");
  expect_error(kVtkHead + kPts + "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 2\n10\n10\n", ErrorCode::Parse, 12, "differs");
  expect_error(kVtkHead + kPts + kCells + "CELL_DATA 1\nSCALARS ref int 1\nLOOKUP_TABLE default\n1 2\n", ErrorCode::Parse,
               17, "unexpected keyword '2'");
  expect_error(kVtkHead + kPts + "CELLS 1 5\n3 0 1 2 3\nCELL_TYPES 1\n10\n", ErrorCode::Parse, 0, "does not match");
}

TEST(IoVtkHostile, AbsurdCountsAllocateNothing) {
  expect_error(kVtkHead + "POINTS 4000000000000 double\n0 0 0\n", ErrorCode::Parse, 5, "remain");
  expect_error(kVtkHead + kPts + "CELLS 1 99999999999999\n4 0 1 2 3\n", ErrorCode::Parse, 10, "remain");
  std::string bin = "# vtk DataFile Version 3.0\nx\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 900000000 double\n";
  bin += std::string(24, '\0');
  expect_error(bin, ErrorCode::Parse, 0, "remain");
  const std::string vtu =
      "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"99999999999\" NumberOfCells=\"1\">";
  expect_error(vtu, ErrorCode::Parse, 1, "exceed", true);
}

TEST(IoVtkHostile, NanAndInfCoordinates) {
  expect_error(kVtkHead + "POINTS 4 double\n0 0 0\n1 nan 0\n0 1 0\n0 0 1\n" + kCells, ErrorCode::InvalidMesh, 0, "NaN");
  expect_error(kVtkHead + "POINTS 4 float\n0 0 0\n1 0 0\n0 inf 0\n0 0 1\n" + kCells, ErrorCode::InvalidMesh, 0,
               "infinite");
  expect_error(kVtkHead + "POINTS 4 float\n0 0 0\n1 0 0\n0 1e60 0\n0 0 1\n" + kCells, ErrorCode::Parse, 8, "'1e60'");
}

TEST(IoVtkHostile, IndexOutOfRange) {
  expect_error(kVtkHead + kPts + "CELLS 1 5\n4 0 1 2 4\nCELL_TYPES 1\n10\n", ErrorCode::InvalidMesh, 0, "names point 4");
  expect_error(kVtkHead + kPts + "CELLS 1 5\n4 0 -1 2 3\nCELL_TYPES 1\n10\n", ErrorCode::InvalidMesh, 0, "names point -1");
}

TEST(IoVtkHostile, NonNumericTokens) {
  expect_error(kVtkHead + "POINTS 4 double\n0 0 0\n1 0 0\n0 one 0\n0 0 1\n" + kCells, ErrorCode::Parse, 8, "'one'");
  expect_error(kVtkHead + kPts + "CELLS 1 5\n4 0 1 2 3.5\nCELL_TYPES 1\n10\n", ErrorCode::Parse, 11, "'3.5'");
  expect_error(kVtkHead + "POINTS four double\n", ErrorCode::Parse, 5, "'four'");
}

TEST(IoVtkHostile, StructureErrors) {
  expect_error("# not vtk\n", ErrorCode::Parse, 1, "not a legacy VTK file");
  expect_error("# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n", ErrorCode::Unsupported, 4,
               "STRUCTURED_POINTS");
  expect_error(kVtkHead + kPts, ErrorCode::Parse, 0, "no CELLS");
  expect_error(kVtkHead + kPts + "CELL_TYPES 1\n10\n", ErrorCode::Parse, 0, "no CELLS");
  expect_error(kVtkHead + kPts + "CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n5\n", ErrorCode::InvalidMesh, 0, "no tetrahedra");
  expect_error(kVtkHead + kPts + "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n9\n", ErrorCode::Unsupported, 0, "quad");
  expect_error(kVtkHead + kPts + "CELLS 1 11\n10 0 1 2 3 0 1 2 3 0 1\nCELL_TYPES 1\n24\n", ErrorCode::Unsupported, 0,
               "quadratic tetrahedron");
  expect_error(kVtkHead + kPts + "CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n10\n", ErrorCode::Parse, 0, "lists 3 points");
}

// Index values beyond int64's range: they were converted from double to
// int64 unchecked, undefined behaviour that UBSan caught in the vtk fuzzer
// (a binary OFFSETS value of 2^63 - 1, read through a double as 2^63).
TEST(IoVtkHostile, IndicesBeyondInt64AreErrors) {
  const std::string big = "9223372036854775807";  // 2^63 - 1: 2^63 as a double
  expect_error(kVtkHead + kPts + "CELLS 2 4\nOFFSETS vtktypeint64\n0 " + big +
                   "\nCONNECTIVITY vtktypeint64\n0 1 2 3\nCELL_TYPES 1\n10\n",
               ErrorCode::Parse, 0, "OFFSETS value 2");
  expect_error(kVtkHead + kPts + "CELLS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n0 1 " + big +
                   " 3\nCELL_TYPES 1\n10\n",
               ErrorCode::Parse, 0, "CONNECTIVITY value 3");
  expect_error(kVtkHead + kPts + "CELLS 1 5\n4 0 1 " + big + " 3\nCELL_TYPES 1\n10\n", ErrorCode::Parse, 0,
               "CELLS value 4");
  expect_error(kVtkHead + kPts + kCells.substr(0, kCells.find("CELL_TYPES")) + "CELL_TYPES 1\n" + big + "\n",
               ErrorCode::Parse, 0, "CELL_TYPES value 1");
}

TEST(IoVtkHostile, BinaryTruncatedAndCorrupted) {
  const TetMesh m = sample_mesh();
  std::string out;
  ASSERT_TRUE(format_vtk(m, out, true));
  for (size_t cut : {out.size() / 2, out.size() - 10, out.size() / 5, size_t{120}}) {
    TetMesh r;
    const Status s = parse_vtk(out.substr(0, cut), "t.vtk", r);
    EXPECT_FALSE(s) << cut;
    EXPECT_EQ(s.message.find('\n'), std::string::npos);
  }
  for (size_t i = 100; i < out.size(); i += 5) {  // never a crash
    std::string c = out;
    c[i] = static_cast<char>(c[i] ^ 0x77);
    TetMesh x;
    (void)parse_vtk(c, "t.vtk", x);
  }
  std::string vtu;
  ASSERT_TRUE(format_vtu(m, vtu));
  for (size_t i = 300; i < vtu.size(); i += 11) {
    std::string c = vtu;
    c[i] = static_cast<char>(c[i] ^ 0x21);
    TetMesh x;
    (void)parse_vtu(c, "t.vtu", x);
  }
}

TEST(IoVtkHostile, VtuErrors) {
  std::string good;
  ASSERT_TRUE(detail::format_vtu_encoded(sample_mesh(), good, true));
  std::string bad = good;
  const size_t at = bad.find("format=\"binary\">\n") + 20;
  bad[at] = '#';
  expect_error(bad, ErrorCode::Parse, 0, "base64", true);
  bad = good;
  bad.replace(bad.find("Name=\"types\""), 12, "Name=\"kinds\"");
  expect_error(bad, ErrorCode::Parse, 0, "types", true);
  expect_error("<VTKFile type=\"PolyData\">", ErrorCode::Unsupported, 1, "PolyData", true);
  expect_error("<?xml version=\"1.0\"?>\n<Foo/>", ErrorCode::Parse, 2, "no <VTKFile>", true);
  std::string asc;
  ASSERT_TRUE(detail::format_vtu_encoded(sample_mesh(), asc, false));
  const size_t p = asc.find("Name=\"Points\"");
  const size_t q = asc.find('\n', p) + 1;
  const long line = 1 + static_cast<long>(std::count(asc.begin(), asc.begin() + static_cast<std::ptrdiff_t>(q), '\n'));
  asc.insert(q, "zz ");
  expect_error(asc, ErrorCode::Parse, line, "'zz'", true);
}

namespace {
// The zlib-compressed payload VTK writes for `data`: [nb][bs][last][cs...]
// then the blocks, each header word `hb` bytes (4: UInt32, 8: UInt64).
std::string zlib_payload(const std::string& data, uint64_t bs, int hb) {
  std::vector<std::string> blocks;
  for (size_t at = 0; at < data.size(); at += bs) {
    const size_t len = std::min<size_t>(bs, data.size() - at);
    std::string z(compressBound(len), '\0');
    uLongf zs = static_cast<uLongf>(z.size());
    EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(z.data()), &zs, reinterpret_cast<const Bytef*>(data.data() + at), len, 6),
              Z_OK);
    z.resize(zs);
    blocks.push_back(z);
  }
  std::string out;
  auto word = [&](uint64_t w) { out.append(reinterpret_cast<const char*>(&w), static_cast<size_t>(hb)); };  // LE host
  word(blocks.size());
  word(bs);
  word(data.size() % bs);
  for (const std::string& b : blocks) word(b.size());
  for (const std::string& b : blocks) out += b;
  return out;
}

// A one-tet VTU with `np` points whose Points are an appended raw payload.
std::string compressed_vtu(int np, const std::string& payload, int hb) {
  return "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"" + std::string(hb == 8 ? "UInt64" : "UInt32") +
         "\" compressor=\"vtkZLibDataCompressor\">\n<UnstructuredGrid>\n"
         "<Piece NumberOfPoints=\"" + std::to_string(np) + "\" NumberOfCells=\"1\">\n<Points>\n"
         "<DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" offset=\"0\"/>\n"
         "</Points>\n<Cells>\n"
         "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">0 1 2 3</DataArray>\n"
         "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">4</DataArray>\n"
         "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10</DataArray>\n"
         "</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_" +
         payload + "\n</AppendedData>\n</VTKFile>\n";
}

std::string eight_points() {
  std::string pts;
  for (int v = 0; v < 8; ++v)
    for (int k = 0; k < 3; ++k) {
      const double x = (v >> k) & 1;
      pts.append(reinterpret_cast<const char*>(&x), 8);
    }
  return pts;
}
}  // namespace

// A zlib "bomb": 16 blocks of 16 MiB of zeros (a few KB each once
// compressed) where the Points of 4 vertices need 96 bytes.  The header
// already says the size is wrong: refused before inflating anything (the
// reader used to allocate and fill 256 MiB first).
TEST(IoVtkHostile, CompressedArrayOfTheWrongSizeIsNotInflated) {
  const uLong bs = uLong{16} << 20;
  const std::string zeros(bs, '\0');
  std::string block(compressBound(bs), '\0');
  uLongf cs = static_cast<uLongf>(block.size());
  ASSERT_EQ(compress2(reinterpret_cast<Bytef*>(block.data()), &cs, reinterpret_cast<const Bytef*>(zeros.data()), bs, 9),
            Z_OK);
  block.resize(cs);
  const uint32_t nb = 16;
  std::string payload;
  auto word = [&](uint32_t w) { payload.append(reinterpret_cast<const char*>(&w), 4); };  // little-endian host
  word(nb);
  word(static_cast<uint32_t>(bs));
  word(static_cast<uint32_t>(bs));
  for (uint32_t b = 0; b < nb; ++b) word(static_cast<uint32_t>(cs));
  for (uint32_t b = 0; b < nb; ++b) payload += block;
  const std::string vtu = compressed_vtu(4, payload, 4);
  rusage before{};
  getrusage(RUSAGE_SELF, &before);
  expect_error(vtu, ErrorCode::Parse, 6, "holds 33554432 values instead of 12", true);
  rusage after{};
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 64 * 1024) << "KB of peak memory added";  // 256 MiB when inflated
}

// ------------------------------------------------------------ compressed VTU headers (issue 25)


// Valid files of every header width and several block sizes (a last block
// that is full, partial, and a single block) are read value for value.
TEST(IoVtkCompressed, EveryHeaderWidthAndBlockLayoutReads) {
  const std::string pts = eight_points();  // 192 bytes
  for (int hb : {4, 8})
    for (uint64_t bs : {uint64_t{64}, uint64_t{50}, uint64_t{192}, uint64_t{1000}}) {
      SCOPED_TRACE("header " + std::to_string(hb) + " block " + std::to_string(bs));
      TetMesh m;
      const Status s = parse_vtu(compressed_vtu(8, zlib_payload(pts, bs, hb), hb), "c.vtu", m);
      ASSERT_TRUE(s) << s.message;
      ASSERT_EQ(m.nv(), 8);
      for (int v = 0; v < 8; ++v)
        for (int k = 0; k < 3; ++k) EXPECT_EQ(m.point(v)[k], static_cast<double>((v >> k) & 1));
    }
}

// The heap overflow of issue 25: with a UInt64 header, nb = 3 and
// bs = 2^63 gave (nb - 1) * bs + last = 192 in wrapped arithmetic, a
// 192-byte buffer, and zlib allowed to write 2^63 bytes into it.  The first
// block here inflates to 4 KiB.  Now the product is checked and refused.
TEST(IoVtkCompressed, WrappedUncompressedSizeIsRefused) {
  const std::string big(4096, 'x');
  std::string z(compressBound(big.size()), '\0');
  uLongf zs = static_cast<uLongf>(z.size());
  ASSERT_EQ(compress2(reinterpret_cast<Bytef*>(z.data()), &zs, reinterpret_cast<const Bytef*>(big.data()), big.size(), 6), Z_OK);
  z.resize(zs);
  std::string payload;
  auto word = [&](uint64_t w) { payload.append(reinterpret_cast<const char*>(&w), 8); };
  word(3);
  word(uint64_t{1} << 63);
  word(192);
  for (int b = 0; b < 3; ++b) word(z.size());
  for (int b = 0; b < 3; ++b) payload += z;
  expect_error(compressed_vtu(8, payload, 8), ErrorCode::Parse, 6, "overflows", true);
}

// Two compressed sizes of 2^63 summed to 0 and passed the truncation check.
TEST(IoVtkCompressed, WrappedCompressedSizesAreRefused) {
  std::string payload;
  auto word = [&](uint64_t w) { payload.append(reinterpret_cast<const char*>(&w), 8); };
  word(2);
  word(96);
  word(96);
  word(uint64_t{1} << 63);
  word(uint64_t{1} << 63);
  payload += std::string(64, 'z');
  expect_error(compressed_vtu(8, payload, 8), ErrorCode::Parse, 6, "compressed sizes that overflow", true);
}

// A last block larger than the block size, a zero block size, and blocks
// whose inflated sizes disagree with the header: all refused, none written
// past the buffer (the last block's stream inflates to 4 KiB here).
TEST(IoVtkCompressed, InconsistentBlockHeadersAreRefused) {
  const std::string pts = eight_points();
  {
    std::string p = zlib_payload(pts, 100, 8);  // blocks of 100 and 92
    const uint64_t w = 200;                     // last > bs
    std::memcpy(&p[16], &w, 8);
    expect_error(compressed_vtu(8, p, 8), ErrorCode::Parse, 6, "larger than the block size", true);
  }
  {
    std::string p = zlib_payload(pts, 100, 8);
    const uint64_t w = 0;
    std::memcpy(&p[8], &w, 8);
    expect_error(compressed_vtu(8, p, 8), ErrorCode::Parse, 6, "block size 0", true);
  }
  {
    // Header says one block of 192 bytes; the stream holds 4 KiB.
    const std::string big(4096, 'x');
    std::string p = zlib_payload(big, 4096, 4);
    uint32_t w = 192;
    std::memcpy(&p[4], &w, 4);
    w = 0;
    std::memcpy(&p[8], &w, 4);
    expect_error(compressed_vtu(8, p, 4), ErrorCode::Parse, 6, "corrupt zlib block 0", true);
  }
}

// ------------------------------------------------------------ meshio

TEST(IoVtkCross, MeshioReadsOurFiles) {
  if (!have_meshio()) GTEST_SKIP() << "meshio not importable by /usr/bin/python3";
  const std::string dir = tmp_dir();
  const TetMesh m = sample_mesh();
  int64_t ref_sum = 0, fixed_sum = 0;
  for (int32_t r : m.tet_ref) ref_sum += r;
  for (double v : m.point_fields[0].values) fixed_sum += static_cast<int64_t>(v);
  for (Kind k : kKinds) {
    SCOPED_TRACE(kind_name(k));
    std::string out;
    ASSERT_TRUE(format_kind(m, out, k));
    const std::string in = dir + (k == Kind::VtkAscii || k == Kind::VtkBinary ? "/ours.vtk" : "/ours.vtu");
    ASSERT_TRUE(write_file_atomic(in, out));
    const std::string cmd =
        "/usr/bin/python3 -c 'import meshio,sys\n"
        "m=meshio.read(sys.argv[1])\n"
        "nt=sum(len(c.data) for c in m.cells if c.type==\"tetra\")\n"
        "s=sum(int(m.cell_data[\"ref\"][i].sum()) for i,c in enumerate(m.cells) if c.type==\"tetra\")\n"
        // One dimension per block, as tools that take it for tags need
        // (meshio reads SCALARS as shape (n, 1); we wrote those once).
        "assert all(a.ndim == 1 for a in m.cell_data[\"ref\"]), [a.shape for a in m.cell_data[\"ref\"]]\n"
        "print(len(m.points), nt, s, int(m.point_data[\"fixed\"].sum()), repr(float(m.points[1][0])))' " +
        in + " > " + dir + "/res.txt 2>" + dir + "/err.txt";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(dir + "/err.txt");
    std::istringstream ss(slurp(dir + "/res.txt"));
    int64_t np = 0, nt = 0, sum = 0, fs_ = 0;
    std::string y;
    ss >> np >> nt >> sum >> fs_ >> y;
    EXPECT_EQ(np, m.nv());
    EXPECT_EQ(nt, m.nt());
    EXPECT_EQ(sum, ref_sum);
    EXPECT_EQ(fs_, fixed_sum);
    double yv = 0;
    ASSERT_TRUE(gvscan::parse_double(y, yv)) << y;
    EXPECT_EQ(yv, m.xyz[3]);
  }
  fs::remove_all(dir);
}

TEST(IoVtkCross, MeshioWrittenFilesRead) {
  if (!have_meshio()) GTEST_SKIP() << "meshio not importable by /usr/bin/python3";
  const std::string dir = tmp_dir();
  // (extension, meshio keyword arguments)
  const std::pair<const char*, const char*> cases[] = {
      {"a.vtu", ""},  // meshio default: binary, zlib-compressed
      {"b.vtu", ",binary=False"},
      {"c.vtu", ",binary=True,compression=None"},
      {"d.vtk", ",binary=False"},
      {"e.vtk", ",binary=True"},
  };
  for (const auto& [file, kw] : cases) {
    SCOPED_TRACE(file);
    const std::string out = dir + "/" + file;
    const std::string cmd =
        std::string("/usr/bin/python3 -c 'import meshio,numpy as np\n"
                    "p=np.array([[0,0,0],[1,0,0],[0,1,0],[0,0,1],[1,1,1]],dtype=float)+np.array([0.1,0.2,0.3])\n"
                    "c=[(\"tetra\",np.array([[0,1,2,3],[1,2,3,4]])),(\"triangle\",np.array([[0,1,2]]))]\n"
                    "cd={\"medit:ref\":[np.array([4,9],dtype=np.int32),np.array([3],dtype=np.int32)]}\n"
                    "pd={\"fixed\":np.array([1,0,1,0,1],dtype=np.int32)}\n"
                    "meshio.write(\"") +
        out + "\",meshio.Mesh(p,c,cell_data=cd,point_data=pd)" + kw + ")' > " + dir + "/err.txt 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(dir + "/err.txt");
    TetMesh r;
    OrientationReport rep;
    const Status s = read_mesh(out, r, &rep);
    ASSERT_TRUE(s) << s.message;
    EXPECT_EQ(r.nv(), 5);
    EXPECT_EQ(r.nt(), 2);
    EXPECT_EQ(r.ntri(), 1);
    EXPECT_EQ(r.tet_ref, (std::vector<int32_t>{4, 9}));
    EXPECT_EQ(r.tri_ref, (std::vector<int32_t>{3}));
    EXPECT_EQ(r.point(4)[0], 1.0 + 0.1);
    ASSERT_EQ(r.point_fields.size(), 1u);
    EXPECT_EQ(r.point_fields[0].values, (std::vector<double>{1, 0, 1, 0, 1}));
    EXPECT_EQ(rep.negative, 0);
  }
  fs::remove_all(dir);
}

// ------------------------------------------------------------ shared meshes

TEST(IoVtkShared, RealMeshesReadWithRightCounts) {
  const std::string root = shared_meshes();
  if (root.empty()) GTEST_SKIP() << "shared meshes not present";
  const std::tuple<const char*, int32_t, int32_t> cases[] = {
      {"tire/tire.vtk", 2570, 11098},
      {"flat-tet-sphere/flat-tet-sphere.vtk", 4793, 23636},
      {"cube-clip-5/cube-clip-5.vtk", 3408, 16637},
  };
  for (const auto& [file, nv, nt] : cases) {
    SCOPED_TRACE(file);
    const std::string path = root + "/" + file;
    if (!fs::exists(path)) GTEST_SKIP() << path << " missing";
    TetMesh m;
    OrientationReport rep;
    const Status s = read_mesh(path, m, &rep);
    ASSERT_TRUE(s) << s.message;
    EXPECT_EQ(m.nv(), nv);
    EXPECT_EQ(m.nt(), nt);
    EXPECT_TRUE(rep.inverted.empty());
    for (int32_t t = 0; t < m.nt(); ++t) {
      const int32_t* q = m.tet(t);
      ASSERT_EQ(orient3d(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3])), Sign::Positive) << t;
    }
    // one region everywhere (GLOBAL_ID in flat-tet-sphere is not a region)
    for (int32_t r : m.tet_ref) ASSERT_EQ(r, 0);
    // point data "fixed" survives a write/read round trip, as do coordinates
    ASSERT_FALSE(m.point_fields.empty());
    std::string out;
    ASSERT_TRUE(format_vtk(m, out, false));
    TetMesh r;
    ASSERT_TRUE(parse_vtk(out, "again.vtk", r));
    EXPECT_EQ(0, std::memcmp(m.xyz.data(), r.xyz.data(), m.xyz.size() * sizeof(double)));
    ASSERT_EQ(r.point_fields.size(), m.point_fields.size());
    EXPECT_EQ(r.point_fields[0].values, m.point_fields[0].values);
  }
}

TEST(IoVtkShared, TireFloat32CoordinatesAndCoincidentVertices) {
  const std::string root = shared_meshes();
  if (root.empty() || !fs::exists(root + "/tire/tire.vtk")) GTEST_SKIP() << "tire.vtk not present";
  TetMesh m;
  ASSERT_TRUE(read_mesh(root + "/tire/tire.vtk", m));
  // "-3.500000 9.490000 6.290000": declared float, so the float32 values.
  EXPECT_EQ(m.point(0)[0], -3.5);
  EXPECT_EQ(m.point(0)[1], static_cast<double>(9.49f));
  EXPECT_EQ(m.point(0)[2], static_cast<double>(6.29f));
  std::map<std::tuple<double, double, double>, int> seen;
  int pairs = 0;
  for (int32_t v = 0; v < m.nv(); ++v) {
    const double* p = m.point(v);
    if (seen[{p[0], p[1], p[2]}]++ == 1) ++pairs;
  }
  EXPECT_EQ(pairs, 10);
  const TetMesh::PointField* fixed = nullptr;
  for (const auto& f : m.point_fields)
    if (f.name == "fixed") fixed = &f;
  ASSERT_NE(fixed, nullptr);
  EXPECT_EQ(std::count(fixed->values.begin(), fixed->values.end(), 1.0), 1248);
}

// ------------------------------------------------------------ legacy VTK counts and tokens (issue 25)

// A second CELL_DATA section was appended to the first: its ref array was
// silently dropped.  A legacy dataset has at most one of each.
TEST(IoVtkLegacyHostile, SecondDataSectionIsRefused) {
  const std::string base = kVtkHead + kPts + kCells;
  TetMesh m;
  ASSERT_TRUE(parse_vtk(base + "CELL_DATA 1\nSCALARS ref int 1\nLOOKUP_TABLE default\n7\n", "t.vtk", m));
  EXPECT_EQ(m.tet_ref, (std::vector<int32_t>{7}));
  expect_error(base + "CELL_DATA 1\nSCALARS a int 1\nLOOKUP_TABLE default\n7\nCELL_DATA 1\nSCALARS ref int 1\n"
                      "LOOKUP_TABLE default\n9\n",
               ErrorCode::Parse, 18, "a second CELL_DATA section");
  expect_error(base + "POINT_DATA 4\nSCALARS a int 1\n1 2 3 4\nPOINT_DATA 4\nSCALARS b int 1\n1 2 3 4\n", ErrorCode::Parse,
               17, "a second POINT_DATA section");
}

// Products of two counts from the file (components x tuples, 3 x points,
// 4 x table size) were signed int64 products: UB past 2^63.
TEST(IoVtkLegacyHostile, CountProductsThatOverflowAreRefused) {
  expect_error(kVtkHead + "POINTS 4611686018427387904 double\n0 0 0\n", ErrorCode::Parse, 5, "POINTS: count 3 x");
  const std::string base = kVtkHead + kPts + kCells;
  expect_error(base + "CELL_DATA 1\nFIELD f 1\nref 1024 4611686018427387904 int\n7\n", ErrorCode::Parse, 16, "overflows");
  expect_error(base + "CELL_DATA 1\nLOOKUP_TABLE t 4611686018427387904\n", ErrorCode::Parse, 15, "LOOKUP_TABLE: count 4 x");
}

// A name token of 64 MiB was copied whole (and upper-cased keyword tokens
// too): a sparse file with a 2 GB run of bytes took 2 GB of heap.  Names are
// bounded and keywords compared on a bounded copy.
TEST(IoVtkLegacyHostile, HugeTokensAreNotCopied) {
  const std::string big(size_t{64} << 20, 'n');
  // The inputs are built first, so the peak already holds them: a copy of
  // the token during parsing would raise it by 64 MiB.
  const std::string name_in = kVtkHead + kPts + kCells + "CELL_DATA 1\nSCALARS " + big + " int 1\n7\n";
  const std::string kw_in = kVtkHead + kPts + kCells + big + "\n";
  const std::string xml_in = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\"><" + big + ">";
  rusage before{};
  getrusage(RUSAGE_SELF, &before);
  expect_error(name_in, ErrorCode::Parse, 15, "an array name of 67108864 bytes");
  expect_error(kw_in, ErrorCode::Parse, 14, "unexpected keyword 'nnnn");
  expect_error(xml_in, ErrorCode::Parse, 2, "XML element name of 67108864 bytes", true);
  rusage after{};
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 3 * 64 * 1024) << "KB of peak memory added";
}
