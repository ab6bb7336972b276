// Abaqus / CalculiX input (.inp) reader and writer: nodes, C3D4 elements,
// element sets, node sets and element-based surfaces.
//
// Written from the Abaqus Keywords Reference (Abaqus 6.14): "*NODE",
// "*ELEMENT" (TYPE=, ELSET=), "*ELSET" (ELSET=, GENERATE), "*NSET" (NSET=,
// GENERATE), "*SURFACE" (NAME=, TYPE=ELEMENT: data lines "element or
// element set, face identifier"), and the Abaqus Analysis User's Guide,
// section 28.1.4 "Three-dimensional solid element library" for the C3D4
// node ordering and faces: face 1 = nodes 1-2-3, face 2 = 1-4-2, face 3 =
// 2-4-3, face 4 = 3-4-1, with node 4 on the side of face 1's right-hand
// normal for a positive volume (the orientation of conventions.hpp).  The
// CalculiX CrunchiX User's Manual (version 2.20, section 6 "Input deck
// format" and 7 "Input deck keywords") describes the same subset, which is
// what Debian's calculix-ccx reads (tests/scripts/test_abaqus.sh runs a
// static job on tetopt's output).
//
// Syntax kept to: keyword lines start with '*' ("**" a comment), parameters
// "NAME=value" after commas, case-insensitive; data lines are
// comma-separated; a data line ending with ',' continues on the next.
// Other keywords (*HEADING, *MATERIAL, *STEP, ...) and their data lines are
// skipped; *INCLUDE, *PART/*INSTANCE with several parts and element types
// other than C3D4 (and the tet spellings C3D4H, C3D4T) are unsupported.
//
// What tetopt keeps: node coordinates; elements in ascending element id
// order; an element's ref is 1 + the position of the first element set (in
// definition order: ELSET= on *ELEMENT, or *ELSET) holding it (0 in none),
// the set's name its physical name (dim 3); the same for nodes and node
// sets (vert_ref, dim 0); each element surface becomes listed triangles (the
// element face's nodes in the order of the table above) with ref 1 + its
// position, its name the physical name (dim 2).  A comment line
// "**tetopt ref=R" just before a set or surface gives its ref instead (the
// writer writes one where the position would give another).  An element
// or node in several sets keeps the first; the writer writes one set per
// ref.
#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "io/checked.hpp"
#include "io/common.hpp"
#include "io/face_cells.hpp"
#include "tetopt/io.hpp"

namespace tetopt {

namespace {

constexpr int64_t kMaxId = std::numeric_limits<int32_t>::max();
/// C3D4 faces S1..S4 (local nodes, 0-based), Abaqus Analysis User's Guide 28.1.4.
constexpr int kAbqFace[4][3] = {{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {2, 3, 0}};

std::string shown_tok(std::string_view t) { return detail::shown_token(t, false); }
std::string upper(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return u;
}
std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}
std::vector<std::string_view> split(std::string_view l) {
  std::vector<std::string_view> out;
  size_t b = 0;
  for (;;) {
    const size_t e = l.find(',', b);
    out.push_back(trim(l.substr(b, e == std::string_view::npos ? std::string_view::npos : e - b)));
    if (e == std::string_view::npos) break;
    b = e + 1;
  }
  return out;
}
bool parse_int(std::string_view t, int64_t& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return !t.empty() && r.ec == std::errc{} && r.ptr == t.data() + t.size();
}
bool parse_real(std::string_view t, double& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  // Fortran-style exponents (1.0D+00) are accepted by Abaqus.
  std::string s(t);
  for (char& c : s)
    if (c == 'd' || c == 'D') c = 'e';
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || r.ptr != s.data() + s.size()) return false;
  if (r.ec == std::errc::result_out_of_range) {
    v = std::strtod(s.c_str(), nullptr);
    return !std::isinf(v);
  }
  return r.ec == std::errc{} && std::isfinite(v);
}

struct Keyword {
  std::string name;                          // upper case, no '*'
  std::map<std::string, std::string> params;  // keys upper case
};

class Reader {
 public:
  Reader(std::string_view d, std::string name) : d_(d), name_(std::move(name)) {}
  Status run(TetMesh& m);

