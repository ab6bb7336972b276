// Private helpers shared by the format readers and writers.
#pragma once
#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstring>
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

/// A file name as a message shows it, so that the message stays one line and
/// prints no terminal escape: control characters as C escapes (\n, \r, \t,
/// \x1b, \x7f; the C1 controls U+0080-U+009F, UTF-8 C2 80 to C2 9F, as
/// \u0080-\u009f) and each byte that is not part of valid UTF-8 as \xNN.
/// Printable ASCII and valid UTF-8 stay as they are, and so does a backslash:
/// escaping a name twice changes nothing (a name with a literal "\n" in it
/// reads like one with a line break, but still on one line).  Every message
/// that names a file (the readers' "NAME:LINE: ..." prefix, write errors, the
/// command line's own lines) passes the name through this.
inline std::string escaped_name(std::string_view name) {
  static const char kHex[] = "0123456789abcdef";
  std::string s;
  s.reserve(name.size());
  auto hex = [&](const char* pre, unsigned c) {
    s += pre;
    s += kHex[(c >> 4) & 15];
    s += kHex[c & 15];
  };
  const size_t n = name.size();
  for (size_t i = 0; i < n;) {
    const auto c = static_cast<unsigned char>(name[i]);
    if (c >= 32 && c < 127) {
      s += static_cast<char>(c);
      ++i;
      continue;
    }
    if (c < 128) {
      if (c == '\n') s += "\\n";
      else if (c == '\r') s += "\\r";
      else if (c == '\t') s += "\\t";
      else hex("\\x", c);
      ++i;
      continue;
    }
    // The length of a valid UTF-8 sequence starting at i (RFC 3629: no
    // overlong forms, no surrogates, nothing past U+10FFFF), else 0.
    auto cont = [&](size_t k, unsigned lo = 0x80, unsigned hi = 0xBF) {
      if (i + k >= n) return false;
      const auto b = static_cast<unsigned char>(name[i + k]);
      return b >= lo && b <= hi;
    };
    size_t len = 0;
    if (c >= 0xC2 && c <= 0xDF) len = cont(1) ? 2 : 0;
    else if (c == 0xE0) len = cont(1, 0xA0) && cont(2) ? 3 : 0;
    else if (c == 0xED) len = cont(1, 0x80, 0x9F) && cont(2) ? 3 : 0;
    else if (c >= 0xE1 && c <= 0xEF) len = cont(1) && cont(2) ? 3 : 0;
    else if (c == 0xF0) len = cont(1, 0x90) && cont(2) && cont(3) ? 4 : 0;
    else if (c >= 0xF1 && c <= 0xF3) len = cont(1) && cont(2) && cont(3) ? 4 : 0;
    else if (c == 0xF4) len = cont(1, 0x80, 0x8F) && cont(2) && cont(3) ? 4 : 0;
    if (len == 0) {
      hex("\\x", c);
      ++i;
    } else if (c == 0xC2 && static_cast<unsigned char>(name[i + 1]) < 0xA0) {
      hex("\\u00", static_cast<unsigned char>(name[i + 1]));  // a C1 control
      i += 2;
    } else {
      s.append(name.substr(i, len));
      i += len;
    }
  }
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

/// The writers' number formatting, shared by the text and binary writers.
/// An integer in decimal.
inline void put_int(std::string& out, int64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}
/// A double in the shortest form that reads back bit-identical.
inline void put_real(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}
/// v's bytes in little-endian order (OpenFOAM "arch LSB", Fluent binary).
template <class T>
void put_raw_le(std::string& out, T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
  std::reverse(b, b + sizeof(T));
#endif
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
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

/// What the OpenFOAM writer cannot keep of m (dropped_by_format's part for
/// it; openfoam.cpp).
std::vector<std::string> openfoam_dropped(const TetMesh& m);
/// The same for the Fluent writer (fluent.cpp).
std::vector<std::string> fluent_dropped(const TetMesh& m);
/// The same for the Abaqus writer (abaqus.cpp).
std::vector<std::string> abaqus_dropped(const TetMesh& m);
/// The same for the CGNS and Exodus II writers (cgns.cpp, exodus.cpp).
std::vector<std::string> cgns_dropped(const TetMesh& m);
std::vector<std::string> exodus_dropped(const TetMesh& m);
/// format_cgns_file with the file type: 2 HDF5 (what it writes), 1 ADF
/// (smaller; the fuzz seeds).
Status write_cgns_typed(const TetMesh& m, const std::string& path, int file_type);
/// Whether .msh bytes are a Fluent mesh: the first thing after blanks (and
/// a UTF-8 byte order mark) is '(' (fluent.cpp).
bool looks_like_fluent(std::string_view data);

}  // namespace tetopt::detail
