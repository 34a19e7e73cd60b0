// mr's asset reader (tinygltf under mr's checks, mr's OBJ/MTL reader)
// against assimp 5.2 on the same files: read time, peak memory, and what each
// delivers (triangles, bounding box, area, area per material, mean uv), so
// that a difference in what they read shows (docs/dependencies.md, "Why
// tinygltf"; docs/benchmarks.md).  One reader per process, so that the peak
// memory (VmHWM) is that reader's:
//   bench_asset_read mr|assimp FILE
// prints one JSON line;  bench_asset_read assimp-keys FILE  prints the
// material keys assimp carries.
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>

#include <Eigen/Geometry>

#include "geometry/asset.h"

namespace {

struct Stats {
  double seconds = 0;
  int64_t triangles = 0, vertices = 0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  double area = 0, uv_u = 0, uv_v = 0, uv_weight = 0;
  std::map<std::string, double> area_by_material;
};

void AddTriangle(Stats* s, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                 const std::string& material, const Eigen::Vector2d* uv) {
  const double area = 0.5 * (b - a).cross(c - a).norm();
  ++s->triangles;
  s->area += area;
  s->area_by_material[material] += area;
  for (const auto* p : {&a, &b, &c}) {
    s->lo = s->lo.cwiseMin(*p);
    s->hi = s->hi.cwiseMax(*p);
  }
  if (uv) {  // area-weighted mean of the corners' uv
    const Eigen::Vector2d m = (uv[0] + uv[1] + uv[2]) / 3;
    s->uv_u += area * m.x();
    s->uv_v += area * m.y();
    s->uv_weight += area;
  }
}

// mr: v = 0 at the image's top row (glTF's convention, OBJ's v flipped).
Stats ReadMr(const std::string& path) {
  Stats s;
  const auto t0 = std::chrono::steady_clock::now();
  const mr::Asset asset = mr::ReadAsset(path);
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const auto& part : asset.parts) {
    const std::string material = part.material < 0 ? "(default)" : asset.materials[part.material].name;
    const auto& m = part.mesh;
    s.vertices += static_cast<int64_t>(m.positions.size());
    for (const auto& t : m.triangles) {
      Eigen::Vector2d uv[3];
      for (int k = 0; k < 3 && !m.uvs.empty(); ++k) uv[k] = m.uvs[t[k]].cast<double>();
      AddTriangle(&s, m.positions[t[0]].cast<double>(), m.positions[t[1]].cast<double>(),
                  m.positions[t[2]].cast<double>(), material, m.uvs.empty() ? nullptr : uv);
    }
  }
  return s;
}

// assimp: the post-processing a renderer needs to get what mr delivers
// (triangles, every node's transform applied); uv as assimp gives it (v = 0
// at the image's bottom row), flipped here to compare.
Stats ReadAssimp(const std::string& path) {
  Stats s;
  Assimp::Importer importer;
  const auto t0 = std::chrono::steady_clock::now();
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_PreTransformVertices);
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!scene) {
    std::fprintf(stderr, "assimp: %s\n", importer.GetErrorString());
    std::exit(1);
  }
  for (unsigned i = 0; i < scene->mNumMeshes; ++i) {
    const aiMesh* m = scene->mMeshes[i];
    const std::string material = scene->mMaterials[m->mMaterialIndex]->GetName().C_Str();
    s.vertices += m->mNumVertices;
    auto p = [&](unsigned k) { return Eigen::Vector3d(m->mVertices[k].x, m->mVertices[k].y, m->mVertices[k].z); };
    for (unsigned f = 0; f < m->mNumFaces; ++f) {
      const aiFace& face = m->mFaces[f];
      if (face.mNumIndices != 3) continue;
      Eigen::Vector2d uv[3];
      for (int k = 0; k < 3 && m->HasTextureCoords(0); ++k)
        uv[k] = {m->mTextureCoords[0][face.mIndices[k]].x, 1.0 - m->mTextureCoords[0][face.mIndices[k]].y};
      AddTriangle(&s, p(face.mIndices[0]), p(face.mIndices[1]), p(face.mIndices[2]), material,
                  m->HasTextureCoords(0) ? uv : nullptr);
    }
  }
  return s;
}

// The material keys assimp carries for each material (what a renderer over
// assimp could read), one line each: to check which glTF extensions survive.
void PrintAssimpMaterialKeys(const std::string& path) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate);
  if (!scene) return;
  for (unsigned i = 0; i < scene->mNumMaterials; ++i) {
    const aiMaterial* m = scene->mMaterials[i];
    std::printf("%s:", m->GetName().C_Str());
    for (unsigned k = 0; k < m->mNumProperties; ++k) std::printf(" %s", m->mProperties[k]->mKey.C_Str());
    std::printf("\n");
  }
}

long PeakKiB() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: bench_asset_read mr|assimp FILE\n");
    return 2;
  }
  const std::string reader = argv[1];
  if (reader == "assimp-keys") {
    PrintAssimpMaterialKeys(argv[2]);
    return 0;
  }
  const Stats s = reader == "mr" ? ReadMr(argv[2]) : ReadAssimp(argv[2]);
  std::printf(
      "{\"reader\": \"%s\", \"file\": \"%s\", \"seconds\": %.3f, \"peak_mib\": %.1f, \"triangles\": %lld, "
      "\"vertices\": %lld, \"bbox\": [%.6g, %.6g, %.6g, %.6g, %.6g, %.6g], \"area\": %.9g, \"uv_mean\": [%.6f, "
      "%.6f], \"area_by_material\": {",
      reader.c_str(), argv[2], s.seconds, PeakKiB() / 1024.0, static_cast<long long>(s.triangles),
      static_cast<long long>(s.vertices), s.lo.x(), s.lo.y(), s.lo.z(), s.hi.x(), s.hi.y(), s.hi.z(), s.area,
      s.uv_weight > 0 ? s.uv_u / s.uv_weight : 0.0, s.uv_weight > 0 ? s.uv_v / s.uv_weight : 0.0);
  const char* sep = "";
  for (const auto& [name, area] : s.area_by_material) {
    std::printf("%s\"%s\": %.9g", sep, name.c_str(), area);
    sep = ", ";
  }
  std::printf("}}\n");
  return 0;
}
