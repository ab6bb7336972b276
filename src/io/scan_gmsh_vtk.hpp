// Private scanning helpers for the Gmsh and VTK readers and writers:
// a whitespace-token cursor that counts lines, exact number parsing and
// formatting (std::from_chars / std::to_chars, so coordinates round-trip
// bit for bit), little/big-endian loads and stores, and base64.
#pragma once
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>

#include "tetopt/io.hpp"

namespace tetopt::gvscan {

inline bool is_space(char c) {
  return c == ' ' || c == '\n' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

/// Parses the whole token as an integer (a leading '+' is accepted).
inline bool parse_int(std::string_view t, int64_t& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

/// Parses the whole token as a double (NaN / Inf are accepted here; callers
/// that need finite values check std::isfinite).  Integers written with a
/// trailing ".0" or an exponent are fine.
inline bool parse_double(std::string_view t, double& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  if (r.ec == std::errc::result_out_of_range) return false;
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

/// Parses the token as a float32 value (the declared type of the data),
/// widened to double: the same value VTK and meshio hold for it.
inline bool parse_float32(std::string_view t, double& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  float f = 0;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), f);
  if (r.ec != std::errc() || r.ptr != t.data() + t.size()) return false;
  v = f;
  return true;
}

/// A forward cursor over text (possibly with binary blocks) that keeps the
/// 1-based number of the line it is on.
struct Cursor {
  std::string_view s;
  size_t pos = 0;
  long line = 1;

  bool eof() const { return pos >= s.size(); }
  size_t remaining() const { return pos < s.size() ? s.size() - pos : 0; }
  void skip_ws() {
    while (pos < s.size()) {
      const char c = s[pos];
      if (c == '\n') {
        ++line;
        ++pos;
      } else if (is_space(c)) {
        ++pos;
      } else {
        break;
      }
    }
  }
  /// Next whitespace-separated token (empty at the end of the data).
  std::string_view token() {
    skip_ws();
    const size_t b = pos;
    while (pos < s.size() && !is_space(s[pos])) ++pos;
    return s.substr(b, pos - b);
  }
  /// Peeks at the next token without consuming it.
  std::string_view peek() {
    Cursor c = *this;
    return c.token();
  }
  /// The rest of the current line (without '\r'), moving past its '\n'.
  std::string_view rest_of_line() {
    const size_t b = pos;
    size_t e = s.find('\n', pos);
    std::string_view r;
    if (e == std::string_view::npos) {
      r = s.substr(b);
      pos = s.size();
    } else {
      r = s.substr(b, e - b);
      pos = e + 1;
      ++line;
    }
    while (!r.empty() && (r.back() == '\r' || r.back() == ' ' || r.back() == '\t')) r.remove_suffix(1);
    return r;
  }
};

// ---- binary loads / stores ----

template <class T>
T load(const char* p, bool big_endian) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (big_endian)
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

template <class T>
void store(std::string& out, T v, bool big_endian) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian)
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

// Loads and stores above assume a little-endian host; tetopt targets x86-64
// and AArch64 Linux (both little-endian).
static_assert(std::endian::native == std::endian::little, "tetopt I/O assumes a little-endian host");

// ---- text output ----

inline void put_int(std::string& out, int64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

/// Shortest decimal that reads back as the same double (std::to_chars).
inline void put_double(std::string& out, double v) {
  char buf[40];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

// ---- base64 (RFC 4648) ----

inline void base64_encode(std::string& out, const unsigned char* p, size_t n) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  size_t i = 0;
  for (; i + 3 <= n; i += 3) {
    const uint32_t w = (uint32_t(p[i]) << 16) | (uint32_t(p[i + 1]) << 8) | p[i + 2];
    out += kAlphabet[(w >> 18) & 63];
    out += kAlphabet[(w >> 12) & 63];
    out += kAlphabet[(w >> 6) & 63];
    out += kAlphabet[w & 63];
  }
  if (i < n) {
    uint32_t w = uint32_t(p[i]) << 16;
    if (i + 1 < n) w |= uint32_t(p[i + 1]) << 8;
    out += kAlphabet[(w >> 18) & 63];
    out += kAlphabet[(w >> 12) & 63];
    out += (i + 1 < n) ? kAlphabet[(w >> 6) & 63] : '=';
    out += '=';
  }
}

/// Decodes base64 text, skipping whitespace and accepting '=' padding in the
/// middle (VTK encodes a header and its data as separate base64 runs).
/// Returns false on a character outside the alphabet.
inline bool base64_decode(std::string_view in, std::string& out) {
  auto val = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  out.clear();
  out.reserve(in.size() / 4 * 3);
  int q[4];
  int nq = 0, npad = 0;
  for (char c : in) {
    if (is_space(c)) continue;
    if (c == '=') {
      if (nq < 2) return false;
      q[nq++] = 0;
      ++npad;
    } else {
      const int v = val(c);
      if (v < 0 || npad > 0) return false;
      q[nq++] = v;
    }
    if (nq == 4) {
      const uint32_t w = (uint32_t(q[0]) << 18) | (uint32_t(q[1]) << 12) | (uint32_t(q[2]) << 6) | uint32_t(q[3]);
      out += static_cast<char>((w >> 16) & 255);
      if (npad < 2) out += static_cast<char>((w >> 8) & 255);
      if (npad < 1) out += static_cast<char>(w & 255);
      nq = 0;
      npad = 0;
    }
  }
  if (nq == 2 || nq == 3) {  // unpadded tail
    uint32_t w = (uint32_t(q[0]) << 18) | (uint32_t(q[1]) << 12);
    if (nq == 3) w |= uint32_t(q[2]) << 6;
    out += static_cast<char>((w >> 16) & 255);
    if (nq == 3) out += static_cast<char>((w >> 8) & 255);
  } else if (nq != 0) {
    return false;
  }
  return true;
}

}  // namespace tetopt::gvscan

namespace tetopt::detail {
/// format_vtu with a choice of encoding: binary = base64 DataArrays (what
/// format_vtu writes), otherwise format="ascii" (17 significant digits).
Status format_vtu_encoded(const TetMesh& m, std::string& out, bool binary);
}  // namespace tetopt::detail
