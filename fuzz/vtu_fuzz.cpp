// libFuzzer target: parse_vtu on arbitrary bytes (see fuzz_common.hpp).
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetopt;
  TetMesh m;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  if (Status s = parse_vtu(in, "fuzz", m); !s) return tetopt_fuzz::refused("reader refused:", s.message);
  if (!tetopt_fuzz::finish_read(m, Format::Vtu)) return 0;
  tetopt_fuzz::check_topology(m);
  std::string out;
  if (Status s = format_vtu(m, out); !s) tetopt_fuzz::die("writer refused an accepted mesh:", s.message);
  TetMesh back;
  if (Status s = parse_vtu(out, "fuzz-rt", back); !s) tetopt_fuzz::die("re-read of written mesh failed:", s.message);
  if (!tetopt_fuzz::finish_read(back, Format::Vtu)) tetopt_fuzz::die("re-read mesh rejected");
  tetopt_fuzz::same_or_die(m, back, "vtu");
  return 0;
}
