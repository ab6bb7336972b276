// Guards: see guard.hpp.
#include "tetopt/guard.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "detail/parallel.hpp"
#include "detail/tet_kernels.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/quality.hpp"

namespace tetopt {

namespace {
constexpr size_t idx(Measure k) { return static_cast<size_t>(k); }
}  // namespace

namespace {
thread_local Guard::Counts* tl_deferred = nullptr;  // Guard::Deferred
using Oriented = std::array<double, kTetMeasureCount>;
// A block's minima and the first tet holding each.
struct Part {
  Oriented v;
  std::array<int32_t, kTetMeasureCount> id;
};
constexpr double kRad = std::numbers::pi / 180.0;
// The margin of the dihedral cosine tests (Guard::set_angle_cosines).
constexpr double kCosTie = 1e-9;
}  // namespace

void Guard::take(const TetMesh& m, int threads, Guard& g) {
  const int32_t nt = m.nt();
  // Per-measure extremes as the min of oriented values over the tets, one
  // pass over the mesh (fixed blocks merged in order: exact, the same for
  // every thread count).  The values are those admits() compares, from the
  // same functions, so a tet rebuilt unchanged is admitted.
  Part init;
  init.v.fill(std::numeric_limits<double>::infinity());
  init.id.fill(-1);
  const Part best = detail::parallel_reduce_blocks(
      nt, threads, init,
      [&](int64_t b, int64_t e) {
        Part part = init;
        Oriented& lo = part.v;
        // The dihedral angles (atan2) only where the minimum sine cannot
        // prove the tet holds neither extreme: sin θ >= sine_min for each of
        // its angles, the smallest is at most 70.53° and the largest at least
        // that, so sine_min >= sin(lo) * (1 + 1e-9) and >= sin(180° - hi) *
        // (1 + 1e-9) leave lo and hi as they are (the margin covers rounding).
        double skip_lo = 2, skip_hi = 2;  // sine_min at or above both: skip
        // Or the dihedral cosines (set_angle_cosines' margin): at or below
        // cl and at or above ch leave both as they are.
        double cl = -std::numeric_limits<double>::infinity(), ch = std::numeric_limits<double>::infinity();
        for (int64_t i = b; i < e; ++i) {
          const int32_t* v = m.tet(static_cast<int32_t>(i));
          const double *a = m.point(v[0]), *p1 = m.point(v[1]), *c = m.point(v[2]), *d = m.point(v[3]);
          if (!(tet_signed_volume(a, p1, c, d) > 0)) continue;  // untangling's, not the guard's
          auto keep = [&](Measure k, double x) {
            double& y = lo[idx(k)];
            if (x < y) {
              y = x;
              part.id[idx(k)] = static_cast<int32_t>(i);
            }
          };
          const detail::TetMeasureValues mv = detail::tet_measure_values(a, p1, c, d);
          keep(Measure::Alpha, mv.alpha);
          const double sm = mv.sine_min;
          keep(Measure::SineMin, sm);
          if (!(sm >= skip_lo && sm >= skip_hi) && !(mv.cos_max <= cl && mv.cos_min >= ch)) {
            double dlo, dhi;
            dihedral_extremes(a, p1, c, d, dlo, dhi);
            if (dlo < lo[idx(Measure::DihedralMin)]) {
              keep(Measure::DihedralMin, dlo);
              skip_lo = std::sin(dlo * kRad) * (1 + 1e-9) + 1e-300;
              cl = std::cos(dlo * kRad) - kCosTie;
            }
            if (-dhi < lo[idx(Measure::DihedralMax)]) {
              keep(Measure::DihedralMax, -dhi);
              skip_hi = dhi >= 90 ? std::sin((180.0 - dhi) * kRad) * (1 + 1e-9) + 1e-300 : 2;
              ch = std::cos(dhi * kRad) + kCosTie;
            }
          }
          keep(Measure::ScaledJacobian, mv.scaled_jacobian);
          keep(Measure::RadiusRatio, mv.radius_ratio);
          keep(Measure::MeanRatio, mv.mean_ratio);
          keep(Measure::EquivolumeSkewness, -mv.equivolume_skewness);
        }
        return part;
      },
      [](const Part& x, const Part& y) {  // blocks in order: the first tet on ties
        Part r = x;
        for (size_t k = 0; k < r.v.size(); ++k)
          if (y.v[k] < r.v[k]) {
            r.v[k] = y.v[k];
            r.id[k] = y.id[k];
          }
        return r;
      });
  const Oriented& best_bad = best.v;
  for (size_t k = 0; k < best.id.size(); ++k) {
    Holder& h = g.holder_[k];
    h.tet = best.id[k];
    if (h.tet < 0) continue;
    const int32_t* v = m.tet(h.tet);
    for (int j = 0; j < 4; ++j) {
      h.v[j] = v[j];
      for (int c = 0; c < 3; ++c) h.x[3 * j + c] = m.point(v[j])[c];
    }
  }
  g.on_ = true;
  for (int k = 0; k < kTetMeasureCount; ++k) {
    const Measure mk = static_cast<Measure>(k);
    const double o = best_bad[static_cast<size_t>(k)];
    g.worst_[static_cast<size_t>(k)] = std::isinf(o) ? (measure_info(mk).better == Better::Higher ? -INFINITY : INFINITY)
                                                     : oriented(mk, o);
  }
  g.apply_floor_and_sine();
}

void Guard::set_floor(const std::array<double, kTetMeasureCount>& floor) {
  has_floor_ = true;
  floor_ = floor;  // applied by take()
}

void Guard::apply_floor_and_sine() {
  if (has_floor_)
    for (int k = 0; k < kTetMeasureCount; ++k) {
      const Measure mk = static_cast<Measure>(k);
      const double f = floor_[static_cast<size_t>(k)];
      if (!std::isnan(f) && worse(mk, f, worst_[static_cast<size_t>(k)])) worst_[static_cast<size_t>(k)] = f;
    }
  // sin θ >= sine_min for every dihedral angle θ; the smallest angle lies in
  // (0, 70.53°] where sin rises, and the largest in [70.53°, 180°) where
  // sin(180° - θ) does: sine_min >= sin(lo) proves θ_min >= lo, sine_min >=
  // sin(180° - hi) proves θ_max <= hi (when hi >= 90°).  A relative margin of
  // 1e-9 covers the rounding of the two computations.
  const double lo = worst_[idx(Measure::DihedralMin)], hi = worst_[idx(Measure::DihedralMax)];
  if (lo > 0 && hi >= 90 && hi < 180)
    sine_enough_ = std::max(std::sin(lo * kRad), std::sin((180.0 - hi) * kRad)) * (1 + 1e-9) + 1e-12;
  else
    sine_enough_ = 2;  // never: always measure the angles
  set_angle_cosines();
}

void Guard::set_angle_cosines() {
  // The cosine falls with the angle on [0, 180].  A margin of 1e-9 is far
  // above the few ulps by which the cosines from the normals and the cosines
  // of dihedral_extremes' atan2 angles differ, so a tet the cosines admit
  // has both angles inside the extremes as dihedral_extremes computes them:
  // the decision is the same, bit for bit, without the atan2.
  const double lo = worst_[idx(Measure::DihedralMin)], hi = worst_[idx(Measure::DihedralMax)];
  cos_lo_ = lo >= 0 && lo <= 180 ? std::cos(lo * kRad) - kCosTie : -std::numeric_limits<double>::infinity();
  cos_hi_ = hi >= 0 && hi <= 180 ? std::cos(hi * kRad) + kCosTie : std::numeric_limits<double>::infinity();
}

template <bool Decide, class F>
bool Guard::each_measure(const double* a, const double* b, const double* c, const double* d, F&& f) const {
  // The six from one set of pieces (detail::tet_measure_values, the
  // standalone functions' bits): each measure alone recomputed the volume,
  // normals or lengths, and admits() was 9% of an insertion run on ch_0p1_A.
  const detail::TetMeasureValues mv = detail::tet_measure_values(a, b, c, d);
  if (!f(Measure::Alpha, mv.alpha, true)) return false;
  if (!f(Measure::MeanRatio, mv.mean_ratio, true)) return false;
  if (!f(Measure::ScaledJacobian, mv.scaled_jacobian, true)) return false;
  const double sm = mv.sine_min;
  if (!f(Measure::SineMin, sm, true)) return false;
  if (!f(Measure::RadiusRatio, mv.radius_ratio, true)) return false;
  if (!f(Measure::EquivolumeSkewness, mv.equivolume_skewness, false)) return false;
  if (!(sm >= sine_enough_)) {
    if (Decide && mv.cos_max <= cos_lo_ && mv.cos_min >= cos_hi_) return true;  // both inside (NaN: measure)
    double lo_deg, hi_deg;
    dihedral_extremes(a, b, c, d, lo_deg, hi_deg);
    if (!f(Measure::DihedralMin, lo_deg, true)) return false;
    if (!f(Measure::DihedralMax, hi_deg, false)) return false;
  }
  return true;
}

void Guard::add_zone(const double* c, double r) { zones_.push_back({{c[0], c[1], c[2]}, r * r}); }

bool Guard::in_zone(const double* a, const double* b, const double* c, const double* d) const {
  for (const Zone& z : zones_)
    for (const double* p : {a, b, c, d}) {
      const double dx = p[0] - z.c[0], dy = p[1] - z.c[1], dz = p[2] - z.c[2];
      if (dx * dx + dy * dy + dz * dz < z.r2) return true;
    }
  return false;
}

bool Guard::admits(const double* a, const double* b, const double* c, const double* d) const {
  if (!on_) return true;
  if (!zones_.empty() && in_zone(a, b, c, d)) return true;
  // Cheapest first; each comparison is "not worse than the extreme" (NaN
  // fails); a failure is counted against its measure unless exempt.
  return each_measure<true>(a, b, c, d, [&](Measure k, double v, bool higher) {
    const double e = worst_[idx(k)];
    if (higher ? v >= e : v <= e) return true;
    if (exempt_[idx(k)]) return true;
    if (tl_deferred) ++(*tl_deferred)[idx(k)];
    else refused_[idx(k)].fetch_add(1, std::memory_order_relaxed);
    return false;
  });
}

double Guard::slack(const double* a, const double* b, const double* c, const double* d) const {
  if (!on_ || (!zones_.empty() && in_zone(a, b, c, d))) return std::numeric_limits<double>::infinity();
  double s = std::numeric_limits<double>::infinity();
  each_measure<false>(a, b, c, d, [&](Measure k, double v, bool higher) {
    const double e = worst_[idx(k)];
    if (exempt_[idx(k)] || std::isnan(e)) return true;
    const double r = (higher ? v - e : e - v) / std::max(std::fabs(e), 1e-300);
    s = std::isnan(r) ? -std::numeric_limits<double>::infinity() : std::min(s, r);
    return true;
  });
  return s;
}

bool Guard::stale(const TetMesh& m) const {
  if (!on_) return false;
  for (const Holder& h : holder_) {
    if (h.tet < 0) continue;
    if (h.tet >= m.nt()) return true;
    const int32_t* v = m.tet(h.tet);
    for (int j = 0; j < 4; ++j) {
      if (v[j] != h.v[j]) return true;
      for (int c = 0; c < 3; ++c)
        if (m.point(v[j])[c] != h.x[3 * j + c]) return true;
    }
  }
  return false;
}

Guard::Deferred::Deferred(Counts& into) : prev_(tl_deferred) {
  into.fill(0);
  tl_deferred = &into;
}
Guard::Deferred::~Deferred() { tl_deferred = prev_; }

void Guard::add_refused(const Counts& c) const {
  for (size_t k = 0; k < c.size(); ++k)
    if (c[k]) refused_[k].fetch_add(c[k], std::memory_order_relaxed);
}

int64_t Guard::refused_total() const {
  int64_t n = 0;
  for (const auto& r : refused_) n += r.load(std::memory_order_relaxed);
  return n;
}

}  // namespace tetopt
