// libFuzzer target: parse_cgns_file on arbitrary bytes written to a file
// (see lib_fuzz_common.hpp), then the round trip through format_cgns_file.
// Built only where libcgns is found (TETOPT_CGNS); see fuzz/run.sh for why
// it is not in the default list.
#include <algorithm>
#include <array>
#include <utility>

#include "lib_fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetopt;
  const std::string in = tetopt_fuzz::lib_file(".cgns", 0), out = tetopt_fuzz::lib_file(".cgns", 1);
  tetopt_fuzz::write_bytes(in, data, size);
  TetMesh m;
  const Status s = parse_cgns_file(in, "fuzz", m);
  std::remove(in.c_str());
  if (!s) return tetopt_fuzz::refused("reader refused:", s.message);
  if (!tetopt_fuzz::finish_read(m, Format::Cgns)) return 0;
  tetopt_fuzz::check_topology(m);
  if (m.nt() > tetopt_fuzz::kMaxTets) return 0;
  if (Status w = format_cgns_file(m, out); !w) tetopt_fuzz::die("writer refused an accepted mesh:", w.message);
  TetMesh back;
  const Status r = parse_cgns_file(out, "fuzz-rt", back);
  std::remove(out.c_str());
  if (!r) tetopt_fuzz::die("re-read of written mesh failed:", r.message);
  if (!tetopt_fuzz::finish_read(back, Format::Cgns)) tetopt_fuzz::die("re-read mesh rejected");
  tetopt_fuzz::group_by_ref(m);
  tetopt_fuzz::same_or_die(m, back, "cgns");
  if (back.tris != m.tris || back.tri_ref != m.tri_ref) {
    // Triangles are written grouped by ref too; compare the groups.
    TetMesh a = m, b = back;
    auto sorted = [](const TetMesh& x) {
      std::vector<std::pair<int32_t, std::array<int32_t, 3>>> v;
      for (int32_t i = 0; i < x.ntri(); ++i) v.push_back({x.tri_ref[i], {x.tris[3 * i], x.tris[3 * i + 1], x.tris[3 * i + 2]}});
      std::stable_sort(v.begin(), v.end(), [](const auto& p, const auto& q) { return p.first < q.first; });
      return v;
    };
    if (sorted(a) != sorted(b)) tetopt_fuzz::die("cgns", "round trip changed the listed triangles");
  }
  return 0;
}
