// How the library writes (docs/formats.md, "Writing"; issue 25): a
// rewritten file keeps its mode (and owner and group where permitted), link
// loops and names too long are errors with the system's reason, a long
// valid name gets a temporary file that fits, and escaped_name keeps each
// message naming a file on one line.  The command line side (exit codes,
// fsync order, SIGXFSZ) is tests/scripts/test_writes.sh.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

#include "io/common.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"

using namespace tetopt;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& tag) {
  fs::path d = fs::temp_directory_path() / ("tetopt_writes_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

mode_t mode_of(const fs::path& p) {
  struct stat st {};
  EXPECT_EQ(::stat(p.c_str(), &st), 0) << p;
  return st.st_mode & 07777;
}

bool no_temporaries(const fs::path& d) {
  for (const auto& e : fs::directory_iterator(d))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) return false;
  return true;
}

}  // namespace

TEST(EscapedName, ControlCharactersEscapedUtf8Kept) {
  using detail::escaped_name;
  EXPECT_EQ(escaped_name("a\nb\rc\td"), "a\\nb\\rc\\td");
  EXPECT_EQ(escaped_name("x\x1b[31my\x7f"), "x\\x1b[31my\\x7f");
  EXPECT_EQ(escaped_name(std::string_view("a\0b", 3)), "a\\x00b");
  EXPECT_EQ(escaped_name("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80.mesh"), "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80.mesh");
  EXPECT_EQ(escaped_name("\xc2\x9b" "1m\xc2\x85"), "\\u009b1m\\u0085");                 // C1 controls (CSI, NEL)
  EXPECT_EQ(escaped_name("\xff\xc3(\xe2\x82\xed\xa0\x80"), "\\xff\\xc3(\\xe2\\x82\\xed\\xa0\\x80");  // not UTF-8
  EXPECT_EQ(escaped_name("\xc0\xaf\xf4\x90\x80\x80"), "\\xc0\\xaf\\xf4\\x90\\x80\\x80");  // overlong, past U+10FFFF
  EXPECT_EQ(escaped_name("dir\\name"), "dir\\name");  // a backslash stays
  for (const char* s : {"a\n\x1b\xff\xc2\x85z", "plain", ""})
    EXPECT_EQ(escaped_name(escaped_name(s)), escaped_name(s)) << "escaping twice changes nothing: " << s;
}

TEST(Writes, RewriteKeepsModeAndOwner) {
  const fs::path d = temp_dir("mode");
  const fs::path f = d / "r.json";
  ASSERT_TRUE(write_file_atomic(f.string(), "old\n").ok());
  for (const mode_t m : {mode_t{0600}, mode_t{0640}, mode_t{0444}, mode_t{02640}}) {
    ASSERT_EQ(::chmod(f.c_str(), m), 0);
    ASSERT_TRUE(write_file_atomic(f.string(), "new\n").ok());
    EXPECT_EQ(mode_of(f), m);
  }
  const TetMesh box = make_box_mesh({.nx = 2, .ny = 2, .nz = 2});
  for (const char* name : {"m.mesh", "m.vtu", "m.node"}) {
    const fs::path p = d / name;
    ASSERT_TRUE(write_mesh(p.string(), box).ok());
    ASSERT_EQ(::chmod(p.c_str(), 0600), 0);
    ASSERT_TRUE(write_mesh(p.string(), box).ok());
    EXPECT_EQ(mode_of(p), 0600u) << name;
  }
  if (::geteuid() == 0) {  // only root may give a file away
    ASSERT_EQ(::chown(f.c_str(), 12345, 23456), 0);
    ASSERT_TRUE(write_file_atomic(f.string(), "again\n").ok());
    struct stat st {};
    ASSERT_EQ(::stat(f.c_str(), &st), 0);
    EXPECT_EQ(st.st_uid, 12345u);
    EXPECT_EQ(st.st_gid, 23456u);
  }
  EXPECT_TRUE(no_temporaries(d));
  fs::remove_all(d);
}

TEST(Writes, LinkLoopAndNameTooLongAreErrorsWithTheSystemsReason) {
  const fs::path d = temp_dir("loop");
  fs::create_symlink("self.mesh", d / "self.mesh");
  const TetMesh box = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  for (const Status& s : {write_mesh((d / "self.mesh").string(), box), check_output_path((d / "self.mesh").string())}) {
    EXPECT_EQ(s.code, ErrorCode::Io);
    EXPECT_NE(s.message.find(std::string("self.mesh: ") + std::strerror(ELOOP)), std::string::npos) << s.message;
  }
  EXPECT_TRUE(fs::is_symlink(d / "self.mesh"));
  const std::string long_name = (d / (std::string(300, 'n') + ".mesh")).string();
  for (const Status& s : {write_mesh(long_name, box), check_output_path(long_name)}) {
    EXPECT_EQ(s.code, ErrorCode::Io);
    EXPECT_NE(s.message.find(std::strerror(ENAMETOOLONG)), std::string::npos) << s.message;
  }
  // 250 bytes: a valid name, whose temporary file is named shorter.
  const fs::path ok = d / (std::string(245, 'k') + ".mesh");
  EXPECT_TRUE(check_output_path(ok.string()).ok());
  EXPECT_TRUE(write_mesh(ok.string(), box).ok());
  EXPECT_TRUE(fs::is_regular_file(ok));
  EXPECT_TRUE(no_temporaries(d));
  fs::remove_all(d);
}

TEST(Writes, MessagesEscapeTheFileName) {
  const Status s = write_file_atomic("/nonexistent-folder\n\x1b[2J/x.json", "x");
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.message.find('\n'), std::string::npos) << s.message;
  EXPECT_EQ(s.message.find('\x1b'), std::string::npos) << s.message;
  EXPECT_NE(s.message.find("folder\\n\\x1b[2J"), std::string::npos) << s.message;
}
