// group_tets_by_region and region_key_order (mesh.hpp): the tets of one
// region together, for writers that store a region as one block (issue 28:
// `improve` left the impeller's regions interleaved, so the Gmsh 4.1 writer
// wrote 1,012 element blocks and meshio returned 1,012 tetra blocks).
#include <algorithm>
#include <array>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "tetopt/conventions.hpp"
#include "tetopt/mesh.hpp"
#include "detail/permute_tets.hpp"

namespace tetopt {

namespace {
RegionKey key_of(const TetMesh& m, int32_t t, bool has_entity) {
  return {m.tet_ref[static_cast<size_t>(t)], has_entity ? m.tet_entity[static_cast<size_t>(t)] : 0};
}
}  // namespace

std::vector<RegionKey> region_key_order(const TetMesh& m, const std::vector<int32_t>* order) {
  const int32_t nt = m.nt();
  const bool has_entity = m.tet_entity.size() == static_cast<size_t>(nt);
  // The smallest input number of a tet of each key: its first appearance.
  std::map<RegionKey, int32_t> first;
  for (int32_t t = 0; t < nt; ++t) {
    const int32_t in = order && static_cast<size_t>(t) < order->size() ? (*order)[static_cast<size_t>(t)] : t;
    const auto [it, added] = first.emplace(key_of(m, t, has_entity), in);
    if (!added) it->second = std::min(it->second, in);
  }
  std::vector<std::pair<int32_t, RegionKey>> by_first;
  for (const auto& [k, in] : first) by_first.emplace_back(in, k);
  std::sort(by_first.begin(), by_first.end());
  std::vector<RegionKey> out;
  for (const auto& p : by_first) out.push_back(p.second);
  return out;
}

bool group_tets_by_region(TetMesh& m, const std::vector<RegionKey>& keys, std::vector<int32_t>* new_id) {
  const int32_t nt = m.nt();
  const bool has_entity = m.tet_entity.size() == static_cast<size_t>(nt);
  std::map<RegionKey, int32_t> rank;
  for (const RegionKey& k : keys) rank.emplace(k, static_cast<int32_t>(rank.size()));
  // Keys the list does not hold go after it, in order of appearance.
  std::vector<int32_t> r(static_cast<size_t>(nt));
  for (int32_t t = 0; t < nt; ++t) {
    const auto [it, added] = rank.emplace(key_of(m, t, has_entity), static_cast<int32_t>(rank.size()));
    (void)added;
    r[static_cast<size_t>(t)] = it->second;
  }
  std::vector<int32_t> perm(static_cast<size_t>(nt));  // perm[new] = old
  for (int32_t t = 0; t < nt; ++t) perm[static_cast<size_t>(t)] = t;
  std::stable_sort(perm.begin(), perm.end(), [&](int32_t a, int32_t b) { return r[static_cast<size_t>(a)] < r[static_cast<size_t>(b)]; });
  bool moved = false;
  for (int32_t i = 0; i < nt && !moved; ++i) moved = perm[static_cast<size_t>(i)] != i;
  if (new_id) {
    new_id->assign(static_cast<size_t>(nt), 0);
    for (int32_t i = 0; i < nt; ++i) (*new_id)[static_cast<size_t>(perm[static_cast<size_t>(i)])] = i;
  }
  if (!moved) return false;
  detail::permute_tets(m, [&](int32_t i) { return perm[static_cast<size_t>(i)]; });
  return true;
}

}  // namespace tetopt

namespace tetopt {

int32_t add_boundary_triangles(TetMesh& m) {
  const int32_t nt = m.nt();
  // Every face with its tets: sorted vertex triple, tet, local face.
  struct Face {
    std::array<int32_t, 3> key;
    int32_t t;
    int f;
  };
  std::vector<Face> faces;
  faces.reserve(4 * static_cast<size_t>(nt));
  for (int32_t t = 0; t < nt; ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<int32_t, 3> k{m.tet(t)[kFaceVertex[f][0]], m.tet(t)[kFaceVertex[f][1]], m.tet(t)[kFaceVertex[f][2]]};
      std::sort(k.begin(), k.end());
      faces.push_back({k, t, f});
    }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key != b.key ? a.key < b.key : a.t < b.t; });
  std::vector<std::array<int32_t, 3>> listed;
  for (int32_t i = 0; i < m.ntri(); ++i) {
    std::array<int32_t, 3> k{m.tris[3 * static_cast<size_t>(i)], m.tris[3 * static_cast<size_t>(i) + 1], m.tris[3 * static_cast<size_t>(i) + 2]};
    std::sort(k.begin(), k.end());
    listed.push_back(k);
  }
  std::sort(listed.begin(), listed.end());
  // Groups: the boundary of each region (a, a) and each interface (a < b).
  std::map<std::pair<int32_t, int32_t>, std::vector<std::array<int32_t, 3>>> groups;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    const Face& a = faces[i];
    const int32_t ra = m.tet_ref[static_cast<size_t>(a.t)];
    std::pair<int32_t, int32_t> g{ra, ra};
    bool keep = j - i == 1;
    if (j - i == 2) {
      const int32_t rb = m.tet_ref[static_cast<size_t>(faces[i + 1].t)];
      keep = ra != rb;
      g = {std::min(ra, rb), std::max(ra, rb)};
    }
    if (keep && !std::binary_search(listed.begin(), listed.end(), a.key)) {
      // as a face of its first tet, facing out of it
      const int32_t* v = m.tet(a.t);
      groups[g].push_back({v[kFaceVertex[a.f][0]], v[kFaceVertex[a.f][1]], v[kFaceVertex[a.f][2]]});
    }
    i = j;
  }
  if (groups.empty()) return 0;
  int32_t base = 0;
  for (int32_t r : m.tri_ref) base = std::max(base, r);
  for (const PhysicalName& p : m.physical_names)
    if (p.dim == 2) base = std::max(base, static_cast<int32_t>(p.tag));
  auto region_name = [&](int32_t r) {
    for (const PhysicalName& p : m.physical_names)
      if (p.dim == 3 && p.tag == r) return p.name;
    return std::to_string(r);
  };
  int32_t added = 0, ref = base;
  // Boundaries first (a == b), then interfaces, each in ascending refs: the
  // same refs and names for the same mesh, whatever its tet order.
  for (int pass = 0; pass < 2; ++pass)
    for (const auto& [g, tris] : groups) {
      if ((g.first == g.second) != (pass == 0)) continue;
      ++ref;
      for (const auto& t : tris) {
        m.tris.insert(m.tris.end(), t.begin(), t.end());
        m.tri_ref.push_back(ref);
        ++added;
      }
      m.physical_names.push_back(PhysicalName{2, ref, pass == 0 ? "boundary_" + region_name(g.first)
                                                                  : "interface_" + region_name(g.first) + "_" + region_name(g.second)});
    }
  if (!m.tri_entity.empty()) m.tri_entity.resize(static_cast<size_t>(m.ntri()), 0);
  return added;
}

}  // namespace tetopt
