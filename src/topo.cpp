// Topological operations that never touch a constrained face (see topo.hpp).
//
// References:
//   J. R. Shewchuk, "Two discrete optimization algorithms for the topological
//     improvement of tetrahedral meshes", unpublished manuscript, 2002
//     (edge removal by polygon DP, multi-face removal by tree DP).
//   L. A. Freitag and C. Ollivier-Gooch, "Tetrahedral mesh improvement using
//     swapping and smoothing", IJNME 40(21), 1997.
//   B. M. Klingner and J. R. Shewchuk, "Aggressive tetrahedral mesh
//     improvement", Proc. 16th International Meshing Roundtable, 2007.
//   H. Liu et al., "A novel mesh quality improvement method for boundary
//     elements", J. Applied Mathematics, 2012, Algorithm 4.
#include "tetopt/topo.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "tetopt/predicates.hpp"
#include "tetopt/quality.hpp"
#include "detail/cone.hpp"
#include "detail/edge_key.hpp"
#include "detail/parallel.hpp"
#include "detail/shell_alpha.hpp"
#include "detail/vec3.hpp"

#ifdef TETOPT_HAVE_TBB
#include <tbb/enumerable_thread_specific.h>
#endif

namespace tetopt {

namespace {

constexpr int kMaxOld = 96;                 // old tets of a cavity (a vertex star for remove_vertex)
constexpr int kMaxNew = kMaxOld;            // new tets of a cavity
constexpr int kMaxOuter = 4 * kMaxOld;      // outer faces of a cavity
constexpr int kInsertMax = 2 * kMaxShell;   // insert_vertex: cavity tets and outer faces
static_assert(kMaxOld >= 2 * kMaxShell, "an edge shell or sandwich must fit a cavity");
constexpr double kInf = std::numeric_limits<double>::infinity();
// insert_vertex's position search: the coarse step every candidate cavity
// gets and the fine step the best one is refined to (relative sizes).
constexpr double kCoarseStep = 3e-3, kFineStep = 1e-4, kFineWorth = 0.9;

using detail::edge_key;

// Rotates a triangle so its smallest vertex comes first (keeps orientation).
void canonical(const int32_t in[3], int32_t out[3]) {
  int k = 0;
  if (in[1] < in[k]) k = 1;
  if (in[2] < in[k]) k = 2;
  out[0] = in[k];
  out[1] = in[(k + 1) % 3];
  out[2] = in[(k + 2) % 3];
}

bool same3(const int32_t a[3], const int32_t b[3]) { return a[0] == b[0] && a[1] == b[1] && a[2] == b[2]; }

// The sum of the distances from x to the first vertex of each face[0..nf):
// the length scale of insert_vertex's position searches.
double face_distance_sum(const TetMesh& m, const int32_t (*face)[3], int nf, const double* x) {
  double len = 0;
  for (int i = 0; i < nf; ++i) {
    const double* a = m.point(face[i][0]);
    len += std::sqrt((a[0] - x[0]) * (a[0] - x[0]) + (a[1] - x[1]) * (a[1] - x[1]) + (a[2] - x[2]) * (a[2] - x[2]));
  }
  return len;
}

// Compass search (Kolda, Lewis & Torczon 2003, "Optimization by direct
// search", SIAM Review 45): from x, whose value is fx, polls the first
// ndir of kCompassDir (6: the axes, a positive spanning set; 14: the axes
// and the diagonals, each diagonal scaled to the axis step's length) with
// a step h halved down to hmin, at most max_evals calls of f(y, fx) (f may
// return early once it cannot beat fx), moving to the first improvement;
// rotate: each poll starts with the direction that last succeeded.  Ends
// once fx exceeds `enough`.  Returns the best value; x is its point.
constexpr double kCompassDir[14][3] = {{1, 0, 0},   {-1, 0, 0},  {0, 1, 0},    {0, -1, 0}, {0, 0, 1},
                                       {0, 0, -1},  {1, 1, 1},   {-1, -1, -1}, {1, 1, -1}, {-1, -1, 1},
                                       {1, -1, 1},  {-1, 1, -1}, {-1, 1, 1},   {1, -1, -1}};
template <class F>
double compass(const F& f, double* x, double fx, double h, double hmin, int max_evals, int ndir, bool rotate,
               double enough = std::numeric_limits<double>::infinity()) {
  int start = 0;
  for (int evals = 0; h > hmin && evals < max_evals && !(fx > enough);) {
    bool moved = false;
    for (int k = 0; k < ndir; ++k) {
      const int j = (start + k) % ndir;
      const double s = j < 6 ? h : h * 0.57735026918962576;
      const double y[3] = {x[0] + s * kCompassDir[j][0], x[1] + s * kCompassDir[j][1], x[2] + s * kCompassDir[j][2]};
      const double fy = f(y, fx);
      ++evals;
      if (fy > fx) {
        fx = fy;
        std::copy(y, y + 3, x);
        moved = true;
        if (rotate) start = j;
        break;
      }
    }
    if (!moved) h *= 0.5;
  }
  return fx;
}
template <class F>
double compass_axes(const F& f, double* x, double fx, double h, double hmin, int max_evals,
                    double enough = std::numeric_limits<double>::infinity()) {
  return compass(f, x, fx, h, hmin, max_evals, 6, false, enough);
}

// Parity of a permutation of (0,1,2,3): true when odd.
bool odd_perm(const int p[4]) {
  int inv = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) inv += p[i] > p[j];
  return (inv & 1) != 0;
}

// Records tet t among a plan's reads (consecutive repeats once).
inline void note(std::vector<int32_t>* reads, int32_t t) {
  if (reads && (reads->empty() || reads->back() != t)) reads->push_back(t);
}

int local_of(const int32_t* tv, int32_t v) {
  for (int i = 0; i < 4; ++i)
    if (tv[i] == v) return i;
  return -1;
}

}  // namespace

const char* to_string(TopoResult r) {
  switch (r) {
    case TopoResult::Applied: return "Applied";
    case TopoResult::Inverted: return "Inverted";
    case TopoResult::NotImproved: return "NotImproved";
    case TopoResult::BoundaryLocked: return "BoundaryLocked";
    case TopoResult::ShellTooLarge: return "ShellTooLarge";
    case TopoResult::RegionMismatch: return "RegionMismatch";
    case TopoResult::NotApplicable: return "NotApplicable";
  }
  return "?";
}

// A planned operation: the cavity, the new tets and how their faces connect.
struct TopoEditor::Candidate {
  enum Kind { Edge, Multi, Insert, Remove } kind = Edge;
  int size = 0;  // shell size n (Edge) or number of removed faces m (Multi)
  int n_old = 0;
  int32_t old_tets[kMaxOld];
  int n_new = 0;
  int32_t quad[kMaxNew][4];
  double new_alpha[kMaxNew];
  double old_min = 0, new_min = 0;
  int k4_old = 0, k4_new = 0;
  int32_t ref = 0, entity = 0;
  // Face 4i+f of new tet i: link >= 0 is the packed face 4j+g of new tet j
  // across it; link < 0 is outer face -1-link of the cavity.
  int32_t link[4 * kMaxNew];
  int n_outer = 0;
  int32_t outer_v[kMaxOuter][3];  // canonical, outward from the cavity
  int32_t outer_nb[kMaxOuter];    // packed neighbour face outside, or -1
  uint8_t outer_mask[kMaxOuter];  // 1 when constrained
};

namespace {

// finish_plan's pairing of the new tets' faces, by hashing: O(n) where the
// pairing there compares every face with every later one (bib_0p5 with
// --allow-insert: cones of 23 new tets on average in its refinement; that
// loop was 44% of finish_plan's own time, finish_plan 15% of the run, and
// this cut the run's median time by about 7%, the same output).  True when
// the case is clean: no two new faces alike, no two outer faces alike, no
// new face reversed on an outer face, and each new face matched exactly
// once (an outer face with its key, or a face of another new tet with its
// reverse) with every outer face used.  Then the quadratic pairing finds
// exactly these matches and succeeds (each of its refusals needs a
// duplicate, a reversed outer face, or a face with no or two matches), so
// c.link is what it sets.  False leaves the case to it (c.link then stale).
constexpr int kFastPairing = 8;  // new tets from which finish_plan hashes

// An open-addressing table of face keys: the new face with that key (tag
// >= 0) and the outer face (or -1 each).
struct FaceSlot {
  int32_t k[3];
  int32_t nt, ot;
};
constexpr int kFaceTable = 2048;  // the largest table: a power of two >= 3 (4 kMaxNew) + 2 kMaxOuter
static_assert(kFaceTable >= 3 * 4 * kMaxNew + 2 * kMaxOuter);

bool pair_hashed(TopoEditor::Candidate& c, const int32_t (*fkey)[3], const int32_t (*frev)[3]) {
  const int nn = 4 * c.n_new, no = c.n_outer;
  int size = 16;
  while (size < 3 * nn + 2 * no) size *= 2;  // the lookups of reversed keys add up to nn entries
  // On the heap, once per thread: a 40 KiB frame would grow the stack
  // where an address-space limit may refuse it (tests/scripts/test_oom.sh:
  // out of memory must be a message, and stack growth cannot throw).
  thread_local std::vector<FaceSlot> table;
  if (table.size() < static_cast<size_t>(size)) table.resize(kFaceTable);
  for (int i = 0; i < size; ++i) table[i].nt = table[i].ot = -2;  // -2: empty slot
  auto slot = [&](const int32_t* k) -> FaceSlot& {
    uint32_t h = static_cast<uint32_t>(k[0]) * 0x9E3779B1u ^ static_cast<uint32_t>(k[1]) * 0x85EBCA77u ^
                 static_cast<uint32_t>(k[2]) * 0xC2B2AE3Du;
    for (uint32_t i = (h ^ (h >> 15)) & static_cast<uint32_t>(size - 1);; i = (i + 1) & static_cast<uint32_t>(size - 1)) {
      FaceSlot& e = table[i];
      if (e.nt == -2 && e.ot == -2) {
        e.k[0] = k[0]; e.k[1] = k[1]; e.k[2] = k[2];
        e.nt = e.ot = -1;
        return e;
      }
      if (same3(e.k, k)) return e;
    }
  };
  for (int i = 0; i < nn; ++i) {
    FaceSlot& e = slot(fkey[i]);
    if (e.nt >= 0) return false;
    e.nt = i;
  }
  for (int k = 0; k < no; ++k) {
    FaceSlot& e = slot(c.outer_v[k]);
    if (e.ot >= 0) return false;
    e.ot = k;
  }
  int used = 0;
  for (int i = 0; i < nn; ++i) {
    const int32_t o = slot(fkey[i]).ot;
    const FaceSlot& rv = slot(frev[i]);
    if (rv.ot >= 0) return false;
    const int32_t r = rv.nt;
    if ((o >= 0) == (r >= 0) || (r >= 0 && r / 4 == i / 4)) return false;
    c.link[i] = o >= 0 ? -1 - o : r;
    used += o >= 0;
  }
  return used == no;
}

}  // namespace

// What insert_vertex's position search found for one tet (search_insert):
// the best cavity, its outer faces, the new vertex's place and the worst
// alpha of its fan there; with the epoch and the tets read when it was a
// plan of plan_inserts.
struct TopoEditor::InsertSearch {
  int nold = 0, nf = 0;
  int32_t old[kMaxOld];
  int32_t face[kMaxOuter][3];
  double x[3] = {0, 0, 0};
  double f = -kInf;
  // plan_inserts: the tet planned, its epoch, and every tet the search read.
  int32_t t = -1;
  uint32_t epoch = 0;
  std::vector<int32_t> reads;
};

// What insert_point's cavity search found (search_point): the cavity and
// its outer faces; with the point, the epoch and the tets read when it was
// a plan of plan_points.
struct TopoEditor::PointSearch {
  int nc = 0, nf = 0;
  int32_t cav[kMaxPointCavity];
  int32_t face[kMaxNew][3];
  TopoResult r = TopoResult::NotApplicable;
  int32_t t = -1;
  double x[3] = {0, 0, 0};
  double min_dist = 0;
  Acceptance acc;  // what the search's refusal (p.r) was judged with
  uint32_t epoch = 0;
  std::vector<int32_t> reads;
};

bool same_acceptance(const Acceptance& a, const Acceptance& b) {
  return a.on == b.on && a.floor == b.floor && a.cap == b.cap && a.ratio == b.ratio;
}

// plan_points' searches: a pool of entries, the entry of each tet slot
// planned and not yet used (of_tet), and each thread's marks (insert_point's
// mark_ and mark_epoch_).
struct TopoEditor::PointPlans {
  std::vector<PointSearch> pool;
  std::vector<int> free;
  std::vector<int> of_tet;  // per tet slot: its entry, or -1
  std::vector<int> todo;    // entries to search in this call
  int threads = 0;          // resolved on the first call
#ifdef TETOPT_HAVE_TBB
  std::optional<tbb::task_arena> arena;
  tbb::enumerable_thread_specific<std::pair<std::vector<uint32_t>, uint32_t>> marks;
#endif
};

// plan_inserts' searches, one per tet of the last call.
struct TopoEditor::InsertPlans {
  std::vector<InsertSearch> s;
  int n = 0;
  int threads = 0;  // resolved on the first call
#ifdef TETOPT_HAVE_TBB
  std::optional<tbb::task_arena> arena;
#endif
};

