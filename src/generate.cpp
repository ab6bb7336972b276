// Procedural test meshes (see generate.hpp).
#include "tetopt/generate.hpp"

#include <random>
#include <stdexcept>
#include <string>

#include "tetopt/predicates.hpp"

namespace tetopt {

TetMesh make_box_mesh(const BoxMeshOptions& o) {
  TetMesh m;
  const int nx = o.nx, ny = o.ny, nz = o.nz;
  // 6 nx ny nz tets with 32-bit ids (the vertex count, smaller, follows):
  // 1300 cells per axis overflowed int32 and reached resize() negative.
  if (nx < 1 || ny < 1 || nz < 1 ||
      6.0 * static_cast<double>(nx) * static_cast<double>(ny) * static_cast<double>(nz) > 2147483647.0)
    throw std::invalid_argument("make_box_mesh: " + std::to_string(nx) + " x " + std::to_string(ny) + " x " +
                                std::to_string(nz) + " cells: need at least 1 per axis and at most 2^31 - 1 tets, "
                                "6 per cell (tet ids are 32-bit)");
  auto vid = [&](int i, int j, int k) { return static_cast<int32_t>((k * (ny + 1) + j) * (nx + 1) + i); };
  const int32_t nv = (nx + 1) * (ny + 1) * (nz + 1);
  m.xyz.resize(3 * static_cast<size_t>(nv));
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        double* p = m.point(vid(i, j, k));
        p[0] = i; p[1] = j; p[2] = k;
      }
  // Six tets per cube around the diagonal corner 0 -> corner 7; each path
  // 0 -> a -> b -> 7 along unit steps is one tet.
  static const int kPaths[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  m.tets.reserve(24 * static_cast<size_t>(nx) * ny * nz);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        for (const auto& path : kPaths) {
          int c[3] = {i, j, k};
          int32_t t[4];
          t[0] = vid(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            c[path[s]]++;
            t[s + 1] = vid(c[0], c[1], c[2]);
          }
          if (orient3d(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3])) != Sign::Positive)
            std::swap(t[2], t[3]);
          m.tets.insert(m.tets.end(), t, t + 4);
          m.tet_ref.push_back(o.regions == 2 ? (i < nx / 2 ? 1 : 2) : 1);
        }
  m.vert_ref.assign(nv, 0);
  // Boundary triangles: faces on one tet (found through a topology build).
  TetMesh tmp = m;
  if (build_adjacency(tmp)) {
    for (int32_t t = 0; t < tmp.nt(); ++t)
      for (int f = 0; f < 4; ++f)
        if (tmp.adj[4 * t + f] < 0) {
          const int32_t* v = m.tet(t);
          for (int q = 0; q < 3; ++q) m.tris.push_back(v[kFaceVertex[f][q]]);
          m.tri_ref.push_back(1);
        }
  }
  if (o.jitter > 0) {
    std::mt19937_64 rng(o.seed);
    std::uniform_real_distribution<double> u(-o.jitter, o.jitter);
    build_vertex_tets(m);
    for (int k = 1; k < nz; ++k)
      for (int j = 1; j < ny; ++j)
        for (int i = 1; i < nx; ++i) {
          if (o.regions == 2 && i == nx / 2) continue;
          const int32_t v = vid(i, j, k);
          double* p = m.point(v);
          const double old[3] = {p[0], p[1], p[2]};
          for (int a = 0; a < 3; ++a) p[a] += u(rng);
          bool ok = true;
          for (const int32_t* s = m.star_begin(v); s != m.star_end(v) && ok; ++s) {
            const int32_t* t = m.tet(*s);
            ok = orient3d(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3])) == Sign::Positive;
          }
          if (!ok) { p[0] = old[0]; p[1] = old[1]; p[2] = old[2]; }
        }
    m.vt_offsets.clear();
    m.vt_tets.clear();
  }
  return m;
}

}  // namespace tetopt
