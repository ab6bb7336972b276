// checked.hpp: the readers' size arithmetic reports overflow instead of
// wrapping (issue 25).
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

#include "io/checked.hpp"

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
