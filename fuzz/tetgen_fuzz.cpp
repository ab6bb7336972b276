// libFuzzer target: parse_tetgen on arbitrary bytes.  The input holds the
// .node, .ele and (optional) .face files separated by NUL bytes.
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetopt;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const size_t a = in.find('\0');
  if (a == std::string_view::npos) return tetopt_fuzz::refused("no NUL byte between the .node and .ele data");
  const size_t b = in.find('\0', a + 1);
  const std::string_view node = in.substr(0, a);
  const std::string_view ele = in.substr(a + 1, b == std::string_view::npos ? std::string_view::npos : b - a - 1);
  const std::string_view face = b == std::string_view::npos ? std::string_view{} : in.substr(b + 1);
  TetMesh m;
  if (Status s = parse_tetgen(node, ele, face, "fuzz", m); !s) return tetopt_fuzz::refused("reader refused:", s.message);
  if (!tetopt_fuzz::finish_read(m, Format::TetGen)) return 0;
  tetopt_fuzz::check_topology(m);
  std::string n2, e2, f2;
  if (Status s = format_tetgen(m, n2, e2, f2); !s) tetopt_fuzz::die("writer refused an accepted mesh:", s.message);
  TetMesh back;
  if (Status s = parse_tetgen(n2, e2, f2, "fuzz-rt", back); !s)
    tetopt_fuzz::die("re-read of written mesh failed:", s.message);
  if (!tetopt_fuzz::finish_read(back, Format::TetGen)) tetopt_fuzz::die("re-read mesh rejected");
  tetopt_fuzz::same_or_die(m, back, "tetgen");
  return 0;
}
