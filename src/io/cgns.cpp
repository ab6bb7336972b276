// CGNS reader and writer (through the CGNS Mid-Level Library, Debian's
// libcgns-dev; built only when CMake finds it, option TETOPT_CGNS).
//
// Written from the CGNS Standard Interface Data Structures (SIDS, CGNS
// 3.4): section 6 "Zone_t" (an Unstructured zone's VertexSize and
// CellSize), 7.1 "GridCoordinates_t" (CoordinateX/Y/Z), 7.3 "Elements_t"
// (ElementRange, ElementConnectivity, one-based element numbers continuing
// across sections), 9 "Boundary conditions" (BC_t with a PointRange of
// element numbers and GridLocation FaceCenter, its BCType, FamilyName_t),
// 12.6 "Family_t", and from the Mid-Level Library manual (cg_open,
// cg_section_read, cg_boco_info, cg_goto, cg_descriptor_*).  Node numbering
// of TETRA_4 and TRI_3 (SIDS 3.3 "Unstructured Grid Element Numbering
// Conventions"): TETRA_4 nodes 1-2-3 are counter-clockwise seen from node 4,
// the positive right-hand orientation of conventions.hpp; TRI_3 is three
// nodes in the listed order.
//
// What tetopt reads: the first base (cell and physical dimension 3) and its
// one Unstructured zone; the coordinates CoordinateX/Y/Z (RealSingle is
// widened exactly, RealDouble kept bit for bit); every TETRA_4 section as
// tets and every TRI_3 section as listed triangles.  A section's ref is 1 +
// its position among the sections of its kind, or the integer of a
// Descriptor_t "tetopt_ref" under it (the writer writes one where the
// position would give another).  A tet section's name is the physical name
// (dim 3) of its ref; a triangle section's name, or the name of the BC_t
// whose element range is exactly that section, is the physical name (dim 2);
// that BC's BCType goes to the attachment (cgns_bctype), and its FamilyName
// too when it differs from the BC's name (cgns_family).  Names the writer
// made up ("Region_R", "Boundary_R") give no physical name.  Other element
// types (MIXED included), several bases or zones, structured zones are
// refused with the reason; BCs that are not the whole of one TRI_3 section
// (vertex point lists, partial lists) are not read.
//
// What tetopt writes (an HDF5 file, CGNS 3.4's default): base "Base", zone
// "Zone", double coordinates, one TETRA_4 section per tet ref (in the order
// of the refs' first tets, each section's tets in mesh order), then one
// TRI_3 section per triangle ref with a BC_t of the same name over its
// element range (GridLocation FaceCenter) and a FamilyName naming a Family_t
// of that name whose FamilyBC has the same BCType.  Names are at most 32
// characters and hold no '/' (SIDS 2.2): longer or other names are written
// changed, and dropped_by_format says so.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "io/common.hpp"
#include "tetopt/io.hpp"

#if TETOPT_HAVE_CGNS
#include <cgnslib.h>
#include <dlfcn.h>