 private:
  Status fail(const std::string& what, long line = -1) const {
    if (line < 0) line = line_;
    return Status::error(ErrorCode::Parse, name_ + ":" + std::to_string(line) + ": " + what, line);
  }
  Status unsupported(const std::string& what) const {
    Status s = fail(what);
    s.code = ErrorCode::Unsupported;
    return s;
  }
  /// The next line that is no comment and not blank; false at the end.
  /// A "**tetopt ref=R" comment is remembered for the next keyword.
  bool next(std::string_view& l) {
    while (pos_ < d_.size()) {
      size_t e = d_.find('\n', pos_);
      if (e == std::string_view::npos) e = d_.size();
      l = trim(d_.substr(pos_, e - pos_));
      pos_ = e + 1;
      ++line_;
      if (l.size() >= 2 && l[0] == '*' && l[1] == '*') {
        static constexpr std::string_view kRef = "**tetopt ref=";
        int64_t r = 0;
        if (l.substr(0, kRef.size()) == kRef && parse_int(trim(l.substr(kRef.size())), r) && r >= std::numeric_limits<int32_t>::min() && r <= kMaxId) {
          pending_ref_ = r;
          has_pending_ref_ = true;
        }
        continue;
      }
      if (!l.empty()) return true;
    }
    return false;
  }
  /// Puts the line just read back (a keyword ending a data block).
  void unread(std::string_view l) {
    pos_ = static_cast<size_t>(l.data() - d_.data());
    --line_;
  }
  Keyword keyword(std::string_view l) const {
    Keyword k;
    const std::vector<std::string_view> parts = split(l.substr(1));
    k.name = upper(parts[0]);
    for (size_t i = 1; i < parts.size(); ++i) {
      const size_t eq = parts[i].find('=');
      std::string key = upper(trim(parts[i].substr(0, eq)));
      std::string val = eq == std::string_view::npos ? "" : std::string(trim(parts[i].substr(eq + 1)));
      if (val.size() >= 2 && val.front() == '"' && val.back() == '"') val = val.substr(1, val.size() - 2);
      if (!key.empty()) k.params[key] = val;
    }
    return k;
  }
  /// A data line's fields, continuation lines (ending with ',') joined.
  bool data(std::vector<std::string_view>& f, long& at) {
    f.clear();
    std::string_view l;
    if (!next(l)) return false;
    if (l[0] == '*') {
      unread(l);
      return false;
    }
    at = line_;
    for (;;) {
      std::vector<std::string_view> p = split(l);
      const bool more = !p.empty() && p.back().empty();
      if (more) p.pop_back();
      f.insert(f.end(), p.begin(), p.end());
      if (!more) return true;
      std::string_view n;
      if (!next(n)) return true;
      if (n[0] == '*') {
        unread(n);
        return true;
      }
      l = n;
    }
  }

  Status nodes(const Keyword& k);
  Status elements(const Keyword& k);
  Status set(const Keyword& k, bool elset);
  Status surface(const Keyword& k);
  int64_t take_ref(int64_t position) {
    const int64_t r = has_pending_ref_ ? pending_ref_ : position;
    has_pending_ref_ = false;
    return r;
  }
  /// Index of a node / element id, -1 when not defined.
  int64_t node_index(int64_t id) const {
    const auto it = node_ids_.find(id);
    return it == node_ids_.end() ? -1 : it->second;
  }
  int64_t elem_index(int64_t id) const {
    const auto it = elem_ids_.find(id);
    return it == elem_ids_.end() ? -1 : it->second;
  }

  std::string_view d_;
  std::string name_;
  size_t pos_ = 0;
  long line_ = 0;
  int64_t pending_ref_ = 0;
  bool has_pending_ref_ = false;

