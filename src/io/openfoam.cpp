// OpenFOAM polyMesh reader and writer (the folder constant/polyMesh).
//
// Written from the OpenFOAM user guide, section 4.1 "File structure of
// OpenFOAM cases" (FoamFile header, dictionaries, lists "N ( ... )", uniform
// lists "N{v}", comments // and /* */, binary lists whose '(' is followed by
// N raw items) and section 4.1.2 / 5.1 "Mesh description" (polyMesh: points,
// faces, owner, neighbour, boundary; a face's normal, by the right-hand rule
// of its vertex order, points out of its owner cell; owner < neighbour;
// internal faces first, ordered by owner and, for one owner, by neighbour
// ("upper-triangular order"); then the boundary faces patch by patch, each
// patch a contiguous block given by startFace and nFaces in `boundary`).
// Binary layouts and the `arch` entry ("LSB;label=32;scalar=64": byte
// order, label and scalar sizes in bits) were checked against files that
// Debian's OpenFOAM v1912 gmshToFoam writes (writeFormat binary): faces are
// then a faceCompactList (offsets, nFaces + 1 labels, then the vertex ids),
// a List<bool> (flipMap) is one byte per item.  Zones (cellZones, faceZones,
// pointZones) are lists of dictionaries: name { type cellZone; cellLabels
// List<label> N(...); }, faceZones with flipMap List<bool> N(...).
//
// What tetopt keeps (docs/formats.md): tets only (each cell four triangles);
// patches become listed triangles, in face order, with tri_ref the patch's
// number (1-based in file order) and the patch's name as physical name
// (dim 2); its type and other entries go to the attachment (attachment.hpp).
// faceZones list their faces as triangles too (refs after the patches;
// a flipped face is listed with its second and third vertices exchanged),
// cellZones give tet refs (cells in none: ref 0; a cell in two is refused),
// pointZones vertex refs.  A group whose ref is not the number the
// position gives carries it in a `tetoptRef` entry (OpenFOAM ignores
// entries it does not know), so Gmsh -> polyMesh -> Gmsh keeps refs.
// The cells' vertex order is not in the file: every tet is read in the
// canonical order of face_cells.hpp.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "io/checked.hpp"
#include "io/common.hpp"
#include "io/face_cells.hpp"
#include "tetopt/io.hpp"

namespace tetopt {

namespace {

constexpr int64_t kMaxLabel = std::numeric_limits<int32_t>::max();

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }
bool is_punct(char c) { return c == '(' || c == ')' || c == '{' || c == '}' || c == ';' || c == '"'; }

std::string shown_tok(std::string_view t) { return detail::shown_token(t, true); }

bool parse_int(std::string_view t, int64_t& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return !t.empty() && r.ec == std::errc{} && r.ptr == t.data() + t.size();
}
bool parse_real(std::string_view t, double& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || r.ptr != t.data() + t.size()) return false;
  if (r.ec == std::errc::result_out_of_range) {  // underflow reads as 0, overflow fails
    const std::string s(t);
    v = std::strtod(s.c_str(), nullptr);
    return !std::isinf(v);
  }
  return r.ec == std::errc{} && std::isfinite(v);
}

/// One file of the folder: FoamFile header, then the body, read token by
/// token; binary lists are read as raw bytes.
class FoamFile {
 public:
  FoamFile(std::string_view d, std::string name) : d_(d), name_(std::move(name)) {}

  bool binary = false, msb = false;
  int label_bytes = 4, scalar_bytes = 8;
  std::string cls;

