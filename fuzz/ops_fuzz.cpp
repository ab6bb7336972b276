// libFuzzer target: random sequences of smoothing, topological operations
// (the remesher's edge split, collapse and point insertion included) and untangling on a
// small generated box mesh, validating after every step.
//
// Input layout: 6 header bytes (cells per axis, jitter, regions, seed,
// tangle count), then tangle records (3 bytes: vertex, move) that drag free
// vertices to make the mesh tangled before the snapshot, then 4-byte
// operation records (op, a, b, c), at most kMaxSteps of them.  After every
// operation that changed the mesh: validate(Cheap), validate(Full) when the
// snapshot had no inverted tet, check_invariants against the snapshot
// (constrained vertices and faces unchanged, region volumes, no new
// inverted tet), and the untangle promise (never more non-positive tets);
// the same checks once more at the end.  Any failure aborts.
//
// Speed (issue 25: it ran about 50 execs/s): the box has at most kMaxCells
// cubes (it had up to 27), an input runs at most kMaxSteps operations (it
// ran up to 64) of which at most kMaxPasses whole-mesh pass of 1 or 2
// sweeps (TopoOptions::passes, default 5), generated meshes are cached by
// header, and an operation that left the mesh exactly as it was (most
// random ones are refused) is not checked again: the arrays it could touch
// are compared with the last checked state instead.  The library's
// non-reader sources are built without comparison tracing (CMakeLists.txt).
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "tetopt/generate.hpp"
#include "tetopt/invariants.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/smooth.hpp"
#include "tetopt/topo.hpp"
#include "tetopt/untangle.hpp"

namespace {

[[noreturn]] void die(const std::string& what) {
  std::fprintf(stderr, "tetopt ops fuzz: %s\n", what.c_str());
  std::abort();
}

// At most 12 cubes (72 tets; 3x2x2 still has 2 free interior vertices to
// smooth and tangle) and 12 operations per input.
constexpr int kMaxCells = 12;
constexpr int kMaxSteps = 12;
// Whole-mesh passes (flip_pass, remove_all_boundary_tets, smooth_pass,
// untangle: ops 6-9) cost as much as dozens of local operations (flip_pass
// and remove_all_boundary_tets alone took 30% of the time with 2 of them):
// after kMaxPasses of them an input's further pass records are skipped.
constexpr int kMaxPasses = 1;

// The arrays an operation may change (geometry, connectivity, topology);
// equal arrays mean the mesh is the one last checked.
struct State {
  std::vector<double> xyz;
  std::vector<int32_t> tets, tet_ref, adj, vt_offsets, vt_tets;
  std::vector<uint8_t> face_mask, vert_constrained, tet_kind;
  void take(const tetopt::TetMesh& m) {
    xyz = m.xyz;
    tets = m.tets;
    tet_ref = m.tet_ref;
    adj = m.adj;
    vt_offsets = m.vt_offsets;
    vt_tets = m.vt_tets;
    face_mask = m.face_mask;
    vert_constrained = m.vert_constrained;
    tet_kind = m.tet_kind;
  }
  bool same(const tetopt::TetMesh& m) const {
    return xyz == m.xyz && tets == m.tets && tet_ref == m.tet_ref && adj == m.adj && vt_offsets == m.vt_offsets &&
           vt_tets == m.vt_tets && face_mask == m.face_mask && vert_constrained == m.vert_constrained &&
           tet_kind == m.tet_kind;
  }
};

// make_box_mesh + build_topology + validate for each input took a tenth of
// the time; inputs that differ only after the header share the mesh.  Once
// full, the cache drops one mesh for each it adds: as many frees as mallocs,
// so libFuzzer does not rerun the input to look for a leak.
tetopt::TetMesh generated(const tetopt::BoxMeshOptions& bo, uint8_t jr) {
  using namespace tetopt;
  static std::map<uint32_t, TetMesh> cache;
  const uint32_t key = (((static_cast<uint32_t>(bo.nx) * 4 + bo.ny) * 4 + bo.nz) << 16) | (jr << 8) |
                       static_cast<uint32_t>(bo.seed);
  if (const auto it = cache.find(key); it != cache.end()) return it->second;
  TetMesh m = make_box_mesh(bo);
  if (Status s = build_topology(m); !s) die("build_topology of a generated mesh: " + s.message);
  if (Status s = validate(m); !s) die("generated mesh invalid: " + s.message);
  if (cache.size() >= 1024) cache.erase(cache.begin());
  cache.emplace(key, m);
  return m;
}

struct Reader {
  const uint8_t* p;
  size_t n;
  size_t i = 0;
  bool more(size_t k) const { return i + k <= n; }
  uint8_t u8() { return i < n ? p[i++] : 0; }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetopt;
  Reader r{data, size};
  if (!r.more(6)) return 0;
  BoxMeshOptions bo;
  bo.nx = 1 + r.u8() % 3;
  bo.ny = 1 + r.u8() % 3;
  bo.nz = 1 + r.u8() % 3;
  while (bo.nx * bo.ny * bo.nz > kMaxCells) {  // shrink the longest axis
    int& longest = bo.nx >= bo.ny && bo.nx >= bo.nz ? bo.nx : bo.ny >= bo.nz ? bo.ny : bo.nz;
    --longest;
  }
  const uint8_t jr = r.u8();
  bo.jitter = 0.45 * (jr & 0x7f) / 127.0;
  bo.regions = (jr & 0x80) ? 2 : 1;
  bo.seed = r.u8();
  const int tangles = r.u8() % 4;
  TetMesh m = generated(bo, jr);