namespace {
// The scalar fields of a candidate, between Candidate and PackedCandidate
// (below) in either direction.
template <class S, class D>
void copy_header(const S& s, D& d) {
  d.kind = s.kind;
  d.size = s.size;
  d.n_old = s.n_old;
  d.n_new = s.n_new;
  d.n_outer = s.n_outer;
  d.old_min = s.old_min;
  d.new_min = s.new_min;
  d.k4_old = s.k4_old;
  d.k4_new = s.k4_new;
  d.ref = s.ref;
  d.entity = s.entity;
}

// Copies the parts of a candidate that commit() and count() read (the arrays
// only up to their used lengths: a candidate is about 14 KB, a 3-2 flip uses
// a few hundred bytes of it).
void copy_used(const TopoEditor::Candidate& s, TopoEditor::Candidate& d) {
  copy_header(s, d);
  std::copy(s.old_tets, s.old_tets + s.n_old, d.old_tets);
  std::copy(&s.quad[0][0], &s.quad[0][0] + 4 * s.n_new, &d.quad[0][0]);
  std::copy(s.new_alpha, s.new_alpha + s.n_new, d.new_alpha);
  std::copy(s.link, s.link + 4 * s.n_new, d.link);
  std::copy(&s.outer_v[0][0], &s.outer_v[0][0] + 3 * s.n_outer, &d.outer_v[0][0]);
  std::copy(s.outer_nb, s.outer_nb + s.n_outer, d.outer_nb);
  std::copy(s.outer_mask, s.outer_mask + s.n_outer, d.outer_mask);
}
// The parts of a candidate that commit() and count() read, in growable
// arrays: a window of planned options costs what they use, not 512 x 14 KB
// of candidates (whose first touch was page faults at every window pass).
struct PackedCandidate {
  TopoEditor::Candidate::Kind kind = TopoEditor::Candidate::Edge;
  int size = 0, n_old = 0, n_new = 0, n_outer = 0, k4_old = 0, k4_new = 0;
  double old_min = 0, new_min = 0;
  int32_t ref = 0, entity = 0;
  std::vector<int32_t> ints;  // old_tets, quad, link, outer_v, outer_nb
  std::vector<double> new_alpha;
  std::vector<uint8_t> outer_mask;
};

void pack(const TopoEditor::Candidate& s, PackedCandidate& d) {
  copy_header(s, d);
  d.ints.clear();
  d.ints.insert(d.ints.end(), s.old_tets, s.old_tets + s.n_old);
  d.ints.insert(d.ints.end(), &s.quad[0][0], &s.quad[0][0] + 4 * s.n_new);
  d.ints.insert(d.ints.end(), s.link, s.link + 4 * s.n_new);
  d.ints.insert(d.ints.end(), &s.outer_v[0][0], &s.outer_v[0][0] + 3 * s.n_outer);
  d.ints.insert(d.ints.end(), s.outer_nb, s.outer_nb + s.n_outer);
  d.new_alpha.assign(s.new_alpha, s.new_alpha + s.n_new);
  d.outer_mask.assign(s.outer_mask, s.outer_mask + s.n_outer);
}

void unpack(const PackedCandidate& s, TopoEditor::Candidate& d) {
  copy_header(s, d);
  const int32_t* q = s.ints.data();
  std::copy(q, q + s.n_old, d.old_tets);
  q += s.n_old;
  std::copy(q, q + 4 * s.n_new, &d.quad[0][0]);
  q += 4 * s.n_new;
  std::copy(q, q + 4 * s.n_new, d.link);
  q += 4 * s.n_new;
  std::copy(q, q + 3 * s.n_outer, &d.outer_v[0][0]);
  q += 3 * s.n_outer;
  std::copy(q, q + s.n_outer, d.outer_nb);
  std::copy(s.new_alpha.begin(), s.new_alpha.end(), d.new_alpha);
  std::copy(s.outer_mask.begin(), s.outer_mask.end(), d.outer_mask);
}

// TopoOptions::alpha_keep: the tets an operation removes and those it makes
// are tallied (how many below `keep`, the worst alpha); the new ones may
// replace the old when there are no more of them below `keep` and their
// worst is at least min(the old worst, keep).
struct AlphaTally {
  int below = 0;
  double worst = kInf;
  void add(double a, double keep) {
    below += a < keep;
    worst = std::min(worst, a);
  }
};
bool keeps_alpha(const AlphaTally& before, const AlphaTally& after, double keep) {
  return after.below <= before.below && after.worst >= std::min(before.worst, keep);
}
// TopoOptions::angle_keep, the same for the largest dihedral angle (degrees).
struct AngleTally {
  int above = 0;
  double worst = -kInf;
  void add(const double* a, const double* b, const double* c, const double* d, double keep) {
    double lo, hi;
    dihedral_extremes(a, b, c, d, lo, hi);
    above += hi > keep;
    worst = std::max(worst, hi);
  }
};
bool keeps_angle(const AngleTally& before, const AngleTally& after, double keep) {
  return after.above <= before.above && after.worst <= std::max(before.worst, keep);
}
// Whether replacing the tets that for_old enumerates by those for_new
// enumerates keeps TopoOptions::alpha_keep (any measure) and angle_keep
// (dihedral measure only).  Each enumerator calls fn(a, b, c, d) with a
// tet's four points.  The old tets' angles are measured only when a new tet has one above the
// level (else the rule holds whatever they were).
template <class Old, class New>
bool keeps_levels(const TopoOptions& o, const Old& for_old, const New& for_new) {
  if (const double keep = o.alpha_keep; keep > 0) {
    AlphaTally before, after;
    const Objective ob = o.objective;
    for_old([&](const double* a, const double* b, const double* c, const double* d) { before.add(objective_quality(ob, a, b, c, d), keep); });
    for_new([&](const double* a, const double* b, const double* c, const double* d) { after.add(objective_quality(ob, a, b, c, d), keep); });
    if (!keeps_alpha(before, after, keep)) return false;
  }
  if (o.measure != TopoMeasure::Dihedral) return true;
  if (const double keep = o.angle_keep; keep > 0) {
    AngleTally before, after;
    for_new([&](const double* a, const double* b, const double* c, const double* d) { after.add(a, b, c, d, keep); });
    if (after.above > 0) {
      for_old([&](const double* a, const double* b, const double* c, const double* d) { before.add(a, b, c, d, keep); });
      if (!keeps_angle(before, after, keep)) return false;
    }
  }
  return true;
}
}  // namespace

TopoEditor::TopoEditor(TetMesh& m, const TopoOptions& o) : TopoEditor(m, o, nullptr) {}

TopoEditor::TopoEditor(TetMesh& m, const TopoOptions& o, std::vector<double>* alpha_cache) : m_(m), o_(o) {
  o_.max_shell = std::clamp(o_.max_shell, 3, kMaxShell);
  const int32_t nt = m_.nt();
  // A shared cache stands for quality() only with the plain alpha measure.
  if (alpha_cache) {
    if (o_.measure == TopoMeasure::Alpha && !(o_.alpha_floor > -1e300)) {
      shared_ = alpha_cache;
      if (static_cast<int32_t>(shared_->size()) == nt) alpha_.swap(*shared_);
    }
    alpha_cache->clear();
  }
  if (static_cast<int32_t>(alpha_.size()) != nt) fill_cache();
  for (int32_t i = 0; i + 1 < static_cast<int32_t>(m_.edges.size()); i += 2)
    listed_edges_.push_back(edge_key(m_.edges[i], m_.edges[i + 1]));
  std::sort(listed_edges_.begin(), listed_edges_.end());
  // The sorted listed triangles, built once by build_topology (sorting them
  // here for every editor cost 4 ms per pass on the demo impeller).
  if (m_.tri_keys.size() == m_.tris.size()) {
    listed_tris_ = &m_.tri_keys;
  } else {
    build_tri_keys(m_.tris, own_tri_keys_);
    listed_tris_ = &own_tri_keys_;
  }
  vstamp_.assign(m_.nv(), 0);
  tstamp_.assign(nt, 0);
  cand_ = new Candidate;
  best_ = new Candidate;
  stats_.tets_before = nt;
}

void TopoEditor::fill_cache() {
  const int32_t nt = m_.nt();
  alpha_.resize(nt);
  // Dihedral measure: the smallest and largest dihedral angles follow from
  // the largest and smallest cosines of the angles between the outward face
  // normals (two acos instead of the six atan2 of dihedral_angles), which
  // gives the measure up to rounding; with a relative margin of 1e-6 that is
  // a lower bound, and a tet whose bound reaches the threshold is never
  // visited for being poor: its measure proper is computed only if a cavity
  // or min_cached() needs it.  (The former bound, sin(theta) >= alpha /
  // sqrt(6), deferred nothing once the worst alpha was below 0.5: on the
  // demo impeller the pass then cost 0.3 s for no change.)
  const double denom = std::max(o_.dihedral_lo, 180.0 - o_.dihedral_hi);
  const bool defer = o_.measure == TopoMeasure::Dihedral && denom > 0 && o_.dihedral_lo > 0 && o_.dihedral_hi < 180;
  if (defer) lb_.resize(nt);
  detail::parallel_for_each(nt, o_.threads, [&](int64_t i) {
    const auto t = static_cast<int32_t>(i);
    const int32_t* v = m_.tet(t);
    const double *a = m_.point(v[0]), *b = m_.point(v[1]), *c = m_.point(v[2]), *d = m_.point(v[3]);
    if (defer) {
      const double al = objective_quality(o_.objective, a, b, c, d);
      if (al >= o_.alpha_floor && al > 0) {
        const double* p[4] = {a, b, c, d};
        double n[4][3], nl[4];
        detail::face_normals(p, n, nl);
        double cmax = -1, cmin = 1;
        for (int k = 0; k < 4; ++k)
          for (int l = k + 1; l < 4; ++l) {
            const double cs = std::clamp(
                -(n[k][0] * n[l][0] + n[k][1] * n[l][1] + n[k][2] * n[l][2]) / (nl[k] * nl[l]), -1.0, 1.0);
            cmax = std::max(cmax, cs);
            cmin = std::min(cmin, cs);
          }
        constexpr double kDeg = 180.0 / std::numbers::pi;
        const double lo_deg = std::acos(cmax) * kDeg, hi_deg = std::acos(cmin) * kDeg;
        const double lb = std::min(lo_deg / o_.dihedral_lo, (180.0 - hi_deg) / (180.0 - o_.dihedral_hi)) *
                          (1.0 - 1e-6);  // margin for rounding
        if (lb >= o_.quality_threshold) {
          alpha_[t] = std::numeric_limits<double>::quiet_NaN();
          lb_[t] = lb;
          return;
        }
      }
    }
    alpha_[t] = quality(a, b, c, d);
  });
}

TopoEditor::~TopoEditor() {
  finish();
  delete cand_;
  delete best_;
  delete isearch_;
  delete iplans_;
  delete psearch_;
  delete pplans_;
}

double TopoEditor::quality(const double* a, const double* b, const double* c, const double* d) const {
  if (o_.measure == TopoMeasure::Alpha) {
    const double q = objective_quality(o_.objective, a, b, c, d);
    return q < o_.alpha_floor ? -kInf : q;
  }
  // Dihedral measure: min over the six angles of theta / lo (small angles)
  // or (180 - theta) / (180 - hi) (large angles); 1 when the extremes sit
  // exactly at the targets.  Tets below the alpha floor count as -inf, so a
  // dihedral pass never lowers the mesh's worst alpha.
  if (objective_quality(o_.objective, a, b, c, d) < o_.alpha_floor || tet_signed_volume(a, b, c, d) <= 0) return -kInf;
  // min over the six angles x of x / lo and (180 - x) / (180 - hi): the
  // smallest angle gives the first, the largest the second (division and
  // subtraction round monotonically, so this is the same number).
  double lo_deg, hi_deg;
  dihedral_extremes(a, b, c, d, lo_deg, hi_deg);
  return std::min(lo_deg / o_.dihedral_lo, (180.0 - hi_deg) / (180.0 - o_.dihedral_hi));
}

double TopoEditor::deferred(int32_t t) const {
  const int32_t* v = m_.tet(t);
  const double q = quality(m_.point(v[0]), m_.point(v[1]), m_.point(v[2]), m_.point(v[3]));
  if (!nocache_) alpha_[t] = q;  // improve_tets' parallel plans compute it without storing it
  return q;
}

double TopoEditor::min_cached() const {
  // A free slot's cached value is +inf (commit() sets it when it frees the
  // slot), so the live tets need no test here: reading the tets' vertex
  // array for it made this scan, called about 45 times a run, five times
  // slower (0.067 s on the demo impeller at 1 thread).
  const int32_t nt = m_.nt();
  if (lb_.empty())  // nothing deferred: a plain minimum
    return detail::parallel_min(nt, o_.threads, [&](int64_t t) { return alpha_[t]; });
  double lo = kInf;
  for (int32_t t = 0; t < nt; ++t)
    if (alpha_[t] == alpha_[t]) lo = std::min(lo, alpha_[t]);
  for (int32_t t = 0; t < nt; ++t)
    if (alpha_[t] != alpha_[t] && lb_[t] < lo) lo = std::min(lo, deferred(t));
  return lo;
}

bool TopoEditor::alive(int32_t t) const {
  return t >= 0 && t < m_.nt() && m_.tets[4 * static_cast<size_t>(t)] >= 0;
}

// ---------------------------------------------------------------------------
// Edge removal: gather the shell of edge (a,b), triangulate the ring by DP.
TopoResult TopoEditor::gather_shell(int32_t t, int le, int32_t& a, int32_t& b, int32_t* ring, int32_t* shell, int& n,
                                    std::vector<int32_t>* reads) const {
  if (!alive(t) || le < 0 || le > 5) return TopoResult::NotApplicable;
  const int32_t* tv = m_.tet(t);
  int p[4] = {kEdgeVertex[le][0], kEdgeVertex[le][1], 0, 0};
  {
    int k = 2;
    for (int i = 0; i < 4; ++i)
      if (i != p[0] && i != p[1]) p[k++] = i;
    if (odd_perm(p)) std::swap(p[2], p[3]);
  }
  // orient(a, b, ring[i], ring[i+1]) > 0 for every shell tet (a, b, r_i, r_i+1).
  a = tv[p[0]];
  b = tv[p[1]];
  note(reads, t);
  if (!listed_edges_.empty() && std::binary_search(listed_edges_.begin(), listed_edges_.end(), edge_key(a, b)))
    return TopoResult::BoundaryLocked;
  ring[0] = tv[p[2]];
  ring[1] = tv[p[3]];
  shell[0] = t;
  n = 1;
  const int32_t ref = m_.tet_ref[t];
  const bool has_entity = !m_.tet_entity.empty();
  const int32_t ent = has_entity ? m_.tet_entity[t] : 0;
  auto cross = [&](int32_t cur, int lo, int32_t& nb) -> TopoResult {
    note(reads, cur);
    nb = m_.adj[4 * static_cast<size_t>(cur) + lo];
    if (nb < 0) return TopoResult::BoundaryLocked;
    const int32_t o = nb / 4;
    note(reads, o);
    // A face between two regions or entities is constrained (classify), so
    // the neighbour's ref is read only for a constrained face, to tell the
    // two refusals apart: a free face needs no read of the neighbour's ref
    // (a cache miss per shell tet, the largest part of this function's time).
    if (m_.face_mask[cur] & (1u << lo))
      return m_.tet_ref[o] != ref || (has_entity && m_.tet_entity[o] != ent) ? TopoResult::RegionMismatch
                                                                             : TopoResult::BoundaryLocked;
    return TopoResult::Applied;
  };
  while (ring[n] != ring[0]) {
    const int32_t cur = shell[n - 1];
    const int lo = local_of(m_.tet(cur), ring[n - 1]);
    int32_t nb;
    if (TopoResult r = cross(cur, lo, nb); r != TopoResult::Applied) return r;
    if (n >= o_.max_shell) return TopoResult::ShellTooLarge;
    if (nb / 4 == t) return TopoResult::NotApplicable;  // inconsistent adjacency
    shell[n] = nb / 4;
    ring[n + 1] = m_.tets[nb];
    ++n;
  }
  {  // the face (a, b, r0) closing the shell, between shell[n-1] and t
    int32_t nb;
    if (TopoResult r = cross(t, p[3], nb); r != TopoResult::Applied) return r;
    if (nb / 4 != shell[n - 1]) return TopoResult::NotApplicable;
  }
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (ring[i] == ring[j] || shell[i] == shell[j]) return TopoResult::NotApplicable;
  return TopoResult::Applied;
}

