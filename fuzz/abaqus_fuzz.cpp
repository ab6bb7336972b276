// libFuzzer target: parse_abaqus on arbitrary bytes (see fuzz_common.hpp).
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetopt;
  TetMesh m;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  if (Status s = parse_abaqus(in, "fuzz", m); !s) return tetopt_fuzz::refused("reader refused:", s.message);
  if (!tetopt_fuzz::finish_read(m, Format::Abaqus)) return 0;
  tetopt_fuzz::check_topology(m);
  std::string out;
  if (Status s = format_abaqus(m, out); !s) tetopt_fuzz::die("writer refused an accepted mesh:", s.message);
  TetMesh back;
  if (Status s = parse_abaqus(out, "fuzz-rt", back); !s) tetopt_fuzz::die("re-read of written mesh failed:", s.message);
  if (!tetopt_fuzz::finish_read(back, Format::Abaqus)) tetopt_fuzz::die("re-read mesh rejected");
  tetopt_fuzz::same_or_die(m, back, "abaqus");
  if (back.vert_ref != m.vert_ref) tetopt_fuzz::die("abaqus", "round trip changed the vertex refs (node sets)");
  return 0;
}