  // Tangle: move a free vertex by up to +-2 cells per axis (connectivity kept).
  for (int k = 0; k < tangles && r.more(3); ++k) {
    const int32_t v = r.u8() % m.nv();
    const uint8_t a = r.u8(), b = r.u8();
    if (m.vert_constrained[v]) continue;
    double* p = m.point(v);
    p[0] += ((a & 15) - 7.5) / 3.75;
    p[1] += ((a >> 4) - 7.5) / 3.75;
    p[2] += ((b & 15) - 7.5) / 3.75;
  }
  const InvariantSnapshot snap = capture_invariants(m);
  int64_t nonpos = snap.nonpositive;

  State last;
  last.take(m);
  auto check = [&](const char* op, bool always = false) {
    if (!always && last.same(m)) return;  // nothing changed since the last check
    // Full includes Cheap's checks.
    if (snap.nonpositive == 0) {
      if (Status s = validate(m, ValidateLevel::Full); !s) die(std::string(op) + ": validate(Full): " + s.message);
    } else if (Status s = validate(m, ValidateLevel::Cheap); !s) {
      die(std::string(op) + ": validate(Cheap): " + s.message);
    }
    if (Status s = check_invariants(m, snap); !s) die(std::string(op) + ": check_invariants: " + s.message);
    const int64_t now = static_cast<int64_t>(nonpositive_tets(m).size());
    if (now > nonpos) die(std::string(op) + ": non-positive tets grew");
    nonpos = now;
    last.take(m);
  };

  TopoOptions to;
  int passes = 0;
  for (int steps = 0; steps < kMaxSteps && r.more(4); ++steps) {
    const uint8_t op = r.u8(), a = r.u8(), b = r.u8(), c = r.u8();
    const int32_t t = ((a << 8) | b) % m.nt();
    const int32_t v = ((a << 8) | b) % m.nv();
    to.must_improve = !(c & 0x40);
    to.worsen_bound = (c & 0x40) ? 0.5 : 0.0;
    to.quality_threshold = 0.1 + (c & 7) * 0.15;
    to.passes = 1 + ((c >> 4) & 1);  // flip_pass / remove_all_boundary_tets sweeps (default 5)
    if (op % 12 >= 6 && op % 12 <= 9 && ++passes > kMaxPasses) continue;
    switch (op % 12) {
      case 0: {
        SmoothOptions so;
        so.optimizer = (c & 1) ? Optimizer::MaxMin : Optimizer::Paper;
        so.weight = 0.5 + 0.49 * ((c >> 1) & 7) / 7.0;
        smooth_vertex(m, v, so);
        check("smooth_vertex");
        break;
      }
      case 1: flip_23(m, t, c & 3, to); check("flip_23"); break;
      case 2: flip_32(m, t, c % 6, to); check("flip_32"); break;
      case 3: remove_edge(m, t, c % 6, to); check("remove_edge"); break;
      case 4: remove_multi_face(m, t, c & 3, to); check("remove_multi_face"); break;
      case 5: {
        TopoEditor ed(m, to);
        ed.improve_tet(t, c & 0x80);
        ed.finish();
        check("improve_tet");
        break;
      }
      case 6: flip_pass(m, to); check("flip_pass"); break;
      case 7: remove_all_boundary_tets(m, to); check("remove_all_boundary_tets"); break;
      case 8: {
        SmoothOptions so;
        so.optimizer = (c & 1) ? Optimizer::MaxMin : Optimizer::Paper;
        so.iterations = 1 + (c >> 1) % 3;
        so.seed = a;
        so.all_vertices = c & 0x80;
        smooth_pass(m, so);
        check("smooth_pass");
        break;
      }
      case 10:
      case 11: {
        // The remesher's operations (issue 27) with the loosest acceptance
        // (any positive tets), on an edge of t.
        TopoEditor ed(m, to);
        Acceptance acc;
        acc.on = true;
        acc.floor = (c & 0x80) ? 0.0 : 0.2;
        acc.cap = (c & 0x20) ? 1.0 : 0.3;
        acc.ratio = 0.5 + ((c >> 1) & 3) * 0.15;
        const char* name = "split_edge";
        if (op % 12 == 10) {
          ed.split_edge(t, c % 6, acc, 0.25 + 0.5 * (a & 1));
        } else if (b & 1) {
          // Bowyer-Watson point insertion (refine_pass): a point spread
          // from t's centroid by up to 1.5 times t's extent along each axis
          // (b, c choose it), so walks, cavities across faces and points
          // outside the domain are all reached.
          name = "insert_point";
          double x[3] = {0, 0, 0}, lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
          for (int i = 0; i < 4; ++i)
            for (int k = 0; k < 3; ++k) {
              const double p = m.point(m.tet(t)[i])[k];
              x[k] += 0.25 * p;
              lo[k] = std::min(lo[k], p);
              hi[k] = std::max(hi[k], p);
            }
          const int d[3] = {(b >> 1) & 7, (b >> 4) & 7, c & 7};
          for (int k = 0; k < 3; ++k) x[k] += (d[k] - 3.5) / 3.5 * 1.5 * (hi[k] - lo[k]);
          ed.insert_point(t, x, acc, (a & 2) ? 0.0 : 1e-3);
        } else {
          name = "collapse_edge";
          ed.collapse_edge(t, c % 6, acc);
        }
        ed.finish();
        check(name);
        break;
      }
      case 9: {
        UntangleStats us = untangle(m);
        if (!us.status) die("untangle: " + us.status.message);
        if (us.nonpositive_after > us.nonpositive_before) die("untangle made more non-positive tets");
        check("untangle");
        break;
      }
    }
  }
  check("end", true);
  return 0;
}