  std::vector<double> xyz_;
  std::vector<int64_t> node_id_;  // per node, its id
  std::unordered_map<int64_t, int64_t> node_ids_;
  std::vector<int64_t> elem_id_;    // per element, its id
  std::vector<int64_t> elem_node_;  // 4 node ids per element (resolved at the end)
  std::vector<long> elem_line_;
  std::unordered_map<int64_t, int64_t> elem_ids_;
  struct Set {
    std::string name;
    int64_t ref;
    std::vector<int64_t> members;  // element or node indices
  };
  std::vector<Set> elsets_, nsets_;
  struct Surface {
    std::string name;
    int64_t ref;
    std::vector<std::pair<int64_t, int>> faces;  // (element index, face 0..3)
  };
  std::vector<Surface> surfaces_;
};

Status Reader::nodes(const Keyword& k) {
  std::vector<std::string_view> f;
  long at = 0;
  Set* ns = nullptr;
  if (k.params.count("NSET")) {
    nsets_.push_back(Set{k.params.at("NSET"), take_ref(static_cast<int64_t>(nsets_.size()) + 1), {}});
    ns = &nsets_.back();
  }
  while (data(f, at)) {
    if (f.size() < 4) return fail("a node needs an id and three coordinates", at);
    int64_t id = 0;
    if (!parse_int(f[0], id) || id < 1 || id > kMaxId) return fail("expected a node id (1..2^31-1), found '" + shown_tok(f[0]) + "'", at);
    if (node_ids_.count(id)) return fail("node " + std::to_string(id) + " is defined twice", at);
    if (node_id_.size() >= static_cast<size_t>(kMaxId)) return unsupported("more than 2^31-1 nodes");
    for (int j = 1; j <= 3; ++j) {
      double x = 0;
      if (!parse_real(f[j], x)) return fail("node " + std::to_string(id) + ": expected a finite number, found '" + shown_tok(f[j]) + "'", at);
      xyz_.push_back(x);
    }
    node_ids_.emplace(id, static_cast<int64_t>(node_id_.size()));
    if (ns) ns->members.push_back(static_cast<int64_t>(node_id_.size()));
    node_id_.push_back(id);
  }
  return Status::success();
}

Status Reader::elements(const Keyword& k) {
  const auto t = k.params.find("TYPE");
  if (t == k.params.end()) return fail("*ELEMENT without TYPE=");
  const std::string type = upper(t->second);
  if (type != "C3D4" && type != "C3D4H" && type != "C3D4T")
    return unsupported("element type " + shown_tok(type) + " (tetopt reads linear tetrahedra, C3D4)");
  Set* es = nullptr;
  if (k.params.count("ELSET")) {
    const std::string& n = k.params.at("ELSET");
    for (Set& s : elsets_)
      if (upper(s.name) == upper(n)) es = &s;  // blocks may add to one set
    if (!es) {
      elsets_.push_back(Set{n, take_ref(static_cast<int64_t>(elsets_.size()) + 1), {}});
      es = &elsets_.back();
    }
  }
  std::vector<std::string_view> f;
  long at = 0;
  while (data(f, at)) {
    if (f.size() != 5) return fail("a C3D4 element needs an id and 4 nodes, found " + std::to_string(f.size()) + " fields", at);
    int64_t v[5];
    for (int j = 0; j < 5; ++j)
      if (!parse_int(f[j], v[j]) || v[j] < 1 || v[j] > kMaxId)
        return fail("expected an id (1..2^31-1), found '" + shown_tok(f[j]) + "'", at);
    if (elem_ids_.count(v[0])) return fail("element " + std::to_string(v[0]) + " is defined twice", at);
    elem_ids_.emplace(v[0], static_cast<int64_t>(elem_id_.size()));
    if (es) es->members.push_back(static_cast<int64_t>(elem_id_.size()));
    elem_id_.push_back(v[0]);
    elem_node_.insert(elem_node_.end(), v + 1, v + 5);
    elem_line_.push_back(at);
  }
  return Status::success();
}

Status Reader::set(const Keyword& k, bool elset) {
  const char* key = elset ? "ELSET" : "NSET";
  const auto n = k.params.find(key);
  if (n == k.params.end() || n->second.empty()) return fail(std::string("*") + key + " without " + key + "=");
  std::vector<Set>& sets = elset ? elsets_ : nsets_;
  Set* s = nullptr;
  for (Set& x : sets)
    if (upper(x.name) == upper(n->second)) s = &x;  // a set may be extended
  if (!s) {
    sets.push_back(Set{n->second, take_ref(static_cast<int64_t>(sets.size()) + 1), {}});
    s = &sets.back();
  }
  const bool generate = k.params.count("GENERATE") > 0;
  const int64_t count = elset ? static_cast<int64_t>(elem_id_.size()) : static_cast<int64_t>(node_id_.size());
  std::vector<std::string_view> f;
  long at = 0;
  while (data(f, at)) {
    if (generate) {
      int64_t a = 0, b = 0, step = 1;
      if (f.size() < 2 || !parse_int(f[0], a) || !parse_int(f[1], b) || (f.size() > 2 && !f[2].empty() && !parse_int(f[2], step)))
        return fail("GENERATE expects first, last[, step]", at);
      if (step < 1 || a < 1 || b < a || b > kMaxId || (b - a) / step + 1 > count)
        return fail("GENERATE " + std::to_string(a) + ", " + std::to_string(b) + ", " + std::to_string(step) +
                        " names more ids than are defined", at);
      for (int64_t id = a; id <= b; id += step) {
        const int64_t i = elset ? elem_index(id) : node_index(id);
        if (i < 0) return fail(std::string(elset ? "element " : "node ") + std::to_string(id) + " is not defined (before this set)", at);
        s->members.push_back(i);
      }
      continue;
    }
    for (std::string_view t : f) {
      if (t.empty()) continue;
      int64_t id = 0;
      if (parse_int(t, id)) {
        const int64_t i = elset ? elem_index(id) : node_index(id);
        if (i < 0) return fail(std::string(elset ? "element " : "node ") + std::to_string(id) + " is not defined (before this set)", at);
        s->members.push_back(i);
        continue;
      }
      // another set's name: its members (only sets defined before, so no cycle)
      const Set* o = nullptr;
      for (const Set& x : sets)
        if (&x != s && upper(x.name) == upper(t)) o = &x;
      if (!o) return fail(std::string("'") + shown_tok(t) + "' is neither an id nor a " + (elset ? "element" : "node") + " set defined before", at);
      if (s->members.size() + o->members.size() > static_cast<size_t>(count) * 64 + 1024)
        return fail("set '" + shown_tok(s->name) + "' grows past 64 times the ids defined", at);
      s->members.insert(s->members.end(), o->members.begin(), o->members.end());
    }
  }
  return Status::success();
}

Status Reader::surface(const Keyword& k) {
  const auto t = k.params.find("TYPE");
  if (t != k.params.end() && upper(t->second) != "ELEMENT") {
    // node-based (and other) surfaces are skipped with their data lines
    std::vector<std::string_view> f;
    long at = 0;
    while (data(f, at)) {
    }
    return Status::success();
  }
  const auto n = k.params.find("NAME");
  if (n == k.params.end() || n->second.empty()) return fail("*SURFACE without NAME=");
  surfaces_.push_back(Surface{n->second, take_ref(static_cast<int64_t>(surfaces_.size()) + 1), {}});
  Surface& s = surfaces_.back();
  std::vector<std::string_view> f;
  long at = 0;
  while (data(f, at)) {
    if (f.size() < 2) return unsupported("a surface line without a face identifier (S1..S4): tetopt reads element faces only");
    const std::string face = upper(f[1]);
    if (face.size() != 2 || face[0] != 'S' || face[1] < '1' || face[1] > '4')
      return fail("face identifier '" + shown_tok(f[1]) + "' (a C3D4 face is S1, S2, S3 or S4)", at);
    const int fi = face[1] - '1';
    int64_t id = 0;
    if (parse_int(f[0], id)) {
      const int64_t i = elem_index(id);
      if (i < 0) return fail("element " + std::to_string(id) + " is not defined (before this surface)", at);
      s.faces.emplace_back(i, fi);
      continue;
    }
    const Set* o = nullptr;
    for (const Set& x : elsets_)
      if (upper(x.name) == upper(f[0])) o = &x;
    if (!o) return fail("'" + shown_tok(f[0]) + "' is neither an element id nor an element set defined before", at);
    if (s.faces.size() + o->members.size() > elem_id_.size() * 4 + 1024) return fail("surface '" + shown_tok(s.name) + "' lists more faces than the elements have", at);
    for (int64_t i : o->members) s.faces.emplace_back(i, fi);
  }
  return Status::success();
}

Status Reader::run(TetMesh& m) {
  m = TetMesh{};
  std::string_view l;
  int parts = 0;
  while (next(l)) {
    if (l[0] != '*') continue;  // data of a skipped keyword
    const Keyword k = keyword(l);
    Status s;
    if (k.name == "NODE") s = nodes(k);
    else if (k.name == "ELEMENT") s = elements(k);
    else if (k.name == "ELSET") s = set(k, true);
    else if (k.name == "NSET") s = set(k, false);
    else if (k.name == "SURFACE") s = surface(k);
    else if (k.name == "INCLUDE") return unsupported("*INCLUDE (give tetopt the included file's content in one file)");
    else if (k.name == "PART" && ++parts > 1) return unsupported("more than one *PART");
    else if (k.name == "INSTANCE" || k.name == "ASSEMBLY") {
      // an assembly of the one part: skip to *END ASSEMBLY
      while (next(l))
        if (l[0] == '*' && keyword(l).name == "END ASSEMBLY") break;
    } else has_pending_ref_ = false;
    if (!s) return s;
  }
  if (node_id_.empty()) return fail("no *NODE", line_);
  if (elem_id_.empty()) return fail("no C3D4 *ELEMENT", line_);
  // Elements in ascending id order.
  const auto ne = static_cast<int64_t>(elem_id_.size());
  std::vector<int64_t> order(static_cast<size_t>(ne));
  for (int64_t i = 0; i < ne; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](int64_t a, int64_t b) { return elem_id_[a] < elem_id_[b]; });
  std::vector<int64_t> rank(static_cast<size_t>(ne));
  for (int64_t r = 0; r < ne; ++r) rank[order[r]] = r;
  m.xyz = std::move(xyz_);
  m.tets.resize(detail::ck_size(ne, 4));
  for (int64_t r = 0; r < ne; ++r) {
    const int64_t e = order[r];
    for (int j = 0; j < 4; ++j) {
      const int64_t v = node_index(elem_node_[4 * e + j]);
      if (v < 0) return fail("element " + std::to_string(elem_id_[e]) + ": node " + std::to_string(elem_node_[4 * e + j]) + " is not defined", elem_line_[e]);
      m.tets[4 * r + j] = static_cast<int32_t>(v);
    }
  }
  m.tet_ref.assign(static_cast<size_t>(ne), 0);
  std::vector<uint8_t> done(static_cast<size_t>(ne), 0);
  for (const Set& s : elsets_) {
    for (int64_t e : s.members)
      if (!done[e]) {
        done[e] = 1;
        m.tet_ref[rank[e]] = static_cast<int32_t>(s.ref);
      }
    m.physical_names.push_back(PhysicalName{3, static_cast<int>(s.ref), s.name});
  }
  m.vert_ref.assign(node_id_.size(), 0);
  std::vector<uint8_t> vdone(node_id_.size(), 0);
  for (const Set& s : nsets_) {
    for (int64_t v : s.members)
      if (!vdone[v]) {
        vdone[v] = 1;
        m.vert_ref[v] = static_cast<int32_t>(s.ref);
      }
    m.physical_names.push_back(PhysicalName{0, static_cast<int>(s.ref), s.name});
  }
  for (const Surface& s : surfaces_) {
    for (const auto& ef : s.faces) {
      const int32_t* t = &m.tets[4 * static_cast<size_t>(rank[ef.first])];
      for (int j = 0; j < 3; ++j) m.tris.push_back(t[kAbqFace[ef.second][j]]);
      m.tri_ref.push_back(static_cast<int32_t>(s.ref));
    }
    m.physical_names.push_back(PhysicalName{2, static_cast<int>(s.ref), s.name});
  }
  return Status::success();
}