TopoResult TopoEditor::plan_edge(int32_t t, int le, int want_n, bool strict, Candidate& c, double bound,
                                 std::vector<int32_t>* reads) const {
  int32_t a, b, ring[kMaxShell + 2], shell[kMaxShell + 1];
  int n = 0;
  if (TopoResult r = gather_shell(t, le, a, b, ring, shell, n, reads); r != TopoResult::Applied) return r;
  if (want_n > 0 && n != want_n) return TopoResult::NotApplicable;
  const int32_t ref = m_.tet_ref[t];
  const int32_t ent = m_.tet_entity.empty() ? 0 : m_.tet_entity[t];

  c.kind = Candidate::Edge;
  c.size = n;
  c.ref = ref;
  c.entity = ent;
  set_old_tets(c, shell, n);

  // Polygon DP (Klincsek 1980; Shewchuk 2002): q[i][j] is the best worst
  // alpha over triangulations of the sub-polygon r_i .. r_j; triangle
  // (i, k, j) with i < k < j gives tets (r_i, r_k, r_j, b) and (r_i, r_j, r_k, a).
  double q[kMaxShell][kMaxShell];
  int arg[kMaxShell][kMaxShell];
  const double* pa = m_.point(a);
  const double* pb = m_.point(b);
  // Branch and bound: a triangulation whose worst alpha does not exceed
  // `floor` is refused anyway (policy, or a better option already found by
  // improve_tet), so triangles at or below it are never evaluated twice.
  double floor = bound;
  if ((strict || o_.must_improve) && !judged_) floor = std::max(floor, c.old_min + o_.margin);
  for (int i = 0; i + 1 < n; ++i) q[i][i + 1] = kInf;
  // With alpha as the measure, the tets' alpha from memoised pieces (ShellAlpha):
  // the same bits as quality(), a triangle's own area once for its two
  // tets and each ring edge's lengths and side areas once for the polygon.
  const bool memo = o_.measure == TopoMeasure::Alpha &&
                    (o_.objective == Objective::Alpha || o_.objective == Objective::OpenFoam);
  detail::ShellAlpha sa;
  if (memo) sa.reset(n, ring, pa, pb, m_);
  for (int len = 2; len < n; ++len)
    for (int i = 0; i + len < n; ++i) {
      const int j = i + len;
      double best = floor;
      int bk = -1;
      for (int k = i + 1; k < j; ++k) {
        double v = std::min(q[i][k], q[k][j]);
        if (v <= best) continue;
        const double* pi = m_.point(ring[i]);
        const double* pk = m_.point(ring[k]);
        const double* pj = m_.point(ring[j]);
        if (memo) {
          const double top = sa.top(i, k, j);
          v = std::min(v, top < o_.alpha_floor ? -kInf : top);
          if (v <= best) continue;
          const double bottom = sa.bottom(i, k, j);
          v = std::min(v, bottom < o_.alpha_floor ? -kInf : bottom);
        } else {
          v = std::min(v, quality(pi, pk, pj, pb));
          if (v <= best) continue;
          v = std::min(v, quality(pi, pj, pk, pa));
        }
        if (v > best) {
          best = v;
          bk = k;
        }
      }
      q[i][j] = bk < 0 ? -kInf : best;
      arg[i][j] = bk;
    }
  c.new_min = q[0][n - 1];
  if (c.new_min == -kInf) return floor > 0 ? TopoResult::NotImproved : TopoResult::Inverted;
  if (!(c.new_min > 0)) return TopoResult::Inverted;
  if (!judged_ && c.new_min <= c.old_min + o_.margin &&
      (strict || o_.must_improve || c.new_min < c.old_min - o_.worsen_bound))
    return TopoResult::NotImproved;
  // Emit the optimal triangulation.
  c.n_new = 0;
  c.k4_new = 0;
  int stack[2 * kMaxShell][2];
  int sp = 0;
  stack[sp][0] = 0;
  stack[sp][1] = n - 1;
  ++sp;
  while (sp > 0) {
    --sp;
    const int i = stack[sp][0], j = stack[sp][1];
    if (j - i < 2) continue;
    const int k = arg[i][j];
    int32_t* top = c.quad[c.n_new++];
    top[0] = ring[i]; top[1] = ring[k]; top[2] = ring[j]; top[3] = b;
    int32_t* bot = c.quad[c.n_new++];
    bot[0] = ring[i]; bot[1] = ring[j]; bot[2] = ring[k]; bot[3] = a;
    stack[sp][0] = i; stack[sp][1] = k; ++sp;
    stack[sp][0] = k; stack[sp][1] = j; ++sp;
  }
  return finish_plan(strict, c);
}

// ---------------------------------------------------------------------------
// Multi-face removal: faces sandwiched between apexes a (side of t) and b.
TopoResult TopoEditor::plan_multi(int32_t t, int lf, int max_tris, bool strict, Candidate& c,
                                  std::vector<int32_t>* reads) const {
  if (!alive(t) || lf < 0 || lf > 3) return TopoResult::NotApplicable;
  max_tris = std::min(max_tris, o_.max_shell - 2);
  if (max_tris < 1) return TopoResult::ShellTooLarge;
  const int32_t ref = m_.tet_ref[t];
  const bool has_entity = !m_.tet_entity.empty();
  const int32_t ent = has_entity ? m_.tet_entity[t] : 0;
  // A face between two tets of the cavity: must be interior, same region,
  // unconstrained.
  auto removable = [&](int32_t packed) -> TopoResult {
    note(reads, packed / 4);
    const int32_t nb = m_.adj[packed];
    if (nb < 0) return TopoResult::BoundaryLocked;
    const int32_t o = nb / 4;
    note(reads, o);
    if (m_.face_mask[packed / 4] & (1u << (packed % 4)))  // as in plan_edge: a free face has one region
      return m_.tet_ref[o] != ref || (has_entity && m_.tet_entity[o] != ent) ? TopoResult::RegionMismatch
                                                                             : TopoResult::BoundaryLocked;
    return TopoResult::Applied;
  };
  if (TopoResult r = removable(4 * t + lf); r != TopoResult::Applied) return r;
  const int32_t nb0 = m_.adj[4 * static_cast<size_t>(t) + lf];
  const int32_t a = m_.tets[4 * static_cast<size_t>(t) + lf];
  const int32_t b = m_.tets[nb0];
  // Sandwich triangles, oriented with their normal towards b.
  struct Tri {
    int32_t v[3];
    int32_t up, lo;  // tets (a + tri) and (b + tri)
    int child[3];    // for edge (v[e], v[e+1]): child triangle or -1
    int parent_edge;
    double best;     // DP value of the subtree
    bool take[3];    // DP choice: include the child across edge e
  };
  Tri tri[kMaxShell];
  int nt = 1;
  {
    Tri& r = tri[0];
    const int32_t* tv = m_.tet(t);
    for (int i = 0; i < 3; ++i) r.v[i] = tv[kFaceVertex[lf][i]];
    r.up = t;
    r.lo = nb0 / 4;
    r.parent_edge = -1;
  }
  for (int i = 0; i < nt; ++i) {
    Tri& r = tri[i];
    for (int e = 0; e < 3; ++e) {
      r.child[e] = -1;
      r.take[e] = false;
      if (e == r.parent_edge || nt >= max_tris) continue;
      const int32_t x = r.v[e], y = r.v[(e + 1) % 3], z = r.v[(e + 2) % 3];
      // Taking the child across (x, y) removes that edge (it becomes a
      // diagonal inside the removed sandwich): a listed edge stays on the ring.
      if (!listed_edges_.empty() && std::binary_search(listed_edges_.begin(), listed_edges_.end(), edge_key(x, y)))
        continue;
      const int lu = local_of(m_.tet(r.up), z), ll = local_of(m_.tet(r.lo), z);
      const int32_t fu = 4 * r.up + lu, fl = 4 * r.lo + ll;
      if (removable(fu) != TopoResult::Applied || removable(fl) != TopoResult::Applied) continue;
      const int32_t nu = m_.adj[fu], nl = m_.adj[fl];
      const int32_t s = m_.tets[nu];
      if (s != m_.tets[nl] || s == a || s == b) continue;
      const int32_t X = nu / 4, Y = nl / 4;
      // X = (a, y, x, s) and Y = (b, y, x, s) must meet across (y, x, s).
      const int la = local_of(m_.tet(X), a);
      if (la < 0 || m_.adj[4 * X + la] / 4 != Y || removable(4 * X + la) != TopoResult::Applied) continue;
      bool seen = false;  // a cycle in the dual graph: leave that edge on the ring
      for (int q = 0; q < nt && !seen; ++q) seen = tri[q].up == X;
      if (seen) continue;
      Tri& ch = tri[nt];
      ch.v[0] = y; ch.v[1] = x; ch.v[2] = s;
      ch.up = X;
      ch.lo = Y;
      ch.parent_edge = 0;
      r.child[e] = nt++;
    }
  }
  // Tree DP (Shewchuk 2002): for each edge either stop (new tet (a, b, x, y))
  // or include the child subtree; maximise the worst new alpha.
  const double* pa = m_.point(a);
  const double* pb = m_.point(b);
  for (int i = nt - 1; i >= 0; --i) {
    Tri& r = tri[i];
    r.best = kInf;
    for (int e = 0; e < 3; ++e) {
      if (e == r.parent_edge) continue;
      const double stop = quality(pa, pb, m_.point(r.v[e]), m_.point(r.v[(e + 1) % 3]));
      double v = stop;
      if (r.child[e] >= 0 && tri[r.child[e]].best > stop) {
        v = tri[r.child[e]].best;
        r.take[e] = true;
      }
      r.best = std::min(r.best, v);
    }
  }
  c.kind = Candidate::Multi;
  c.ref = ref;
  c.entity = ent;
  c.new_min = tri[0].best;
  if (!(c.new_min > 0)) return TopoResult::Inverted;
  // Collect the chosen subtree.
  int chosen[kMaxShell];
  int nc = 0;
  chosen[nc++] = 0;
  for (int i = 0; i < nc; ++i)
    for (int e = 0; e < 3; ++e)
      if (tri[chosen[i]].take[e]) chosen[nc++] = tri[chosen[i]].child[e];
  c.size = nc;
  c.n_old = 0;
  c.old_min = kInf;
  c.k4_old = 0;
  int32_t verts[kMaxShell + 2];
  int nverts = 0;
  for (int i = 0; i < nc; ++i) {
    const Tri& r = tri[chosen[i]];
    for (int32_t o : {r.up, r.lo}) {
      c.old_tets[c.n_old++] = o;
      c.old_min = std::min(c.old_min, cached_alpha(o));
      c.k4_old += m_.tet_kind[o] == 4;
    }
    for (int k = 0; k < 3; ++k) {
      bool have = false;
      for (int q = 0; q < nverts && !have; ++q) have = verts[q] == r.v[k];
      if (!have) {
        if (nverts >= kMaxShell + 2) return TopoResult::NotApplicable;
        verts[nverts++] = r.v[k];
      }
    }
  }
  // A disk without interior vertices: otherwise a vertex would vanish.
  if (nverts != nc + 2) return TopoResult::NotApplicable;
  if (!judged_ && c.new_min <= c.old_min + o_.margin &&
      (strict || o_.must_improve || c.new_min < c.old_min - o_.worsen_bound))
    return TopoResult::NotImproved;
  c.n_new = 0;
  for (int i = 0; i < nc; ++i) {
    const Tri& r = tri[chosen[i]];
    for (int e = 0; e < 3; ++e) {
      if (e == r.parent_edge || r.take[e]) continue;
      int32_t* q = c.quad[c.n_new++];
      q[0] = a; q[1] = b; q[2] = r.v[e]; q[3] = r.v[(e + 1) % 3];
    }
  }
  if (c.n_new != nc + 2) return TopoResult::NotApplicable;
  return finish_plan(strict, c);
}

// ---------------------------------------------------------------------------
// Shared tail of every plan: kind-4 count, exact orientation, policy, and the
// combinatorial check that the new tets fill exactly the cavity.
TopoResult TopoEditor::finish_plan(bool strict, Candidate& c) const {
  c.k4_new = 0;
  double worst = kInf, worst_k4 = kInf;
  for (int i = 0; i < c.n_new; ++i) {
    const int32_t* q = c.quad[i];
    const bool k4 = (m_.vert_constrained[q[0]] + m_.vert_constrained[q[1]] + m_.vert_constrained[q[2]] +
                     m_.vert_constrained[q[3]]) == 4;
    c.k4_new += k4;
    c.new_alpha[i] = quality(m_.point(q[0]), m_.point(q[1]), m_.point(q[2]), m_.point(q[3]));
    worst = std::min(worst, c.new_alpha[i]);
    if (k4) worst_k4 = std::min(worst_k4, c.new_alpha[i]);
  }
  c.new_min = worst;
  bool ok = c.new_min > c.old_min + o_.margin || ((any_valid_ || judged_) && c.new_min > 0) || restoring_ ||
            (accept_ && c.new_min >= accept_.floor_for(c.old_min) && c.new_min > 0);
  // May-worsen policy (Liu et al. §4): fewer kind-4 tets, and only tets that
  // smoothing can still fix (kind < 4) may fall below the old worst alpha.
  if (!ok && !strict && !o_.must_improve)
    ok = c.k4_new < c.k4_old && c.new_min >= c.old_min - o_.worsen_bound && worst_k4 >= c.old_min;
  if (!ok) return c.new_min > 0 ? TopoResult::NotImproved : TopoResult::Inverted;
  if (!restoring_) {
    auto quad_points = [&](const int32_t* q, auto fn) { fn(m_.point(q[0]), m_.point(q[1]), m_.point(q[2]), m_.point(q[3])); };
    if (!keeps_levels(
            o_, [&](auto fn) { for (int i = 0; i < c.n_old; ++i) quad_points(m_.tet(c.old_tets[i]), fn); },
            [&](auto fn) { for (int i = 0; i < c.n_new; ++i) quad_points(c.quad[i], fn); }))
      return TopoResult::NotImproved;
  }
  // (An undo restores tets that were there, flat or inverted input tets that
  // untangling could not fix included: no orientation test for them.)
  for (int i = 0; i < c.n_new && !restoring_; ++i) {
    const int32_t* q = c.quad[i];
    if (orient3d(m_.point(q[0]), m_.point(q[1]), m_.point(q[2]), m_.point(q[3])) != Sign::Positive)
      return TopoResult::Inverted;
  }
  // Guards (guard.hpp): no new tet worse than the extremes on any measure;
  // measured after the exact orientation test, so only valid candidates
  // count as refused.
  // The first operation of a pair (any_valid_) is judged with the pair: see
  // improve_tet_pair.
  if (o_.guard && !restoring_ && !any_valid_)
    for (int i = 0; i < c.n_new; ++i) {
      const int32_t* q = c.quad[i];
      if (!o_.guard->admits(m_.point(q[0]), m_.point(q[1]), m_.point(q[2]), m_.point(q[3])))
        return TopoResult::NotImproved;
    }
  // Outer faces of the cavity; faces between cavity tets must be free.
  auto in_cavity = [&](int32_t o) {
    for (int i = 0; i < c.n_old; ++i)
      if (c.old_tets[i] == o) return true;
    return false;
  };
  c.n_outer = 0;
  for (int i = 0; i < c.n_old; ++i) {
    const int32_t o = c.old_tets[i];
    const int32_t* tv = m_.tet(o);
    for (int f = 0; f < 4; ++f) {
      const int32_t nb = m_.adj[4 * static_cast<size_t>(o) + f];
      const bool constrained = (m_.face_mask[o] >> f) & 1u;
      if (nb >= 0 && in_cavity(nb / 4)) {
        if (constrained) return TopoResult::BoundaryLocked;
        continue;
      }
      const int32_t v[3] = {tv[kFaceVertex[f][0]], tv[kFaceVertex[f][1]], tv[kFaceVertex[f][2]]};
      canonical(v, c.outer_v[c.n_outer]);
      c.outer_nb[c.n_outer] = nb;
      c.outer_mask[c.n_outer] = constrained ? 1 : 0;
      ++c.n_outer;
    }
  }
  bool used[kMaxOuter] = {};
  // Every new face's canonical triple and that of its reverse, computed once
  // (the pairing below compares each face with all later ones).
  int32_t fkey[4 * kMaxNew][3], frev[4 * kMaxNew][3];
  for (int i = 0; i < c.n_new; ++i)
    for (int f = 0; f < 4; ++f) {
      const int32_t* q = c.quad[i];
      const int32_t v[3] = {q[kFaceVertex[f][0]], q[kFaceVertex[f][1]], q[kFaceVertex[f][2]]};
      canonical(v, fkey[4 * i + f]);
      const int32_t vr[3] = {v[0], v[2], v[1]};
      canonical(vr, frev[4 * i + f]);
    }
  // A face between two new tets must not be a listed triangle.
  auto listed_inside = [&](const int32_t* v) {
    if (listed_tris_->empty()) return false;
    const std::vector<int32_t>& keys = *listed_tris_;
    int32_t s[3] = {v[0], v[1], v[2]};
    std::sort(s, s + 3);
    // binary search over flattened sorted triples
    size_t lo = 0, hi = keys.size() / 3;
    while (lo < hi) {
      const size_t mid = (lo + hi) / 2;
      const int32_t* x = &keys[3 * mid];
      if (std::lexicographical_compare(x, x + 3, s, s + 3)) lo = mid + 1;
      else hi = mid;
    }
    return lo < keys.size() / 3 && same3(&keys[3 * lo], s);
  };
  if (c.n_new >= kFastPairing && pair_hashed(c, fkey, frev)) {
    // In the quadratic pairing's order: each inner face once, from its
    // lower tet.
    for (int i = 0; i < c.n_new; ++i)
      for (int f = 0; f < 4; ++f)
        if (c.link[4 * i + f] >= 4 * (i + 1) && listed_inside(fkey[4 * i + f])) return TopoResult::BoundaryLocked;
    return TopoResult::Applied;
  }
  for (int i = 0; i < 4 * c.n_new; ++i) c.link[i] = std::numeric_limits<int32_t>::min();
  for (int i = 0; i < c.n_new; ++i)
    for (int f = 0; f < 4; ++f) {
      if (c.link[4 * i + f] != std::numeric_limits<int32_t>::min()) continue;
      const int32_t* q = c.quad[i];
      const int32_t v[3] = {q[kFaceVertex[f][0]], q[kFaceVertex[f][1]], q[kFaceVertex[f][2]]};
      const int32_t* key = fkey[4 * i + f];
      const int32_t* rev = frev[4 * i + f];
      int found = 0;
      for (int k = 0; k < c.n_outer; ++k) {
        if (same3(c.outer_v[k], key)) {
          if (used[k]) return TopoResult::NotApplicable;
          used[k] = true;
          c.link[4 * i + f] = -1 - k;
          ++found;
        } else if (same3(c.outer_v[k], rev)) {
          return TopoResult::NotApplicable;
        }
      }
      for (int j = i + 1; j < c.n_new; ++j)
        for (int g = 0; g < 4; ++g) {
          const int32_t* wk = fkey[4 * j + g];
          if (same3(wk, rev)) {
            if (found || c.link[4 * j + g] != std::numeric_limits<int32_t>::min()) return TopoResult::NotApplicable;
            c.link[4 * i + f] = 4 * j + g;
            c.link[4 * j + g] = 4 * i + f;
            ++found;
          } else if (same3(wk, key)) {
            return TopoResult::NotApplicable;
          }
        }
      if (found != 1) return TopoResult::NotApplicable;
      if (c.link[4 * i + f] >= 0 && listed_inside(v)) return TopoResult::BoundaryLocked;
    }
  for (int k = 0; k < c.n_outer; ++k)
    if (!used[k]) return TopoResult::NotApplicable;
  return TopoResult::Applied;
}

