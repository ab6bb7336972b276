// Random tets of the shapes that measures break on, for the bit-for-bit
// tests of the fused and memoised kernels against the standalone functions.
#pragma once
#include <cmath>
#include <random>

namespace tetopt_test {

/// Tet k of a sequence: k % 8 picks random, sliver (d close to the plane of
/// a, b, c), needle (b close to a), cap (d close to the triangle, inside
/// it), flat (four coplanar points), a repeated point, tiny or huge scale
/// (1/huge or huge), nearly regular (near-ties); the closeness is
/// 10^-(1 + k % eps_steps).
inline void shaped_tet(int k, std::mt19937_64& rng, double p[4][3], int eps_steps = 15, double huge = 1e150) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) p[i][j] = u(rng);
  const int shape = k % 8;
  const double eps = std::pow(10.0, -1.0 - static_cast<double>(k % eps_steps));
  if (shape == 1) {
    for (int j = 0; j < 3; ++j) p[3][j] = 0.5 * (p[0][j] + p[1][j]) + 0.3 * (p[2][j] - p[0][j]);
    p[3][2] += eps;
  } else if (shape == 2) {
    for (int j = 0; j < 3; ++j) p[1][j] = p[0][j] + eps * u(rng);
  } else if (shape == 3) {
    for (int j = 0; j < 3; ++j) p[3][j] = (p[0][j] + p[1][j] + p[2][j]) / 3;
    p[3][0] += eps;
  } else if (shape == 4) {
    for (int i = 0; i < 4; ++i) p[i][2] = 0.25;
  } else if (shape == 5) {
    for (int j = 0; j < 3; ++j) p[2][j] = p[1][j];
  } else if (shape == 6) {
    const double scale = (k % 16 < 8) ? 1 / huge : huge;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 3; ++j) p[i][j] *= scale;
  } else if (shape == 7) {
    const double r[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 3; ++j) p[i][j] = r[i][j] + eps * u(rng);
  }
}

}  // namespace tetopt_test