// libcgns is loaded when a .cgns file is first read or written (dlopen),
// not linked: linked, it and HDF5 were mapped into every program using
// tetopt, and the address-space limits of tests/scripts/test_oom.sh and the
// Python tests no longer left room for their out-of-memory cases.
#define TETOPT_CGNS_FUNCS(X) X(cg_ElementDataSize) X(cg_base_read) X(cg_base_write) X(cg_boco_gridlocation_read) X(cg_boco_gridlocation_write) X(cg_boco_info) X(cg_boco_read) X(cg_boco_write) X(cg_close) X(cg_coord_info) X(cg_coord_read) X(cg_coord_write) X(cg_dataclass_write) X(cg_descriptor_read) X(cg_descriptor_write) X(cg_elements_read) X(cg_exponents_write) X(cg_fambc_write) X(cg_family_read) X(cg_family_write) X(cg_famname_read) X(cg_famname_write) X(cg_free) X(cg_get_error) X(cg_goto) X(cg_is_cgns) X(cg_nbases) X(cg_nbocos) X(cg_ncoords) X(cg_ndescriptors) X(cg_nfamilies) X(cg_nsections) X(cg_nzones) X(cg_open) X(cg_section_read) X(cg_section_write) X(cg_set_file_type) X(cg_zone_read) X(cg_zone_type) X(cg_zone_write)
namespace tetopt {
namespace {
struct CgnsLib {
#define TETOPT_X(f) decltype(&::f) f = nullptr;
  TETOPT_CGNS_FUNCS(TETOPT_X)
#undef TETOPT_X
  const char** BCTypeName = nullptr;
  const char** ElementTypeName = nullptr;
  std::string why;  // empty when loaded
};
const CgnsLib* cgns_lib() {
  static const CgnsLib lib = [] {
    CgnsLib L;
    void* h = nullptr;
    for (const char* n : {TETOPT_CGNS_SONAME, "libcgns.so.3.4", "libcgns.so"})
      if (!h && n[0]) h = ::dlopen(n, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
      const char* e = ::dlerror();
      L.why = std::string("cannot load libcgns (Debian: libcgns3.4): ") + (e ? e : "dlopen failed");
      return L;
    }
#define TETOPT_X(f)                                                        \
  L.f = reinterpret_cast<decltype(L.f)>(::dlsym(h, #f));                   \
  if (!L.f && L.why.empty()) L.why = "libcgns lacks " #f;
    TETOPT_CGNS_FUNCS(TETOPT_X)
#undef TETOPT_X
    L.BCTypeName = reinterpret_cast<const char**>(::dlsym(h, "BCTypeName"));
    L.ElementTypeName = reinterpret_cast<const char**>(::dlsym(h, "ElementTypeName"));
    if ((!L.BCTypeName || !L.ElementTypeName) && L.why.empty()) L.why = "libcgns lacks its type name tables";
    return L;
  }();
  return &lib;
}
#define CG cgns_lib()
}  // namespace
}  // namespace tetopt
#endif

namespace tetopt {

namespace {

/// libcgns keeps global state (open files, the goto position): one caller at a time.
std::mutex& cgns_mutex() {
  static std::mutex m;
  return m;
}

/// A CGNS node name from a group name: '/' becomes '_', at most 32
/// characters (SIDS 2.2), not "." or "..", unique among `used`.
std::string cgns_label(const std::string& s, std::set<std::string>& used, bool& changed) {
  std::string w = s;
  for (char& c : w)
    if (c == '/' || static_cast<unsigned char>(c) < 32) c = '_';
  if (w.size() > 32) w.resize(32);
  if (w.empty() || w == "." || w == "..") w.insert(w.begin(), '_');
  std::string base = w;
  for (int k = 2; used.count(w); ++k) {
    std::string suf(1, '_');
    suf += std::to_string(k);
    w = base;
    if (w.size() > 32 - suf.size()) w.resize(32 - suf.size());
    w.append(suf);
  }
  used.insert(w);
  changed = w != s;
  return w;
}

const std::string* name_of(const TetMesh& m, int dim, int32_t ref) {
  for (const PhysicalName& p : m.physical_names)
    if (p.dim == dim && p.tag == ref) return &p.name;
  return nullptr;
}

std::string default_name(int dim, int32_t ref) { return (dim == 3 ? "Region_" : "Boundary_") + std::to_string(ref); }

/// The writer's plan: sections per ref in first-appearance order, their names.
struct CPlan {
  struct Group {
    int32_t ref;
    std::string name;            // the CGNS node name
    std::vector<int32_t> items;  // tets or triangles, in mesh order
  };
  std::vector<Group> tets, tris;
  int64_t renamed = 0;
};

void make_plan(const TetMesh& m, CPlan& p) {
  auto group = [](const std::vector<int32_t>& refs, int32_t n, std::vector<CPlan::Group>& out) {
    std::map<int32_t, size_t> at;
    for (int32_t i = 0; i < n; ++i) {
      auto it = at.find(refs[i]);
      if (it == at.end()) {
        it = at.emplace(refs[i], out.size()).first;
        out.push_back({refs[i], {}, {}});
      }
      out[it->second].items.push_back(i);
    }
  };
  group(m.tet_ref, m.nt(), p.tets);
  group(m.tri_ref, m.ntri(), p.tris);
  std::set<std::string> used;  // Elements_t siblings under the zone; BC and family names follow the triangle sections
  for (int dim : {3, 2})
    for (CPlan::Group& g : dim == 3 ? p.tets : p.tris) {
      const std::string* n = name_of(m, dim, g.ref);
      bool changed = false;
      g.name = cgns_label(n ? *n : default_name(dim, g.ref), used, changed);
      p.renamed += n && changed;
    }
}

}  // namespace

std::vector<std::string> detail::cgns_dropped(const TetMesh& m) {
  std::vector<std::string> out;
  CPlan p;
  make_plan(m, p);
  if (p.renamed > 0)
    out.push_back("names longer than 32 characters, with '/', or repeating another (" + std::to_string(p.renamed) +
                  "); written changed");
  int64_t nz = std::count_if(m.vert_ref.begin(), m.vert_ref.end(), [](int32_t r) { return r != 0; });
  if (nz > 0) out.push_back("vertex refs (" + std::to_string(nz) + " nonzero)");
  int64_t unused = 0;
  for (const PhysicalName& pn : m.physical_names) {
    bool used = false;
    if (pn.dim == 3 || pn.dim == 2)
      for (const CPlan::Group& g : pn.dim == 3 ? p.tets : p.tris) used = used || g.ref == pn.tag;
    unused += !used;
  }
  if (unused > 0) out.push_back("physical names of groups with no section (" + std::to_string(unused) + ")");
  return out;
}

#if TETOPT_HAVE_CGNS

namespace {

using CgSize = cgsize_t;

/// The most elements / vertices a file of `bytes` bytes may claim: 64 values
/// per byte of file (HDF5 may compress, and a lying count must end in an
/// error, not in an allocation of gigabytes).
int64_t claim_limit(int64_t bytes) { return bytes * 64 + (1 << 16); }

struct Closer {
  int fn = -1;
  ~Closer() {
    if (fn >= 0) CG->cg_close(fn);
  }
};

class CReader {
 public:
  CReader(const std::string& path, const std::string& name) : path_(path), name_(name) {}
  Status run(TetMesh& m);

