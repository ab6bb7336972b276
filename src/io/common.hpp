// Private helpers shared by the format readers and writers.
#pragma once
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "tetopt/conventions.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"

namespace tetopt::detail {

/// A token as a reader's error message shows it: at most 40 bytes, then
/// "..."; control bytes (a NUL cut a message short) as '?', and with
/// ascii_only every byte past '~' too (the Gmsh and VTK readers, whose
/// binary sections would otherwise print raw bytes); Medit and TetGen keep
/// UTF-8 text.
inline std::string shown_token(std::string_view t, bool ascii_only) {
  std::string s(t.substr(0, 40));
  for (char& ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 32 || c == 127 || (ascii_only && c > 126)) ch = '?';
  }
  if (t.size() > 40) s += "...";
  return s;
}

/// Whether a writer of format `target` must swap kFlipA/kFlipB: to restore
/// the source file's own convention when writing the same format family
/// (.mesh/.meshb, .vtk/.vtu, .node/.ele); otherwise every format is written
/// with a positive right-hand determinant, which is also what TetGen 1.5
/// itself writes (checked: `tetgen -r` on an all-negative .ele writes the
/// same tets back positive).  Stellar's .ele files (house2) are negative; they
/// keep that when written back as TetGen.
inline Format format_family(Format f) { return f == Format::MeditBinary ? Format::Medit : (f == Format::Vtu ? Format::Vtk : f); }
inline bool write_flipped(const TetMesh& m, Format target) {
  if (format_family(target) == format_family(static_cast<Format>(m.source_format))) return m.flipped_on_read;
  return false;
}

/// Vertex ids of tet t in the orientation a writer of `target` uses.
inline void file_tet(const TetMesh& m, int32_t t, Format target, int32_t out[4]) {
  const int32_t* v = m.tet(t);
  out[0] = v[0]; out[1] = v[1]; out[2] = v[2]; out[3] = v[3];
  if (write_flipped(m, target)) {
    const int32_t x = out[kFlipA];
    out[kFlipA] = out[kFlipB];
    out[kFlipB] = x;
  }
}

/// parse_medit with the knobs of its parallel fast path (medit.cpp,
/// ParallelRecords) exposed for tests and fuzzing: sections of at least
/// min_records records take it, the rest of the file cut into `chunk`-byte
/// pieces.  parse_medit uses 20,000 and 1 MiB (threads != 1) or never.
Status parse_medit_tuned(std::string_view data, const std::string& name, TetMesh& m, int threads,
                         int64_t min_records, size_t chunk);

}  // namespace tetopt::detail
