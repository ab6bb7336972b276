// Tets from a face-based mesh (OpenFOAM polyMesh, Fluent .msh) and back.
//
// Face-based formats store no cells, only faces (three vertex ids each here)
// with the cell on either side.  tets_from_faces rebuilds each cell's four
// vertices; faces_of_tets lists a tet mesh's faces with the tets on either
// side, for the writers.  Both formats are read through these, so a tet
// comes back in the same canonical vertex order from either.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "io/checked.hpp"
#include "io/common.hpp"
#include "tetopt/conventions.hpp"
#include "tetopt/mesh.hpp"

namespace tetopt::detail {

/// A positive tet's canonical vertex order: an even permutation (the same
/// orientation) with the smallest id first and the smallest of the other
/// three second.  A face-based file cannot say which order a tet had, so
/// every tet read from one comes back in this order, the same after any
/// number of round trips.
inline void canonical_tet(int32_t v[4]) {
  int k = 0;
  for (int i = 1; i < 4; ++i)
    if (v[i] < v[k]) k = i;
  int32_t q[4];
  // Even permutations bringing position k to the front.
  static constexpr int kFront[4][4] = {{0, 1, 2, 3}, {1, 0, 3, 2}, {2, 3, 0, 1}, {3, 2, 1, 0}};
  for (int i = 0; i < 4; ++i) q[i] = v[kFront[k][i]];
  // A cyclic rotation of the last three is even too.
  int r = 1;
  if (q[2] < q[r]) r = 2;
  if (q[3] < q[r]) r = 3;
  v[0] = q[0];
  v[1] = q[r];
  v[2] = q[r == 3 ? 1 : r + 1];
  v[3] = q[r == 1 ? 3 : r - 1];
}

/// Cells from faces.  faces: 3 vertex ids per face; first[f] and second[f]:
/// the cells on either side (second -1 on the boundary), face f oriented
/// (right-hand normal) OUT of first[f].  ncells: the number of cells (every
/// cell id below it, checked by the caller).  On success tets holds 4 ids
/// per cell, positive when the faces are oriented as said, canonical.
/// On failure `what` says why and `bad` names the cell (0-based).
inline bool tets_from_faces(const std::vector<int32_t>& faces, const std::vector<int32_t>& first,
                            const std::vector<int32_t>& second, int64_t ncells, std::vector<int32_t>& tets,
                            std::string& what, int64_t& bad) {
  const int64_t nf = static_cast<int64_t>(first.size());
  // Four faces per cell: count, refusing a fifth before any allocation
  // depends on it.  ncells <= 2 * nf / 4 is checked by the callers.
  std::vector<int32_t> slot(ck_size(ncells, 4), -1);
  std::vector<uint8_t> count(ck_size(ncells, 1), 0);
  for (int64_t f = 0; f < nf; ++f) {
    for (int side = 0; side < 2; ++side) {
      const int32_t c = side == 0 ? first[f] : second[f];
      if (c < 0) continue;
      if (count[c] == 4) {
        what = "has more than 4 faces (only tetrahedra are supported)";
        bad = c;
        return false;
      }
      slot[4 * static_cast<size_t>(c) + count[c]++] = static_cast<int32_t>(f);
    }
  }
  tets.assign(ck_size(ncells, 4), -1);
  for (int64_t c = 0; c < ncells; ++c) {
    bad = c;
    if (count[c] != 4) {
      what = "has " + std::to_string(count[c]) + " faces (only tetrahedra, 4 triangles, are supported)";
      return false;
    }
    const int32_t* fs = &slot[4 * static_cast<size_t>(c)];
    // fs is in ascending face order (faces were visited in order): the
    // first one, oriented out of c, gives three vertices.
    const int32_t f0 = fs[0];
    const int32_t* p = &faces[3 * static_cast<size_t>(f0)];
    int32_t a = p[0], b = p[1], cc = p[2];
    if (first[f0] != c) std::swap(b, cc);  // f0 points into c: reverse it
    int32_t d = -1;
    for (int k = 1; k < 4 && d < 0; ++k) {
      const int32_t* q = &faces[3 * static_cast<size_t>(fs[k])];
      for (int j = 0; j < 3; ++j)
        if (q[j] != a && q[j] != b && q[j] != cc) d = q[j];
    }
    if (a == b || b == cc || a == cc || d < 0) {
      what = "is not a tetrahedron (its faces do not span four vertices)";
      return false;
    }
    // Every face must be a face of (a, b, cc, d), each leaving out a
    // different vertex.
    const int32_t t4[4] = {a, cc, b, d};
    unsigned seen = 0;
    for (int k = 0; k < 4; ++k) {
      const int32_t* q = &faces[3 * static_cast<size_t>(fs[k])];
      unsigned mask = 0;
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 4; ++i)
          if (q[j] == t4[i]) mask |= 1u << i;
      if (__builtin_popcount(mask) != 3 || (seen & ~mask & 15u) != 0) {
        // a face with a vertex outside the four, a repeated vertex, or two
        // faces leaving out the same vertex
        what = "is not a tetrahedron (its faces do not close up)";
        return false;
      }
      seen |= ~mask & 15u;
    }
    int32_t* t = &tets[4 * static_cast<size_t>(c)];
    for (int i = 0; i < 4; ++i) t[i] = t4[i];
    canonical_tet(t);
  }
  return true;
}

