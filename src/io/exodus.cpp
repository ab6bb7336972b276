// Exodus II reader and writer (through the Exodus II library, Debian's
// libexodusii-dev; built only when CMake finds it, option TETOPT_EXODUS).
//
// Written from "EXODUS II: A Finite Element Data Model" (Schoof and Yarberry,
// SAND92-2137, and its API reference for version 6): section 3.1
// "Initialization Parameters", 3.2 "Nodal Coordinates", 3.4 "Element
// Blocks" (element type "TETRA" with 4 nodes: nodes 1-2-3 counter-clockwise
// seen from node 4, a positive right-hand volume), 3.9 "Node Sets", 3.10
// "Side Sets" (pairs of element number, counting across the blocks in their
// order, and local side number), 3.12 "Properties" (integer properties per
// block or set, ID among them), and Table 4-1's TETRA side numbering: side 1
// = nodes 1-2-4, side 2 = 2-3-4, side 3 = 1-4-3, side 4 = 1-3-2, each
// ordered for an outward normal.
//
// What tetopt reads: the coordinates (3-dimensional files only); each
// element block of type TETRA / TETRA4 / TET4 (any case) with 4 nodes per
// element as tets (other types are refused with the block and type named),
// its ref the block's property TETOPT_REF when the file has that property,
// else its ID, its name the physical name (dim 3); each side set as listed
// triangles, the side's nodes in the order of the table above, its ref and
// name likewise (dim 2); each node set as vertex refs (a node in several
// sets keeps the first), its name a physical name of dim 0.
//
// What tetopt writes: a netCDF file (the library's default, 64-bit
// offsets), double coordinates, one TETRA block per tet ref (in the order of
// the refs' first tets, each block's tets in mesh order), one side set per
// triangle ref, one node set per nonzero vertex ref; IDs are the refs where
// they are positive, and a TETOPT_REF property is written when some ID is
// not its ref.  A listed triangle is written as the side of a tet whose side
// has its vertex order; where no tet has, the writer rotates a tet holding
// it (an even permutation: same tet, same orientation) so that one does,
// and only where that is impossible (an inward triangle on a boundary, a
// tet already rotated for another side) does the triangle come back in the
// side's order, which dropped_by_format names.  Triangles that are no tet's
// face cannot be written at all; dropped_by_format names them too.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "io/common.hpp"
#include "io/face_cells.hpp"
#include "tetopt/io.hpp"

#if TETOPT_HAVE_EXODUS
#include <dlfcn.h>
#include <exodusII.h>

