// group_tets_by_region, region_key_order and add_boundary_triangles
// (mesh.hpp, src/regions.cpp; issue 28).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "tetopt/generate.hpp"
#include "tetopt/mesh.hpp"

using namespace tetopt;

namespace {
/// ref -> (name, set of sorted triangles) of the listed triangles.
std::map<int32_t, std::pair<std::string, std::set<std::array<int32_t, 3>>>> groups(const TetMesh& m) {
  std::map<int32_t, std::pair<std::string, std::set<std::array<int32_t, 3>>>> g;
  for (int32_t i = 0; i < m.ntri(); ++i) {
    std::array<int32_t, 3> k{m.tris[3 * i], m.tris[3 * i + 1], m.tris[3 * i + 2]};
    std::sort(k.begin(), k.end());
    g[m.tri_ref[i]].second.insert(k);
  }
  for (const PhysicalName& p : m.physical_names)
    if (p.dim == 2 && g.count(p.tag)) g[p.tag].first = p.name;
  return g;
}
}  // namespace

TEST(Regions, GroupKeepsEachRegionsOrderAndPutsRegionsInTheGivenOrder) {
  TetMesh m = make_box_mesh({.nx = 4, .ny = 2, .nz = 2, .regions = 2});
  const TetMesh before = m;
  // region 2 first, as if IN had listed it first
  std::vector<int32_t> new_id;
  ASSERT_TRUE(group_tets_by_region(m, {{2, 0}, {1, 0}}, &new_id));
  int32_t switches = 0;
  for (int32_t t = 1; t < m.nt(); ++t) switches += m.tet_ref[t] != m.tet_ref[t - 1];
  EXPECT_EQ(switches, 1);
  EXPECT_EQ(m.tet_ref.front(), 2);
  for (int32_t t = 0; t < before.nt(); ++t) {
    EXPECT_TRUE(std::equal(before.tet(t), before.tet(t) + 4, m.tet(new_id[t])));
    EXPECT_EQ(before.tet_ref[t], m.tet_ref[new_id[t]]);
  }
  // within a region, old order kept
  for (int32_t a = 0; a + 1 < before.nt(); ++a)
    for (int32_t b = a + 1; b < before.nt() && b < a + 40; ++b)
      if (before.tet_ref[a] == before.tet_ref[b]) {
        EXPECT_LT(new_id[a], new_id[b]);
      }
  EXPECT_TRUE(m.adj.empty());
  EXPECT_TRUE(build_topology(m));
  // Grouped already: nothing moves.
  EXPECT_FALSE(group_tets_by_region(m, region_key_order(m)));
  // region_key_order with a file order: the region whose first tet came first in IN.
  TetMesh n = make_box_mesh({.nx = 4, .ny = 1, .nz = 1, .regions = 2});
  std::vector<int32_t> order(n.nt());
  for (int32_t t = 0; t < n.nt(); ++t) order[t] = n.nt() - 1 - t;  // IN listed them backwards
  const std::vector<RegionKey> k = region_key_order(n, &order);
  ASSERT_EQ(k.size(), 2u);
  EXPECT_EQ(k[0].first, n.tet_ref.back());
}

TEST(Regions, AddBoundaryTrianglesNamesBoundariesAndInterfacesStably) {
  TetMesh m = make_box_mesh({.nx = 4, .ny = 2, .nz = 2, .regions = 2});
  m.tris.clear();
  m.tri_ref.clear();
  m.physical_names = {{3, 1, "fluid"}, {2, 40, "taken"}};
  const int32_t added = add_boundary_triangles(m);
  // the box's boundary: 2 * (4*2 + 4*2 + 2*2) cells faces, 2 triangles each; the interface 2*2 cells, 2 each
  EXPECT_EQ(added, 2 * 2 * (8 + 8 + 4) + 2 * 4);
  const auto g = groups(m);
  ASSERT_EQ(g.size(), 3u);
  EXPECT_EQ(g.at(41).first, "boundary_fluid");  // refs above every tag in use (40)
  EXPECT_EQ(g.at(42).first, "boundary_2");
  EXPECT_EQ(g.at(43).first, "interface_fluid_2");
  EXPECT_EQ(g.at(43).second.size(), 8u);
  // Listed already: nothing more.
  EXPECT_EQ(add_boundary_triangles(m), 0);
  // The same groups whatever the tet order.
  TetMesh p = make_box_mesh({.nx = 4, .ny = 2, .nz = 2, .regions = 2});
  p.tris.clear();
  p.tri_ref.clear();
  p.physical_names = m.physical_names;
  p.physical_names.resize(2);
  sort_tets_spatially(p);  // another tet order
  add_boundary_triangles(p);
  const auto q = groups(p);
  ASSERT_EQ(q.size(), 3u);
  for (const auto& [ref, ns] : g) {
    EXPECT_EQ(q.at(ref).first, ns.first);
    EXPECT_EQ(q.at(ref).second, ns.second) << ref;
  }
  // They are constrained faces already: the topology agrees.
  EXPECT_TRUE(build_topology(m));
}
