// checked.hpp: the readers' size arithmetic reports overflow instead of
// wrapping; and the file names in read messages, escaped (issue 25).
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <unistd.h>

#include "io/checked.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"

using namespace tetopt::detail;

TEST(Checked, ProductsThatWrapAreReported) {
  uint64_t r = 0;
  // The VTU case: (nb - 1) * bs with nb = 3, bs = 2^63 wrapped to 0.
  EXPECT_FALSE(ck_mul(uint64_t{2}, uint64_t{1} << 63, r));
  EXPECT_TRUE(ck_mul(uint64_t{2}, uint64_t{1} << 62, r));
  EXPECT_EQ(r, uint64_t{1} << 63);
  int64_t s = 0;
  EXPECT_FALSE(ck_mul(int64_t{3}, int64_t{1} << 62, s));  // 3 x points in legacy VTK
  EXPECT_TRUE(ck_mul(int64_t{-3}, int64_t{5}, s));
  EXPECT_EQ(s, -15);
}

TEST(Checked, SumsAndDifferencesThatWrapAreReported) {
  uint64_t r = 0;
  EXPECT_FALSE(ck_add(uint64_t{1} << 63, uint64_t{1} << 63, r));  // two compressed sizes of 2^63
  EXPECT_TRUE(ck_add(uint64_t{1} << 62, uint64_t{1} << 62, r));
  EXPECT_EQ(r, uint64_t{1} << 63);
  EXPECT_FALSE(ck_sub(uint64_t{1}, uint64_t{2}, r));
  size_t z = 0;
  EXPECT_TRUE(ck_add(size_t{10}, int64_t{5}, z));  // mixed types: an offset from the file
  EXPECT_EQ(z, 15u);
  EXPECT_FALSE(ck_add(size_t{10}, int64_t{-11}, z));
}

TEST(Checked, ConversionsOutOfRangeAreReported) {
  int32_t i = 0;
  EXPECT_FALSE(ck_cast(int64_t{1} << 31, i));
  EXPECT_TRUE(ck_cast(int64_t{-(int64_t{1} << 31)}, i));
  EXPECT_EQ(i, std::numeric_limits<int32_t>::min());
  size_t z = 0;
  EXPECT_FALSE(ck_cast(int64_t{-1}, z));
  uint64_t big = std::numeric_limits<uint64_t>::max();
  int64_t s = 0;
  EXPECT_FALSE(ck_cast(big, s));
}

TEST(Checked, SizesSaturateSoTheAllocationFails) {
  EXPECT_EQ(ck_size(5, 3), 15u);
  EXPECT_EQ(ck_size(-1, 3), SIZE_MAX);
  EXPECT_EQ(ck_size(int64_t{1} << 62, 8), SIZE_MAX);
  size_t b = 0;
  EXPECT_TRUE(ck_bytes(1000, 4, 8, b));
  EXPECT_EQ(b, 32000u);
  EXPECT_FALSE(ck_bytes(uint64_t{1} << 44, uint64_t{1} << 20, 8, b));  // 2^67
}

// ---- file names in the library's read messages (issue 25) ----

// A name with a newline or ESC kept every read message one line only in
// the CLI (which escaped on printing); the library's own Status, which
// Python raises as is, printed it raw.
TEST(ReadMessages, FileNamesAreEscapedInEveryReadError) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("tetopt_names_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string bad = (dir / "a\nb\x1b[31m.mesh").string();
  {
    std::ofstream(bad) << "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 zz 0\nEnd\n";
  }
  for (const std::string& path :
       {bad, (dir / "missing\n.vtu").string(), (dir / "x\n.unknown").string(), (dir / "t\x01s.node").string()}) {
    tetopt::TetMesh m;
    const tetopt::Status s = tetopt::read_mesh(path, m);
    ASSERT_FALSE(s);
    EXPECT_EQ(s.message.find('\n'), std::string::npos) << s.message;
    EXPECT_EQ(s.message.find('\x1b'), std::string::npos) << s.message;
    EXPECT_EQ(s.message.find('\x01'), std::string::npos) << s.message;
    EXPECT_TRUE(s.message.find("\\n") != std::string::npos || s.message.find("\\x01") != std::string::npos)
        << s.message;
  }
  fs::remove_all(dir);
}