 private:
  Status fail(const std::string& what, ErrorCode c = ErrorCode::Parse) const {
    return Status::error(c, name_ + ": " + what);
  }
  Status lib(const std::string& what) const {
    const char* e = CG->cg_get_error();
    return fail(what + (e && *e ? std::string(": ") + detail::shown_token(e, true) : std::string()));
  }
  /// The integer of Descriptor_t "tetopt_ref" under the current goto node, if any.
  bool ref_descriptor(int64_t& ref) const {
    int nd = 0;
    if (CG->cg_ndescriptors(&nd) != CG_OK) return false;
    bool found = false;
    for (int d = 1; d <= nd && d <= 64; ++d) {
      char dname[33] = {0};
      char* text = nullptr;
      if (CG->cg_descriptor_read(d, dname, &text) != CG_OK) continue;
      if (std::strcmp(dname, "tetopt_ref") == 0 && text) {
        char* end = nullptr;
        errno = 0;
        const long long v = std::strtoll(text, &end, 10);
        if (errno == 0 && end != text && *end == '\0' && v >= INT32_MIN && v <= INT32_MAX) {
          ref = v;
          found = true;
        }
      }
      if (text) CG->cg_free(text);
    }
    return found;
  }

  std::string path_, name_;
};

Status CReader::run(TetMesh& m) {
  m = TetMesh{};
  struct stat st {};
  if (::stat(path_.c_str(), &st) != 0) return fail("no such file", ErrorCode::Io);
  if (!S_ISREG(st.st_mode)) return fail("not a regular file", ErrorCode::Io);
  const int64_t limit = claim_limit(static_cast<int64_t>(st.st_size));
  // Only HDF5 CGNS files reach libcgns.  libcgns 3.4.0 writes past a heap
  // buffer while cg_is_cgns opens some malformed ADF files (found by
  // fuzz/cgns_fuzz.cpp, 2026-11-28: ADFI_read_sub_node_table), before any
  // check of ours could run, so a hostile ADF file could corrupt tetopt's
  // memory: ADF input is refused, with the conversion that helps.  The HDF5
  // signature is at offset 0, or 512, 1024, 2048, ... after a user block
  // (HDF5 File Format Specification, "Format Signature").
  {
    static const unsigned char kHdf5[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
    std::FILE* f = std::fopen(path_.c_str(), "rb");
    if (!f) return fail(std::string("cannot open: ") + std::strerror(errno), ErrorCode::Io);
    bool hdf5 = false, adf = false;
    unsigned char head[32] = {0};
    const size_t got = std::fread(head, 1, sizeof head, f);
    // An ADF file opens with "@(#)" (libcgns writes it with the high bits
    // set) and "ADF Database Version" (ADF User's Guide, file header).
    adf = got >= 16 && std::memcmp(head + 4, "ADF Database", 12) == 0;
    for (long off = 0; !hdf5 && off <= (1L << 20) && off + 8 <= static_cast<long>(st.st_size); off = off ? 2 * off : 512) {
      unsigned char sig[8];
      if (std::fseek(f, off, SEEK_SET) != 0 || std::fread(sig, 1, 8, f) != 8) break;
      hdf5 = std::memcmp(sig, kHdf5, 8) == 0;
    }
    std::fclose(f);
    if (adf)
      return fail("an ADF-format CGNS file: tetopt reads HDF5 CGNS only (libcgns 3.4 can overrun memory on a malformed "
                  "ADF file); convert it first with 'adf2hdf IN.cgns OUT.cgns' (Debian's cgns-convert)",
                  ErrorCode::Unsupported);
    if (!hdf5) return fail("not a CGNS file (no HDF5 signature)");
  }
  int ftype = 0;
  if (CG->cg_is_cgns(path_.c_str(), &ftype) != CG_OK) return fail("not a CGNS file (an HDF5 file that libcgns does not take)");
  Closer c;
  if (CG->cg_open(path_.c_str(), CG_MODE_READ, &c.fn) != CG_OK) {
    c.fn = -1;
    return lib("cannot open as CGNS");
  }
  const int fn = c.fn;
  int nb = 0;
  if (CG->cg_nbases(fn, &nb) != CG_OK) return lib("reading the bases");
  if (nb < 1) return fail("no CGNS base (CGNSBase_t)");
  if (nb > 1) return fail("more than one CGNS base (" + std::to_string(nb) + "); tetopt reads one", ErrorCode::Unsupported);
  char bname[33] = {0};
  int cell_dim = 0, phys_dim = 0;
  if (CG->cg_base_read(fn, 1, bname, &cell_dim, &phys_dim) != CG_OK) return lib("reading the base");
  if (cell_dim != 3 || phys_dim != 3)
    return fail("base with cell dimension " + std::to_string(cell_dim) + " and physical dimension " +
                    std::to_string(phys_dim) + " (tetopt reads 3 and 3)",
                ErrorCode::Unsupported);
  int nz = 0;
  if (CG->cg_nzones(fn, 1, &nz) != CG_OK) return lib("reading the zones");
  if (nz < 1) return fail("no zone");
  if (nz > 1) return fail("more than one zone (" + std::to_string(nz) + "); tetopt reads one unstructured zone", ErrorCode::Unsupported);
  CGNS_ENUMT(ZoneType_t) zt{};
  if (CG->cg_zone_type(fn, 1, 1, &zt) != CG_OK) return lib("reading the zone type");
  if (zt != CGNS_ENUMV(Unstructured)) return fail("a structured zone (tetopt reads an Unstructured zone of tetrahedra)", ErrorCode::Unsupported);
  char zname[33] = {0};
  CgSize size[9] = {0};
  if (CG->cg_zone_read(fn, 1, 1, zname, size) != CG_OK) return lib("reading the zone");
  const int64_t nv = size[0];
  if (nv < 1) return fail("zone with " + std::to_string(nv) + " vertices");
  if (nv > limit || nv > INT32_MAX) return fail("zone claims " + std::to_string(nv) + " vertices, more than the file can hold");
  // Coordinates.
  int ncoord = 0;
  if (CG->cg_ncoords(fn, 1, 1, &ncoord) != CG_OK) return lib("reading the coordinates");
  bool have[3] = {false, false, false};
  for (int k = 1; k <= ncoord; ++k) {
    CGNS_ENUMT(DataType_t) dt{};
    char cname[33] = {0};
    if (CG->cg_coord_info(fn, 1, 1, k, &dt, cname) != CG_OK) return lib("reading coordinate " + std::to_string(k));
    for (int a = 0; a < 3; ++a)
      if (std::strcmp(cname, a == 0 ? "CoordinateX" : a == 1 ? "CoordinateY" : "CoordinateZ") == 0) have[a] = true;
  }
  for (int a = 0; a < 3; ++a)
    if (!have[a]) return fail(std::string("no ") + (a == 0 ? "CoordinateX" : a == 1 ? "CoordinateY" : "CoordinateZ") + " (tetopt reads Cartesian coordinates)");
  m.xyz.resize(static_cast<size_t>(3 * nv));
  {
    std::vector<double> col(static_cast<size_t>(nv));
    const CgSize rmin = 1, rmax = static_cast<CgSize>(nv);
    for (int a = 0; a < 3; ++a) {
      const char* cn = a == 0 ? "CoordinateX" : a == 1 ? "CoordinateY" : "CoordinateZ";
      if (CG->cg_coord_read(fn, 1, 1, cn, CGNS_ENUMV(RealDouble), &rmin, &rmax, col.data()) != CG_OK)
        return lib(std::string("reading ") + cn);
      for (int64_t v = 0; v < nv; ++v) {
        if (!std::isfinite(col[v])) return fail(std::string(cn) + " of vertex " + std::to_string(v + 1) + " is not finite");
        m.xyz[3 * v + a] = col[v];
      }
    }
  }
  // Sections.
  int ns = 0;
  if (CG->cg_nsections(fn, 1, 1, &ns) != CG_OK) return lib("reading the element sections");
  struct Sec {
    std::string name;
    int dim;  // 3 tets, 2 triangles
    int64_t start, end;
    int32_t ref;
    int64_t first;  // index of its first tet / triangle
  };
  std::vector<Sec> secs;
  int ntet_sec = 0, ntri_sec = 0;
  int64_t total = 0;
  for (int s = 1; s <= ns; ++s) {
    char sname[33] = {0};
    CGNS_ENUMT(ElementType_t) et{};
    CgSize start = 0, end = 0;
    int nbndry = 0, parent = 0;
    if (CG->cg_section_read(fn, 1, 1, s, sname, &et, &start, &end, &nbndry, &parent) != CG_OK)
      return lib("reading section " + std::to_string(s));
    const std::string shown = "section '" + detail::shown_token(sname, true) + "'";
    int npe = 0;
    if (et == CGNS_ENUMV(TETRA_4)) npe = 4;
    else if (et == CGNS_ENUMV(TRI_3)) npe = 3;
    else {
      const char* tn = (et >= 0 && et < NofValidElementTypes) ? CG->ElementTypeName[et] : "unknown";
      return fail(shown + ": element type " + std::string(tn) + " (tetopt reads TETRA_4 and TRI_3 sections)", ErrorCode::Unsupported);
    }
    if (start < 1 || end < start) return fail(shown + ": element range " + std::to_string(start) + ".." + std::to_string(end));
    const int64_t count = static_cast<int64_t>(end) - start + 1;
    total += count;
    if (total > limit || total > INT32_MAX) return fail(shown + ": claims " + std::to_string(count) + " elements, more than the file can hold");
    CgSize data_size = 0;
    if (CG->cg_ElementDataSize(fn, 1, 1, s, &data_size) != CG_OK) return lib(shown + ": reading its size");
    if (data_size != count * npe)
      return fail(shown + ": " + std::to_string(data_size) + " connectivity values for " + std::to_string(count) + " elements of " + std::to_string(npe) + " nodes");
    std::vector<CgSize> conn(static_cast<size_t>(data_size));
    std::vector<CgSize> parents(parent ? static_cast<size_t>(4 * count) : 0);
    if (CG->cg_elements_read(fn, 1, 1, s, conn.data(), parent ? parents.data() : nullptr) != CG_OK) return lib(shown + ": reading its elements");
    Sec sec{sname, npe == 4 ? 3 : 2, start, end, 0, npe == 4 ? m.nt() : m.ntri()};
    std::vector<int32_t>& dst = npe == 4 ? m.tets : m.tris;
    for (int64_t e = 0; e < count; ++e)
      for (int j = 0; j < npe; ++j) {
        const CgSize v = conn[npe * e + j];
        if (v < 1 || v > nv)
          return fail(shown + ": element " + std::to_string(start + e) + ": node " + std::to_string(v) + " out of range 1.." + std::to_string(nv));
        dst.push_back(static_cast<int32_t>(v - 1));
      }
    int64_t ref = npe == 4 ? ++ntet_sec : ++ntri_sec;
    if (CG->cg_goto(fn, 1, "Zone_t", 1, "Elements_t", s, "end") == CG_OK) ref_descriptor(ref);
    sec.ref = static_cast<int32_t>(ref);
    (npe == 4 ? m.tet_ref : m.tri_ref).insert((npe == 4 ? m.tet_ref : m.tri_ref).end(), static_cast<size_t>(count), sec.ref);
    secs.push_back(std::move(sec));
  }
  if (m.nt() == 0) return fail("no TETRA_4 section");
  // Element ranges must not overlap (SIDS 7.3: element numbers are unique in a zone).
  {
    std::vector<std::pair<int64_t, int64_t>> r;
    for (const Sec& s : secs) r.emplace_back(s.start, s.end);
    std::sort(r.begin(), r.end());
    for (size_t i = 1; i < r.size(); ++i)
      if (r[i].first <= r[i - 1].second) return fail("element ranges of two sections overlap at element " + std::to_string(r[i].first));
  }
  // BCs over a whole triangle section name it.
  std::vector<std::string> tri_name(secs.size());
  for (size_t i = 0; i < secs.size(); ++i) tri_name[i] = secs[i].name;
  int nbc = 0;
  if (CG->cg_nbocos(fn, 1, 1, &nbc) != CG_OK) nbc = 0;
  for (int b = 1; b <= nbc; ++b) {
    char bcname[33] = {0};
    CGNS_ENUMT(BCType_t) bct{};
    CGNS_ENUMT(PointSetType_t) pst{};
    CgSize npnts = 0, nlist = 0;
    int nindex[3] = {0, 0, 0}, nds = 0;
    CGNS_ENUMT(DataType_t) ndt{};
    if (CG->cg_boco_info(fn, 1, 1, b, bcname, &bct, &pst, &npnts, nindex, &nlist, &ndt, &nds) != CG_OK) return lib("reading BC " + std::to_string(b));
    CGNS_ENUMT(GridLocation_t) loc = CGNS_ENUMV(Vertex);
    if (CG->cg_boco_gridlocation_read(fn, 1, 1, b, &loc) != CG_OK) continue;
    const bool range = pst == CGNS_ENUMV(PointRange) || pst == CGNS_ENUMV(ElementRange);
    if (!range || npnts != 2 || loc == CGNS_ENUMV(Vertex) || nlist != 0) continue;
    CgSize pts[2] = {0, 0};
    if (CG->cg_boco_read(fn, 1, 1, b, pts, nullptr) != CG_OK) return lib("reading BC '" + detail::shown_token(bcname, true) + "'");
    for (size_t i = 0; i < secs.size(); ++i) {
      if (secs[i].dim != 2 || secs[i].start != pts[0] || secs[i].end != pts[1]) continue;
      tri_name[i] = bcname;
      GroupAttachment& g = m.attachment.get(2, secs[i].ref);
      if (bct >= 0 && bct < NofValidBCTypes) g.cgns_bctype = CG->BCTypeName[bct];
      char fam[33] = {0};
      if (CG->cg_goto(fn, 1, "Zone_t", 1, "ZoneBC_t", 1, "BC_t", b, "end") == CG_OK && CG->cg_famname_read(fam) == CG_OK &&
          std::strcmp(fam, bcname) != 0)
        g.cgns_family = fam;
    }
  }
  for (size_t i = 0; i < secs.size(); ++i) {
    const std::string& n = secs[i].dim == 2 ? tri_name[i] : secs[i].name;
    if (n == default_name(secs[i].dim, secs[i].ref)) continue;
    bool dup = false;
    for (const PhysicalName& p : m.physical_names) dup = dup || (p.dim == secs[i].dim && p.tag == secs[i].ref);
    if (!dup) m.physical_names.push_back(PhysicalName{secs[i].dim, secs[i].ref, n});
  }
  return Status::success();
}

CGNS_ENUMT(BCType_t) bc_type(const TetMesh& m, int32_t ref) {
  const GroupAttachment* g = m.attachment.find(2, ref);
  if (g && !g->cgns_bctype.empty())
    for (int k = 0; k < NofValidBCTypes; ++k)
      if (g->cgns_bctype == CG->BCTypeName[k]) return static_cast<CGNS_ENUMT(BCType_t)>(k);
  if (g && (g->foam_type == "wall" || g->fluent_type == "wall")) return CGNS_ENUMV(BCWall);
  if (g && (g->foam_type == "symmetryPlane" || g->foam_type == "symmetry" || g->fluent_type == "symmetry"))
    return CGNS_ENUMV(BCSymmetryPlane);
  return CGNS_ENUMV(BCTypeUserDefined);
}

}  // namespace

bool cgns_available() { return CG->why.empty(); }

Status parse_cgns_file(const std::string& path, const std::string& name, TetMesh& m) {
  const std::lock_guard<std::mutex> lock(cgns_mutex());
  if (!CG->why.empty()) return Status::error(ErrorCode::Unsupported, name + ": " + CG->why);
  CReader r(path, name);
  return r.run(m);
}

Status detail::write_cgns_typed(const TetMesh& m, const std::string& path, int file_type) {
  const std::lock_guard<std::mutex> lock(cgns_mutex());
  if (!CG->why.empty()) return Status::error(ErrorCode::Unsupported, CG->why);
  auto lib = [&](const std::string& what) {
    const char* e = CG->cg_get_error();
    return Status::error(ErrorCode::Io, "CGNS: " + what + (e && *e ? std::string(": ") + e : std::string()));
  };
  if (m.nv() < 1 || m.nt() < 1) return Status::error(ErrorCode::Unsupported, "CGNS: a zone needs vertices and tets");
  CPlan p;
  make_plan(m, p);
  if (CG->cg_set_file_type(file_type) != CG_OK) return lib("file type");
  Closer c;
  if (CG->cg_open(path.c_str(), CG_MODE_WRITE, &c.fn) != CG_OK) {
    c.fn = -1;
    return lib("cannot create the file");
  }
  const int fn = c.fn;
  int B = 0, Z = 0, C = 0, S = 0, BC = 0, F = 0, FB = 0;
  if (CG->cg_base_write(fn, "Base", 3, 3, &B) != CG_OK) return lib("base");
  // SIDS 4.1: the data class of the base's data (coordinates): dimensional
  // values in no stated unit system.
  if (CG->cg_goto(fn, B, "end") != CG_OK || CG->cg_dataclass_write(CGNS_ENUMV(NormalizedByUnknownDimensional)) != CG_OK)
    return lib("data class");
  const CgSize size[3] = {static_cast<CgSize>(m.nv()), static_cast<CgSize>(m.nt()), 0};
  if (CG->cg_zone_write(fn, B, "Zone", size, CGNS_ENUMV(Unstructured), &Z) != CG_OK) return lib("zone");
  {
    std::vector<double> col(static_cast<size_t>(m.nv()));
    for (int a = 0; a < 3; ++a) {
      for (int32_t v = 0; v < m.nv(); ++v) col[v] = m.xyz[3 * static_cast<size_t>(v) + a];
      const char* cn = a == 0 ? "CoordinateX" : a == 1 ? "CoordinateY" : "CoordinateZ";
      if (CG->cg_coord_write(fn, B, Z, CGNS_ENUMV(RealDouble), cn, col.data(), &C) != CG_OK) return lib(cn);
      // SIDS 5.3: a coordinate is a length (exponent 1 of length, 0 of the rest).
      const float exps[5] = {0, 1, 0, 0, 0};
      if (CG->cg_goto(fn, B, "Zone_t", Z, "GridCoordinates", 0, "DataArray_t", C, "end") != CG_OK ||
          CG->cg_exponents_write(CGNS_ENUMV(RealSingle), exps) != CG_OK)
        return lib("exponents of " + std::string(cn));
    }
  }
  CgSize next = 1;
  auto ref_note = [&](int32_t ref, size_t position) -> Status {
    if (ref == static_cast<int64_t>(position) + 1) return Status::success();
    if (CG->cg_goto(fn, B, "Zone_t", Z, "Elements_t", S, "end") != CG_OK) return lib("goto section");
    if (CG->cg_descriptor_write("tetopt_ref", std::to_string(ref).c_str()) != CG_OK) return lib("descriptor");
    return Status::success();
  };
  for (size_t i = 0; i < p.tets.size(); ++i) {
    const CPlan::Group& g = p.tets[i];
    std::vector<CgSize> conn;
    conn.reserve(4 * g.items.size());
    for (int32_t t : g.items) {
      int32_t v[4];
      detail::file_tet(m, t, Format::Cgns, v);
      for (int j = 0; j < 4; ++j) conn.push_back(v[j] + 1);
    }
    const CgSize end = next + static_cast<CgSize>(g.items.size()) - 1;
    if (CG->cg_section_write(fn, B, Z, g.name.c_str(), CGNS_ENUMV(TETRA_4), next, end, 0, conn.data(), &S) != CG_OK)
      return lib("section " + g.name);
    if (Status s = ref_note(g.ref, i); !s) return s;
    next = end + 1;
  }
  for (size_t i = 0; i < p.tris.size(); ++i) {
    const CPlan::Group& g = p.tris[i];
    std::vector<CgSize> conn;
    conn.reserve(3 * g.items.size());
    for (int32_t t : g.items)
      for (int j = 0; j < 3; ++j) conn.push_back(m.tris[3 * static_cast<size_t>(t) + j] + 1);
    const CgSize end = next + static_cast<CgSize>(g.items.size()) - 1;
    if (CG->cg_section_write(fn, B, Z, g.name.c_str(), CGNS_ENUMV(TRI_3), next, end, 0, conn.data(), &S) != CG_OK)
      return lib("section " + g.name);
    if (Status s = ref_note(g.ref, i); !s) return s;
    const CGNS_ENUMT(BCType_t) bct = bc_type(m, g.ref);
    const CgSize range[2] = {next, end};
    if (CG->cg_boco_write(fn, B, Z, g.name.c_str(), bct, CGNS_ENUMV(PointRange), 2, range, &BC) != CG_OK) return lib("BC " + g.name);
    if (CG->cg_boco_gridlocation_write(fn, B, Z, BC, CGNS_ENUMV(FaceCenter)) != CG_OK) return lib("BC location " + g.name);
    const GroupAttachment* ga = m.attachment.find(2, g.ref);
    std::string fam = ga && !ga->cgns_family.empty() ? ga->cgns_family : g.name;
    for (char& ch : fam)
      if (ch == '/') ch = '_';
    if (fam.size() > 32) fam.resize(32);
    bool fam_exists = false;
    {
      int nf = 0;
      CG->cg_nfamilies(fn, B, &nf);
      for (int k = 1; k <= nf; ++k) {
        char fn2[33] = {0};
        int nbo = 0, ngeo = 0;
        if (CG->cg_family_read(fn, B, k, fn2, &nbo, &ngeo) == CG_OK && fam == fn2) fam_exists = true;
      }
    }
    if (!fam_exists) {
      if (CG->cg_family_write(fn, B, fam.c_str(), &F) != CG_OK) return lib("family " + fam);
      if (CG->cg_fambc_write(fn, B, F, "FamBC", bct, &FB) != CG_OK) return lib("family BC " + fam);
    }
    if (CG->cg_goto(fn, B, "Zone_t", Z, "ZoneBC_t", 1, "BC_t", BC, "end") != CG_OK) return lib("goto BC");
    if (CG->cg_famname_write(fam.c_str()) != CG_OK) return lib("family name of BC " + g.name);
    next = end + 1;
  }
  const int fnum = c.fn;
  c.fn = -1;
  if (CG->cg_close(fnum) != CG_OK) return lib("closing the file");
  return Status::success();
}

#else  // !TETOPT_HAVE_CGNS

bool cgns_available() { return false; }

Status parse_cgns_file(const std::string&, const std::string& name, TetMesh&) {
  return Status::error(ErrorCode::Unsupported,
                       name + ": this tetopt was built without CGNS (libcgns-dev was not found at configure time; "
                              "install it and reconfigure, option TETOPT_CGNS)");
}

Status detail::write_cgns_typed(const TetMesh&, const std::string&, int) {
  return Status::error(ErrorCode::Unsupported,
                       "this tetopt was built without CGNS (libcgns-dev was not found at configure time; install it "
                       "and reconfigure, option TETOPT_CGNS)");
}

#endif

Status format_cgns_file(const TetMesh& m, const std::string& path) { return detail::write_cgns_typed(m, path, 2); }

}  // namespace tetopt