  Status fail(const std::string& what, size_t at = std::string::npos) const {
    if (at == std::string::npos) at = pos_;
    at = std::min(at, d_.size());
    const long line = 1 + static_cast<long>(std::count(d_.begin(), d_.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    return Status::error(ErrorCode::Parse, name_ + ":" + std::to_string(line) + ": " + what, line);
  }
  Status unsupported(const std::string& what) const {
    Status s = fail(what);
    s.code = ErrorCode::Unsupported;
    return s;
  }

  /// Skips blanks and comments.
  void skip() {
    for (;;) {
      while (pos_ < d_.size() && is_space(d_[pos_])) ++pos_;
      if (pos_ + 1 < d_.size() && d_[pos_] == '/' && d_[pos_ + 1] == '/') {
        const size_t e = d_.find('\n', pos_);
        pos_ = e == std::string_view::npos ? d_.size() : e + 1;
      } else if (pos_ + 1 < d_.size() && d_[pos_] == '/' && d_[pos_ + 1] == '*') {
        const size_t e = d_.find("*/", pos_ + 2);
        pos_ = e == std::string_view::npos ? d_.size() : e + 2;
      } else {
        return;
      }
    }
  }
  bool at_end() {
    skip();
    return pos_ >= d_.size();
  }
  /// The next character after blanks and comments, or 0 at the end.
  char peek() {
    skip();
    return pos_ < d_.size() ? d_[pos_] : '\0';
  }
  Status expect(char c, const char* where) {
    const char p = peek();
    if (p != c) {
      if (pos_ >= d_.size()) return fail(std::string("file ends where '") + c + "' was expected " + where);
      return fail(std::string("expected '") + c + "' " + where + ", found '" + shown_tok(d_.substr(pos_, 1)) + "'");
    }
    ++pos_;
    return Status::success();
  }
  /// A word, a number or a quoted string (with its quotes); empty at the end
  /// or at punctuation.
  std::string_view word() {
    skip();
    if (pos_ >= d_.size()) return {};
    const size_t b = pos_;
    if (d_[pos_] == '"') {
      const size_t e = d_.find('"', pos_ + 1);
      pos_ = e == std::string_view::npos ? d_.size() : e + 1;
      return d_.substr(b, pos_ - b);
    }
    while (pos_ < d_.size() && !is_space(d_[pos_]) && !is_punct(d_[pos_])) {
      if (d_[pos_] == '/' && pos_ + 1 < d_.size() && (d_[pos_ + 1] == '/' || d_[pos_ + 1] == '*')) break;
      ++pos_;
    }
    return d_.substr(b, pos_ - b);
  }
  Status integer(int64_t& v, const char* what) {
    const size_t at = (skip(), pos_);
    const std::string_view w = word();
    if (w.empty()) return pos_ >= d_.size() ? fail(std::string("file ends where ") + what + " was expected")
                                            : fail(std::string("expected ") + what + ", found '" + shown_tok(d_.substr(pos_, 1)) + "'");
    if (!parse_int(w, v)) return fail(std::string("expected ") + what + ", found '" + shown_tok(w) + "'", at);
    return Status::success();
  }
  size_t pos() const { return pos_; }
  void seek(size_t p) { pos_ = p; }
  size_t left() const { return d_.size() - std::min(pos_, d_.size()); }

  /// The FoamFile header: format, arch and class.
  Status header() {
    const std::string_view w = word();
    if (w != "FoamFile") return fail(w.empty() && pos_ >= d_.size() ? std::string("empty file (no FoamFile header)")
                                                                     : "expected the FoamFile header, found '" + shown_tok(w) + "'");
    if (Status s = expect('{', "after FoamFile"); !s) return s;
    while (peek() != '}') {
      if (pos_ >= d_.size()) return fail("file ends inside the FoamFile header");
      const std::string_view key = word();
      if (key.empty()) return fail("unexpected '" + shown_tok(d_.substr(pos_, 1)) + "' in the FoamFile header");
      std::string value;
      while (peek() != ';') {
        if (pos_ >= d_.size() || peek() == '}') return fail("entry '" + shown_tok(key) + "' of the FoamFile header has no ';'");
        const std::string_view v = word();
        if (v.empty()) return fail("unexpected '" + shown_tok(d_.substr(pos_, 1)) + "' in the FoamFile header");
        value.append(v);
      }
      ++pos_;
      if (value.size() >= 2 && value.front() == '"' && value.back() == '"') value = value.substr(1, value.size() - 2);
      if (key == "format") {
        if (value == "binary") binary = true;
        else if (value != "ascii") return unsupported("format '" + shown_tok(value) + "' (ascii or binary)");
      } else if (key == "class") {
        cls = value;
      } else if (key == "arch") {
        // "LSB;label=32;scalar=64"
        size_t b = 0;
        while (b <= value.size()) {
          size_t e = value.find(';', b);
          if (e == std::string::npos) e = value.size();
          const std::string part = value.substr(b, e - b);
          if (part == "MSB") msb = true;
          else if (part == "LSB") msb = false;
          else if (part == "label=32") label_bytes = 4;
          else if (part == "label=64") label_bytes = 8;
          else if (part == "scalar=32") scalar_bytes = 4;
          else if (part == "scalar=64") scalar_bytes = 8;
          else if (!part.empty()) return unsupported("arch entry '" + shown_tok(part) + "' (LSB or MSB, label=32/64, scalar=32/64)");
          b = e + 1;
        }
      }
    }
    ++pos_;
    return Status::success();
  }

  /// Reads raw item k (of `bytes` bytes) at p in the file's byte order.
  uint64_t raw(const char* p, int bytes) const {
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) {
      const auto b = static_cast<unsigned char>(p[msb ? i : bytes - 1 - i]);
      v = (v << 8) | b;
    }
    return v;
  }

  /// A list's count, then its opening: '(' (items follow; returns false in
  /// uniform) or '{' (one item follows: uniform = true).  max_n bounds the
  /// count where the caller knows one (-1: none), min_bytes is the least
  /// an ASCII item takes with its separator; a count that the bytes left
  /// cannot hold is refused before anything is allocated.
  Status open_list(int64_t& n, bool& uniform, int64_t max_n, int64_t min_bytes, int64_t raw_bytes, const char* what) {
    skip();
    const size_t at = pos_;
    if (peek() == '(') {  // a list without a count (ASCII only); unsupported to keep counts checked
      return unsupported(std::string(what) + ": a list without its count before '(' (tetopt reads counted lists)");
    }
    if (Status s = integer(n, (std::string("the count of ") + what).c_str()); !s) return s;
    if (n < 0) return fail(std::string(what) + ": negative count " + std::to_string(n), at);
    if (max_n >= 0 && n > max_n)
      return fail(std::string(what) + ": count " + std::to_string(n) + " is larger than " + std::to_string(max_n) +
                  " (the file says so elsewhere)", at);
    const char c = peek();
    if (c == '{') {
      ++pos_;
      uniform = true;
      if (max_n < 0) return unsupported(std::string(what) + ": a uniform list N{...} here");
      return Status::success();
    }
    if (c != '(') return fail(std::string("expected '(' after the count of ") + what);
    ++pos_;
    uniform = false;
    uint64_t need = 0;
    const int64_t per = binary ? raw_bytes : min_bytes;
    if (!detail::ck_mul(static_cast<uint64_t>(n), static_cast<uint64_t>(per), need) ||
        need > static_cast<uint64_t>(left()) + (binary ? 0 : static_cast<uint64_t>(per)))
      return fail(std::string(what) + ": count " + std::to_string(n) + " is more than the file holds", at);
    return Status::success();
  }
  Status close_list(char c, const char* what) {
    return expect(c, (std::string("at the end of ") + what).c_str());
  }

  /// A label in the text, checked against 0..hi (lo may be -1).
  Status label_text(int64_t lo, int64_t hi, int64_t& v, const char* what) {
    const size_t at = (skip(), pos_);
    if (Status s = integer(v, what); !s) return s;
    if (v < lo || v > hi) return fail(std::string(what) + " " + std::to_string(v) + " out of range " + std::to_string(lo) + ".." + std::to_string(hi), at);
    return Status::success();
  }
  Status label_raw(int64_t lo, int64_t hi, int64_t& v, const char* what) {
    const uint64_t u = raw(d_.data() + pos_, label_bytes);
    v = label_bytes == 4 ? static_cast<int64_t>(static_cast<int32_t>(static_cast<uint32_t>(u))) : static_cast<int64_t>(u);
    if (v < lo || v > hi) return fail(std::string(what) + " " + std::to_string(v) + " out of range " + std::to_string(lo) + ".." + std::to_string(hi));
    pos_ += static_cast<size_t>(label_bytes);
    return Status::success();
  }

  /// A labelList (or List<label>): values in lo..hi.
  Status labels(std::vector<int32_t>& out, int64_t max_n, int64_t lo, int64_t hi, const char* what) {
    int64_t n = 0;
    bool uniform = false;
    if (Status s = open_list(n, uniform, max_n, 2, label_bytes, what); !s) return s;
    out.clear();
    int64_t v = 0;
    if (uniform) {
      if (binary) {
        if (left() < static_cast<size_t>(label_bytes)) return fail(std::string(what) + ": file ends inside the list");
        if (Status s = label_raw(lo, hi, v, what); !s) return s;
      } else if (Status s = label_text(lo, hi, v, what); !s) {
        return s;
      }
      out.assign(static_cast<size_t>(n), static_cast<int32_t>(v));
      return close_list('}', what);
    }
    out.reserve(static_cast<size_t>(n));
    for (int64_t i = 0; i < n; ++i) {
      if (binary) {
        if (Status s = label_raw(lo, hi, v, what); !s) return s;
      } else if (Status s = label_text(lo, hi, v, what); !s) {
        return s;
      }
      out.push_back(static_cast<int32_t>(v));
    }
    return close_list(')', what);
  }

  /// A List<bool>: ASCII 0/1/true/false/on/off/yes/no, binary one byte each.
  Status bools(std::vector<uint8_t>& out, int64_t max_n, const char* what) {
    int64_t n = 0;
    bool uniform = false;
    if (Status s = open_list(n, uniform, max_n, 2, 1, what); !s) return s;
    auto one = [&](uint8_t& b) -> Status {
      if (binary) {
        if (left() < 1) return fail(std::string(what) + ": file ends inside the list");
        b = d_[pos_++] != 0;
        return Status::success();
      }
      const size_t at = (skip(), pos_);
      const std::string_view w = word();
      if (w == "1" || w == "true" || w == "on" || w == "yes") b = 1;
      else if (w == "0" || w == "false" || w == "off" || w == "no") b = 0;
      else return fail(std::string(what) + ": expected a bool, found '" + shown_tok(w) + "'", at);
      return Status::success();
    };
    out.clear();
    if (uniform) {
      uint8_t b = 0;
      if (Status s = one(b); !s) return s;
      out.assign(static_cast<size_t>(n), b);
      return close_list('}', what);
    }
    out.reserve(static_cast<size_t>(n));
    for (int64_t i = 0; i < n; ++i) {
      uint8_t b = 0;
      if (Status s = one(b); !s) return s;
      out.push_back(b);
    }
    return close_list(')', what);
  }

  /// A vectorField: 3 scalars per item.
  Status vectors(std::vector<double>& xyz, const char* what) {
    int64_t n = 0;
    bool uniform = false;
    if (Status s = open_list(n, uniform, -1, 8, 3 * static_cast<int64_t>(scalar_bytes), what); !s) return s;
    if (n > kMaxLabel) return unsupported(std::string(what) + ": more than 2^31-1 points");
    xyz.clear();
    xyz.reserve(detail::ck_size(n, 3));
    for (int64_t i = 0; i < n; ++i) {
      if (binary) {
        for (int k = 0; k < 3; ++k) {
          const uint64_t u = raw(d_.data() + pos_, scalar_bytes);
          double x;
          if (scalar_bytes == 8) {
            std::memcpy(&x, &u, 8);
          } else {
            const auto u32 = static_cast<uint32_t>(u);
            float f;
            std::memcpy(&f, &u32, 4);
            x = f;
          }
          if (!std::isfinite(x)) return fail(std::string(what) + ": point " + std::to_string(i) + " has a coordinate that is not a finite number");
          xyz.push_back(x);
          pos_ += static_cast<size_t>(scalar_bytes);
        }
        continue;
      }
      if (Status s = expect('(', "before a point"); !s) return s;
      for (int k = 0; k < 3; ++k) {
        const size_t at = (skip(), pos_);
        const std::string_view w = word();
        double x = 0;
        if (!parse_real(w, x)) return fail(std::string(what) + ": point " + std::to_string(i) + ": expected a finite number, found '" + shown_tok(w) + "'", at);
        xyz.push_back(x);
      }
      if (Status s = expect(')', "after a point's three coordinates"); !s) return s;
    }
    return close_list(')', what);
  }

  /// A faceList: each face a labelList of three vertex ids.
  Status face_list(std::vector<int32_t>& faces, int64_t nv, int64_t& nfaces) {
    int64_t n = 0;
    bool uniform = false;
    if (Status s = open_list(n, uniform, -1, 9, 3 * static_cast<int64_t>(label_bytes), "faces"); !s) return s;
    faces.clear();
    faces.reserve(detail::ck_size(n, 3));
    std::vector<int32_t> f;
    for (int64_t i = 0; i < n; ++i) {
      const size_t at = (skip(), pos_);
      if (Status s = labels(f, 1 << 16, 0, nv - 1, "vertex id"); !s) return s;
      if (f.size() != 3) {
        Status s = fail("face " + std::to_string(i) + " has " + std::to_string(f.size()) +
                        " vertices (only tetrahedral meshes, triangle faces, are supported)", at);
        s.code = ErrorCode::Unsupported;
        return s;
      }
      faces.insert(faces.end(), f.begin(), f.end());
    }
    nfaces = n;
    return close_list(')', "faces");
  }

 private:
  std::string_view d_;
  std::string name_;
  size_t pos_ = 0;
};

/// A group of the boundary or a zone file, as read.
struct Group {
  std::string name;
  std::string type;
  std::string entries;  // further entries, tokens joined by blanks
  bool has_ref = false;
  int64_t ref = 0;
  int64_t n_faces = -1, start_face = -1;
  std::vector<int32_t> labels;
  std::vector<uint8_t> flips;
};

/// Reads one entry's value tokens up to its ';' (or a sub-dictionary), as
/// text (tokens joined by blanks); the key is read already.
Status entry_text(FoamFile& f, std::string& text, std::vector<std::string_view>* tokens) {
  int depth = 0;
  if (f.peek() == '{') {  // a sub-dictionary: kept whole
    for (;;) {
      const char c = f.peek();
      if (c == '\0') return f.fail("file ends inside a sub-dictionary");
      if (c == '{' || c == '}' || c == ';' || c == '(' || c == ')') {
        f.expect(c, "");
        text += c;
        text += ' ';
        if (c == '{') ++depth;
        if (c == '}' && --depth == 0) return Status::success();
        continue;
      }
      const std::string_view w = f.word();
      text.append(w);
      text += ' ';
    }
  }
  for (;;) {
    const char c = f.peek();
    if (c == '\0') return f.fail("file ends inside an entry (no ';')");
    if (c == ';' && depth == 0) {
      f.expect(';', "");
      while (!text.empty() && text.back() == ' ') text.pop_back();
      text += ';';
      return Status::success();
    }
    if (c == '}' && depth == 0) return f.fail("entry has no ';' before '}'");
    if (c == '(' || c == ')' || c == '{' || c == '}' || c == ';') {
      f.expect(c, "");
      if (c == '(' || c == '{') ++depth;
      if ((c == ')' || c == '}') && --depth < 0) return f.fail(std::string("unbalanced '") + c + "'");
      text += c;
      text += ' ';
      continue;
    }
    const std::string_view w = f.word();
    if (tokens) tokens->push_back(w);
    text.append(w);
    text += ' ';
  }
}

/// A list of dictionaries: `boundary` (patches) or a zone file.  labels_key:
/// "cellLabels" etc. (nullptr for the boundary); max_label: the largest id
/// those may hold.
Status groups(FoamFile& f, std::vector<Group>& out, const char* labels_key, int64_t max_label, int64_t max_faces) {
  int64_t n = 0;
  bool uniform = false;
  if (Status s = f.open_list(n, uniform, -1, 4, 4, labels_key ? "zones" : "patches"); !s) return s;
  if (uniform) return f.unsupported("a uniform list of patches or zones");
  // open_list read '('; binary files hold these dictionaries as text.
  for (int64_t i = 0; i < n; ++i) {
    Group g;
    const size_t at = (f.skip(), f.pos());
    const std::string_view name = f.word();
    if (name.empty()) return f.fail("expected a patch or zone name");
    if (name.front() == '"') return f.fail("a quoted patch or zone name '" + shown_tok(name) + "'", at);
    g.name = std::string(name);
    if (Status s = f.expect('{', "after a patch or zone name"); !s) return s;
    while (f.peek() != '}') {
      const size_t kat = (f.skip(), f.pos());
      const std::string_view key = f.word();
      if (key.empty()) return f.at_end() ? f.fail("file ends inside the dictionary of '" + shown_tok(g.name) + "'")
                                         : f.fail("unexpected '" + shown_tok(std::string(1, f.peek())) + "' in the dictionary of '" + shown_tok(g.name) + "'");
      if (labels_key && (key == labels_key || key == "flipMap")) {
        // "List<label>" / "List<bool>" may stand before the count
        const size_t save = (f.skip(), f.pos());
        if (f.word().substr(0, 4) != "List") f.seek(save);
        if (key == "flipMap") {
          if (Status s = f.bools(g.flips, max_faces, "flipMap"); !s) return s;
        } else if (Status s = f.labels(g.labels, max_label + 1, 0, max_label, labels_key); !s) {
          return s;
        }
        if (Status s = f.expect(';', (std::string("after ") + std::string(key)).c_str()); !s) return s;
        continue;
      }
      std::string text(key);
      text += ' ';
      std::vector<std::string_view> toks;
      if (Status s = entry_text(f, text, &toks); !s) return s;
      auto one_int = [&](int64_t& v) -> Status {
        if (toks.size() != 1 || !parse_int(toks[0], v))
          return f.fail("entry '" + shown_tok(key) + "' of '" + shown_tok(g.name) + "' is not one integer", kat);
        return Status::success();
      };
      if (key == "type") {
        if (toks.size() != 1) return f.fail("entry 'type' of '" + shown_tok(g.name) + "' is not one word", kat);
        g.type = std::string(toks[0]);
      } else if (!labels_key && key == "nFaces") {
        if (Status s = one_int(g.n_faces); !s) return s;
      } else if (!labels_key && key == "startFace") {
        if (Status s = one_int(g.start_face); !s) return s;
      } else if (key == "tetoptRef") {
        if (Status s = one_int(g.ref); !s) return s;
        if (g.ref < std::numeric_limits<int32_t>::min() || g.ref > kMaxLabel)
          return f.fail("tetoptRef " + std::to_string(g.ref) + " of '" + shown_tok(g.name) + "' out of the 32-bit range", kat);
        g.has_ref = true;
      } else {
        if (!g.entries.empty()) g.entries += ' ';
        while (!text.empty() && text.back() == ' ') text.pop_back();
        g.entries += text;
      }
    }
    if (Status s = f.expect('}', "at the end of a dictionary"); !s) return s;
    out.push_back(std::move(g));
  }
  return f.close_list(')', labels_key ? "the zones" : "the patches");
}

/// Refs for a list of groups: tetoptRef where given, else position + 1 +
/// offset (the writer gives a tetoptRef to every group whose ref is not
/// that).  Two groups may share a ref: a patch and a faceZone of one ref.
void assign_refs(std::vector<Group*>& gs, int64_t offset) {
  for (size_t i = 0; i < gs.size(); ++i)
    if (!gs[i]->has_ref) gs[i]->ref = static_cast<int64_t>(i) + 1 + offset;
}

}  // namespace

