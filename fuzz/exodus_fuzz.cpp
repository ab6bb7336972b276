// libFuzzer target: parse_exodus_file on arbitrary bytes written to a file
// (see lib_fuzz_common.hpp), then the round trip through format_exodus_file.
// Built only where the Exodus II library is found (TETOPT_EXODUS).
#include <algorithm>
#include <array>

#include "lib_fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetopt;
  const std::string in = tetopt_fuzz::lib_file(".exo", 0), out = tetopt_fuzz::lib_file(".exo", 1);
  tetopt_fuzz::write_bytes(in, data, size);
  TetMesh m;
  const Status s = parse_exodus_file(in, "fuzz", m);
  std::remove(in.c_str());
  if (!s) return tetopt_fuzz::refused("reader refused:", s.message);
  if (!tetopt_fuzz::finish_read(m, Format::Exodus)) return 0;
  tetopt_fuzz::check_topology(m);
  if (m.nt() > tetopt_fuzz::kMaxTets) return 0;
  if (Status w = format_exodus_file(m, out); !w) tetopt_fuzz::die("writer refused an accepted mesh:", w.message);
  TetMesh back;
  const Status r = parse_exodus_file(out, "fuzz-rt", back);
  std::remove(out.c_str());
  if (!r) tetopt_fuzz::die("re-read of written mesh failed:", r.message);
  if (!tetopt_fuzz::finish_read(back, Format::Exodus)) tetopt_fuzz::die("re-read mesh rejected");
  tetopt_fuzz::group_by_ref(m);
  // Coordinates bit for bit, refs; each tet the same vertex set (a tet
  // holding a listed triangle may be rotated, exodus.cpp).
  if (m.xyz.size() != back.xyz.size() || (!m.xyz.empty() && std::memcmp(m.xyz.data(), back.xyz.data(), m.xyz.size() * sizeof(double)) != 0))
    tetopt_fuzz::die("exodus", "round trip changed the coordinates");
  if (m.tet_ref != back.tet_ref) tetopt_fuzz::die("exodus", "round trip changed the tet refs");
  if (m.tets.size() != back.tets.size()) tetopt_fuzz::die("exodus", "round trip changed the tet count");
  for (int32_t t = 0; t < m.nt(); ++t) {
    std::array<int32_t, 4> a, b;
    std::copy(m.tet(t), m.tet(t) + 4, a.begin());
    std::copy(back.tet(t), back.tet(t) + 4, b.begin());
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    if (a != b) tetopt_fuzz::die("exodus", "round trip changed a tet");
  }
  if (back.vert_ref != m.vert_ref) tetopt_fuzz::die("exodus", "round trip changed the vertex refs (node sets)");
  return 0;
}