// The Exodus II library is loaded when an Exodus file is first read or
// written (dlopen), not linked: linked, it pulled Debian's MPI-enabled
// netCDF, HDF5 and Open MPI into every program using tetopt, and the
// address-space limits of tests/scripts/test_oom.sh and the Python tests no
// longer left room for their out-of-memory cases.
#define TETOPT_EXODUS_FUNCS(X) X(ex_close) X(ex_create_int) X(ex_get_block) X(ex_get_conn) X(ex_get_coord) X(ex_get_err) X(ex_get_ids) X(ex_get_init) X(ex_get_name) X(ex_get_prop) X(ex_get_prop_names) X(ex_get_set) X(ex_get_set_param) X(ex_inquire_int) X(ex_open_int) X(ex_opts) X(ex_put_block) X(ex_put_conn) X(ex_put_coord) X(ex_put_init) X(ex_put_name) X(ex_put_prop) X(ex_put_set) X(ex_put_set_param) X(ex_set_max_name_length)
namespace tetopt {
namespace {
struct ExodusLib {
#define TETOPT_X(f) decltype(&::f) f = nullptr;
  TETOPT_EXODUS_FUNCS(TETOPT_X)
#undef TETOPT_X
  std::string why;  // empty when loaded
};
const ExodusLib* exodus_lib() {
  static const ExodusLib lib = [] {
    ExodusLib L;
    void* h = nullptr;
    for (const char* n : {TETOPT_EXODUS_SONAME, "libexoIIv2c.so.5", "libexoIIv2c.so"})
      if (!h && n[0]) h = ::dlopen(n, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
      const char* e = ::dlerror();
      L.why = std::string("cannot load the Exodus II library (Debian: libexodusii5): ") + (e ? e : "dlopen failed");
      return L;
    }
#define TETOPT_X(f)                                                        \
  L.f = reinterpret_cast<decltype(L.f)>(::dlsym(h, #f));                   \
  if (!L.f && L.why.empty()) L.why = "the Exodus II library lacks " #f;
    TETOPT_EXODUS_FUNCS(TETOPT_X)
#undef TETOPT_X
    return L;
  }();
  return &lib;
}
#define EX exodus_lib()
}  // namespace
}  // namespace tetopt
#endif

namespace tetopt {

namespace {

/// Exodus TETRA sides (0-based local nodes), Table 4-1 of the Exodus II manual.
constexpr int kExoSide[4][3] = {{0, 1, 3}, {1, 2, 3}, {0, 3, 2}, {0, 2, 1}};

std::mutex& exodus_mutex() {
  static std::mutex m;
  return m;
}

const std::string* name_of(const TetMesh& m, int dim, int32_t ref) {
  for (const PhysicalName& p : m.physical_names)
    if (p.dim == dim && p.tag == ref) return &p.name;
  return nullptr;
}

/// Parity of the permutation taking a to b (both 4 distinct values): true when even.
bool even_perm(const int32_t a[4], const int32_t b[4]) {
  int p[4];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      if (b[i] == a[j]) p[i] = j;
  int inv = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) inv += p[i] > p[j];
  return inv % 2 == 0;
}

struct XPlan {
  struct Group {
    int32_t ref;
    int64_t id;
    std::vector<int64_t> items;  // tets; vertices; 4*tet+side
  };
  std::vector<Group> blocks, nsets, ssets;
  std::vector<std::array<int32_t, 4>> file_tets;  // as written (some rotated)
  std::vector<int32_t> block_pos;                 // per tet, its element number - 1
  int64_t unmatched = 0, reordered = 0, rotated = 0, long_names = 0;
  bool block_prop = false, nset_prop = false, sset_prop = false;
};

// IDs: the ref where positive and unused, else the next free positive number.
bool assign_ids(std::vector<XPlan::Group>& g) {
  std::set<int64_t> used;
  for (const XPlan::Group& x : g)
    if (x.ref > 0) used.insert(x.ref);
  int64_t next = 1;
  bool differs = false;
  for (XPlan::Group& x : g) {
    if (x.ref > 0) {
      x.id = x.ref;
      continue;
    }
    while (used.count(next)) ++next;
    x.id = next;
    used.insert(next);
    differs = true;
  }
  return differs;
}

void make_plan(const TetMesh& m, XPlan& p) {
  std::map<int32_t, size_t> at;
  for (int32_t t = 0; t < m.nt(); ++t) {
    auto it = at.find(m.tet_ref[t]);
    if (it == at.end()) {
      it = at.emplace(m.tet_ref[t], p.blocks.size()).first;
      p.blocks.push_back({m.tet_ref[t], 0, {}});
    }
    p.blocks[it->second].items.push_back(t);
  }
  p.block_prop = assign_ids(p.blocks);
  p.block_pos.assign(static_cast<size_t>(m.nt()), 0);
  int64_t k = 0;
  for (const XPlan::Group& g : p.blocks)
    for (int64_t t : g.items) p.block_pos[static_cast<size_t>(t)] = static_cast<int32_t>(k++);
  p.file_tets.resize(static_cast<size_t>(m.nt()));
  for (int32_t t = 0; t < m.nt(); ++t) detail::file_tet(m, t, Format::Exodus, p.file_tets[t].data());
  // node sets: one per nonzero vertex ref, ascending
  std::map<int32_t, std::vector<int64_t>> vr;
  for (int32_t v = 0; v < m.nv(); ++v)
    if (static_cast<size_t>(v) < m.vert_ref.size() && m.vert_ref[v] != 0) vr[m.vert_ref[v]].push_back(v);
  for (auto& [r, v] : vr) p.nsets.push_back({r, 0, std::move(v)});
  p.nset_prop = assign_ids(p.nsets);
  // side sets: each listed triangle as the side of a tet
  struct Item {
    std::array<int32_t, 3> key;
    int32_t tet;
  };
  std::vector<Item> items;
  items.reserve(4 * static_cast<size_t>(m.nt()));
  for (int32_t t = 0; t < m.nt(); ++t) {
    const int32_t* v = p.file_tets[t].data();
    for (int f = 0; f < 4; ++f) {
      const int32_t fv[3] = {v[kExoSide[f][0]], v[kExoSide[f][1]], v[kExoSide[f][2]]};
      items.push_back({detail::tri_key(fv), t});
    }
  }
  std::sort(items.begin(), items.end(), [](const Item& x, const Item& y) { return x.key != y.key ? x.key < y.key : x.tet < y.tet; });
  std::vector<uint8_t> locked(static_cast<size_t>(m.nt()), 0);  // a side relies on the tet's order
  std::map<int32_t, size_t> sat;
  for (int32_t i = 0; i < m.ntri(); ++i) {
    const int32_t* tri = &m.tris[3 * static_cast<size_t>(i)];
    const auto key = detail::tri_key(tri);
    auto it = std::lower_bound(items.begin(), items.end(), key, [](const Item& x, const std::array<int32_t, 3>& y) { return x.key < y; });
    if (it == items.end() || it->key != key || key[0] == key[1] || key[1] == key[2]) {
      ++p.unmatched;
      continue;
    }
    int64_t best = -1;
    auto side_of = [&](int32_t t, bool exact) {
      const int32_t* v = p.file_tets[t].data();
      for (int f = 0; f < 4; ++f) {
        if (exact && v[kExoSide[f][0]] == tri[0] && v[kExoSide[f][1]] == tri[1] && v[kExoSide[f][2]] == tri[2]) return f;
        if (!exact && detail::tri_key(std::array<int32_t, 3>{v[kExoSide[f][0]], v[kExoSide[f][1]], v[kExoSide[f][2]]}.data()) == key) return f;
      }
      return -1;
    };
    for (auto j = it; j != items.end() && j->key == key && best < 0; ++j)
      if (int f = side_of(j->tet, true); f >= 0) best = 4 * static_cast<int64_t>(j->tet) + f;
    // Rotate a tet not yet relied on: w = (a, b, d, c) puts (a, b, c) on side 1.
    for (auto j = it; j != items.end() && j->key == key && best < 0; ++j) {
      if (locked[j->tet]) continue;
      int32_t* v = p.file_tets[j->tet].data();
      int32_t d = -1;
      for (int q = 0; q < 4; ++q)
        if (v[q] != tri[0] && v[q] != tri[1] && v[q] != tri[2]) d = v[q];
      const int32_t w[4] = {tri[0], tri[1], d, tri[2]};
      if (d < 0 || !even_perm(v, w)) continue;
      std::copy(w, w + 4, v);
      ++p.rotated;
      best = 4 * static_cast<int64_t>(j->tet);
    }
    if (best < 0) {
      best = 4 * static_cast<int64_t>(it->tet) + side_of(it->tet, false);
      ++p.reordered;
    }
    locked[static_cast<size_t>(best / 4)] = 1;
    auto s = sat.find(m.tri_ref[i]);
    if (s == sat.end()) {
      s = sat.emplace(m.tri_ref[i], p.ssets.size()).first;
      p.ssets.push_back({m.tri_ref[i], 0, {}});
    }
    p.ssets[s->second].items.push_back(best);
  }
  p.sset_prop = assign_ids(p.ssets);
  for (const PhysicalName& pn : m.physical_names) p.long_names += pn.name.size() > 255;
}

}  // namespace

std::vector<std::string> detail::exodus_dropped(const TetMesh& m) {
  std::vector<std::string> out;
  XPlan p;
  make_plan(m, p);
  auto add = [&](int64_t n, const std::string& what) {
    if (n > 0) out.push_back(what + " (" + std::to_string(n) + ")");
  };
  add(p.unmatched, "listed triangles that are no tet's face");
  add(p.reordered, "listed triangles whose vertex order no TETRA side can take; written as element sides");
  add(p.long_names, "names longer than 255 characters; written cut");
  int64_t unused = 0;
  for (const PhysicalName& pn : m.physical_names) {
    bool used = false;
    const auto* l = pn.dim == 3 ? &p.blocks : pn.dim == 2 ? &p.ssets : pn.dim == 0 ? &p.nsets : nullptr;
    if (l)
      for (const XPlan::Group& g : *l) used = used || g.ref == pn.tag;
    unused += !used;
  }
  add(unused, "physical names of groups with no block or set");
  return out;
}

#if TETOPT_HAVE_EXODUS

namespace {

int64_t claim_limit(int64_t bytes) { return bytes * 64 + (1 << 16); }

struct ExoCloser {
  int id = -1;
  ~ExoCloser() {
    if (id >= 0) EX->ex_close(id);
  }
};

std::string lib_error() {
  const char* msg = nullptr;
  const char* func = nullptr;
  int code = 0;
  EX->ex_get_err(&msg, &func, &code);
  if (!msg || !*msg) return {};
  return ": " + detail::shown_token(msg, true);
}

bool is_tet_type(std::string t) {
  for (char& c : t) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return t == "TETRA" || t == "TETRA4" || t == "TET4" || t == "TET";
}

// The netCDF classic header ("The NetCDF Classic Format Specification",
// netCDF-C documentation, formats CDF-1, CDF-2 and CDF-5), checked before
// the library parses it: the library allocates every name, attribute and
// list at the length the header claims (a fuzzed length of 2^31 made
// libnetcdf allocate gigabytes), and reads the data of a cut file as fill
// values.  So every length must fit in the bytes that follow, and every
// fixed-size variable's data must lie inside the file.  Returns an empty
// string when the header is sound, else what is wrong.  A netCDF-4 (HDF5)
// file is refused: Debian's Exodus II library refuses it too ("a netcdf
// library that does not support netcdf-4", on stderr).
std::string check_cdf_header(const std::string& path, int64_t file_size) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return "cannot open";
  std::string h(static_cast<size_t>(std::min<int64_t>(file_size, 1 << 20)), '\0');
  const size_t got = std::fread(h.data(), 1, h.size(), f);
  std::fclose(f);
  h.resize(got);
  if (h.size() >= 4 && h.compare(1, 3, "HDF") == 0)
    return "a netCDF-4 (HDF5) file; tetopt reads Exodus II files in classic netCDF (CDF1, CDF2, CDF5), which "
           "Debian's Exodus II library (6.02) is limited to";
  if (h.size() < 8 || h.compare(0, 3, "CDF") != 0 || (h[3] != 1 && h[3] != 2 && h[3] != 5))
    return "no netCDF magic number (CDF1, CDF2, CDF5 or HDF5)";
  const int ver = h[3];
  size_t pos = 4;
  bool bad = false;
  auto u = [&](int bytes) -> uint64_t {
    if (bad || pos + static_cast<size_t>(bytes) > h.size()) {
      bad = true;
      return 0;
    }
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v = (v << 8) | static_cast<unsigned char>(h[pos + i]);
    pos += static_cast<size_t>(bytes);
    return v;
  };
  const int nw = ver == 5 ? 8 : 4;  // NON_NEG and nelems
  auto left = [&] { return static_cast<uint64_t>(h.size() - std::min(pos, h.size())); };
  auto skip = [&](uint64_t n) {
    n = (n + 3) / 4 * 4;
    if (n > left()) bad = true;
    else pos += static_cast<size_t>(n);
  };
  std::string last_name;
  auto name = [&] {
    const uint64_t n = u(nw);
    if (n > 256) bad = true;  // NC_MAX_NAME
    else {
      if (!bad && pos + n <= h.size()) last_name.assign(h, pos, static_cast<size_t>(n));
      skip(n);
    }
  };
  // Attributes the Exodus II library reads into one value or a fixed
  // buffer (fuzzing: a 'file_size' of several values overran the stack in
  // ex_large_model): one value each, and an element type of at most 32
  // characters.
  auto att_ok = [&](const std::string& an, uint64_t type, uint64_t cnt) {
    static const char* const kScalar[] = {"api_version", "version", "floating_point_word_size", "file_size",
                                          "maximum_name_length", "int64_status", "last_written_time"};
    for (const char* k : kScalar)
      if (an == k) return type != 2 && cnt == 1;
    if (an == "elem_type" || an == "entity_type1" || an == "entity_type2") return type == 2 && cnt <= 32;
    return true;
  };
  auto type_size = [](uint64_t t) -> uint64_t {
    switch (t) {
      case 1: case 2: case 7: return 1;  // byte, char, ubyte
      case 3: case 8: return 2;          // short, ushort
      case 4: case 5: case 9: return 4;  // int, float, uint
      case 6: case 10: case 11: return 8;  // double, int64, uint64
      default: return 0;
    }
  };
  auto atts = [&] {
    const uint64_t tag = u(4);
    const uint64_t n = u(nw);
    if (tag == 0 && n == 0) return;
    if (tag != 0x0C || n > left() / 8) { bad = true; return; }
    for (uint64_t i = 0; i < n && !bad; ++i) {
      name();
      const uint64_t type = u(4);
      const uint64_t ts = type_size(type);
      const uint64_t cnt = u(nw);
      if (ts == 0 || cnt > left() / ts || !att_ok(last_name, type, cnt)) bad = true;
      else skip(cnt * ts);
    }
  };
  const uint64_t numrecs = u(nw);
  std::vector<uint64_t> dims;
  {
    const uint64_t tag = u(4), n = u(nw);
    if (!(tag == 0 && n == 0)) {
      if (tag != 0x0A || n > left() / 8) return "the header's dimension list is cut or lies";
      for (uint64_t i = 0; i < n && !bad; ++i) {
        name();
        dims.push_back(u(nw));
      }
    }
  }
  atts();
  if (bad) return "the header's global attributes are cut or lie";
  const uint64_t tag = u(4), nvars = u(nw);
  if (bad || (!(tag == 0 && nvars == 0) && (tag != 0x0B || nvars > left() / 8))) return "the header's variable list is cut or lies";
  for (uint64_t i = 0; i < nvars && !bad; ++i) {
    name();
    const uint64_t nd = u(nw);
    if (nd > 1024 || nd > left() / 4) return "a variable of the header has too many dimensions";
    uint64_t count = 1;
    bool record = false;
    for (uint64_t k = 0; k < nd && !bad; ++k) {
      const uint64_t d = u(nw);
      if (d >= dims.size()) return "a variable of the header names a dimension it does not have";
      if (dims[d] == 0) record = true;
      else if (count > (uint64_t{1} << 62) / dims[d]) return "a variable of the header is too large";
      else count *= dims[d];
    }
    atts();
    const uint64_t ts = type_size(u(4));
    u(nw);  // vsize (redundant, and wrong for large variables by the specification)
    const uint64_t begin = u(ver == 1 ? 4 : 8);
    if (bad) break;
    if (ts == 0) return "a variable of the header has an unknown type";
    if (record && numrecs != 0xFFFFFFFFu && numrecs > 0 && begin > static_cast<uint64_t>(file_size))
      return "a variable's data starts past the end of the file (cut short?)";
    const uint64_t fs = static_cast<uint64_t>(file_size);
    if (!record && (count > fs / ts || begin > fs - count * ts)) return "a variable's data lies past the end of the file (cut short?)";
  }
  if (bad) return "the header is cut or lies";
  return {};
}

class XReader {
 public:
  XReader(const std::string& path, const std::string& name) : path_(path), name_(name) {}
  Status run(TetMesh& m);