Status parse_openfoam(const std::string_view* files, const std::string& dir, TetMesh& m) {
  m = TetMesh{};
  auto named = [&](int k) { return dir + "/" + kFoamFileNames[k]; };
  auto open = [&](int k, FoamFile& f, const char* want) -> Status {
    if (Status s = f.header(); !s) return s;
    if (want && !f.cls.empty() && f.cls != want && !(k == 1 && f.cls == "faceCompactList"))
      return f.unsupported("class '" + shown_tok(f.cls) + "' (expected " + want + ")");
    return Status::success();
  };
  // points
  FoamFile fp(files[0], named(0));
  if (Status s = open(0, fp, "vectorField"); !s) return s;
  if (Status s = fp.vectors(m.xyz, "points"); !s) return s;
  const int64_t nv = m.nv();
  // faces
  FoamFile ff(files[1], named(1));
  if (Status s = open(1, ff, "faceList"); !s) return s;
  std::vector<int32_t> faces;
  int64_t nfaces = 0;
  if (ff.cls == "faceCompactList") {
    std::vector<int32_t> offsets, flat;
    if (Status s = ff.labels(offsets, -1, 0, kMaxLabel, "face offsets"); !s) return s;
    if (Status s = ff.labels(flat, -1, 0, nv - 1, "face vertex ids"); !s) return s;
    if (offsets.empty() || offsets[0] != 0) return ff.fail("faces: the offsets do not start with 0");
    nfaces = static_cast<int64_t>(offsets.size()) - 1;
    for (int64_t i = 0; i < nfaces; ++i)
      if (offsets[i + 1] - static_cast<int64_t>(offsets[i]) != 3) {
        Status s = ff.fail("face " + std::to_string(i) + " has " + std::to_string(static_cast<int64_t>(offsets[i + 1]) - offsets[i]) +
                           " vertices (only tetrahedral meshes, triangle faces, are supported)");
        s.code = ErrorCode::Unsupported;
        return s;
      }
    if (static_cast<int64_t>(flat.size()) != 3 * nfaces)
      return ff.fail("faces: the offsets end at " + std::to_string(offsets.back()) + " but " + std::to_string(flat.size()) + " vertex ids follow");
    faces = std::move(flat);
  } else if (Status s = ff.face_list(faces, nv, nfaces); !s) {
    return s;
  }
  if (nfaces > kMaxLabel) return ff.unsupported("more than 2^31-1 faces");
  // owner, neighbour
  FoamFile fo(files[2], named(2));
  if (Status s = open(2, fo, "labelList"); !s) return s;
  std::vector<int32_t> owner, neighbour;
  if (Status s = fo.labels(owner, nfaces, 0, kMaxLabel, "owner cell"); !s) return s;
  if (static_cast<int64_t>(owner.size()) != nfaces)
    return fo.fail("owner lists " + std::to_string(owner.size()) + " cells for " + std::to_string(nfaces) + " faces");
  FoamFile fn(files[3], named(3));
  if (Status s = open(3, fn, "labelList"); !s) return s;
  if (Status s = fn.labels(neighbour, nfaces, -1, kMaxLabel, "neighbour cell"); !s) return s;
  // Old files list a neighbour per face, -1 on the boundary.
  int64_t ninternal = static_cast<int64_t>(neighbour.size());
  for (int64_t i = 0; i < static_cast<int64_t>(neighbour.size()); ++i)
    if (neighbour[i] < 0) { ninternal = i; break; }
  for (int64_t i = ninternal; i < static_cast<int64_t>(neighbour.size()); ++i)
    if (neighbour[i] >= 0) return fn.fail("neighbour of face " + std::to_string(i) + " follows a boundary face's -1");
  int64_t ncells = 0;
  for (int64_t i = 0; i < nfaces; ++i) {
    ncells = std::max<int64_t>(ncells, static_cast<int64_t>(owner[i]) + 1);
    if (i < ninternal) {
      ncells = std::max<int64_t>(ncells, static_cast<int64_t>(neighbour[i]) + 1);
      if (neighbour[i] == owner[i]) return fn.fail("face " + std::to_string(i) + " has the same cell " + std::to_string(owner[i]) + " on both sides");
    }
  }
  // Four faces per tet, each on at most two: 4 * ncells <= 2 * nfaces,
  // checked before any per-cell array is sized.
  if (ncells == 0) return fo.fail("no cells");
  {
    int64_t need = 0, have = 0;
    if (!detail::ck_mul(ncells, int64_t{4}, need) || !detail::ck_add(nfaces, ninternal, have) || need > have)
      return fo.fail(std::to_string(ncells) + " cells cannot be tetrahedra with " + std::to_string(nfaces) + " faces (" +
                     std::to_string(ninternal) + " internal)");
  }
  std::vector<int32_t> second(static_cast<size_t>(nfaces), -1);
  for (int64_t i = 0; i < ninternal; ++i) second[i] = neighbour[i];
  {
    std::string what;
    int64_t bad = 0;
    if (!detail::tets_from_faces(faces, owner, second, ncells, m.tets, what, bad)) {
      Status s = fo.fail("cell " + std::to_string(bad) + " " + what);
      if (what.find("supported") != std::string::npos) s.code = ErrorCode::Unsupported;
      return s;
    }
  }
  // boundary
  FoamFile fb(files[4], named(4));
  if (files[4].empty() && nfaces > ninternal) return Status::error(ErrorCode::Parse, named(4) + ": missing (the mesh has boundary faces)");
  std::vector<Group> patches;
  if (!files[4].empty()) {
    if (Status s = open(4, fb, "polyBoundaryMesh"); !s) return s;
    if (Status s = groups(fb, patches, nullptr, 0, nfaces); !s) return s;
  }
  int64_t start = ninternal;
  for (const Group& g : patches) {
    if (g.n_faces < 0 || g.start_face < 0)
      return fb.fail("patch '" + shown_tok(g.name) + "' lacks nFaces or startFace");
    if (g.start_face != start)
      return fb.fail("patch '" + shown_tok(g.name) + "' starts at face " + std::to_string(g.start_face) + ", not " +
                     std::to_string(start) + " (patches follow the internal faces and each other)");
    if (g.n_faces > nfaces - start)
      return fb.fail("patch '" + shown_tok(g.name) + "' has " + std::to_string(g.n_faces) + " faces; only " +
                     std::to_string(nfaces - start) + " are left");
    start += g.n_faces;
  }
  if (start != nfaces)
    return fb.fail("the patches hold faces " + std::to_string(ninternal) + ".." + std::to_string(start - 1) + ", but the mesh has " +
                   std::to_string(nfaces) + " faces");
  // zones (optional files)
  std::vector<Group> zones[3];  // cell, face, point
  const int64_t zmax[3] = {ncells - 1, nfaces - 1, nv - 1};
  const char* zkey[3] = {"cellLabels", "faceLabels", "pointLabels"};
  const char* zcls[3] = {"cellZone", "faceZone", "pointZone"};
  for (int z = 0; z < 3; ++z) {
    if (files[5 + z].empty()) continue;
    FoamFile fz(files[5 + z], named(5 + z));
    if (Status s = open(5 + z, fz, nullptr); !s) return s;
    if (Status s = groups(fz, zones[z], zkey[z], zmax[z], nfaces); !s) return s;
    for (const Group& g : zones[z]) {
      if (z == 1 && !g.flips.empty() && g.flips.size() != g.labels.size())
        return fz.fail("faceZone '" + shown_tok(g.name) + "': flipMap has " + std::to_string(g.flips.size()) + " entries for " +
                       std::to_string(g.labels.size()) + " faces");
      if (z != 1 && g.has_ref && g.ref == 0)
        return fz.fail(std::string(zcls[z]) + " '" + shown_tok(g.name) + "': tetoptRef 0 (the ref of no zone)");
    }
  }
  // refs: patches then faceZones share the triangle refs
  std::vector<Group*> tri_groups;
  for (Group& g : patches) tri_groups.push_back(&g);
  for (Group& g : zones[1]) tri_groups.push_back(&g);
  assign_refs(tri_groups, 0);
  std::vector<Group*> cz, pz;
  for (Group& g : zones[0]) cz.push_back(&g);
  for (Group& g : zones[2]) pz.push_back(&g);
  assign_refs(cz, 0);
  assign_refs(pz, 0);
  // triangles
  size_t ntri = static_cast<size_t>(nfaces - ninternal);
  for (const Group& g : zones[1]) ntri += g.labels.size();
  m.tris.reserve(3 * ntri);
  m.tri_ref.reserve(ntri);
  int64_t f0 = ninternal;
  for (const Group& g : patches) {
    for (int64_t i = f0; i < f0 + g.n_faces; ++i) {
      m.tris.insert(m.tris.end(), faces.begin() + 3 * i, faces.begin() + 3 * i + 3);
      m.tri_ref.push_back(static_cast<int32_t>(g.ref));
    }
    f0 += g.n_faces;
  }
  for (const Group& g : zones[1])
    for (size_t i = 0; i < g.labels.size(); ++i) {
      const int32_t* p = &faces[3 * static_cast<size_t>(g.labels[i])];
      const bool flip = !g.flips.empty() && g.flips[i];
      m.tris.push_back(p[0]);
      m.tris.push_back(flip ? p[2] : p[1]);
      m.tris.push_back(flip ? p[1] : p[2]);
      m.tri_ref.push_back(static_cast<int32_t>(g.ref));
    }
  // cell and point zones -> refs
  m.tet_ref.assign(static_cast<size_t>(ncells), 0);
  m.vert_ref.assign(static_cast<size_t>(nv), 0);
  for (int z = 0; z < 3; z += 2) {
    std::vector<uint8_t> in(static_cast<size_t>(z == 0 ? ncells : nv), 0);
    std::vector<int32_t>& refs = z == 0 ? m.tet_ref : m.vert_ref;
    for (const Group& g : zones[z])
      for (int32_t c : g.labels) {
        if (in[c])
          return Status::error(ErrorCode::Unsupported, named(5 + z) + ": " + (z == 0 ? "cell " : "point ") + std::to_string(c) +
                                                           " is in two " + zcls[z] + "s (tetopt gives each one ref)");
        in[c] = 1;
        refs[c] = static_cast<int32_t>(g.ref);
      }
  }
  // names and the attachment, in file order
  auto keep = [&](const Group& g, int dim, const char* kind) {
    m.physical_names.push_back(PhysicalName{dim, static_cast<int>(g.ref), g.name});
    GroupAttachment& a = m.attachment.get(dim, static_cast<int32_t>(g.ref));
    if (a.foam_kind.empty() || std::string(kind) == "patch") a.foam_kind = kind;
    if (std::string(kind) == "patch") {
      a.foam_type = g.type;
      a.foam_entries = g.entries;
    }
  };
  for (const Group& g : patches) keep(g, 2, "patch");
  for (const Group& g : zones[1]) keep(g, 2, "faceZone");
  for (const Group& g : zones[0]) keep(g, 3, "cellZone");
  for (const Group& g : zones[2]) keep(g, 0, "pointZone");
  // One name per (dim, ref): a patch and a faceZone given the same ref keep the first.
  {
    std::vector<PhysicalName> uniq;
    for (const PhysicalName& p : m.physical_names) {
      bool dup = false;
      for (const PhysicalName& q : uniq) dup = dup || (q.dim == p.dim && q.tag == p.tag);
      if (!dup) uniq.push_back(p);
    }
    m.physical_names = std::move(uniq);
  }
  return Status::success();
}