// ---------------------------------------------------------------- writer ----

/// A name as an Abaqus label: letters, digits, '_', '-', '.'; starts with a
/// letter; at most 80 characters.
std::string abq_label(const std::string& s, bool& changed) {
  std::string w;
  for (char c : s) w += (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.') ? c : '_';
  if (w.empty() || !std::isalpha(static_cast<unsigned char>(w[0]))) w = "S" + w;
  if (w.size() > 80) w.resize(80);
  changed = w != s;
  return w;
}

const std::string* name_of(const TetMesh& m, int dim, int32_t ref) {
  for (const PhysicalName& p : m.physical_names)
    if (p.dim == dim && p.tag == ref) return &p.name;
  return nullptr;
}

void put_double(std::string& out, double v) {
  char buf[40];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 17);
  out.append(buf, r.ptr);
}

struct APlan {
  struct Group {
    int32_t ref;
    std::string name;
    std::vector<int64_t> items;  // tets, vertices, or 4*tet+face
  };
  std::vector<Group> elsets, nsets, surfaces;
  int64_t unmatched = 0, reordered = 0, renamed = 0;
};

void make_plan(const TetMesh& m, APlan& p) {
  std::map<std::string, int> used;
  auto label = [&](int dim, int32_t ref, const char* prefix) {
    const std::string* n = name_of(m, dim, ref);
    bool changed = false;
    std::string w = n ? abq_label(*n, changed) : std::string(prefix) + (ref < 0 ? "M" + std::to_string(-static_cast<int64_t>(ref)) : std::to_string(ref));
    p.renamed += n && changed;
    std::string key = upper(w);
    if (used[key]++) {  // Abaqus names are case-insensitive and unique per kind
      w += "_" + std::to_string(used[key]);
      ++p.renamed;
    }
    return w;
  };
  // element sets: one per nonzero tet ref, ascending
  std::map<int32_t, std::vector<int64_t>> er, vr, sr;
  for (int32_t t = 0; t < m.nt(); ++t)
    if (m.tet_ref[t] != 0) er[m.tet_ref[t]].push_back(t);
  for (auto& [r, v] : er) p.elsets.push_back({r, label(3, r, "REGION"), std::move(v)});
  used.clear();
  for (int32_t v = 0; v < m.nv(); ++v)
    if (static_cast<size_t>(v) < m.vert_ref.size() && m.vert_ref[v] != 0) vr[m.vert_ref[v]].push_back(v);
  for (auto& [r, v] : vr) p.nsets.push_back({r, label(0, r, "NODES"), std::move(v)});
  used.clear();
  // surfaces: each listed triangle as the face of a tet.  Every (tet, C3D4
  // face) by its sorted vertex triple; no manifold mesh is needed (the
  // fuzzer found a face on three tets that the writer refused).
  struct Item {
    std::array<int32_t, 3> key;
    int64_t ef;  // 4 * tet + face
  };
  std::vector<Item> items;
  items.reserve(4 * static_cast<size_t>(m.nt()));
  for (int32_t t = 0; t < m.nt(); ++t) {
    int32_t v[4];
    detail::file_tet(m, t, Format::Abaqus, v);
    for (int f = 0; f < 4; ++f) {
      const int32_t fv[3] = {v[kAbqFace[f][0]], v[kAbqFace[f][1]], v[kAbqFace[f][2]]};
      items.push_back({detail::tri_key(fv), 4 * static_cast<int64_t>(t) + f});
    }
  }
  std::sort(items.begin(), items.end(), [](const Item& x, const Item& y) { return x.key != y.key ? x.key < y.key : x.ef < y.ef; });
  for (int32_t i = 0; i < m.ntri(); ++i) {
    const int32_t* tri = &m.tris[3 * static_cast<size_t>(i)];
    const auto k = detail::tri_key(tri);
    auto it = std::lower_bound(items.begin(), items.end(), k, [](const Item& x, const std::array<int32_t, 3>& y) { return x.key < y; });
    if (it == items.end() || it->key != k || k[0] == k[1] || k[1] == k[2]) {
      ++p.unmatched;
      continue;
    }
    // The (tet, face) whose node order is the triangle's, else the first.
    int64_t best = -1;
    for (auto j = it; j != items.end() && j->key == k && best < 0; ++j) {
      int32_t v[4];
      detail::file_tet(m, static_cast<int32_t>(j->ef / 4), Format::Abaqus, v);
      const int f = static_cast<int>(j->ef % 4);
      if (v[kAbqFace[f][0]] == tri[0] && v[kAbqFace[f][1]] == tri[1] && v[kAbqFace[f][2]] == tri[2]) best = j->ef;
    }
    if (best < 0) {
      best = it->ef;
      ++p.reordered;
    }
    sr[m.tri_ref[i]].push_back(best);
  }
  for (auto& [r, v] : sr) p.surfaces.push_back({r, label(2, r, "SURF"), std::move(v)});
}

}  // namespace

