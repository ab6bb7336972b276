// libFuzzer target: parse_fluent on arbitrary bytes (see fuzz_common.hpp);
// an accepted mesh is written in ASCII and in binary and read back.
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetopt;
  TetMesh m;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  if (Status s = parse_fluent(in, "fuzz", m); !s) return tetopt_fuzz::refused("reader refused:", s.message);
  if (!tetopt_fuzz::finish_read(m, Format::Fluent)) return 0;
  tetopt_fuzz::check_topology(m);
  // A Fluent file stores faces, not cells: tets whose vertex orders
  // disagree across a face cannot come back as they were (every command
  // refuses them anyway).
  {
    TetMesh t = m;
    if (!build_topology(t) || !orient_consistently(t, false)) return tetopt_fuzz::refused("tets disagree in orientation");
  }
  for (bool binary : {false, true}) {
    std::string out;
    if (Status s = format_fluent(m, out, binary); !s) tetopt_fuzz::die("writer refused an accepted mesh:", s.message);
    TetMesh back;
    if (Status s = parse_fluent(out, "fuzz-rt", back); !s) tetopt_fuzz::die("re-read of written mesh failed:", s.message);
    if (!tetopt_fuzz::finish_read(back, Format::Fluent)) tetopt_fuzz::die("re-read mesh rejected");
    tetopt_fuzz::same_or_die(m, back, binary ? "fluent binary" : "fluent");
  }
  return 0;
}