// ---------------------------------------------------------------- writer ----

namespace {

/// A name as an OpenFOAM word: no blanks, quotes, punctuation of the
/// syntax, not empty and not starting like a number.  changed: set when
/// the name had to change.
std::string foam_word(const std::string& name, bool& changed) {
  std::string w = name;
  for (char& c : w) {
    const auto u = static_cast<unsigned char>(c);
    if (u <= 32 || u == 127 || std::strchr("\"'/;{}()[]$#\\", c)) c = '_';
  }
  if (w.empty() || std::isdigit(static_cast<unsigned char>(w[0])) || w[0] == '-' || w[0] == '+' || w[0] == '.') w = "_" + w;
  changed = w != name;
  return w;
}

/// The groups the writer makes, shared with openfoam_dropped.
struct Plan {
  std::vector<detail::WrittenFace> faces;  // in written order
  std::vector<int32_t> owner, neighbour;
  int64_t ninternal = 0;
  struct Out {
    std::string name;
    int32_t ref = 0;
    bool has_ref_entry = false;
    std::string type, entries;
    int64_t start = 0, count = 0;  // patches
    std::vector<int32_t> labels;   // zones
    std::vector<uint8_t> flips;
  };
  std::vector<Out> patches, face_zones, cell_zones, point_zones;
  int64_t unmatched_tris = 0, inward_tris = 0, renamed = 0;
};

const std::string* name_of(const TetMesh& m, int dim, int32_t ref) {
  for (const PhysicalName& p : m.physical_names)
    if (p.dim == dim && p.tag == ref) return &p.name;
  return nullptr;
}

Status make_plan(const TetMesh& m, Plan& plan) {
  std::vector<detail::WrittenFace> faces;
  std::vector<std::array<int32_t, 3>> keys;
  std::string what;
  if (!detail::faces_of_tets(m, Format::OpenFoam, faces, &keys, what)) return Status::error(ErrorCode::InvalidMesh, what);
  const size_t nf = faces.size();
  // Listed triangles onto faces: the first listing of a boundary face puts
  // it in the patch of its ref; every other listing (an internal face, or a
  // boundary face listed again) in the faceZone of its ref.
  const int32_t ntri = m.ntri();
  std::vector<int32_t> patch_tri(nf, -1);
  struct ZoneFace {
    int32_t ref;
    int32_t face;
    int32_t tri;
  };
  std::vector<ZoneFace> zone_faces;
  std::vector<std::pair<int32_t, int32_t>> tri_face;  // (tri, face) of the patch triangles, in tri order
  for (int32_t t = 0; t < ntri; ++t) {
    const int32_t* p = &m.tris[3 * static_cast<size_t>(t)];
    const auto k = detail::tri_key(p);
    const auto it = std::lower_bound(keys.begin(), keys.end(), k);
    if (it == keys.end() || *it != k || k[0] == k[1] || k[1] == k[2]) {
      ++plan.unmatched_tris;
      continue;
    }
    const auto f = static_cast<int32_t>(it - keys.begin());
    if (faces[f].second < 0 && patch_tri[f] < 0) {
      patch_tri[f] = t;
      tri_face.emplace_back(t, f);
    } else {
      zone_faces.push_back(ZoneFace{m.tri_ref[t], f, t});
    }
  }
  // Patch order: the attachment's patches (file order), then the refs of
  // boundary triangles, ascending; defaultFaces for the unlisted rest.
  std::vector<int32_t> patch_refs;
  for (const GroupAttachment& g : m.attachment.groups)
    if (g.dim == 2 && g.foam_kind == "patch") patch_refs.push_back(g.ref);
  {
    std::set<int32_t> seen(patch_refs.begin(), patch_refs.end()), more;
    for (const auto& tf : tri_face)
      if (!seen.count(m.tri_ref[tf.first])) more.insert(m.tri_ref[tf.first]);
    patch_refs.insert(patch_refs.end(), more.begin(), more.end());
  }
  std::map<int32_t, size_t> patch_index;
  for (size_t i = 0; i < patch_refs.size(); ++i) patch_index.emplace(patch_refs[i], i);
  std::vector<std::vector<std::pair<int32_t, int32_t>>> patch_faces(patch_refs.size() + 1);  // (face, tri) ; last: defaultFaces
  for (const auto& tf : tri_face) patch_faces[patch_index.at(m.tri_ref[tf.first])].emplace_back(tf.second, tf.first);
  for (size_t f = 0; f < nf; ++f)
    if (faces[f].second < 0 && patch_tri[f] < 0) patch_faces.back().emplace_back(static_cast<int32_t>(f), -1);
  // Internal faces in upper-triangular order.
  std::vector<int32_t> order;
  for (size_t f = 0; f < nf; ++f)
    if (faces[f].second >= 0) order.push_back(static_cast<int32_t>(f));
  std::sort(order.begin(), order.end(), [&](int32_t a, int32_t b) {
    return faces[a].first != faces[b].first ? faces[a].first < faces[b].first : faces[a].second < faces[b].second;
  });
  plan.ninternal = static_cast<int64_t>(order.size());
  std::vector<int32_t> written(nf, -1);  // face -> written index
  // The vertex order of a face: its listed triangle's where there is one
  // (so a file read and written keeps it), turned to point out of the owner.
  std::vector<int32_t> zone_tri(nf, -1);
  for (const ZoneFace& z : zone_faces)
    if (zone_tri[z.face] < 0) zone_tri[z.face] = z.tri;
  auto emit = [&](int32_t f, int32_t tri) {
    detail::WrittenFace w = faces[f];
    if (tri >= 0) {
      const int32_t* p = &m.tris[3 * static_cast<size_t>(tri)];
      if (detail::same_rotation(p, w.v)) {
        w.v[0] = p[0]; w.v[1] = p[1]; w.v[2] = p[2];
      } else {
        w.v[0] = p[0]; w.v[1] = p[2]; w.v[2] = p[1];
        if (w.second < 0) ++plan.inward_tris;
      }
    }
    written[f] = static_cast<int32_t>(plan.faces.size());
    plan.faces.push_back(w);
    plan.owner.push_back(w.first);
    if (w.second >= 0) plan.neighbour.push_back(w.second);
  };
  for (int32_t f : order) emit(f, zone_tri[f]);
  auto unique_name = [&](std::vector<Plan::Out>& list, std::string name, int32_t ref) {
    for (const Plan::Out& o : list)
      if (o.name == name) {
        name += "_" + std::to_string(ref);
        ++plan.renamed;
        break;
      }
    return name;
  };
  auto named = [&](int dim, int32_t ref, const char* prefix) {
    const std::string* n = name_of(m, dim, ref);
    if (!n) return std::string(prefix) + std::to_string(ref);
    bool changed = false;
    std::string w = foam_word(*n, changed);
    plan.renamed += changed;
    return w;
  };
  for (size_t i = 0; i <= patch_refs.size(); ++i) {
    if (i == patch_refs.size() && patch_faces[i].empty()) break;
    Plan::Out o;
    if (i < patch_refs.size()) {
      o.ref = patch_refs[i];
      o.name = named(2, o.ref, "patch");
      const GroupAttachment* a = m.attachment.find(2, o.ref);
      if (a && a->foam_kind == "patch") {
        o.type = a->foam_type;
        o.entries = a->foam_entries;
      } else if (a && (a->fluent_type == "wall" || a->fluent_type == "symmetry")) {
        // a Fluent zone's type where OpenFOAM has the same one
        o.type = a->fluent_type == "wall" ? "wall" : "symmetryPlane";
      }
      o.has_ref_entry = o.ref != static_cast<int32_t>(i + 1);
    } else {
      o.name = "defaultFaces";
    }
    if (o.type.empty()) o.type = "patch";
    o.name = unique_name(plan.patches, o.name, o.ref);
    o.start = static_cast<int64_t>(plan.faces.size());
    for (const auto& ft : patch_faces[i]) emit(ft.first, ft.second);
    o.count = static_cast<int64_t>(plan.faces.size()) - o.start;
    plan.patches.push_back(std::move(o));
  }
  // faceZones: the attachment's, then the other refs ascending.
  std::vector<int32_t> fz_refs;
  for (const GroupAttachment& g : m.attachment.groups)
    if (g.dim == 2 && g.foam_kind == "faceZone") fz_refs.push_back(g.ref);
  {
    std::set<int32_t> seen(fz_refs.begin(), fz_refs.end()), more;
    for (const ZoneFace& z : zone_faces)
      if (!seen.count(z.ref)) more.insert(z.ref);
    fz_refs.insert(fz_refs.end(), more.begin(), more.end());
  }
  const size_t npatch_refs = patch_refs.size() + (plan.patches.size() > patch_refs.size() ? 1 : 0);
  for (size_t i = 0; i < fz_refs.size(); ++i) {
    Plan::Out o;
    o.ref = fz_refs[i];
    o.name = unique_name(plan.face_zones, named(2, o.ref, "faceZone"), o.ref);
    o.has_ref_entry = o.ref != static_cast<int32_t>(npatch_refs + i + 1);
    for (const ZoneFace& z : zone_faces) {
      if (z.ref != o.ref) continue;
      const detail::WrittenFace& w = plan.faces[written[z.face]];
      o.labels.push_back(written[z.face]);
      o.flips.push_back(detail::same_rotation(&m.tris[3 * static_cast<size_t>(z.tri)], w.v) ? 0 : 1);
    }
    plan.face_zones.push_back(std::move(o));
  }
  // cellZones and pointZones from the refs (0: in none).
  for (int z = 0; z < 2; ++z) {
    const int dim = z == 0 ? 3 : 0;
    const std::vector<int32_t>& refs = z == 0 ? m.tet_ref : m.vert_ref;
    std::vector<int32_t> zr;
    for (const GroupAttachment& g : m.attachment.groups)
      if (g.dim == dim && g.ref != 0 && g.foam_kind == (z == 0 ? "cellZone" : "pointZone")) zr.push_back(g.ref);
    std::set<int32_t> seen(zr.begin(), zr.end()), more;
    for (int32_t r : refs)
      if (r != 0 && !seen.count(r)) more.insert(r);
    zr.insert(zr.end(), more.begin(), more.end());
    std::map<int32_t, size_t> index;
    std::vector<Plan::Out>& list = z == 0 ? plan.cell_zones : plan.point_zones;
    for (size_t i = 0; i < zr.size(); ++i) {
      index.emplace(zr[i], i);
      Plan::Out o;
      o.ref = zr[i];
      o.name = unique_name(list, named(dim, o.ref, z == 0 ? "cellZone" : "pointZone"), o.ref);
      o.has_ref_entry = o.ref != static_cast<int32_t>(i + 1);
      list.push_back(std::move(o));
    }
    for (size_t i = 0; i < refs.size(); ++i)
      if (refs[i] != 0) list[index.at(refs[i])].labels.push_back(static_cast<int32_t>(i));
  }
  return Status::success();
}

// ---- output helpers ----

using detail::put_int;
using detail::put_raw_le;
void put_double(std::string& out, double v) { detail::put_real(out, v); }

void header(std::string& out, bool binary, const char* cls, const char* object, const std::string& note = {}) {
  out += "/*--------------------------------*- C++ -*----------------------------------*\\\n"
         "  OpenFOAM polyMesh written by tetopt\n"
         "\\*---------------------------------------------------------------------------*/\n"
         "FoamFile\n{\n    version     2.0;\n    format      ";
  out += binary ? "binary" : "ascii";
  out += ";\n    arch        \"LSB;label=32;scalar=64\";\n    class       ";
  out += cls;
  out += ";\n";
  if (!note.empty()) out += "    note        \"" + note + "\";\n";
  out += "    location    \"constant/polyMesh\";\n    object      ";
  out += object;
  out += ";\n}\n// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //\n\n";
}
const char* kFooter = "\n\n// ************************************************************************* //\n";

void label_list(std::string& out, const std::vector<int32_t>& v, bool binary) {
  put_int(out, static_cast<int64_t>(v.size()));
  out += binary ? "\n(" : "\n(\n";
  for (int32_t x : v) {
    if (binary) {
      put_raw_le(out, x);
    } else {
      put_int(out, x);
      out += '\n';
    }
  }
  out += ")";
}

void zone_file(std::string& out, const std::vector<Plan::Out>& zones, const char* kind, const char* key, bool flips, bool binary) {
  put_int(out, static_cast<int64_t>(zones.size()));
  out += "\n(\n";
  for (const Plan::Out& z : zones) {
    out += z.name + "\n{\n    type " + kind + ";\n";
    if (z.has_ref_entry) out += "    tetoptRef " + std::to_string(z.ref) + ";\n";
    out += std::string(key) + " List<label> ";
    label_list(out, z.labels, binary);
    out += ";\n";
    if (flips) {
      out += "flipMap List<bool> ";
      put_int(out, static_cast<int64_t>(z.flips.size()));
      out += binary ? "\n(" : "\n(\n";
      for (uint8_t b : z.flips) {
        if (binary) out += static_cast<char>(b);
        else out += b ? "1\n" : "0\n";
      }
      out += ");\n";
    }
    out += "}\n";
  }
  out += ")";
}

}  // namespace

