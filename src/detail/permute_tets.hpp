// Reorders a mesh's tets (with their refs and Gmsh entity tags) by a
// permutation, and drops the topology built on the old numbers.  Shared by
// sort_tets_spatially (mesh.cpp) and group_tets_by_region (regions.cpp).
#pragma once
#include <algorithm>
#include <cstdint>
#include <vector>

#include "tetopt/mesh.hpp"

namespace tetopt::detail {

/// old_of(i) = the old id of the tet that goes to position i.
template <typename OldOf>
void permute_tets(TetMesh& m, OldOf&& old_of) {
  const int32_t nt = m.nt();
  const bool has_entity = m.tet_entity.size() == static_cast<size_t>(nt);
  std::vector<int32_t> tets(m.tets.size()), ref(static_cast<size_t>(nt)), ent(has_entity ? static_cast<size_t>(nt) : 0);
  for (int32_t i = 0; i < nt; ++i) {
    const int32_t t = old_of(i);
    std::copy(m.tet(t), m.tet(t) + 4, &tets[4 * static_cast<size_t>(i)]);
    ref[static_cast<size_t>(i)] = m.tet_ref[static_cast<size_t>(t)];
    if (has_entity) ent[static_cast<size_t>(i)] = m.tet_entity[static_cast<size_t>(t)];
  }
  m.tets = std::move(tets);
  m.tet_ref = std::move(ref);
  if (has_entity) m.tet_entity = std::move(ent);
  // Whatever topology was built refers to the old tet numbers.
  m.adj.clear();
  m.vt_offsets.clear();
  m.vt_tets.clear();
  m.face_mask.clear();
  m.tet_kind.clear();
  m.topology_epoch++;
}

}  // namespace tetopt::detail