 private:
  Status fail(const std::string& what, ErrorCode c = ErrorCode::Parse) const { return Status::error(c, name_ + ": " + what); }
  Status lib(const std::string& what) const { return fail(what + lib_error()); }
  /// The refs of the objects of one kind: the TETOPT_REF property, else the IDs.
  Status refs(ex_entity_type type, ex_inquiry prop_inq, const std::vector<int>& ids, std::vector<int32_t>& out) const {
    out.assign(ids.begin(), ids.end());
    const int64_t np = EX->ex_inquire_int(id_, prop_inq);
    if (np <= 0 || np > 1024 || ids.empty()) return Status::success();
    std::vector<std::vector<char>> buf(static_cast<size_t>(np), std::vector<char>(260, 0));
    std::vector<char*> names;
    for (auto& b : buf) names.push_back(b.data());
    if (EX->ex_get_prop_names(id_, type, names.data()) < 0) return Status::success();
    for (const auto& b : buf)
      if (std::strcmp(b.data(), "TETOPT_REF") == 0) {
        for (size_t i = 0; i < ids.size(); ++i) {
          int v = 0;
          if (EX->ex_get_prop(id_, type, ids[i], "TETOPT_REF", &v) < 0) return lib("reading property TETOPT_REF");
          out[i] = v;
        }
      }
    return Status::success();
  }
  std::string name(ex_entity_type type, int id) const {
    char buf[260] = {0};
    if (EX->ex_get_name(id_, type, id, buf) < 0) return {};
    buf[256] = '\0';
    return buf;
  }