Status format_openfoam(const TetMesh& m, std::string* out, bool binary) {
  Plan plan;
  if (Status s = make_plan(m, plan); !s) return s;
  const int64_t nf = static_cast<int64_t>(plan.faces.size());
  const std::string note = "nPoints:" + std::to_string(m.nv()) + "  nCells:" + std::to_string(m.nt()) + "  nFaces:" +
                           std::to_string(nf) + "  nInternalFaces:" + std::to_string(plan.ninternal);
  // points
  std::string& p = out[0];
  header(p, binary, "vectorField", "points");
  put_int(p, m.nv());
  p += binary ? "\n(" : "\n(\n";
  for (int32_t v = 0; v < m.nv(); ++v) {
    const double* x = m.point(v);
    if (binary) {
      for (int k = 0; k < 3; ++k) put_raw_le(p, x[k]);
    } else {
      p += '(';
      for (int k = 0; k < 3; ++k) {
        if (k) p += ' ';
        put_double(p, x[k]);
      }
      p += ")\n";
    }
  }
  p += ")";
  p += kFooter;
  // faces: faceList in ASCII, faceCompactList in binary (as OpenFOAM writes them)
  std::string& f = out[1];
  header(f, binary, binary ? "faceCompactList" : "faceList", "faces");
  if (binary) {
    std::vector<int32_t> offsets, flat;
    offsets.reserve(static_cast<size_t>(nf) + 1);
    flat.reserve(3 * static_cast<size_t>(nf));
    for (int64_t i = 0; i <= nf; ++i) offsets.push_back(static_cast<int32_t>(3 * i));
    for (const detail::WrittenFace& w : plan.faces) flat.insert(flat.end(), w.v, w.v + 3);
    label_list(f, offsets, true);
    f += "\n\n";
    label_list(f, flat, true);
  } else {
    put_int(f, nf);
    f += "\n(\n";
    for (const detail::WrittenFace& w : plan.faces) {
      f += "3(";
      put_int(f, w.v[0]);
      f += ' ';
      put_int(f, w.v[1]);
      f += ' ';
      put_int(f, w.v[2]);
      f += ")\n";
    }
    f += ")";
  }
  f += kFooter;
  header(out[2], binary, "labelList", "owner", note);
  label_list(out[2], plan.owner, binary);
  out[2] += kFooter;
  header(out[3], binary, "labelList", "neighbour", note);
  label_list(out[3], plan.neighbour, binary);
  out[3] += kFooter;
  // boundary (text in either format)
  std::string& b = out[4];
  header(b, binary, "polyBoundaryMesh", "boundary");
  put_int(b, static_cast<int64_t>(plan.patches.size()));
  b += "\n(\n";
  for (const Plan::Out& o : plan.patches) {
    b += "    " + o.name + "\n    {\n        type            " + o.type + ";\n";
    if (!o.entries.empty()) b += "        " + o.entries + "\n";
    b += "        nFaces          " + std::to_string(o.count) + ";\n        startFace       " + std::to_string(o.start) + ";\n";
    if (o.has_ref_entry) b += "        tetoptRef       " + std::to_string(o.ref) + ";\n";
    b += "    }\n";
  }
  b += ")";
  b += kFooter;
  header(out[5], binary, "regIOobject", "cellZones");
  zone_file(out[5], plan.cell_zones, "cellZone", "cellLabels", false, binary);
  out[5] += kFooter;
  header(out[6], binary, "regIOobject", "faceZones");
  zone_file(out[6], plan.face_zones, "faceZone", "faceLabels", true, binary);
  out[6] += kFooter;
  header(out[7], binary, "regIOobject", "pointZones");
  zone_file(out[7], plan.point_zones, "pointZone", "pointLabels", false, binary);
  out[7] += kFooter;
  return Status::success();
}