// ---------------------------------------------------------------------------
void TopoEditor::commit(const Candidate& c, int32_t* slots, bool counted) {
  int32_t local[kMaxNew];
  int32_t* slot = slots ? slots : local;
  const bool has_entity = !m_.tet_entity.empty();
  for (int i = 0; i < c.n_new; ++i) {
    if (i < c.n_old) {
      slot[i] = c.old_tets[i];
    } else if (!free_.empty()) {
      slot[i] = free_.back();
      free_.pop_back();
    } else {
      slot[i] = m_.nt();
      m_.tets.insert(m_.tets.end(), 4, -1);
      m_.adj.insert(m_.adj.end(), 4, -1);
      m_.tet_ref.push_back(c.ref);
      if (has_entity) m_.tet_entity.push_back(c.entity);
      m_.face_mask.push_back(0);
      m_.tet_kind.push_back(0);
      alpha_.push_back(0);
      tstamp_.push_back(0);
    }
  }
  for (int i = c.n_new; i < c.n_old; ++i) {
    const int32_t o = c.old_tets[i];
    for (int k = 0; k < 4; ++k) {
      m_.tets[4 * static_cast<size_t>(o) + k] = -1;
      m_.adj[4 * static_cast<size_t>(o) + k] = -1;
    }
    m_.face_mask[o] = 0;
    m_.tet_kind[o] = 0;
    alpha_[o] = kInf;
    tstamp_[o] = stamp_;
  }
  // Outer faces' neighbours must be read before slots are overwritten: they
  // are outside the cavity, so they are never among the slots.
  for (int i = 0; i < c.n_new; ++i) {
    const int32_t s = slot[i];
    uint8_t mask = 0;
    int kind = 0;
    for (int k = 0; k < 4; ++k) {
      m_.tets[4 * static_cast<size_t>(s) + k] = c.quad[i][k];
      kind += m_.vert_constrained[c.quad[i][k]];
    }
    for (int f = 0; f < 4; ++f) {
      const int32_t l = c.link[4 * i + f];
      int32_t& a = m_.adj[4 * static_cast<size_t>(s) + f];
      if (l >= 0) {
        a = 4 * slot[l / 4] + l % 4;
      } else {
        const int k = -1 - l;
        a = c.outer_nb[k];
        if (a >= 0) {
          m_.adj[a] = 4 * s + f;
          tstamp_[a / 4] = stamp_;
        }
        if (c.outer_mask[k]) mask |= static_cast<uint8_t>(1u << f);
      }
    }
    m_.tet_ref[s] = c.ref;
    if (has_entity) m_.tet_entity[s] = c.entity;
    m_.face_mask[s] = mask;
    m_.tet_kind[s] = static_cast<uint8_t>(kind);
    alpha_[s] = c.new_alpha[i];
    tstamp_[s] = stamp_;
  }
  for (int i = c.n_new; i < c.n_old; ++i) free_.push_back(c.old_tets[i]);
  for (int i = 0; i < c.n_new; ++i)
    for (int k = 0; k < 4; ++k) vstamp_[c.quad[i][k]] = stamp_;
  if (counted) count(c);
}

void TopoEditor::count(const Candidate& c) {
  if (c.kind == Candidate::Insert) {
    ++stats_.insertions;
  } else if (c.kind == Candidate::Remove) {
    ++stats_.removals;
  } else if (c.kind == Candidate::Edge) {
    if (c.size == 3) ++stats_.flip32;
    else if (c.size == 4) ++stats_.flip44;
    else ++stats_.edge_removals;
  } else {
    if (c.size == 1) ++stats_.flip23;
    else ++stats_.multi_face_removals;
  }
}

// ---------------------------------------------------------------------------
TopoResult TopoEditor::flip_23(int32_t t, int lf) {
  TopoResult r = plan_multi(t, lf, 1, false, *cand_, nullptr);
  if (r == TopoResult::Applied) commit(*cand_);
  return r;
}

TopoResult TopoEditor::flip_32(int32_t t, int le) {
  TopoResult r = plan_edge(t, le, 3, false, *cand_, -kInf, nullptr);
  if (r == TopoResult::Applied) commit(*cand_);
  return r;
}

TopoResult TopoEditor::flip_44(int32_t t, int le) {
  TopoResult r = plan_edge(t, le, 4, false, *cand_, -kInf, nullptr);
  if (r == TopoResult::Applied) commit(*cand_);
  return r;
}

TopoResult TopoEditor::flip_22(int32_t t, int le) {
  // A 2-2 flip needs an edge with exactly two tets: such an edge lies on the
  // domain boundary and the flip would replace its two boundary faces.
  TopoResult r = plan_edge(t, le, 2, true, *cand_, -kInf, nullptr);
  if (r == TopoResult::BoundaryLocked || r == TopoResult::RegionMismatch) return TopoResult::BoundaryLocked;
  return TopoResult::NotApplicable;
}

TopoResult TopoEditor::remove_edge(int32_t t, int le) {
  TopoResult r = plan_edge(t, le, 0, false, *cand_, -kInf, nullptr);
  if (r == TopoResult::Applied) commit(*cand_);
  return r;
}

TopoResult TopoEditor::remove_multi_face(int32_t t, int lf) {
  TopoResult r = plan_multi(t, lf, o_.max_shell - 2, false, *cand_, nullptr);
  if (r == TopoResult::Applied) commit(*cand_);
  return r;
}

TopoResult TopoEditor::judge_plan(TopoResult r, const Judge& judge) {
  judged_ = false;
  if (r != TopoResult::Applied) return r;
  const Candidate& c = *cand_;
  Planned p;
  p.n_old = c.n_old;
  p.n_new = c.n_new;
  p.old_tets = c.old_tets;
  p.quad = c.quad;
  p.across.resize(4 * static_cast<size_t>(c.n_new));
  for (int i = 0; i < 4 * c.n_new; ++i) {
    const int32_t l = c.link[i];
    if (l >= 0) {
      p.across[i] = c.quad[l / 4][l % 4];
    } else {
      const int32_t nb = c.outer_nb[-1 - l];
      p.across[i] = nb < 0 ? -1 : m_.tets[nb];
    }
  }
  if (!judge(p)) return TopoResult::NotImproved;
  commit(c);
  return TopoResult::Applied;
}

TopoResult TopoEditor::remove_edge_judged(int32_t t, int le, const Judge& judge) {
  judged_ = true;
  return judge_plan(plan_edge(t, le, 0, false, *cand_, -kInf, nullptr), judge);
}

TopoResult TopoEditor::remove_face_judged(int32_t t, int lf, int max_faces, const Judge& judge) {
  judged_ = true;
  return judge_plan(plan_multi(t, lf, max_faces, false, *cand_, nullptr), judge);
}

// A new free vertex at x, appended (existing ids unchanged): vert_ref 0 when
// the mesh has vertex refs, point fields 0; pop_vertex takes the last back.
int32_t TopoEditor::push_vertex(const double* x) {
  const int32_t nv = m_.nv();
  m_.xyz.insert(m_.xyz.end(), x, x + 3);
  if (m_.vert_ref.size() == static_cast<size_t>(nv)) m_.vert_ref.push_back(0);
  m_.vert_constrained.push_back(0);
  for (auto& pf : m_.point_fields) pf.values.insert(pf.values.end(), pf.components, 0.0);
  vstamp_.push_back(0);
  return nv;
}

void TopoEditor::pop_vertex() {
  const int32_t nv = m_.nv() - 1;
  m_.xyz.resize(3 * static_cast<size_t>(nv));
  if (m_.vert_ref.size() == static_cast<size_t>(nv) + 1) m_.vert_ref.pop_back();
  m_.vert_constrained.pop_back();
  for (auto& pf : m_.point_fields) pf.values.resize(pf.values.size() - pf.components);
  vstamp_.pop_back();
}

TopoResult TopoEditor::insert_vertex(int32_t t) {
  if (!alive(t) || o_.measure != TopoMeasure::Alpha) return TopoResult::NotApplicable;
  if (!isearch_) isearch_ = new InsertSearch;
  search_insert(t, *isearch_, nullptr);
  return insert_found(t, *isearch_);
}

void TopoEditor::search_insert(int32_t t, InsertSearch& s, std::vector<int32_t>* reads) const {
  const int32_t ref = m_.tet_ref[t];
  const int32_t entity = m_.tet_entity.empty() ? 0 : m_.tet_entity[t];
  auto joinable = [&](int32_t o, int f) { return joinable_nb(o, f, ref, entity); };
  note(reads, t);
  int32_t nbs[4];
  int nn = 0;
  for (int f = 0; f < 4; ++f) {
    const int32_t n = joinable(t, f);
    if (n >= 0) nbs[nn++] = n;
  }
  // Candidate cavities: t alone, then a growing cavity (t plus its joinable
  // face neighbours, grown one tet at a time across the unconstrained outer
  // face whose fan tet is worst at the best position so far: Klingner &
  // Shewchuk 2007 grow the cavity where the star fails).  The best fan
  // (highest worst alpha after the position search) wins.  Until the
  // twenty-first session every subset of the face neighbours was tried
  // first: on raw tetgen meshes none of them ever won over the grown
  // cavities, and they were half the insertion rounds' time (docs/benchmarks.md).
  int nf = 0, best_nf = 0;
  int32_t face[kMaxOuter][3], best_face[kMaxOuter][3];
  int32_t face_nb[kMaxOuter];
  int32_t best_old[kMaxOld];
  int best_nold = 0;
  double best_x[3] = {0, 0, 0}, best_f = -kInf;
  // Worst alpha of the fan at p; stops early (returning a value <= stop) once
  // it cannot beat stop.  The face that failed last is tried first next time.
  int lead = 0;
  // With the alpha objective the fan runs on a ConeFan copy of the outer
  // faces (cone_alpha4, the same numbers as quality()), refreshed by each
  // evaluate(), four faces at a time.  An early stop then comes after a
  // whole block and lead is a block: a value returned at or below stop may
  // differ from the face-by-face loop's, one above it never does (it is the
  // minimum over all faces), and compass() only compares it with stop.
  const bool fast = o_.objective == Objective::Alpha;
  static_assert(kInsertMax % 4 == 0, "ConeFan holds whole blocks");
  detail::ConeFan<kInsertMax> cone;
  auto fan = [&](const double* p, double stop = -kInf) {
    double w = kInf;
    if (fast) {
      const int nb = (nf + 3) / 4;
      for (int k = 0; k < nb && w > stop; ++k) {
        const int b = (k + lead) % nb;
        double q[4];
        detail::cone_alpha4(cone, 4 * b, p, q);
        for (const double x : q) w = std::min(w, x < o_.alpha_floor ? -kInf : x);
        if (w <= stop) lead = b;
      }
      return w;
    }
    for (int k = 0; k < nf && w > stop; ++k) {
      const int i = (k + lead) % nf;
      const double q = quality(m_.point(face[i][0]), m_.point(face[i][2]), m_.point(face[i][1]), p);
      if (q < w) {
        w = q;
        if (w <= stop) lead = i;
      }
    }
    return w;
  };
  int32_t old[kMaxOld];
  int nold = 0;
  double x[3] = {0, 0, 0};
  bool have_x = false;
  // Collects the outer faces of old[0..nold) and optimises the new vertex;
  // false when the cavity is unusable (too many faces, a vertex inside).
  // The position search stops at hmin_rel (relative to the mean distance
  // from the start to the outer faces' first vertices): every candidate
  // cavity gets a coarse search, and only the best one is refined to
  // kFineStep at the end (the ranking of cavities hardly changes below
  // the coarse step, and the fine steps were most of the cost).
  auto evaluate = [&](double h0_rel = 0.1, double hmin_rel = kCoarseStep) -> bool {
    nf = 0;
    double centre[3] = {0, 0, 0};
    int ncentre = 0;
    for (int i = 0; i < nold; ++i) {
      const int32_t o = old[i];
      const int32_t* tv = m_.tet(o);
      note(reads, o);
      for (int f = 0; f < 4; ++f) {
        const int32_t nb = m_.adj[4 * static_cast<size_t>(o) + f];
        if (nb >= 0) note(reads, nb / 4);
        bool inside = false;
        for (int j = 0; j < nold && nb >= 0 && !inside; ++j) inside = old[j] == nb / 4;
        if (inside && ((m_.face_mask[o] >> f) & 1u)) return false;
        if (inside) continue;
        if (nf >= kInsertMax) return false;
        face_nb[nf] = joinable(o, f);
        for (int k = 0; k < 3; ++k) {
          face[nf][k] = tv[kFaceVertex[f][k]];
          const double* p = m_.point(face[nf][k]);
          centre[0] += p[0]; centre[1] += p[1]; centre[2] += p[2];
          ++ncentre;
        }
        ++nf;
      }
    }
    // Every vertex of the cavity must stay on its boundary (no vertex may
    // vanish with the old tets).
    for (int i = 0; i < nold; ++i)
      for (int k = 0; k < 4; ++k) {
        const int32_t v = m_.tet(old[i])[k];
        bool on = false;
        for (int j = 0; j < nf && !on; ++j) on = face[j][0] == v || face[j][1] == v || face[j][2] == v;
        if (!on) return false;
      }
    for (double& y : centre) y /= ncentre;
    if (fast) {
      for (int i = 0; i < nf; ++i) cone.set(i, m_.point(face[i][0]), m_.point(face[i][1]), m_.point(face[i][2]));
      cone.pad(nf);
    }
    // Compass search from the best of: the previous position, the centre of
    // t, the centre of the cavity's outer vertices.
    double tc[3] = {0, 0, 0};
    for (int k = 0; k < 4; ++k)
      for (int d = 0; d < 3; ++d) tc[d] += 0.25 * m_.point(m_.tet(t)[k])[d];
    double fx = fan(centre);
    std::copy(centre, centre + 3, x);
    if (const double f2 = fan(tc); f2 > fx) { fx = f2; std::copy(tc, tc + 3, x); }
    double px[3] = {best_x[0], best_x[1], best_x[2]};
    if (have_x)
      if (const double f3 = fan(px); f3 > fx) { fx = f3; std::copy(px, px + 3, x); }
    const double len = face_distance_sum(m_, face, nf, x);
    const double h = h0_rel * len / nf;
    const double hmin = hmin_rel * len / nf;
    // The coarse search polls the 6 axes, the fine one the 14 axes and
    // diagonals (compass).  Until the twenty-second session the coarse
    // search polled all 14 too, and scaled a step by its place in the
    // rotated order rather than by its direction; the 6 cut its
    // evaluations by ~60% and the whole run on tw_A / ch_0p1_A to 0.81x /
    // 0.77x (docs/benchmarks.md).
    fx = compass(fan, x, fx, h, hmin, 400, hmin_rel < kCoarseStep ? 14 : 6, true);
    if (fx > best_f) {
      best_f = fx;
      std::copy(x, x + 3, best_x);
      have_x = true;
      best_nf = nf;
      std::copy(&face[0][0], &face[0][0] + 3 * nf, &best_face[0][0]);
      best_nold = nold;
      std::copy(old, old + nold, best_old);
    }
    return true;
  };
  nold = 0;
  old[nold++] = t;
  lead = 0;
  evaluate();
  // Growth from the full one-ring of faces.
  nold = 0;
  old[nold++] = t;
  for (int i = 0; i < nn; ++i) old[nold++] = nbs[i];
  for (int step = 0, stale = 0; step < 12 && nold < kInsertMax && stale < 3; ++step) {
    const double before = best_f;
    lead = 0;
    if (!evaluate()) break;
    stale = best_f > before ? 0 : stale + 1;
    // Worst fan tet at the current position among faces we may cross.
    int pick = -1;
    double pw = kInf;
    for (int i = 0; i < nf; ++i) {
      if (face_nb[i] < 0) continue;
      bool dup = false;
      for (int j = 0; j < nold && !dup; ++j) dup = old[j] == face_nb[i];
      if (dup) continue;
      const double q = quality(m_.point(face[i][0]), m_.point(face[i][2]), m_.point(face[i][1]), x);
      if (q < pw) { pw = q; pick = i; }
    }
    if (pick < 0) break;
    old[nold++] = face_nb[pick];
  }
  // Refine the best cavity's position from where its coarse search ended,
  // unless the coarse search stayed below kFineWorth of what acceptance
  // needs.  Of 11,260 fine searches in the insertion runs of tw_A,
  // ch_0p1_A, bib_0p25_bnd, bib_0p25 and hinge_raw, 9,033 started there and
  // 2 of them ended accepted; 64 that started between kFineWorth and the
  // need did (twenty-second session, an instrumented build).
  double old_min = kInf;  // what set_old_tets gives insert_found
  for (int i = 0; i < best_nold; ++i) old_min = std::min(old_min, cached_alpha(best_old[i]));
  if (const double need = old_min + o_.margin; have_x && !(need > 0 && best_f < kFineWorth * need)) {
    nold = best_nold;
    std::copy(best_old, best_old + nold, old);
    lead = 0;
    evaluate(2 * kCoarseStep, kFineStep);
  }
  s.nold = best_nold;
  std::copy(best_old, best_old + best_nold, s.old);
  s.nf = best_nf;
  std::copy(&best_face[0][0], &best_face[0][0] + 3 * best_nf, &s.face[0][0]);
  std::copy(best_x, best_x + 3, s.x);
  s.f = best_f;
}

