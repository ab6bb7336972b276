// Consistent combinatorial orientation of the tets (orient_consistently).
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "tetopt/conventions.hpp"
#include "tetopt/mesh.hpp"
#include "tetopt/predicates.hpp"
#include "detail/parallel.hpp"

namespace tetopt {

namespace {

// Bit f: parity of the permutation taking the tet's vertex list to (the
// vertices of face f in ascending order, then the apex f).  Two tets sharing
// a face agree on orientation exactly when their bits for it differ: with
// both lists positively oriented, orient3d(a,b,c,p) and orient3d(a,b,c,q)
// for the two apexes p, q on opposite sides of the face have opposite signs.
// With the apex ranked above every vertex, the inversions are those among
// the other three plus the 3 - f pairs (f, j > f).
uint8_t face_parities(const int32_t* v) {
  const int g01 = v[0] > v[1], g02 = v[0] > v[2], g03 = v[0] > v[3], g12 = v[1] > v[2], g13 = v[1] > v[3],
            g23 = v[2] > v[3];
  const int p0 = g12 + g13 + g23 + 3, p1 = g02 + g03 + g23 + 2, p2 = g01 + g03 + g13 + 1, p3 = g01 + g02 + g12;
  return static_cast<uint8_t>((p0 & 1) | (p1 & 1) << 1 | (p2 & 1) << 2 | (p3 & 1) << 3);
}

int exact_sign(const TetMesh& m, int32_t t) {
  const int32_t* v = m.tet(t);
  return static_cast<int>(orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])));
}

}  // namespace

Status orient_consistently(TetMesh& m, bool repair, OrientationReport* r, int threads) {
  const int32_t nt = m.nt();
  if (m.adj.size() != 4 * static_cast<size_t>(nt))
    return Status::error(ErrorCode::Invariant, "orient_consistently: topology not built");
  // Does any shared face see the same orientation from both sides?  One
  // byte of face parities per tet first (a sequential pass over the tets),
  // then each face compared once, from its smaller tet, in that byte array.
  std::vector<uint8_t> par(static_cast<size_t>(nt));
  detail::parallel_for_each(nt, threads, [&](int64_t t) { par[t] = face_parities(m.tet(static_cast<int32_t>(t))); });
  auto disagrees = [&](int32_t t, int f) {
    const int32_t n = m.adj[4 * static_cast<size_t>(t) + f];
    return n >= 0 && (par[t] >> f & 1) == (par[n / 4] >> (n % 4) & 1);
  };
  const bool any = detail::parallel_reduce_blocks(
      nt, threads, false,
      [&](int64_t b, int64_t e) {
        for (auto t = static_cast<int32_t>(b); t < e; ++t)
          for (int f = 0; f < 4; ++f)
            if (m.adj[4 * static_cast<size_t>(t) + f] / 4 > t && disagrees(t, f)) return true;
        return false;
      },
      [](bool x, bool y) { return x || y; });
  if (!any) return Status::success();

  // Serial from here (rare): flip[t] = 1 reverses tet t.  Each
  // connected set of tets is walked from its smallest tet; a disagreeing
  // face asks its two tets for different flips.
  std::vector<int8_t> flip(static_cast<size_t>(nt), -1);
  std::vector<int32_t> comp, stack;
  std::vector<int32_t> reoriented;
  for (int32_t s = 0; s < nt; ++s) {
    if (flip[s] >= 0) continue;
    comp.clear();
    stack.assign(1, s);
    flip[s] = 0;
    bool mixed = false;
    while (!stack.empty()) {
      const int32_t t = stack.back();
      stack.pop_back();
      comp.push_back(t);
      for (int f = 0; f < 4; ++f) {
        const int32_t n = m.adj[4 * static_cast<size_t>(t) + f];
        if (n < 0) continue;
        const bool d = disagrees(t, f);
        mixed |= d;
        const auto want = static_cast<int8_t>(flip[t] ^ static_cast<int8_t>(d));
        if (flip[n / 4] < 0) {
          flip[n / 4] = want;
          stack.push_back(n / 4);
        } else if (flip[n / 4] != want) {
          return Status::error(ErrorCode::InvalidMesh,
                               "tets " + std::to_string(t + 1) + " and " + std::to_string(n / 4 + 1) +
                                   " (counted from 1): the tets around them admit no consistent orientation "
                                   "(not a valid tetrahedral mesh)");
        }
      }
    }
    if (!mixed) continue;
    // The orientation that gives more tets a positive volume (ties: fewer
    // tets reoriented).
    int64_t score = 0, flips = 0;  // positive minus negative tets with `flip` applied; tets flipped
    for (const int32_t t : comp) {
      const int sg = exact_sign(m, t);
      score += flip[t] ? -sg : sg;
      flips += flip[t];
    }
    const bool invert = score < 0 || (score == 0 && 2 * flips > static_cast<int64_t>(comp.size()));
    for (const int32_t t : comp)
      if ((flip[t] != 0) != invert) reoriented.push_back(t);
  }
  std::sort(reoriented.begin(), reoriented.end());
  if (!repair) {
    std::string ids;
    for (size_t i = 0; i < reoriented.size() && i < 10; ++i)
      ids += (i ? ", " : "") + std::to_string(reoriented[i] + 1);
    if (reoriented.size() > 10) ids += ", ... (" + std::to_string(reoriented.size()) + " in all)";
    return Status::error(ErrorCode::InvalidMesh,
                         std::to_string(reoriented.size()) + " tet" + (reoriented.size() == 1 ? " is" : "s are") +
                             " listed with vertices in the opposite order to " +
                             (reoriented.size() == 1 ? "its" : "their") + " neighbours' (tet" + (reoriented.size() == 1 ? " " : "s ") + ids +
                             ", counted from 1 in file order): the faces are not consistently oriented, so the "
                             "region volumes are not defined; exchange two vertices of each");
  }
  for (const int32_t t : reoriented)
    std::swap(m.tets[4 * static_cast<size_t>(t) + kFlipA], m.tets[4 * static_cast<size_t>(t) + kFlipB]);
  if (Status s = build_topology(m, threads); !s) return s;
  if (r) {
    r->reoriented = reoriented;
    r->positive = r->negative = r->flat = 0;
    r->inverted.clear();
    r->flat_tets.clear();
    for (int32_t t = 0; t < nt; ++t) {
      const int sg = exact_sign(m, t);
      if (sg > 0) r->positive++;
      else if (sg < 0) (r->negative++, r->inverted.push_back(t));
      else (r->flat++, r->flat_tets.push_back(t));
    }
  }
  return Status::success();
}

}  // namespace tetopt
