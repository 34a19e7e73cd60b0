// Procedural meshes shared by the benchmarks.
#pragma once

#include <cmath>

#include "core/math.h"
#include "geometry/mesh.h"

namespace mr::bench {

// A bumpy sphere of (n+1) x 2n vertices: self-occlusion in its folds.
inline Mesh Bumpy(int n) {
  Mesh m;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      const double th = kPi * i / n, ph = kPi * j / n;
      const double r = 1 + 0.15 * std::sin(6 * th) * std::cos(5 * ph);
      m.positions.emplace_back(static_cast<float>(r * std::sin(th) * std::cos(ph)), static_cast<float>(r * std::cos(th)),
                               static_cast<float>(r * std::sin(th) * std::sin(ph)));
    }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      const int a = i * 2 * n + j, b = i * 2 * n + (j + 1) % (2 * n), c = a + 2 * n, d = b + 2 * n;
      if (i > 0) m.triangles.push_back({a, b, c});
      if (i < n - 1) m.triangles.push_back({b, d, c});
    }
  return m;
}

}  // namespace mr::bench