TopoEditor::Candidate& TopoEditor::cone_candidate(int32_t t, const int32_t* old, int n) {
  Candidate& c = *cand_;
  c.kind = Candidate::Insert;
  c.size = 1;
  c.ref = m_.tet_ref[t];
  c.entity = m_.tet_entity.empty() ? 0 : m_.tet_entity[t];
  set_old_tets(c, old, n);
  return c;
}

TopoResult TopoEditor::insert_found(int32_t t, InsertSearch& s) {
  Candidate& c = cone_candidate(t, s.old, s.nold);
  double bx[3] = {s.x[0], s.x[1], s.x[2]};
  const double fx = s.f;
  if (!(fx > c.old_min + o_.margin)) return fx > 0 ? TopoResult::NotImproved : TopoResult::Inverted;
  if (o_.guard && o_.guard->on()) guarded_position(s.face, s.nf, c.old_min + o_.margin, bx);
  return commit_cone(c, bx, s.face, s.nf, nullptr);
}

int TopoEditor::plan_threads(int requested) {
#ifdef TETOPT_HAVE_TBB
  return std::min(detail::resolve_threads(requested), tbb::info::default_concurrency());
#else
  (void)requested;
  return 1;
#endif
}

bool TopoEditor::unchanged_since(const std::vector<int32_t>& reads, uint32_t epoch) const {
  for (const int32_t r : reads)
    if (tstamp_[r] >= epoch) return false;
  return true;
}

int TopoEditor::plan_inserts(const int32_t* tets, int n) {
  if (!iplans_) {
    iplans_ = new InsertPlans;
#ifdef TETOPT_HAVE_TBB
    iplans_->threads = plan_threads(o_.threads);
    if (iplans_->threads > 1) iplans_->arena.emplace(iplans_->threads);
#endif
  }
  InsertPlans& P = *iplans_;
  P.n = 0;
#ifdef TETOPT_HAVE_TBB
  // The searches read the mesh, the links and the cached alpha, never write
  // them (a deferred dihedral measure would: lb_ is empty with alpha).
  if (P.threads < 2 || n < 2 || !lb_.empty() || o_.measure != TopoMeasure::Alpha) return 0;
  if (P.s.size() < static_cast<size_t>(n)) P.s.resize(static_cast<size_t>(n));
  // A commit after this stamps every tet slot it writes with >= epoch.
  const uint32_t epoch = next_stamp();
  P.arena->execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, n, 1), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i < r.end(); ++i) {
        InsertSearch& x = P.s[static_cast<size_t>(i)];
        x.reads.clear();
        x.epoch = epoch;
        x.t = alive(tets[i]) ? tets[i] : -1;
        if (x.t >= 0) search_insert(x.t, x, &x.reads);
        // Each growth step reads its cavity again: check each tet once.
        std::sort(x.reads.begin(), x.reads.end());
        x.reads.erase(std::unique(x.reads.begin(), x.reads.end()), x.reads.end());
      }
    });
  });
  P.n = n;
  return n;
#else
  (void)tets;
  (void)n;
  return 0;
#endif
}

TopoResult TopoEditor::insert_planned(int i, int32_t t) {
  if (!alive(t) || o_.measure != TopoMeasure::Alpha) return TopoResult::NotApplicable;
  if (iplans_ && i >= 0 && i < iplans_->n) {
    InsertSearch& x = iplans_->s[static_cast<size_t>(i)];
    if (x.t == t && unchanged_since(x.reads, x.epoch)) {
      ++inserts_used_;
      return insert_found(t, x);
    }
    ++inserts_redone_;
  }
  return insert_vertex(t);
}

int TopoEditor::plan_points(const int32_t* tets, const double* x, const double* min_dist, int n,
                            const Acceptance& acc) {
#ifdef TETOPT_HAVE_TBB
  if (!lb_.empty() || o_.measure != TopoMeasure::Alpha) return 0;
  if (!pplans_) {
    pplans_ = new PointPlans;
    pplans_->threads = plan_threads(o_.threads);
    if (pplans_->threads > 1) pplans_->arena.emplace(pplans_->threads);
  }
  PointPlans& P = *pplans_;
  if (P.threads < 2) return 0;
  if (P.of_tet.size() < static_cast<size_t>(m_.nt())) P.of_tet.resize(static_cast<size_t>(m_.nt()), -1);
  // An entry not yet used for the same tet, point and distance stays (it is
  // checked when used); the others are searched now.
  P.todo.clear();
  for (int i = 0; i < n; ++i) {
    const int32_t t = tets[i];
    if (!alive(t)) continue;
    int e = P.of_tet[t];
    if (e >= 0) {
      const PointSearch& p = P.pool[static_cast<size_t>(e)];
      if (p.t == t && tstamp_[t] < p.epoch && std::memcmp(p.x, x + 3 * i, sizeof p.x) == 0 &&
          p.min_dist == min_dist[i] && same_acceptance(p.acc, acc))
        continue;
    } else if (!P.free.empty()) {
      e = P.free.back();
      P.free.pop_back();
    } else {
      e = static_cast<int>(P.pool.size());
      P.pool.emplace_back();
    }
    P.of_tet[t] = e;
    PointSearch& p = P.pool[static_cast<size_t>(e)];
    p.t = t;
    std::copy(x + 3 * i, x + 3 * i + 3, p.x);
    p.min_dist = min_dist[i];
    p.acc = acc;
    P.todo.push_back(e);
  }
  if (P.todo.size() < 4) {  // too few to pay for waking a thread: searched when used
    for (const int e : P.todo) {
      P.of_tet[P.pool[static_cast<size_t>(e)].t] = -1;
      P.free.push_back(e);
    }
    return 0;
  }
  const uint32_t epoch = next_stamp();  // a later commit stamps what it writes with >= epoch
  P.arena->execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, P.todo.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
      auto& mk = P.marks.local();
      for (size_t k = r.begin(); k < r.end(); ++k) {
        PointSearch& p = P.pool[static_cast<size_t>(P.todo[k])];
        p.reads.clear();
        p.epoch = epoch;
        p.r = search_point(p.t, p.x, acc, p.min_dist, p, mk.first, mk.second, &p.reads);
      }
    });
  });
  return static_cast<int>(P.todo.size());
#else
  (void)tets;
  (void)x;
  (void)min_dist;
  (void)n;
  (void)acc;
  return 0;
#endif
}

bool TopoEditor::point_planned(int32_t t) const {
  if (!pplans_ || static_cast<size_t>(t) >= pplans_->of_tet.size() || pplans_->of_tet[t] < 0) return false;
  const PointSearch& p = pplans_->pool[static_cast<size_t>(pplans_->of_tet[t])];
  return p.t == t && tstamp_[t] < p.epoch;
}

TopoResult TopoEditor::insert_point_planned(int32_t t, const double* x, const Acceptance& acc, double min_dist,
                                            std::vector<int32_t>* made) {
  if (!alive(t) || o_.measure != TopoMeasure::Alpha) return TopoResult::NotApplicable;
  if (pplans_ && static_cast<size_t>(t) < pplans_->of_tet.size() && pplans_->of_tet[t] >= 0) {
    PointPlans& P = *pplans_;
    const int e = P.of_tet[t];
    P.of_tet[t] = -1;
    P.free.push_back(e);
    PointSearch& p = P.pool[static_cast<size_t>(e)];
    if (p.t == t && std::memcmp(p.x, x, sizeof p.x) == 0 && p.min_dist == min_dist && same_acceptance(p.acc, acc) &&
        unchanged_since(p.reads, p.epoch)) {
      ++points_used_;
      // The entry stays intact until the next plan_points call.
      return p.r == TopoResult::Applied ? point_found(t, x, acc, p, made) : p.r;
    }
    ++points_redone_;
  }
  return insert_point(t, x, acc, min_dist, made);
}

bool TopoEditor::guarded_position(const int32_t (*face)[3], int nf, double need, double* x) const {
  // The guard (guard.hpp) refuses a new tet worse than the mesh's extreme on
  // any measure, and the position search above knows only the objective: on
  // cylinder_hole.geo's raw mesh at --size 0.06 the worst tet (alpha 0.0589,
  // four constrained vertices) stayed for the whole run because every
  // alpha-best position made a tet whose scaled Jacobian fell below the
  // mesh's extreme.  When that happens, a compass search from there raises
  // the least of (q / need - 1) and the guard's slack over the cone; a
  // position where it is positive keeps the acceptance and passes the guard.
  auto g = [&](const double* p) {
    double w = kInf;
    for (int i = 0; i < nf && w > -kInf; ++i) {
      const double* a = m_.point(face[i][0]);
      const double* b = m_.point(face[i][2]);
      const double* c = m_.point(face[i][1]);
      const double q = quality(a, b, c, p);
      w = std::min(w, need > 0 ? q / need - 1 : q - need);
      w = std::min(w, o_.guard->slack(a, b, c, p));
    }
    return w;
  };
  double gx = g(x);
  if (gx > 0) return true;
  const double len = face_distance_sum(m_, face, nf, x) / std::max(nf, 1);
  double y[3] = {x[0], x[1], x[2]};
  gx = compass_axes([&](const double* z, double) { return g(z); }, y, gx, 0.05 * len, 1e-4 * len, 300, 0.0);
  if (!(gx > 0)) return false;
  std::copy(y, y + 3, x);
  return true;
}

TopoResult TopoEditor::commit_cone(Candidate& c, const double* x, const int32_t (*face)[3], int nf,
                                   std::vector<int32_t>* made) {
  // Append the vertex (existing ids unchanged), plan, and take it back if the
  // plan fails.
  const int32_t nv = push_vertex(x);
  c.n_new = nf;
  for (int i = 0; i < nf; ++i) {
    c.quad[i][0] = face[i][0];
    c.quad[i][1] = face[i][2];
    c.quad[i][2] = face[i][1];
    c.quad[i][3] = nv;
  }
  const TopoResult r = finish_plan(true, c);
  if (r != TopoResult::Applied) {
    pop_vertex();
    return r;
  }
  int32_t slots[kMaxNew];
  commit(c, slots);
  if (made) made->assign(slots, slots + nf);
  return TopoResult::Applied;
}

int32_t TopoEditor::joinable_nb(int32_t o, int f, int32_t ref, int32_t entity) const {
  const int32_t nb = m_.adj[4 * static_cast<size_t>(o) + f];
  if (nb < 0 || ((m_.face_mask[o] >> f) & 1u)) return -1;
  const int32_t n = nb / 4;
  if (!alive(n) || m_.tet_ref[n] != ref || (!m_.tet_entity.empty() && m_.tet_entity[n] != entity)) return -1;
  return n;
}

TopoResult TopoEditor::remove_vertex(int32_t t) { return contract(t, -1, -1); }

TopoResult TopoEditor::collapse_edge(int32_t t, int le, const Acceptance& acc, int32_t removable_from) {
  if (!alive(t) || le < 0 || le > 5) return TopoResult::NotApplicable;
  const int32_t a = m_.tet(t)[kEdgeVertex[le][0]], b = m_.tet(t)[kEdgeVertex[le][1]];
  accept_ = acc;
  accept_.on = true;
  TopoResult r = m_.vert_constrained[a] || a < removable_from ? TopoResult::BoundaryLocked : contract(t, a, b);
  if (r != TopoResult::Applied && !m_.vert_constrained[b] && b >= removable_from) r = contract(t, b, a);
  accept_ = {};
  if (r == TopoResult::Applied) ++stats_.collapses;
  return r;
}

