#include "geometry/primitives.h"

#include <cmath>
#include <functional>

#include "core/math.h"

namespace mr {

Mesh Box(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  Mesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  m.triangles = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                 {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  return m;
}

Mesh Quad(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c, const Eigen::Vector3f& d) {
  Mesh m;
  m.positions = {a, b, c, d};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

namespace {
Mesh LatLongGrid(int n, const std::function<double(double, double)>& radius) {
  Mesh m;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      const double th = kPi * i / n, ph = kPi * j / n, r = radius(th, ph);
      m.positions.emplace_back(static_cast<float>(r * std::sin(th) * std::cos(ph)),
                               static_cast<float>(r * std::cos(th)),
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
}  // namespace

Mesh UvSphere(float r, int n) {
  return LatLongGrid(n, [r](double, double) { return static_cast<double>(r); });
}

Mesh BumpySphere(int n) {
  return LatLongGrid(n, [](double th, double ph) { return 1 + 0.15 * std::sin(6 * th) * std::cos(5 * ph); });
}

}  // namespace mr
