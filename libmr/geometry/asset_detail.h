// Internal to geometry: the asset readers (asset_gltf.cpp, asset_obj.cpp)
// and what they share (asset.cpp).
#pragma once

#include <Eigen/Core>

#include "geometry/asset.h"

namespace mr::detail {

Asset ReadGltf(const fs::path& path);
Asset ReadObjAsset(const fs::path& path);

// Applies a node's world transform to a part: positions, normals (by the
// inverse transpose), tangents and their handedness, and the winding where
// the transform mirrors (glTF 2.0, 3.7.4: a negative determinant makes the
// front faces clockwise).
void TransformPart(const Eigen::Matrix4d& world, AssetPart* part);

// Every factor finite and in its range (base colour, metallic, roughness,
// transmission in [0, 1]; emission, strength, thickness >= 0; ior in
// [1, 10]; attenuation distance >= 0): mr::Error naming `file` and `what`.
void CheckMaterial(const AssetMaterial& m, const std::string& file, const std::string& what);

}  // namespace mr::detail