TopoResult TopoEditor::contract(int32_t t, int32_t only_v, int32_t only_w) {
  if (!alive(t) || o_.measure != TopoMeasure::Alpha) return TopoResult::NotApplicable;
  const bool has_entity = !m_.tet_entity.empty();
  TopoResult why = TopoResult::NotApplicable;
  bool have = false;
  int32_t best_v = -1;
  double best_min = -kInf;
  for (int k = 0; k < 4; ++k) {
    const int32_t v = m_.tet(t)[k];
    if (only_v >= 0 && v != only_v) continue;
    if (m_.vert_constrained[v]) {
      if (why == TopoResult::NotApplicable) why = TopoResult::BoundaryLocked;
      continue;
    }
    // The star of v, across the faces that contain v.
    int32_t star[kMaxOld];
    int ns = 0;
    star[ns++] = t;
    bool usable = true;
    for (int i = 0; i < ns && usable; ++i) {
      const int32_t o = star[i];
      const int lv = local_of(m_.tet(o), v);
      for (int f = 0; f < 4 && usable; ++f) {
        if (f == lv) continue;
        const int32_t nb = m_.adj[4 * static_cast<size_t>(o) + f];
        if (nb < 0 || ((m_.face_mask[o] >> f) & 1u)) {  // a free vertex is on no such face
          usable = false;
          why = TopoResult::BoundaryLocked;
          break;
        }
        const int32_t n = nb / 4;
        bool seen = false;
        for (int j = 0; j < ns && !seen; ++j) seen = star[j] == n;
        if (seen) continue;
        if (ns == kMaxOld) {
          usable = false;
          why = TopoResult::ShellTooLarge;
        } else {
          star[ns++] = n;
        }
      }
    }
    if (!usable) continue;
    Candidate& c = *cand_;
    c.kind = Candidate::Remove;
    c.size = 1;
    c.ref = m_.tet_ref[t];
    c.entity = has_entity ? m_.tet_entity[t] : 0;
    c.n_old = ns;
    c.old_min = kInf;
    c.k4_old = 0;
    for (int i = 0; i < ns; ++i) {
      const int32_t o = star[i];
      if (m_.tet_ref[o] != c.ref || (has_entity && m_.tet_entity[o] != c.entity)) usable = false;
      c.old_tets[i] = o;
      c.old_min = std::min(c.old_min, cached_alpha(o));
      c.k4_old += m_.tet_kind[o] == 4;
    }
    if (!usable) {
      why = TopoResult::RegionMismatch;
      continue;
    }
    if (!(c.old_min > 0)) continue;  // a tangled star: the cone argument needs positive tets
    // Candidate targets w: the other vertices of the star, in first-seen order.
    int32_t nbr[4 * kMaxOld];
    int nn = 0;
    for (int i = 0; i < ns; ++i)
      for (int q = 0; q < 4; ++q) {
        const int32_t w = m_.tet(star[i])[q];
        bool dup = w == v;
        for (int j = 0; j < nn && !dup; ++j) dup = nbr[j] == w;
        if (!dup) nbr[nn++] = w;
      }
    for (int j = 0; j < nn; ++j) {
      const int32_t w = nbr[j];
      if (only_w >= 0 && w != only_w) continue;
      // Improvement by the margin, or (collapse_edge) the caller's floor.
      const double floor =
          accept_ ? std::max(best_min, std::nextafter(accept_.floor_for(c.old_min), -kInf))
                  : std::max(best_min, c.old_min + o_.margin);
      // Worst alpha of the cone from w, stopping once it cannot win.
      double worst = kInf;
      c.n_new = 0;
      for (int i = 0; i < ns && worst > floor; ++i) {
        const int32_t* tv = m_.tet(star[i]);
        if (tv[0] == w || tv[1] == w || tv[2] == w || tv[3] == w) continue;
        int32_t* q = c.quad[c.n_new++];
        for (int r = 0; r < 4; ++r) q[r] = tv[r] == v ? w : tv[r];
        worst = std::min(worst, quality(m_.point(q[0]), m_.point(q[1]), m_.point(q[2]), m_.point(q[3])));
      }
      if (!(worst > floor)) {
        if (why == TopoResult::NotApplicable) why = worst > 0 ? TopoResult::NotImproved : TopoResult::Inverted;
        continue;
      }
      const TopoResult r = finish_plan(true, c);
      if (r != TopoResult::Applied) {
        why = r;
        continue;
      }
      best_min = c.new_min;
      best_v = v;
      copy_used(c, *best_);
      have = true;
    }
  }
  if (!have) return why;
  commit(*best_);
  removed_.push_back(best_v);
  return TopoResult::Applied;
}

void TopoEditor::set_old_tets(Candidate& c, const int32_t* tets, int n) const {
  c.n_old = n;
  c.old_min = kInf;
  c.k4_old = 0;
  for (int i = 0; i < n; ++i) {
    c.old_tets[i] = tets[i];
    c.old_min = std::min(c.old_min, cached_alpha(tets[i]));
    c.k4_old += m_.tet_kind[tets[i]] == 4;
  }
}

TopoResult TopoEditor::split_edge(int32_t t, int le, const Acceptance& acc, double wa) {
  if (o_.measure != TopoMeasure::Alpha) return TopoResult::NotApplicable;
  int32_t a, b, ring[kMaxShell + 2], shell[kMaxShell + 1];
  int n = 0;
  if (TopoResult r = gather_shell(t, le, a, b, ring, shell, n, nullptr); r != TopoResult::Applied) return r;
  Candidate& c = cone_candidate(t, shell, n);
  // The shell (a, b, r_i, r_i+1) becomes (p, b, r_i, r_i+1) and
  // (a, p, r_i, r_i+1): the cone from p over the shell's outer faces, valid
  // for any p that sees them all (exact orient3d below).
  const double floor = acc.floor_for(c.old_min);
  const double* pa = m_.point(a);
  const double* pb = m_.point(b);
  auto fan = [&](const double* x, double stop) {
    double w = kInf;
    for (int i = 0; i < n && w > stop; ++i) {
      const double* r0 = m_.point(ring[i]);
      const double* r1 = m_.point(ring[(i + 1) % n]);
      w = std::min(w, quality(x, pb, r0, r1));
      if (w > stop) w = std::min(w, quality(pa, x, r0, r1));
    }
    return w;
  };
  double x[3];
  for (int d = 0; d < 3; ++d) x[d] = wa * pa[d] + (1 - wa) * pb[d];
  double fx = fan(x, -kInf);
  if (fx < floor) {
    // A short compass search from the split point (Klingner & Shewchuk
    // 2007 place an inserted vertex to maximise its cavity's worst quality).
    const double len = std::sqrt((pa[0] - pb[0]) * (pa[0] - pb[0]) + (pa[1] - pb[1]) * (pa[1] - pb[1]) +
                                 (pa[2] - pb[2]) * (pa[2] - pb[2]));
    fx = compass_axes(fan, x, fx, 0.1 * len, 1e-3 * len, 96);
    if (fx < floor) return fx > 0 ? TopoResult::NotImproved : TopoResult::Inverted;
  }
  const int32_t nv = push_vertex(x);
  c.n_new = 2 * n;
  for (int i = 0; i < n; ++i) {
    const int32_t r0 = ring[i], r1 = ring[(i + 1) % n];
    int32_t* q0 = c.quad[2 * i];
    q0[0] = nv; q0[1] = b; q0[2] = r0; q0[3] = r1;
    int32_t* q1 = c.quad[2 * i + 1];
    q1[0] = a; q1[1] = nv; q1[2] = r0; q1[3] = r1;
  }
  accept_ = acc;
  accept_.on = true;
  const TopoResult r = finish_plan(true, c);
  accept_ = {};
  if (r != TopoResult::Applied) {
    pop_vertex();
    return r;
  }
  commit(c);
  ++stats_.splits;
  return TopoResult::Applied;
}

TopoResult TopoEditor::insert_point(int32_t t, const double* x, const Acceptance& acc, double min_dist,
                                     std::vector<int32_t>* made) {
  if (!alive(t) || o_.measure != TopoMeasure::Alpha) return TopoResult::NotApplicable;
  if (!psearch_) psearch_ = new PointSearch;
  const TopoResult r = search_point(t, x, acc, min_dist, *psearch_, mark_, mark_epoch_, nullptr);
  if (r != TopoResult::Applied) return r;
  return point_found(t, x, acc, *psearch_, made);
}

TopoResult TopoEditor::search_point(int32_t t, const double* x, const Acceptance& acc, double min_dist,
                                    PointSearch& s, std::vector<uint32_t>& mark, uint32_t& mark_epoch,
                                    std::vector<int32_t>* reads) const {
  const int32_t ref = m_.tet_ref[t];
  const int32_t entity = m_.tet_entity.empty() ? 0 : m_.tet_entity[t];
  auto joinable = [&](int32_t o, int f) { return joinable_nb(o, f, ref, entity); };
  // Walk: cross the face x lies farthest beyond until x is inside.
  int32_t cur = t;
  for (int step = 0;; ++step) {
    if (step > 256) return TopoResult::NotApplicable;
    note(reads, cur);
    const int32_t* tv = m_.tet(cur);
    int bf = -1;
    double bo = 0;
    for (int f = 0; f < 4; ++f) {
      // Positive when x lies beyond face f (floating point: the walk's
      // guide; the exact orient3d below decides validity).
      const double o = tet_signed_volume(m_.point(tv[kFaceVertex[f][0]]), m_.point(tv[kFaceVertex[f][1]]),
                                         m_.point(tv[kFaceVertex[f][2]]), x);
      if (o > bo) { bo = o; bf = f; }
    }
    if (bf < 0) break;
    const int32_t n = joinable(cur, bf);
    if (n < 0) return TopoResult::BoundaryLocked;
    cur = n;
  }
  // The containing tet is always in the cavity (it never leaves it below),
  // so a vertex of it nearer than min_dist refuses x as the full check at
  // the end would, before the cavity search (whose refusals of other kinds
  // it may pre-empt: a refusal either way).
  for (int k = 0; k < 4; ++k) {
    const double* p = m_.point(m_.tet(cur)[k]);
    if ((p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]) + (p[2] - x[2]) * (p[2] - x[2]) <
        min_dist * min_dist)
      return TopoResult::NotApplicable;
  }
  // Bowyer-Watson cavity, breadth first from the containing tet.  A tet
  // is tested once: mark[tet] == the call's epoch once seen, + 1 once in
  // the cavity.
  if (mark.size() < static_cast<size_t>(m_.nt())) mark.resize(m_.nt(), 0);
  mark_epoch += 2;
  if (mark_epoch < 2) {  // wrapped
    std::fill(mark.begin(), mark.end(), 0);
    mark_epoch = 2;
  }
  const uint32_t seen_mark = mark_epoch, cav_mark = mark_epoch + 1;
  int32_t* cav = s.cav;
  int& nc = s.nc;
  nc = 0;
  cav[nc++] = cur;
  mark[cur] = cav_mark;
  auto in_cav = [&](int32_t v) { return mark[v] == cav_mark; };
  for (int i = 0; i < nc; ++i)
    for (int f = 0; f < 4; ++f) {
      const int32_t n = joinable(cav[i], f);
      if (n < 0 || mark[n] >= seen_mark) continue;
      mark[n] = seen_mark;
      if (nc >= kMaxPointCavity) continue;
      note(reads, n);
      const int32_t* nv = m_.tet(n);
      double cc[3], r2;
      if (!detail::circumsphere(m_.point(nv[0]), m_.point(nv[1]), m_.point(nv[2]), m_.point(nv[3]), cc, r2)) continue;
      const double d2 = (x[0] - cc[0]) * (x[0] - cc[0]) + (x[1] - cc[1]) * (x[1] - cc[1]) + (x[2] - cc[2]) * (x[2] - cc[2]);
      if (d2 < r2 * (1 - 1e-12)) {
        cav[nc++] = n;
        mark[n] = cav_mark;
      }
    }
  // Shrink until x sees every outer face; a tet whose outer face x does not
  // see leaves the cavity (the containing tet never does: then no insertion).
  int32_t (*face)[3] = s.face;
  int& nf = s.nf;
  for (;;) {
    nf = 0;
    int drop = -1;
    for (int i = 0; i < nc && drop < 0; ++i) {
      const int32_t o = cav[i];
      const int32_t* tv = m_.tet(o);
      for (int f = 0; f < 4; ++f) {
        const int32_t nb = m_.adj[4 * static_cast<size_t>(o) + f];
        if (nb >= 0 && in_cav(nb / 4)) continue;
        const int32_t v0 = tv[kFaceVertex[f][0]], v1 = tv[kFaceVertex[f][1]], v2 = tv[kFaceVertex[f][2]];
        if (orient3d(m_.point(v0), m_.point(v2), m_.point(v1), x) != Sign::Positive) {
          drop = i;
          break;
        }
        if (nf >= kMaxNew) return TopoResult::ShellTooLarge;
        face[nf][0] = v0;
        face[nf][1] = v1;
        face[nf][2] = v2;
        ++nf;
      }
    }
    if (drop < 0) break;
    if (drop == 0) return TopoResult::Inverted;
    mark[cav[drop]] = seen_mark;
    cav[drop] = cav[--nc];
  }
  // The acceptance first (finish_plan checks it again), without the vertex:
  // most refused points fail here, so before the cavity's vertex checks
  // below, which cost more (a refusal either way).
  double old_min = kInf;  // what set_old_tets gives point_found
  for (int i = 0; i < nc; ++i) old_min = std::min(old_min, cached_alpha(cav[i]));
  const double floor = std::max(acc.floor_for(old_min), 0.0);
  for (int i = 0; i < nf; ++i)
    if (!(quality(m_.point(face[i][0]), m_.point(face[i][2]), m_.point(face[i][1]), x) >= floor))
      return TopoResult::NotImproved;
  // No vertex and no listed edge may vanish inside the cavity.
  auto on_surface = [&](int32_t a, int32_t b) {
    for (int j = 0; j < nf; ++j) {
      const bool ha = face[j][0] == a || face[j][1] == a || face[j][2] == a;
      if (ha && (b < 0 || face[j][0] == b || face[j][1] == b || face[j][2] == b)) return true;
    }
    return false;
  };
  for (int i = 0; i < nc; ++i) {
    const int32_t* tv = m_.tet(cav[i]);
    for (int k = 0; k < 4; ++k) {
      if (!on_surface(tv[k], -1)) return TopoResult::NotApplicable;
      const double* p = m_.point(tv[k]);
      if ((p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]) + (p[2] - x[2]) * (p[2] - x[2]) <
          min_dist * min_dist)
        return TopoResult::NotApplicable;
    }
    if (!listed_edges_.empty())
      for (int le = 0; le < 6; ++le) {
        const int32_t a = tv[kEdgeVertex[le][0]], b = tv[kEdgeVertex[le][1]];
        if (std::binary_search(listed_edges_.begin(), listed_edges_.end(), edge_key(a, b)) && !on_surface(a, b))
          return TopoResult::BoundaryLocked;
      }
  }
  return TopoResult::Applied;
}

TopoResult TopoEditor::point_found(int32_t t, const double* x, const Acceptance& acc, PointSearch& s,
                                   std::vector<int32_t>* made) {
  Candidate& c = cone_candidate(t, s.cav, s.nc);
  accept_ = acc;
  accept_.on = true;
  const TopoResult r = commit_cone(c, x, s.face, s.nf, made);
  accept_ = {};
  return r;
}

TopoResult TopoEditor::plan_best(int32_t t, bool strict, Candidate*& cand, Candidate*& best,
                                 std::vector<int32_t>* reads, double floor) const {
  if (!alive(t)) return TopoResult::NotApplicable;
  note(reads, t);
  bool have = false;
  // Most informative refusal when nothing applies (order of preference).
  TopoResult why = TopoResult::NotApplicable;
  auto rank = [](TopoResult r) {
    switch (r) {
      case TopoResult::NotImproved: return 5;
      case TopoResult::Inverted: return 4;
      case TopoResult::ShellTooLarge: return 3;
      case TopoResult::RegionMismatch: return 2;
      case TopoResult::BoundaryLocked: return 1;
      default: return 0;
    }
  };
  // Branch and bound: later options must beat the best so far (ties on
  // alpha may still win on the kind-4 count, hence nextafter).
  double bound = floor;
  auto consider = [&](TopoResult r) {
    if (r == TopoResult::Applied && !(cand->new_min > floor)) r = TopoResult::NotImproved;
    if (r == TopoResult::Applied) {
      // Better: higher worst alpha; on ties fewer kind-4 tets; then first.
      if (!have || cand->new_min > best->new_min ||
          (cand->new_min == best->new_min && cand->k4_new < best->k4_new)) {
        std::swap(cand, best);
        have = true;
      }
    } else if (rank(r) > rank(why)) {
      why = r;
    }
    if (have) bound = std::max(floor, std::nextafter(best->new_min, -kInf));
  };
  if (o_.use_edge_removal)
    for (int le = 0; le < 6; ++le) consider(plan_edge(t, le, 0, strict, *cand, bound, reads));
  for (int lf = 0; lf < 4; ++lf) {
    if (o_.use_face_swap) consider(plan_multi(t, lf, 1, strict, *cand, reads));
    if (o_.use_multi_face) consider(plan_multi(t, lf, o_.max_shell - 2, strict, *cand, reads));
  }
  return have ? TopoResult::Applied : why;
}

TopoResult TopoEditor::improve_tet(int32_t t, bool strict) {
  const TopoResult r = plan_best(t, strict, cand_, best_, nullptr);
  if (r == TopoResult::Applied) commit(*best_);
  return r;
}