/// One face of the written mesh: vertex ids (oriented out of `first`),
/// the tet on each side (second -1 on the boundary).
struct WrittenFace {
  int32_t v[3];
  int32_t first, second;
};

/// Sorted vertex triple of a triangle.
inline std::array<int32_t, 3> tri_key(const int32_t* p) {
  std::array<int32_t, 3> k{p[0], p[1], p[2]};
  std::sort(k.begin(), k.end());
  return k;
}

/// Whether (x, y, z) is a rotation of (a, b, c): the same orientation.
inline bool same_rotation(const int32_t* t, const int32_t* f) {
  for (int r = 0; r < 3; ++r)
    if (t[0] == f[r] && t[1] == f[(r + 1) % 3] && t[2] == f[(r + 2) % 3]) return true;
  return false;
}

/// Every face of m's tets once (tets in the orientation of `target`, see
/// file_tet): internal faces with first < second, oriented out of first;
/// boundary faces oriented out of their tet.  Faces come in the order of
/// their sorted vertex triples.  keys (optional): the sorted triple of each.
/// Fails (a message naming tets, 1-based) when a face lies on three tets or
/// twice on one.
inline bool faces_of_tets(const TetMesh& m, Format target, std::vector<WrittenFace>& out,
                          std::vector<std::array<int32_t, 3>>* keys, std::string& what) {
  const int32_t nt = m.nt();
  struct Item {
    std::array<int32_t, 3> key;
    int32_t id;  // 4t+f
  };
  std::vector<Item> items(ck_size(nt, 4));
  std::vector<int32_t> tv(ck_size(nt, 4));
  for (int32_t t = 0; t < nt; ++t) {
    int32_t v[4];
    file_tet(m, t, target, v);
    for (int i = 0; i < 4; ++i) tv[4 * static_cast<size_t>(t) + i] = v[i];
    for (int f = 0; f < 4; ++f) {
      const int32_t p[3] = {v[kFaceVertex[f][0]], v[kFaceVertex[f][1]], v[kFaceVertex[f][2]]};
      items[4 * static_cast<size_t>(t) + f] = Item{tri_key(p), 4 * t + f};
    }
  }
  std::sort(items.begin(), items.end(), [](const Item& x, const Item& y) {
    return x.key != y.key ? x.key < y.key : x.id < y.id;
  });
  out.clear();
  if (keys) keys->clear();
  for (size_t i = 0; i < items.size();) {
    size_t j = i + 1;
    while (j < items.size() && items[j].key == items[i].key) ++j;
    if (j - i > 2) {
      what = "tets " + std::to_string(items[i].id / 4 + 1) + ", " + std::to_string(items[i + 1].id / 4 + 1) +
             " and " + std::to_string(items[i + 2].id / 4 + 1) + " share a face (a face-based file needs at most two)";
      return false;
    }
    if (j - i == 2 && items[i].id / 4 == items[i + 1].id / 4) {
      what = "tet " + std::to_string(items[i].id / 4 + 1) + " has two equal faces";
      return false;
    }
    const int32_t id = items[i].id, t = id / 4, f = id % 4;
    WrittenFace w;
    const int32_t* v = &tv[4 * static_cast<size_t>(t)];
    for (int k = 0; k < 3; ++k) w.v[k] = v[kFaceVertex[f][k]];
    w.first = t;
    w.second = j - i == 2 ? items[i + 1].id / 4 : -1;
    out.push_back(w);
    if (keys) keys->push_back(items[i].key);
    i = j;
  }
  return true;
}

}  // namespace tetopt::detail
