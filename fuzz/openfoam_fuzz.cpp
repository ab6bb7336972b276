// libFuzzer target: parse_openfoam on arbitrary bytes.  The input holds the
// polyMesh files in the order of kFoamFileNames (points, faces, owner,
// neighbour, boundary, cellZones, faceZones, pointZones) separated by the
// line "@@FILE@@" (a binary list may hold any byte, NUL included); files
// not given are empty (absent).
#include "fuzz_common.hpp"

namespace {
constexpr std::string_view kSep = "\n@@FILE@@\n";

void split(std::string_view in, std::string_view out[8]) {
  for (int k = 0; k < 7; ++k) {
    const size_t e = in.find(kSep);
    out[k] = in.substr(0, e);
    in = e == std::string_view::npos ? std::string_view{} : in.substr(e + kSep.size());
  }
  out[7] = in;  // the rest
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetopt;
  std::string_view files[8];
  split(std::string_view(reinterpret_cast<const char*>(data), size), files);
  TetMesh m;
  if (Status s = parse_openfoam(files, "fuzz", m); !s) return tetopt_fuzz::refused("reader refused:", s.message);
  if (!tetopt_fuzz::finish_read(m, Format::OpenFoam)) return 0;
  tetopt_fuzz::check_topology(m);
  // A polyMesh stores faces, not cells: tets whose vertex orders disagree
  // across a face (orient_consistently) cannot be written so that the same
  // orders come back, and every command refuses them anyway.
  {
    TetMesh t = m;
    if (!build_topology(t) || !orient_consistently(t, false)) return tetopt_fuzz::refused("tets disagree in orientation");
  }
  for (bool binary : {false, true}) {
    std::string out[8];
    if (Status s = format_openfoam(m, out, binary); !s) tetopt_fuzz::die("writer refused an accepted mesh:", s.message);
    std::string_view views[8];
    for (int k = 0; k < 8; ++k) views[k] = out[k];
    TetMesh back;
    if (Status s = parse_openfoam(views, "fuzz-rt", back); !s) tetopt_fuzz::die("re-read of written mesh failed:", s.message);
    if (!tetopt_fuzz::finish_read(back, Format::OpenFoam)) tetopt_fuzz::die("re-read mesh rejected");
    tetopt_fuzz::same_or_die(m, back, binary ? "openfoam binary" : "openfoam");
    if (back.vert_ref != m.vert_ref) tetopt_fuzz::die("openfoam", "round trip changed the vertex refs (pointZones)");
  }
  return 0;
}