TopoResult TopoEditor::improve_tet_pair(int32_t t, int reach) {
  const TopoResult single = plan_best(t, true, cand_, best_, nullptr);
  if (single == TopoResult::Applied) {
    commit(*best_);
    return single;
  }
  if (o_.measure != TopoMeasure::Alpha || o_.alpha_floor > -1e300) return single;
  // First operations: every valid option on t and on the tets near it,
  // whatever its quality: 6 edges and 4 faces x (face swap, multi-face) per tet.
  constexpr int kOptionsPerTet = 14;
  int n1 = 0;
  {
    const TopoOptions saved = o_;
    o_.must_improve = false;
    o_.worsen_bound = kInf;
    any_valid_ = true;
    // t and the tets within `reach` face-to-face steps of it.
    std::vector<int32_t>& around = around_;
    around.assign(1, t);
    for (int d = 0; d < reach; ++d) {
      const size_t n0 = around.size();
      for (size_t i = 0; i < n0; ++i)
        for (int f = 0; f < 4; ++f) {
          const int32_t nb = m_.adj[4 * static_cast<size_t>(around[i]) + f];
          if (nb >= 0 && std::find(around.begin(), around.end(), nb / 4) == around.end()) around.push_back(nb / 4);
        }
    }
    if (trial_.size() < kOptionsPerTet * around.size()) trial_.resize(kOptionsPerTet * around.size());
    for (const int32_t u : around) {
      for (int le = 0; le < 6; ++le)
        if (plan_edge(u, le, 0, false, trial_[n1], -kInf, nullptr) == TopoResult::Applied) ++n1;
      for (int lf = 0; lf < 4; ++lf) {
        if (o_.use_face_swap && plan_multi(u, lf, 1, false, trial_[n1], nullptr) == TopoResult::Applied) ++n1;
        if (o_.use_multi_face &&
            plan_multi(u, lf, o_.max_shell - 2, false, trial_[n1], nullptr) == TopoResult::Applied &&
            trial_[n1].size > 1)
          ++n1;
      }
    }
    any_valid_ = false;
    o_ = saved;
  }
  // Applies trial i, returning the new tets' slots; undo() restores the
  // tets it replaced (same ids, same vertex order; the alpha cache gets the
  // same values back, since both are quality() of the same four points).
  int32_t slots[kMaxNew];
  int32_t saved_quads[kMaxOld][4];
  auto undo = [&](const Candidate& c1) {
    Candidate& inv = *cand_;
    inv.kind = c1.kind;
    inv.size = c1.size;
    inv.ref = c1.ref;
    inv.entity = c1.entity;
    inv.n_old = c1.n_new;
    inv.old_min = -kInf;
    inv.k4_old = c1.k4_new;
    for (int i = 0; i < c1.n_new; ++i) inv.old_tets[i] = slots[i];
    inv.n_new = c1.n_old;
    for (int i = 0; i < c1.n_old; ++i) std::copy(saved_quads[i], saved_quads[i] + 4, inv.quad[i]);
    restoring_ = true;
    const TopoResult r = finish_plan(false, inv);
    restoring_ = false;
    // The tets of c1 filled exactly this cavity, so the inverse is valid.
    if (r != TopoResult::Applied) throw std::logic_error("improve_tet_pair: undo refused");
    // c1 freed old_tets[n_new..n_old) in order: pop them back in that order
    // so every restored tet gets its id again (later trials refer to them).
    const int freed = c1.n_old - c1.n_new;
    if (freed > 1) std::reverse(free_.end() - freed, free_.end());
    commit(inv, nullptr, false);
    // c1 took slots[n_old..n_new) from the back of free_ (or appended them):
    // give them back in the order that restores free_.
    const int taken = c1.n_new - c1.n_old;
    if (taken > 1) std::reverse(free_.end() - taken, free_.end());
  };
  // Evaluates trial c1 applied: the best second operation on t (when c1
  // left it) or on one of c1's new tets at or below the worst alpha c1
  // replaced; returns the worst alpha of the pair's result when it beats
  // every tet the pair replaced, else -inf.  which: the target, as an index
  // into slots, or -2 for t.
  auto second = [&](const Candidate& c1, double floor, int& which) {
    double best = floor;
    for (int j = -2; j < c1.n_new; ++j) {
      if (j == -1) continue;
      const int32_t w = j == -2 ? t : slots[j];
      if (j == -2 ? !alive(t) || std::find(slots, slots + c1.n_new, t) != slots + c1.n_new
                  : alpha_[w] > c1.old_min + o_.margin)
        continue;
      // Only a second operation whose new tets beat the best pair so far
      // can make a better pair.
      if (plan_best(w, true, cand_, best_, nullptr, std::max(best, floor)) != TopoResult::Applied) continue;
      const Candidate& c2 = *best_;
      double new_min = c2.new_min, old_min = c1.old_min;
      for (int i = 0; i < c2.n_old; ++i) {
        const int32_t o = c2.old_tets[i];
        if (std::find(slots, slots + c1.n_new, o) == slots + c1.n_new) old_min = std::min(old_min, alpha_[o]);
      }
      for (int i = 0; i < c1.n_new; ++i)
        if (std::find(c2.old_tets, c2.old_tets + c2.n_old, slots[i]) == c2.old_tets + c2.n_old)
          new_min = std::min(new_min, alpha_[slots[i]]);
      // Guards: the first operation's new tets that the second leaves in
      // place were not judged when it was planned (finish_plan skips the
      // guard for it); the second's were.
      auto guarded = [&] {
        if (!o_.guard) return true;
        for (int i = 0; i < c1.n_new; ++i)
          if (std::find(c2.old_tets, c2.old_tets + c2.n_old, slots[i]) == c2.old_tets + c2.n_old) {
            const int32_t* q = m_.tet(slots[i]);
            if (!o_.guard->admits(m_.point(q[0]), m_.point(q[1]), m_.point(q[2]), m_.point(q[3]))) return false;
          }
        return true;
      };
      if (new_min > old_min + o_.margin && new_min > best && guarded()) {
        best = new_min;
        which = j;
      }
    }
    return best;
  };
  double best = -kInf;
  int best_i = -1, best_j = -1;
  for (int i = 0; i < n1; ++i) {
    const Candidate& c1 = trial_[i];
    for (int k = 0; k < c1.n_old; ++k) std::copy(m_.tet(c1.old_tets[k]), m_.tet(c1.old_tets[k]) + 4, saved_quads[k]);
    commit(c1, slots, false);
    int j = -1;
    const double v = second(c1, best, j);
    if (v > best) {
      best = v;
      best_i = i;
      best_j = j;
    }
    undo(c1);
  }
  if (best_i < 0) return single;
  // Apply the best pair again; the mesh is as it was before the trials, so
  // the second plan is the one evaluated.
  const Candidate& c1 = trial_[best_i];
  for (int k = 0; k < c1.n_old; ++k) std::copy(m_.tet(c1.old_tets[k]), m_.tet(c1.old_tets[k]) + 4, saved_quads[k]);
  commit(c1, slots, false);
  if (plan_best(best_j == -2 ? t : slots[best_j], true, cand_, best_, nullptr) != TopoResult::Applied) {
    undo(c1);  // cannot happen: same cavity, same geometry as the trial
    return single;
  }
  count(c1);
  commit(*best_);
  ++stats_.pairs;
  return TopoResult::Applied;
}

namespace {
// TopoOptions::stop (an abort) is set.
inline bool halted(const TopoOptions& o) { return o.stop && o.stop->load(std::memory_order_relaxed); }
// Sets a flag for a scope (TopoEditor::nocache_ while threads plan).
struct NoCache {
  bool& f;
  explicit NoCache(bool& flag) : f(flag) { f = true; }
  ~NoCache() { f = false; }
  NoCache(const NoCache&) = delete;
  NoCache& operator=(const NoCache&) = delete;
};
}  // namespace

int64_t TopoEditor::improve_tets(const std::vector<int32_t>& work, bool strict, bool kind4_only, double threshold) {
  auto eligible = [&](int32_t t) {
    return alive(t) && (!kind4_only || m_.tet_kind[t] == 4) && below(t, threshold);
  };
  int64_t changed = 0;
#ifdef TETOPT_HAVE_TBB
  // Windows of up to W tets (sized below).  Planning reads only (a deferred
  // dihedral measure is computed without being stored meanwhile: nocache_;
  // until the twenty-third session the dihedral pass planned serially
  // because of that cache, 18% of hinge_raw's runs).  A plan
  // keeps the stamp taken just before it was made (its epoch) and every tet
  // it read; a commit stamps every tet slot it writes (removed, rewritten,
  // or an outer neighbour whose link it updates) with the current stamp, so
  // a plan that read a tet changed since sees a stamp >= its epoch and is
  // redone on the current mesh.  Otherwise it read exactly what the serial
  // loop would read at that point (vertices do not move here), and its
  // outcome (applied option or refusal) is the serial one.  A former check
  // on two vertices of every tet read also redid plans next to a change:
  // 4,884 replans on the demo impeller, 90% of them giving the same plan
  // again.
  const int threads = plan_threads(o_.threads);
  // The window adapts to how often a plan is found invalid: where poor tets
  // are dense (a jittered box: 84% of 411k plans were redone at W = 512,
  // in 94k parallel batches, and 2 threads took 1.6x the time of 1), it
  // halves while more than 1 plan in 8 is redone, and doubles while fewer
  // than 1 in 32 are, up to W.  Where even windows of kMinW redo more than
  // 1 plan in 4 (the same box: 32% at 16), the next kSerial entries go
  // through the serial loop, which has no batches to wait for; then windows
  // are tried again.  The outcome does not depend on any of this.
  constexpr size_t W = 512, kMinW = 16, kSerial = 256;
  if (threads > 1 && work.size() >= 64) {
    struct Plan {
      uint8_t state = 0;  // 0 not planned (not eligible when planned), 1 refused, 2 applied
      uint32_t epoch = 0;  // the stamp taken just before it was planned
      std::vector<int32_t> reads;
      Guard::Counts refused{};  // the guards' refusals while planning it, counted when it is used
    };
    std::vector<Plan> plan(W);
    std::vector<PackedCandidate> chosen(W);
    struct Scratch {
      Candidate a, b;
    };
    tbb::enumerable_thread_specific<Scratch> scratch;
    tbb::task_arena arena(threads);
    size_t w0 = 0;
    // Plans entry i of the window on the current mesh (read only).
    auto plan_one = [&](size_t i, uint32_t epoch) {
      Scratch& sc = scratch.local();
      const int32_t t = work[w0 + i];
      Plan& p = plan[i];
      p.reads.clear();
      p.epoch = epoch;
      if (!eligible(t)) {
        p.state = 0;
        return;
      }
      Candidate* c = &sc.a;
      Candidate* b = &sc.b;
      const Guard::Deferred deferred(p.refused);
      if (plan_best(t, strict, c, b, &p.reads) == TopoResult::Applied) {
        pack(*b, chosen[i]);
        p.state = 2;
      } else {
        p.state = 1;
      }
    };
    auto valid = [&](size_t i) { return plan[i].state != 0 && unchanged_since(plan[i].reads, plan[i].epoch); };
    // Entries after an invalid one that are replanned with it (see below).
    constexpr size_t kAhead = 64;
    std::vector<size_t> redo;
    size_t win = W;
    arena.execute([&] {
      for (size_t n = 0; w0 < work.size() && !halted(o_); w0 += n) {
        if (win == 0) {  // a serial stretch
          n = std::min(kSerial, work.size() - w0);
          for (size_t i = 0; i < n; ++i) {
            const int32_t t = work[w0 + i];
            if (eligible(t) && improve_tet(t, strict) == TopoResult::Applied) ++changed;
          }
          win = kMinW;
          continue;
        }
        n = std::min(win, work.size() - w0);
        size_t redone = 0;
        const uint32_t s0 = next_stamp();
        {
          const NoCache nc(nocache_);
          tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 8), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t i = r.begin(); i < r.end(); ++i) plan_one(i, s0);
          });
        }
        stats_.planned_ahead += static_cast<int64_t>(n);
        for (size_t i = 0; i < n; ++i) {
          const int32_t t = work[w0 + i];
          if (!eligible(t)) continue;
          if (!valid(i)) {
            // A commit of this window changed what the plan read: plan it
            // again on the current mesh, together with the next entries
            // whose plans are invalid now too (on the other threads; each
            // is checked again when its turn comes, against the stamp taken
            // here).  The serial replans of the former loop were most of
            // the window path's serial time at 2 threads.
            redo.assign(1, i);
            for (size_t k = i + 1; k < std::min(n, i + 1 + kAhead); ++k)
              if (eligible(work[w0 + k]) && !valid(k)) redo.push_back(k);
            const uint32_t s1 = next_stamp();
            if (redo.size() == 1) {  // no batch to share: no wake-up to wait for
              plan_one(i, s1);
            } else {
              const NoCache nc(nocache_);
              tbb::parallel_for(tbb::blocked_range<size_t>(0, redo.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
                for (size_t j = r.begin(); j < r.end(); ++j) plan_one(redo[j], s1);
              });
            }
            ++redone;
          }
          if (o_.guard) o_.guard->add_refused(plan[i].refused);  // the plan the serial loop would make
          if (plan[i].state == 2) {
            unpack(chosen[i], *best_);
            commit(*best_);
            ++changed;
          }
        }
        if (win == kMinW && 4 * redone > n) win = 0;
        else if (8 * redone > n) win = std::max(kMinW, win / 2);
        else if (32 * redone < n) win = std::min(W, 2 * win);
      }
    });
    return changed;
  }
#endif
  for (const int32_t t : work) {
    if (halted(o_)) break;
    if (eligible(t) && improve_tet(t, strict) == TopoResult::Applied) ++changed;
  }
  return changed;
}

// ---------------------------------------------------------------------------
void TopoEditor::finish() {
  if (finished_) return;
  finished_ = true;
  stats_.tets_after = m_.nt();
  // Nothing changed (trials of improve_tet_pair that were undone restore
  // every tet in its slot, but may leave appended tombstones): the derived
  // topology is still current.
  if (stats_.applied() == 0 && m_.nt() == stats_.tets_before) {
    if (shared_) shared_->swap(alpha_);
    return;
  }
  // Compact tombstones: the last live tet moves into each hole (ascending),
  // i.e. the i-th smallest hole below the final count takes the i-th
  // largest live tet above it.  The pairs are found first (a filled hole
  // counts as live where the scan from the top meets it); then the moves
  // run in parallel: each reads only its tet above the final count and
  // writes its hole and the links of its neighbours that stay.
  std::sort(free_.begin(), free_.end());
  int32_t nt = m_.nt();
  const bool has_entity = !m_.tet_entity.empty();
  std::vector<int32_t> to, from;  // hole, tet moved into it
  auto dead = [&](int32_t s) {
    return m_.tets[4 * static_cast<size_t>(s)] < 0 &&
           !(!to.empty() && s <= to.back() && std::binary_search(to.begin(), to.end(), s));
  };
  for (const int32_t h : free_) {
    while (nt > 0 && dead(nt - 1)) --nt;
    if (h >= nt) break;
    to.push_back(h);
    from.push_back(--nt);
  }
  while (nt > 0 && dead(nt - 1)) --nt;
  // Every live tet at or above nt moves: its new number.
  std::vector<int32_t> renum(static_cast<size_t>(m_.nt() - nt), -1);
  for (size_t j = 0; j < to.size(); ++j) renum[static_cast<size_t>(from[j] - nt)] = to[j];
  detail::parallel_for_each(static_cast<int64_t>(to.size()), o_.threads, [&](int64_t j) {
    const int32_t h = to[static_cast<size_t>(j)], l = from[static_cast<size_t>(j)];
    for (int k = 0; k < 4; ++k) {
      m_.tets[4 * static_cast<size_t>(h) + k] = m_.tets[4 * static_cast<size_t>(l) + k];
      int32_t nb = m_.adj[4 * static_cast<size_t>(l) + k];
      if (nb >= 0) {
        const int32_t tn = nb / 4;
        if (tn >= nt) nb = 4 * renum[static_cast<size_t>(tn - nt)] + nb % 4;
        else m_.adj[nb] = 4 * h + k;
      }
      m_.adj[4 * static_cast<size_t>(h) + k] = nb;
    }
    m_.tet_ref[h] = m_.tet_ref[l];
    if (has_entity) m_.tet_entity[h] = m_.tet_entity[l];
    m_.face_mask[h] = m_.face_mask[l];
    m_.tet_kind[h] = m_.tet_kind[l];
    alpha_[h] = alpha_[l];
  });
  free_.clear();
  m_.tets.resize(4 * static_cast<size_t>(nt));
  m_.adj.resize(4 * static_cast<size_t>(nt));
  m_.tet_ref.resize(nt);
  if (has_entity) m_.tet_entity.resize(nt);
  m_.face_mask.resize(nt);
  m_.tet_kind.resize(nt);
  alpha_.resize(nt);
  if (shared_) shared_->swap(alpha_);
  // face_mask and tet_kind were kept right by commit() (new interior faces
  // are free, outer faces keep their bit, vertex flags never change), so
  // classify() is not needed; only the vertex->tet CSR is stale.
  if (o_.rebuild_stars) {
    build_vertex_tets(m_, o_.threads);
  } else {
    m_.vt_offsets.clear();
    m_.vt_tets.clear();
  }
  m_.topology_epoch++;
  stats_.tets_after = nt;
}