  std::string path_, name_;
  int id_ = -1;
};

Status XReader::run(TetMesh& m) {
  m = TetMesh{};
  struct stat st {};
  if (::stat(path_.c_str(), &st) != 0) return fail("no such file", ErrorCode::Io);
  if (!S_ISREG(st.st_mode)) return fail("not a regular file", ErrorCode::Io);
  const int64_t limit = claim_limit(static_cast<int64_t>(st.st_size));
  if (const std::string why = check_cdf_header(path_, static_cast<int64_t>(st.st_size)); !why.empty())
    return fail("not an Exodus II file: " + why);
  int cpu_ws = 8, io_ws = 0;
  float version = 0;
  ExoCloser c;
  c.id = EX->ex_open_int(path_.c_str(), EX_READ, &cpu_ws, &io_ws, &version, EX_API_VERS_NODOT);
  if (c.id < 0) return fail("not an Exodus II file (the library cannot open it" + lib_error() + ")");
  id_ = c.id;
  const int64_t used = EX->ex_inquire_int(id_, EX_INQ_DB_MAX_USED_NAME_LENGTH);
  EX->ex_set_max_name_length(id_, static_cast<int>(std::clamp<int64_t>(used, 32, 255)));
  char title[MAX_LINE_LENGTH + 1] = {0};
  int ndim = 0, nv = 0, ne = 0, nblk = 0, nns = 0, nss = 0;
  if (EX->ex_get_init(id_, title, &ndim, &nv, &ne, &nblk, &nns, &nss) < 0) return lib("reading the initialization parameters");
  if (ndim != 3) return fail("a " + std::to_string(ndim) + "-dimensional model (tetopt reads 3-dimensional ones)", ErrorCode::Unsupported);
  if (nv < 1) return fail("no nodes");
  if (ne < 1 || nblk < 1) return fail("no elements");
  if (nv > limit || ne > limit || nblk > limit || nns > limit || nss > limit || nblk < 0 || nns < 0 || nss < 0)
    return fail("the initialization parameters claim more nodes, elements, blocks or sets than the file can hold");
  // netCDF reads past the end of a cut file as fill values (zeros), so a
  // file too short for its coordinates and connectivity alone is cut.
  // (A cut in the last variables, names or properties, is caught only where
  // its zeros are invalid: node 0, side 0.)
  if (static_cast<int64_t>(st.st_size) < 3 * static_cast<int64_t>(nv) * std::max(io_ws, 4) + 16 * static_cast<int64_t>(ne))
    return fail("the file is shorter than its " + std::to_string(nv) + " nodes and " + std::to_string(ne) +
                " elements need (cut short?)");
  // Coordinates.
  {
    std::vector<double> x(static_cast<size_t>(nv)), y(x.size()), z(x.size());
    if (EX->ex_get_coord(id_, x.data(), y.data(), z.data()) < 0) return lib("reading the coordinates");
    m.xyz.resize(3 * x.size());
    for (size_t v = 0; v < x.size(); ++v) {
      if (!std::isfinite(x[v]) || !std::isfinite(y[v]) || !std::isfinite(z[v]))
        return fail("node " + std::to_string(v + 1) + ": coordinate not finite");
      m.xyz[3 * v] = x[v];
      m.xyz[3 * v + 1] = y[v];
      m.xyz[3 * v + 2] = z[v];
    }
  }
  // Element blocks.
  std::vector<int> bids(static_cast<size_t>(nblk));
  if (EX->ex_get_ids(id_, EX_ELEM_BLOCK, bids.data()) < 0) return lib("reading the element block IDs");
  std::vector<int32_t> brefs;
  if (Status s = refs(EX_ELEM_BLOCK, EX_INQ_EB_PROP, bids, brefs); !s) return s;
  int64_t total = 0;
  for (size_t b = 0; b < bids.size(); ++b) {
    char type[MAX_STR_LENGTH + 260] = {0};
    int nel = 0, npe = 0, ned = 0, nfa = 0, nat = 0;
    const std::string shown = "element block " + std::to_string(bids[b]);
    if (EX->ex_get_block(id_, EX_ELEM_BLOCK, bids[b], type, &nel, &npe, &ned, &nfa, &nat) < 0) return lib("reading " + shown);
    type[MAX_STR_LENGTH] = '\0';
    if (nel == 0) continue;
    if (!is_tet_type(type) || npe != 4)
      return fail(shown + ": element type '" + detail::shown_token(type, true) + "' with " + std::to_string(npe) +
                      " nodes (tetopt reads TETRA elements with 4 nodes)",
                  ErrorCode::Unsupported);
    total += nel;
    if (nel < 0 || total > ne) return fail(shown + ": more elements than the file's " + std::to_string(ne));
    std::vector<int> conn(4 * static_cast<size_t>(nel));
    if (EX->ex_get_conn(id_, EX_ELEM_BLOCK, bids[b], conn.data(), nullptr, nullptr) < 0) return lib("reading the connectivity of " + shown);
    for (size_t k = 0; k < conn.size(); ++k) {
      if (conn[k] < 1 || conn[k] > nv)
        return fail(shown + ": element " + std::to_string(k / 4 + 1) + ": node " + std::to_string(conn[k]) + " out of range 1.." + std::to_string(nv));
      m.tets.push_back(conn[k] - 1);
    }
    m.tet_ref.insert(m.tet_ref.end(), static_cast<size_t>(nel), brefs[b]);
    if (std::string n = name(EX_ELEM_BLOCK, bids[b]); !n.empty()) m.physical_names.push_back({3, brefs[b], n});
  }
  if (total != ne) return fail("the blocks hold " + std::to_string(total) + " elements, the file says " + std::to_string(ne));
  // Side sets.
  if (nss > 0) {
    std::vector<int> ids(static_cast<size_t>(nss));
    if (EX->ex_get_ids(id_, EX_SIDE_SET, ids.data()) < 0) return lib("reading the side set IDs");
    std::vector<int32_t> r;
    if (Status s = refs(EX_SIDE_SET, EX_INQ_SS_PROP, ids, r); !s) return s;
    for (size_t i = 0; i < ids.size(); ++i) {
      const std::string shown = "side set " + std::to_string(ids[i]);
      int n = 0, nd = 0;
      if (EX->ex_get_set_param(id_, EX_SIDE_SET, ids[i], &n, &nd) < 0) return lib("reading " + shown);
      if (n < 0 || n > 4 * static_cast<int64_t>(ne)) return fail(shown + ": " + std::to_string(n) + " sides, more than the elements have");
      std::vector<int> el(static_cast<size_t>(n)), side(static_cast<size_t>(n));
      if (n > 0 && EX->ex_get_set(id_, EX_SIDE_SET, ids[i], el.data(), side.data()) < 0) return lib("reading " + shown);
      for (int k = 0; k < n; ++k) {
        if (el[k] < 1 || el[k] > ne) return fail(shown + ": element " + std::to_string(el[k]) + " out of range 1.." + std::to_string(ne));
        if (side[k] < 1 || side[k] > 4) return fail(shown + ": side " + std::to_string(side[k]) + " of element " + std::to_string(el[k]) + " (a TETRA has sides 1-4)");
        const int32_t* t = &m.tets[4 * static_cast<size_t>(el[k] - 1)];
        for (int j = 0; j < 3; ++j) m.tris.push_back(t[kExoSide[side[k] - 1][j]]);
        m.tri_ref.push_back(r[i]);
      }
      if (std::string nm = name(EX_SIDE_SET, ids[i]); !nm.empty()) m.physical_names.push_back({2, r[i], nm});
    }
  }
  // Node sets.
  m.vert_ref.assign(static_cast<size_t>(nv), 0);
  if (nns > 0) {
    std::vector<int> ids(static_cast<size_t>(nns));
    if (EX->ex_get_ids(id_, EX_NODE_SET, ids.data()) < 0) return lib("reading the node set IDs");
    std::vector<int32_t> r;
    if (Status s = refs(EX_NODE_SET, EX_INQ_NS_PROP, ids, r); !s) return s;
    std::vector<uint8_t> done(static_cast<size_t>(nv), 0);
    for (size_t i = 0; i < ids.size(); ++i) {
      const std::string shown = "node set " + std::to_string(ids[i]);
      int n = 0, nd = 0;
      if (EX->ex_get_set_param(id_, EX_NODE_SET, ids[i], &n, &nd) < 0) return lib("reading " + shown);
      if (n < 0 || n > limit) return fail(shown + ": claims " + std::to_string(n) + " nodes, more than the file can hold");
      std::vector<int> nodes(static_cast<size_t>(n));
      if (n > 0 && EX->ex_get_set(id_, EX_NODE_SET, ids[i], nodes.data(), nullptr) < 0) return lib("reading " + shown);
      for (int v : nodes) {
        if (v < 1 || v > nv) return fail(shown + ": node " + std::to_string(v) + " out of range 1.." + std::to_string(nv));
        if (!done[v - 1]) {
          done[v - 1] = 1;
          m.vert_ref[v - 1] = r[i];
        }
      }
      if (std::string nm = name(EX_NODE_SET, ids[i]); !nm.empty()) m.physical_names.push_back({0, r[i], nm});
    }
  }
  return Status::success();
}

}  // namespace

bool exodus_available() { return EX->why.empty(); }

Status parse_exodus_file(const std::string& path, const std::string& name, TetMesh& m) {
  const std::lock_guard<std::mutex> lock(exodus_mutex());
  if (!EX->why.empty()) return Status::error(ErrorCode::Unsupported, name + ": " + EX->why);
  EX->ex_opts(EX_DEFAULT);  // no messages on stderr, and never exit() on an error
  XReader r(path, name);
  return r.run(m);
}

Status format_exodus_file(const TetMesh& m, const std::string& path) {
  const std::lock_guard<std::mutex> lock(exodus_mutex());
  if (!EX->why.empty()) return Status::error(ErrorCode::Unsupported, EX->why);
  EX->ex_opts(EX_DEFAULT);
  auto lib = [](const std::string& what) { return Status::error(ErrorCode::Io, "Exodus II: " + what + lib_error()); };
  if (m.nv() < 1 || m.nt() < 1) return Status::error(ErrorCode::Unsupported, "Exodus II: a model needs nodes and elements");
  XPlan p;
  make_plan(m, p);
  int cpu_ws = 8, io_ws = 8;
  ExoCloser c;
  c.id = EX->ex_create_int(path.c_str(), EX_CLOBBER, &cpu_ws, &io_ws, EX_API_VERS_NODOT);
  if (c.id < 0) return lib("cannot create the file");
  const int id = c.id;
  size_t longest = 32;
  for (const PhysicalName& pn : m.physical_names) longest = std::max(longest, std::min<size_t>(pn.name.size(), 255));
  EX->ex_set_max_name_length(id, static_cast<int>(longest));
  if (EX->ex_put_init(id, "tetopt mesh", 3, m.nv(), m.nt(), static_cast<int64_t>(p.blocks.size()),
                  static_cast<int64_t>(p.nsets.size()), static_cast<int64_t>(p.ssets.size())) < 0)
    return lib("initialization parameters");
  {
    std::vector<double> x(static_cast<size_t>(m.nv())), y(x.size()), z(x.size());
    for (size_t v = 0; v < x.size(); ++v) {
      x[v] = m.xyz[3 * v];
      y[v] = m.xyz[3 * v + 1];
      z[v] = m.xyz[3 * v + 2];
    }
    if (EX->ex_put_coord(id, x.data(), y.data(), z.data()) < 0) return lib("coordinates");
  }
  auto put_name = [&](ex_entity_type type, int64_t oid, int dim, int32_t ref) -> Status {
    const std::string* n = name_of(m, dim, ref);
    if (!n) return Status::success();
    const std::string cut = n->substr(0, 255);
    if (EX->ex_put_name(id, type, oid, cut.c_str()) < 0) return lib("name " + cut);
    return Status::success();
  };
  for (const XPlan::Group& g : p.blocks) {
    if (EX->ex_put_block(id, EX_ELEM_BLOCK, g.id, "TETRA", static_cast<int64_t>(g.items.size()), 4, 0, 0, 0) < 0)
      return lib("element block " + std::to_string(g.id));
    std::vector<int> conn;
    conn.reserve(4 * g.items.size());
    for (int64_t t : g.items)
      for (int j = 0; j < 4; ++j) conn.push_back(p.file_tets[static_cast<size_t>(t)][j] + 1);
    if (EX->ex_put_conn(id, EX_ELEM_BLOCK, g.id, conn.data(), nullptr, nullptr) < 0) return lib("connectivity of block " + std::to_string(g.id));
    if (Status s = put_name(EX_ELEM_BLOCK, g.id, 3, g.ref); !s) return s;
  }
  for (const XPlan::Group& g : p.ssets) {
    if (EX->ex_put_set_param(id, EX_SIDE_SET, g.id, static_cast<int64_t>(g.items.size()), 0) < 0) return lib("side set " + std::to_string(g.id));
    std::vector<int> el, side;
    for (int64_t ef : g.items) {
      el.push_back(p.block_pos[static_cast<size_t>(ef / 4)] + 1);
      side.push_back(static_cast<int>(ef % 4) + 1);
    }
    if (!g.items.empty() && EX->ex_put_set(id, EX_SIDE_SET, g.id, el.data(), side.data()) < 0) return lib("side set " + std::to_string(g.id));
    if (Status s = put_name(EX_SIDE_SET, g.id, 2, g.ref); !s) return s;
  }
  for (const XPlan::Group& g : p.nsets) {
    if (EX->ex_put_set_param(id, EX_NODE_SET, g.id, static_cast<int64_t>(g.items.size()), 0) < 0) return lib("node set " + std::to_string(g.id));
    std::vector<int> nodes;
    for (int64_t v : g.items) nodes.push_back(static_cast<int>(v) + 1);
    if (EX->ex_put_set(id, EX_NODE_SET, g.id, nodes.data(), nullptr) < 0) return lib("node set " + std::to_string(g.id));
    if (Status s = put_name(EX_NODE_SET, g.id, 0, g.ref); !s) return s;
  }
  auto props = [&](bool needed, ex_entity_type type, const std::vector<XPlan::Group>& gs) -> Status {
    if (!needed) return Status::success();
    for (const XPlan::Group& g : gs)
      if (EX->ex_put_prop(id, type, g.id, "TETOPT_REF", g.ref) < 0) return lib("property TETOPT_REF");
    return Status::success();
  };
  if (Status s = props(p.block_prop, EX_ELEM_BLOCK, p.blocks); !s) return s;
  if (Status s = props(p.sset_prop, EX_SIDE_SET, p.ssets); !s) return s;
  if (Status s = props(p.nset_prop, EX_NODE_SET, p.nsets); !s) return s;
  const int closing = c.id;
  c.id = -1;
  if (EX->ex_close(closing) < 0) return lib("closing the file");
  return Status::success();
}

#else  // !TETOPT_HAVE_EXODUS

bool exodus_available() { return false; }

Status parse_exodus_file(const std::string&, const std::string& name, TetMesh&) {
  return Status::error(ErrorCode::Unsupported,
                       name + ": this tetopt was built without Exodus II (libexodusii-dev was not found at configure "
                              "time; install it and reconfigure, option TETOPT_EXODUS)");
}

Status format_exodus_file(const TetMesh&, const std::string&) {
  return Status::error(ErrorCode::Unsupported,
                       "this tetopt was built without Exodus II (libexodusii-dev was not found at configure time; "
                       "install it and reconfigure, option TETOPT_EXODUS)");
}

#endif

}  // namespace tetopt
