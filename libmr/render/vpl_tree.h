// A light tree over virtual point lights, for lightcuts (Walter et al. 2005,
// "Lightcuts: a scalable approach to illumination"): each node stands for
// the VPLs below it by one representative, and carries what bounds their
// light at any point (a box of positions, a cone of normals, the VPLs'
// summed flux times their BSDFs' bounds).  docs/methods.md, "vpl".
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace mr {

struct Vpl;

struct VplCluster {
  Eigen::AlignedBox3d box;  // the VPLs' positions
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  double cos_half = 1;  // every VPL's normal lies within acos(cos_half) of axis (-1: any)
  double sin_half = 0;
  Eigen::Vector3d axis_t = Eigen::Vector3d::UnitX(), axis_b = Eigen::Vector3d::UnitY();  // a frame around axis
  // Per channel, summed over the VPLs: flux times the bound of f cos of the
  // VPL's diffuse lobe (times the emitter's cosine, bounded by the cone) and
  // of its glossy lobe (Bsdf::DiffuseBound, Bsdf::GlossyBound).
  Eigen::Vector3d diffuse = Eigen::Vector3d::Zero(), glossy = Eigen::Vector3d::Zero();
  double weight = 0;  // luminance of diffuse + glossy: the odds of each VPL being the representative
  int rep = -1;       // a leaf's VPL (index into the set's VPLs); -1 at inner nodes
  int child[2] = {-1, -1};
  bool leaf() const { return child[0] < 0; }
};

// One tree over the VPLs of `indices` (those of one set: shared, mixed-only
// or real-only).  Built top-down by median splits on the longest of six
// extents (position, and normal times half the scene's diagonal, so that a
// floor's VPLs and a wall's part early).  A node's representative is drawn
// at each point it is used (SampleLeaf), each VPL with probability its share
// of the node's weight.
class VplTree {
 public:
  VplTree() = default;
  VplTree(const std::vector<Vpl>& vpls, std::vector<int> indices, uint8_t sets, double diagonal);
  bool empty() const { return nodes_.empty(); }
  int root() const { return 0; }
  const VplCluster& node(int i) const { return nodes_[static_cast<size_t>(i)]; }
  size_t size() const { return nodes_.size(); }
  uint8_t sets() const { return sets_; }
  // The VPL's own weight (a leaf's): its representative's estimate of a node
  // is scaled by node.weight / this.
  double weight(int vpl) const { return weights_[static_cast<size_t>(vpl)]; }

  // A leaf of the node's subtree (a node index; node(leaf).rep is its VPL)
  // drawn in proportion to the leaves' weights from u in [0, 1): each
  // level picks a child by its share of the weight.  Nodes are stored in
  // preorder, so the leaf lies under child[0] exactly when it is below
  // child[1]'s index.
  int SampleLeaf(int node, double u) const;

  // An upper bound, per channel, on the unshadowed light the node's VPLs
  // give a point at x with frame (t, b, n) whose BSDF's bounds are
  // (diffuse_x, glossy_x), with the clamp's 1 / max(d^2, clamp2).
  Eigen::Vector3d Bound(int node, const Eigen::Vector3d& x, const Eigen::Vector3d& t, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& n, const Eigen::Vector3d& diffuse_x, const Eigen::Vector3d& glossy_x,
                        double clamp2) const;

 private:
  int BuildNode(const std::vector<Vpl>& vpls, std::vector<int>& idx, size_t begin, size_t end, double normal_scale);
  std::vector<VplCluster> nodes_;
  std::vector<double> weights_;  // per VPL of the whole set (0 for those not in this tree)
  uint8_t sets_ = 0;
};

}  // namespace mr