Status parse_abaqus(std::string_view data, const std::string& name, TetMesh& m) {
  Reader r(data, name);
  return r.run(m);
}

Status format_abaqus(const TetMesh& m, std::string& out) {
  APlan p;
  make_plan(m, p);
  out += "** Abaqus / CalculiX input written by tetopt: nodes, C3D4 elements, sets, surfaces\n*HEADING\ntetopt mesh\n*NODE\n";
  for (int32_t v = 0; v < m.nv(); ++v) {
    out += std::to_string(v + 1);
    for (int k = 0; k < 3; ++k) {
      out += ", ";
      put_double(out, m.point(v)[k]);
    }
    out += '\n';
  }
  out += "*ELEMENT, TYPE=C3D4\n";
  for (int32_t t = 0; t < m.nt(); ++t) {
    int32_t v[4];
    detail::file_tet(m, t, Format::Abaqus, v);
    out += std::to_string(t + 1) + ", " + std::to_string(v[0] + 1) + ", " + std::to_string(v[1] + 1) + ", " +
           std::to_string(v[2] + 1) + ", " + std::to_string(v[3] + 1) + "\n";
  }
  auto list = [&](const std::vector<int64_t>& ids) {
    for (size_t i = 0; i < ids.size(); ++i) {
      out += std::to_string(ids[i] + 1);
      out += (i + 1 == ids.size() || i % 16 == 15) ? "\n" : ", ";
    }
  };
  auto ref_line = [&](int32_t ref, size_t position) {
    if (ref != static_cast<int64_t>(position) + 1) out += "**tetopt ref=" + std::to_string(ref) + "\n";
  };
  for (size_t i = 0; i < p.elsets.size(); ++i) {
    ref_line(p.elsets[i].ref, i);
    out += "*ELSET, ELSET=" + p.elsets[i].name + "\n";
    list(p.elsets[i].items);
  }
  for (size_t i = 0; i < p.nsets.size(); ++i) {
    ref_line(p.nsets[i].ref, i);
    out += "*NSET, NSET=" + p.nsets[i].name + "\n";
    list(p.nsets[i].items);
  }
  for (size_t i = 0; i < p.surfaces.size(); ++i) {
    ref_line(p.surfaces[i].ref, i);
    out += "*SURFACE, NAME=" + p.surfaces[i].name + ", TYPE=ELEMENT\n";
    for (int64_t ef : p.surfaces[i].items) out += std::to_string(ef / 4 + 1) + ", S" + std::to_string(ef % 4 + 1) + "\n";
  }
  return Status::success();
}

std::vector<std::string> detail::abaqus_dropped(const TetMesh& m) {
  std::vector<std::string> out;
  APlan p;
  make_plan(m, p);
  auto add = [&](int64_t n, const std::string& what) {
    if (n > 0) out.push_back(what + " (" + std::to_string(n) + ")");
  };
  add(p.unmatched, "listed triangles that are no tet's face");
  add(p.reordered, "listed triangles whose vertex order is no C3D4 face's; written as element faces");
  add(p.renamed, "names that are no Abaqus label or repeat another; written changed");
  int64_t unused = 0;
  for (const PhysicalName& pn : m.physical_names) {
    bool used = false;
    for (const auto* l : {&p.elsets, &p.nsets, &p.surfaces})
      for (const APlan::Group& g : *l) used = used || (g.ref == pn.tag && ((l == &p.elsets && pn.dim == 3) || (l == &p.nsets && pn.dim == 0) || (l == &p.surfaces && pn.dim == 2)));
    unused += !used;
  }
  add(unused, "physical names of groups with no set or surface");
  return out;
}

}  // namespace tetopt
