#include "render/vpl_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/color.h"
#include "core/math.h"
#include "core/spherical.h"
#include "render/vpl.h"

namespace mr {

namespace {

// The largest z / |v| over the points v of the box (centre c, half-extents
// e; coordinates relative to the apex), z along `axis` of the orthonormal
// frame (tx, ty, axis).  The box seen in that frame lies in the box of
// centre R c and half-extents |R| e; z / |v| grows with z and, for z > 0,
// falls with x^2 + y^2 (for z <= 0 it rises with them).
double MaxCosine(const Eigen::Vector3d& c, const Eigen::Vector3d& e, const Eigen::Vector3d& tx,
                 const Eigen::Vector3d& ty, const Eigen::Vector3d& axis) {
  auto range = [&](const Eigen::Vector3d& r, double* lo, double* hi) {
    const double m = r.dot(c), h = r.cwiseAbs().dot(e);
    *lo = m - h;
    *hi = m + h;
  };
  double xl, xh, yl, yh, zl, z;
  range(tx, &xl, &xh);
  range(ty, &yl, &yh);
  range(axis, &zl, &z);
  auto nearest = [](double l, double h) { return l <= 0 && h >= 0 ? 0.0 : std::min(std::abs(l), std::abs(h)); };
  auto farthest = [](double l, double h) { return std::max(std::abs(l), std::abs(h)); };
  if (z > 0) {
    const double x = nearest(xl, xh), y = nearest(yl, yh);
    return z / std::sqrt(x * x + y * y + z * z);
  }
  const double x = farthest(xl, xh), y = farthest(yl, yh);
  const double r = std::sqrt(x * x + y * y + z * z);
  return r > 0 ? z / r : 1.0;
}

}  // namespace

VplTree::VplTree(const std::vector<Vpl>& vpls, std::vector<int> indices, uint8_t sets, double diagonal) : sets_(sets) {
  weights_.assign(vpls.size(), 0.0);
  if (indices.empty()) return;
  nodes_.reserve(2 * indices.size());
  BuildNode(vpls, indices, 0, indices.size(), 0.5 * diagonal);
}

int VplTree::BuildNode(const std::vector<Vpl>& vpls, std::vector<int>& idx, size_t begin, size_t end,
                       double normal_scale) {
  const int at = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  if (end - begin == 1) {
    const int i = idx[begin];
    const Vpl& v = vpls[static_cast<size_t>(i)];
    VplCluster& c = nodes_.back();
    c.box = Eigen::AlignedBox3d(v.p, v.p);
    c.axis = v.frame.n;
    c.cos_half = 1;
    CoordinateSystem(c.axis, &c.axis_t, &c.axis_b);
    c.diffuse = v.flux.cwiseProduct(v.bsdf.DiffuseBound());
    c.glossy = v.flux.cwiseProduct(v.bsdf.GlossyBound(v.wi_local));
    c.weight = Luminance(c.diffuse + c.glossy);
    c.rep = i;
    weights_[static_cast<size_t>(i)] = c.weight;
    return at;
  }
  // The longest of the six extents: position, and normal times normal_scale.
  Eigen::Matrix<double, 6, 1> lo = Eigen::Matrix<double, 6, 1>::Constant(std::numeric_limits<double>::infinity());
  Eigen::Matrix<double, 6, 1> hi = -lo;
  auto key = [&](int i) {
    const Vpl& v = vpls[static_cast<size_t>(i)];
    Eigen::Matrix<double, 6, 1> k;
    k << v.p, v.frame.n * normal_scale;
    return k;
  };
  for (size_t j = begin; j < end; ++j) {
    const auto k = key(idx[j]);
    lo = lo.cwiseMin(k);
    hi = hi.cwiseMax(k);
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  const size_t mid = begin + (end - begin) / 2;
  std::nth_element(idx.begin() + static_cast<std::ptrdiff_t>(begin), idx.begin() + static_cast<std::ptrdiff_t>(mid),
                   idx.begin() + static_cast<std::ptrdiff_t>(end), [&](int a, int b) {
                     const double ka = key(a)[axis], kb = key(b)[axis];
                     return ka < kb || (ka == kb && a < b);  // a total order: the same tree on every run
                   });
  const int c0 = BuildNode(vpls, idx, begin, mid, normal_scale);
  const int c1 = BuildNode(vpls, idx, mid, end, normal_scale);
  const VplCluster& a = nodes_[static_cast<size_t>(c0)];
  const VplCluster& b = nodes_[static_cast<size_t>(c1)];
  VplCluster c;
  c.child[0] = c0;
  c.child[1] = c1;
  c.box = a.box.merged(b.box);
  c.diffuse = a.diffuse + b.diffuse;
  c.glossy = a.glossy + b.glossy;
  c.weight = a.weight + b.weight;
  // The normal cone: around the children's mean axis, wide enough for both.
  const Eigen::Vector3d sum = a.axis + b.axis;
  if (sum.norm() < 1e-9 || a.cos_half <= -1 || b.cos_half <= -1) {
    c.cos_half = -1;
  } else {
    c.axis = sum.normalized();
    double half = 0;
    for (const VplCluster* k : {&a, &b})
      half = std::max(
          half, std::acos(std::clamp(c.axis.dot(k->axis), -1.0, 1.0)) + std::acos(std::clamp(k->cos_half, -1.0, 1.0)));
    c.cos_half = half >= kPi ? -1.0 : std::cos(half);
  }
  c.sin_half = std::sqrt(std::max(0.0, 1 - c.cos_half * c.cos_half));
  CoordinateSystem(c.axis, &c.axis_t, &c.axis_b);
  nodes_[static_cast<size_t>(at)] = c;
  return at;
}

int VplTree::SampleLeaf(int node, double u) const {
  for (;;) {
    const VplCluster& c = nodes_[static_cast<size_t>(node)];
    if (c.leaf()) return node;
    const double w0 = nodes_[static_cast<size_t>(c.child[0])].weight, w = c.weight;
    const double p0 = w > 0 ? w0 / w : 0.5;
    if (u < p0) {
      node = c.child[0];
      u = p0 > 0 ? u / p0 : 0;
    } else {
      node = c.child[1];
      u = p0 < 1 ? (u - p0) / (1 - p0) : 0;
    }
    u = std::clamp(u, 0.0, std::nextafter(1.0, 0.0));
  }
}

Eigen::Vector3d VplTree::Bound(int node, const Eigen::Vector3d& x, const Eigen::Vector3d& t, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& n, const Eigen::Vector3d& diffuse_x,
                               const Eigen::Vector3d& glossy_x, double clamp2) const {
  const VplCluster& c = nodes_[static_cast<size_t>(node)];
  const Eigen::Vector3d centre = 0.5 * (c.box.min() + c.box.max()) - x;  // the VPLs, seen from x
  const Eigen::Vector3d extent = 0.5 * (c.box.max() - c.box.min());
  const double cos_x = MaxCosine(centre, extent, t, b, n);
  if (cos_x <= 0) return Eigen::Vector3d::Zero();
  double cos_y = 1;
  if (c.cos_half > -1) {
    // The directions from the VPLs to x (the box -centre) against the cone
    // of their normals: cos(angle - cone) where the angle is past the cone.
    const double m = std::clamp(MaxCosine(-centre, extent, c.axis_t, c.axis_b, c.axis), -1.0, 1.0);
    if (m < c.cos_half) {
      cos_y = m * c.cos_half + std::sqrt(1 - m * m) * c.sin_half;
      if (cos_y <= 0) return Eigen::Vector3d::Zero();
    }
  }
  const double d2 = c.box.squaredExteriorDistance(x);
  const double g = 1 / std::max(d2, clamp2);
  const Eigen::Vector3d mx = diffuse_x * cos_x + glossy_x;
  return mx.cwiseProduct(c.diffuse * cos_y + c.glossy) * g;
}

}  // namespace mr