std::vector<std::string> detail::openfoam_dropped(const TetMesh& m) {
  std::vector<std::string> out;
  Plan plan;
  if (!make_plan(m, plan)) return out;  // the write itself will say why
  auto add = [&](int64_t n, const std::string& what) {
    if (n > 0) out.push_back(what + " (" + std::to_string(n) + ")");
  };
  add(plan.unmatched_tris, "listed triangles that are no tet's face");
  add(plan.inward_tris, "boundary triangles listed facing inward; written facing out");
  add(plan.renamed, "names that are no OpenFOAM word or repeat another; written with '_' or '_REF'");
  // Names of groups the writer makes no patch or zone for.
  int64_t unused = 0;
  for (const PhysicalName& pn : m.physical_names) {
    bool used = false;
    for (const auto* list : {&plan.patches, &plan.face_zones})
      for (const Plan::Out& o : *list) used = used || (pn.dim == 2 && o.ref == pn.tag && o.name != "defaultFaces");
    for (const Plan::Out& o : plan.cell_zones) used = used || (pn.dim == 3 && o.ref == pn.tag);
    for (const Plan::Out& o : plan.point_zones) used = used || (pn.dim == 0 && o.ref == pn.tag);
    unused += !used;
  }
  add(unused, "physical names of groups with no patch or zone");
  return out;
}

}  // namespace tetopt