// ---------------------------------------------------------------------------
TopoResult flip_23(TetMesh& m, int32_t t, int lf, const TopoOptions& o) {
  TopoEditor ed(m, o);
  return ed.flip_23(t, lf);
}
TopoResult flip_32(TetMesh& m, int32_t t, int le, const TopoOptions& o) {
  TopoEditor ed(m, o);
  return ed.flip_32(t, le);
}
TopoResult remove_edge(TetMesh& m, int32_t t, int le, const TopoOptions& o) {
  TopoEditor ed(m, o);
  return ed.remove_edge(t, le);
}
TopoResult remove_multi_face(TetMesh& m, int32_t t, int lf, const TopoOptions& o) {
  TopoEditor ed(m, o);
  return ed.remove_multi_face(t, lf);
}

namespace {

enum class PassKind { AllBoundary, Quality };

// The operation counters of an editor's session into a pass's result.
void take_counts(const TopoStats& es, TopoStats& st) {
  st.flip23 = es.flip23;
  st.flip32 = es.flip32;
  st.flip44 = es.flip44;
  st.edge_removals = es.edge_removals;
  st.multi_face_removals = es.multi_face_removals;
  st.flip22 = es.flip22;
  st.all_boundary_removed = es.all_boundary_removed;
  st.pairs = es.pairs;
  st.passes = es.passes;
  st.planned_ahead = es.planned_ahead;
}

int64_t count_kind4(const TetMesh& m, int threads) {
  return detail::parallel_count(m.nt(), threads, [&](int64_t t) { return m.tet_kind[t] == 4; });
}

TopoStats run_passes(TetMesh& m, const TopoOptions& o, const LogFn& log, PassKind kind,
                     std::vector<double>* alpha_cache) {
  const auto t0 = std::chrono::steady_clock::now();
  TopoStats st;
  if (!topology_current(m)) {
    st.status = build_topology(m);
    if (!st.status) return st;
  }
  st.tets_before = m.nt();
  {
    TopoEditor ed(m, o, alpha_cache);
    st.kind4_before = count_kind4(m, o.threads);
    st.alpha_worst_before = ed.min_cached();
    std::vector<int32_t> work;
    uint32_t prev_stamp = 0;
    for (int p = 0; p < o.passes; ++p) {
      // Pass 1 visits every poor tet; later passes only those next to a
      // change of the previous pass: the others would meet the same shells
      // and sandwiches (geometry does not move here) and fail again.
      const uint32_t stamp = ed.next_stamp();
      auto wanted = [&](int32_t t) {
        return ed.alive(t) && (p == 0 || ed.touched_since(t, prev_stamp)) &&
               (kind == PassKind::Quality || m.tet_kind[t] == 4) && ed.below(t, o.quality_threshold);
      };
      // below() may fill a deferred dihedral cache: then serial.
      work = detail::parallel_select(m.nt(), ed.deferring() ? 1 : o.threads,
                                     [&](int64_t t) { return wanted(static_cast<int32_t>(t)); });
      prev_stamp = stamp;
      const bool all_boundary = kind == PassKind::AllBoundary;
      const int64_t changed = ed.improve_tets(work, !all_boundary, all_boundary, o.quality_threshold);
      if (all_boundary) ed.stats().all_boundary_removed += changed;
      ++ed.stats().passes;
      if (log)
        log(LogLevel::Info, std::string(kind == PassKind::AllBoundary ? "topo all-boundary" : "topo flip") +
                                " pass " + std::to_string(p + 1) + ": " + std::to_string(work.size()) +
                                " tets visited, " + std::to_string(changed) + " operations applied");
      if (changed == 0 || halted(o)) break;
    }
    st.alpha_worst_after = ed.min_cached();
    ed.finish();
    st.kind4_after = count_kind4(m, o.threads);
    take_counts(ed.stats(), st);
  }
  st.tets_after = m.nt();
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace

TopoStats pair_flip_pass(TetMesh& m, const TopoOptions& o, double band, int64_t max_tets, bool stop_at_worst,
                         const LogFn& log, std::vector<double>* alpha_cache) {
  const auto t0 = std::chrono::steady_clock::now();
  TopoStats st;
  if (!topology_current(m)) {
    st.status = build_topology(m);
    if (!st.status) return st;
  }
  st.tets_before = m.nt();
  {
    TopoEditor ed(m, o, alpha_cache);
    st.alpha_worst_before = ed.min_cached();
    st.kind4_before = count_kind4(m, o.threads);
    double worst = ed.min_cached();
    for (int p = 0; p < std::max(1, o.passes); ++p) {
      const double thr = std::min(o.quality_threshold, worst + band);
      std::vector<int32_t> work = detail::parallel_select(
          m.nt(), o.threads,
          [&](int64_t t) { return ed.alive(static_cast<int32_t>(t)) && ed.below(static_cast<int32_t>(t), thr); });
      std::stable_sort(work.begin(), work.end(),
                       [&](int32_t a, int32_t b) { return ed.cached_alpha(a) < ed.cached_alpha(b); });
      if (max_tets >= 0 && static_cast<int64_t>(work.size()) > max_tets) work.resize(max_tets);
      int64_t changed = 0, visited = 0;
      for (const int32_t t : work) {
        if (halted(o)) break;
        if (!ed.alive(t) || !ed.below(t, thr)) continue;
        ++visited;
        if (ed.improve_tet_pair(t) == TopoResult::Applied) {
          ++changed;
        } else if (stop_at_worst && ed.cached_alpha(t) <= worst) {
          // t is the worst tet (a commit raises the worst alpha of its
          // cavity, so nothing fell below it).  When only topology can help
          // it (all four vertices constrained), one wider search: first
          // operations on every tet within two face steps (about 17 tets).
          // If that fails too, the worst alpha cannot rise in this pass.
          if (m.tet_kind[t] != 4 || ed.improve_tet_pair(t, 2) != TopoResult::Applied) break;
          ++changed;
        }
      }
      ++ed.stats().passes;
      if (log)
        log(LogLevel::Info, "topo pair pass " + std::to_string(p + 1) + ": " + std::to_string(visited) + " of " +
                                std::to_string(work.size()) + " tets visited, " + std::to_string(changed) +
                                " changes (" + std::to_string(ed.stats().pairs) + " pairs so far)");
      // stop_at_worst: another pass only after one that raised the worst
      // alpha (the band moves up with it).
      const double w = ed.min_cached();
      if (changed == 0 || halted(o) || (stop_at_worst && !(w > worst + o.margin))) break;
      worst = w;
    }
    st.alpha_worst_after = ed.min_cached();
    ed.finish();
    st.kind4_after = count_kind4(m, o.threads);
    take_counts(ed.stats(), st);
  }
  st.tets_after = m.nt();
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

TopoStats remove_all_boundary_tets(TetMesh& m, const TopoOptions& o, const LogFn& log) {
  return run_passes(m, o, log, PassKind::AllBoundary, nullptr);
}

TopoStats remove_all_boundary_tets(TetMesh& m, const TopoOptions& o, const LogFn& log,
                                   std::vector<double>* alpha_cache) {
  return run_passes(m, o, log, PassKind::AllBoundary, alpha_cache);
}

TopoStats flip_pass(TetMesh& m, const TopoOptions& o, const LogFn& log) {
  return run_passes(m, o, log, PassKind::Quality, nullptr);
}

TopoStats flip_pass(TetMesh& m, const TopoOptions& o, const LogFn& log, std::vector<double>* alpha_cache) {
  return run_passes(m, o, log, PassKind::Quality, alpha_cache);
}

namespace {

// The worst dihedral measure of the star of free vertex v with v at x (-inf
// when a tet falls below the alpha floor or is flat / inverted in floating
// point).  It stops as soon as that is at or below `enough` (a candidate
// position that cannot be accepted), so the exact value comes back whenever
// it is above `enough`.  The star's tet
// `first` (its index in the star) is measured first: the worst tet at the
// current position is the likeliest to stop a candidate at once.  *worst
// (optional) gets the index of the worst tet when the value is exact.
double star_quality(const TetMesh& m, const TopoEditor& q, int32_t v, const double x[3], double enough = -kInf,
                    int first = 0, int* worst = nullptr) {
  const int32_t* star = m.star_begin(v);
  const int n = static_cast<int>(m.star_end(v) - star);
  double w = kInf;
  for (int i = 0; i < n; ++i) {
    const int j = i == 0 ? first : (i <= first ? i - 1 : i);
    const int32_t* tv = m.tet(star[j]);
    const double* p[4];
    for (int k = 0; k < 4; ++k) p[k] = tv[k] == v ? x : m.point(tv[k]);
    const double qj = q.quality(p[0], p[1], p[2], p[3]);
    if (qj < w) {
      w = qj;
      if (worst) *worst = j;
    }
    if (w == -kInf || w <= enough) break;
  }
  return w;
}

// Compass (pattern) search on the position of free vertex v maximising the
// star's worst dihedral measure (derivative free: the measure is a nonsmooth
// min of angles).  Commits only when every star tet stays exactly positive.
bool relocate_vertex(TetMesh& m, const TopoEditor& q, int32_t v) {
  if (m.vert_constrained[v] || m.star_begin(v) == m.star_end(v)) return false;
  double x[3] = {m.point(v)[0], m.point(v)[1], m.point(v)[2]};
  int first = 0;
  const double f0 = star_quality(m, q, v, x, -kInf, 0, &first);
  if (!(f0 > -kInf)) return false;
  double len = 0;
  int ne = 0;
  for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it)
    for (int k = 0; k < 4; ++k) {
      const int32_t u = m.tet(*it)[k];
      if (u == v) continue;
      const double* p = m.point(u);
      len += std::sqrt((p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]) + (p[2] - x[2]) * (p[2] - x[2]));
      ++ne;
    }
  double h = 0.1 * len / ne;
  const double hmin = 1e-4 * len / ne;
  static constexpr double kDir[14][3] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},   {0, -1, 0},  {0, 0, 1},
                                         {0, 0, -1}, {1, 1, 1},  {-1, -1, -1}, {1, -1, 1}, {-1, 1, -1},
                                         {1, 1, -1}, {-1, -1, 1}, {-1, 1, 1},  {1, -1, -1}};
  double f = f0;
  for (int evals = 0; h > hmin && evals < 200;) {
    bool moved = false;
    for (const auto& d : kDir) {
      const double s = (&d - kDir) < 6 ? h : h * 0.57735026918962584;
      const double y[3] = {x[0] + s * d[0], x[1] + s * d[1], x[2] + s * d[2]};
      const double need = f * (1 + 1e-9) + 1e-12;
      int worst = first;
      const double fy = star_quality(m, q, v, y, need, first, &worst);
      ++evals;
      if (fy > need) {
        first = worst;
        f = fy;
        x[0] = y[0]; x[1] = y[1]; x[2] = y[2];
        moved = true;
        break;
      }
    }
    if (!moved) h *= 0.5;
  }
  if (!(f > f0)) return false;
  // fn(its four points) for every tet of v's star with v at y.
  auto star_at = [&](const double* y) {
    return [&m, v, y](auto fn) {
      for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
        const int32_t* tv = m.tet(*it);
        const double* p[4];
        for (int k = 0; k < 4; ++k) p[k] = tv[k] == v ? y : m.point(tv[k]);
        fn(p[0], p[1], p[2], p[3]);
      }
    };
  };
  if (!keeps_levels(q.options(), star_at(m.point(v)), star_at(x))) return false;
  const double old[3] = {m.point(v)[0], m.point(v)[1], m.point(v)[2]};
  std::copy(x, x + 3, m.point(v));
  for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
    const int32_t* tv = m.tet(*it);
    if (orient3d(m.point(tv[0]), m.point(tv[1]), m.point(tv[2]), m.point(tv[3])) != Sign::Positive) {
      std::copy(old, old + 3, m.point(v));
      return false;
    }
  }
  if (const Guard* g = q.options().guard)
    for (const int32_t* it = m.star_begin(v); it != m.star_end(v); ++it) {
      const int32_t* tv = m.tet(*it);
      if (!g->admits(m.point(tv[0]), m.point(tv[1]), m.point(tv[2]), m.point(tv[3]))) {
        std::copy(old, old + 3, m.point(v));
        return false;
      }
    }
  return true;
}

}  // namespace

TopoStats dihedral_pass(TetMesh& m, const TopoOptions& o, const LogFn& log) {
  const auto t0 = std::chrono::steady_clock::now();
  TopoOptions d = o;
  d.measure = TopoMeasure::Dihedral;
  // Default floor: the current worst alpha (never lowered).  A caller may
  // trade some worst alpha for angles by giving a lower floor explicitly.
  if (!(d.alpha_floor > -1e300))
    d.alpha_floor =
        detail::parallel_min(m.nt(), o.threads, [&](int64_t t) { return tet_objective(m, static_cast<int32_t>(t), o.objective); });
  TopoStats total;
  int64_t moves = 0;
  std::optional<TopoEditor> evaluator;
  for (int round = 0; round < std::max(1, d.passes) && !halted(d); ++round) {
    TopoStats st = run_passes(m, d, log, PassKind::Quality, nullptr);
    if (!st.status) return st;
    if (round == 0) {
      total = st;
    } else {
      total.flip23 += st.flip23; total.flip32 += st.flip32; total.flip44 += st.flip44;
      total.edge_removals += st.edge_removals; total.multi_face_removals += st.multi_face_removals;
      total.passes += st.passes;
      total.planned_ahead += st.planned_ahead;
      total.alpha_worst_after = st.alpha_worst_after;
      total.tets_after = st.tets_after;
    }
    // Relocate the free vertices of tets still below the threshold.
    int64_t moved = 0;
    ensure_vertex_tets(m, d.threads);  // relocate_vertex reads stars
    {
      evaluator.reset();
      evaluator.emplace(m, d);  // measure evaluator (no edits: finish() is a no-op)
      TopoEditor& q = *evaluator;
      std::vector<uint8_t> seen(m.nv(), 0);
      for (int32_t t = 0; t < m.nt() && !halted(d); ++t) {
        if (!q.below(t, d.quality_threshold)) continue;
        for (int k = 0; k < 4; ++k) {
          const int32_t v = m.tet(t)[k];
          if (seen[v]) continue;
          seen[v] = 1;
          moved += relocate_vertex(m, q, v);
        }
      }
    }
    moves += moved;
    if (log)
      log(LogLevel::Info, "topo dihedral round " + std::to_string(round + 1) + ": " + std::to_string(st.applied()) +
                              " flips, " + std::to_string(moved) + " vertex moves");
    if (moved == 0 && st.applied() == 0) {
      // Nothing changed since the evaluator was built: its cache is current.
      total.alpha_worst_after = evaluator->min_cached();
      evaluator.reset();
      break;
    }
  }
  if (evaluator) {  // vertices moved since it was built: measure afresh
    evaluator.reset();
    TopoEditor q(m, d);
    total.alpha_worst_after = q.min_cached();
  }
  total.vertex_moves = moves;
  total.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return total;
}

}  // namespace tetopt
