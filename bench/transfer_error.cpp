// Error against run time of form-factor transfer (docs/benchmarks.md):
// for each mesh and environment, cube resolutions and SH orders with and
// without interreflection, the per-vertex radiance's relative RMS error
// against a path-traced reference, and the precomputation and shading
// times.  Prints a markdown table and writes a CSV for
// scripts/plot_error_time.py.
//   bench_transfer_error OUT.csv
#include <chrono>
#include <cstdio>
#include <fstream>

#include "core/image.h"
#include "core/math.h"
#include "eval/transfer_reference.h"
#include "geometry/primitives.h"
#include "transfer/formfactor.h"

namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double RelativeRms(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    num += (a[i] - b[i]).squaredNorm();
    den += b[i].squaredNorm();
  }
  return std::sqrt(num / den);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: bench_transfer_error OUT.csv\n");
    return 2;
  }
  const std::string data = MR_SHARED_DATA;
  struct NamedMesh {
    std::string name;
    mr::Mesh mesh;
  };
  std::vector<NamedMesh> meshes = {{"bunny (1889 v)", mr::ReadMesh(data + "/meshes/bun_zipper_res3.ply")},
                                   {"dragon (5205 v)", mr::ReadMesh(data + "/meshes/dragon_vrip_res4.ply")},
                                   {"bumpy sphere (3280 v)", mr::BumpySphere(40)}};
  mr::Image sun = mr::Image::Rgb(256, 129, 0.2f);  // a dim sky and a sun 1e5 x brighter, 40 degrees up
  for (int c = 0; c < 3; ++c) sun.at(100, 36, c) = 2e4f;
  struct NamedEnv {
    std::string name;
    mr::Image img;
  };
  std::vector<NamedEnv> envs = {{"grace probe", mr::ReadImage(data + "/probes-latlong/grace.hdr")},
                                {"synthetic sun", sun}};
  struct Config {
    mr::TransferBasis basis;
    int n, order, ss;
  };
  std::vector<Config> configs;
  for (int n : {2, 4, 8, 16, 32}) configs.push_back({mr::TransferBasis::kCube, n, 0, n >= 16 ? 1 : 2});
  for (int l : {2, 4, 6, 8}) configs.push_back({mr::TransferBasis::kSh, 16, l, 1});
  std::ofstream csv(argv[1]);
  csv << "mesh,environment,basis,size,bounces,precompute_s,shade_s,relative_rms,reference_noise\n";
  std::printf(
      "| mesh | environment | basis | bounces | precompute s | shade ms | relative RMS error "
      "|\n|---|---|---|---|---|---|---|\n");
  const int kRefRays = 1024;
  for (const auto& m : meshes)
    for (const auto& e : envs)
      for (int bounces : {0, 2}) {
        const auto ref =
            mr::ReferenceVertexRadiance(m.mesh, e.img, e.name, Eigen::Matrix3d::Identity(), 0.8, bounces, kRefRays, 1);
        const auto ref2 =
            mr::ReferenceVertexRadiance(m.mesh, e.img, e.name, Eigen::Matrix3d::Identity(), 0.8, bounces, kRefRays, 2);
        const double noise = RelativeRms(ref2, ref) / std::sqrt(2.0);  // one reference's own error
        std::printf("| %s | %s | reference (%d rays, MIS) | %d | | | %.4f (its own noise) |\n", m.name.c_str(),
                    e.name.c_str(), kRefRays, bounces, noise);
        for (const Config& c : configs) {
          if (bounces > 0 && c.basis == mr::TransferBasis::kCube && c.n > 16) continue;
          mr::TransferOptions o;
          o.basis = c.basis;
          o.resolution = c.n;
          o.order = c.order == 0 ? 4 : c.order;
          o.supersample = c.ss;
          o.bounces = bounces;
          o.albedo = 0.8;
          mr::TransferStats st;
          auto t0 = Clock::now();
          const mr::VertexTransfer t = mr::ComputeTransfer(m.mesh, o, &st);
          const double pre = Since(t0);
          t0 = Clock::now();
          const auto ec = mr::ProjectEnvironment(e.img, e.name, t.header, Eigen::Matrix3d::Identity());
          const auto lit = mr::ShadeVertices(t, ec, Eigen::Vector3d::Constant(0.8), nullptr);
          const double shade = Since(t0);
          const double err = RelativeRms(lit, ref);  // both at albedo 0.8
          const std::string size = c.basis == mr::TransferBasis::kCube
                                       ? std::to_string(c.n) + "x" + std::to_string(c.n) + "x6"
                                       : "order " + std::to_string(c.order);
          std::printf("| %s | %s | %s | %d | %.3f | %.1f | %.4f |\n", m.name.c_str(), e.name.c_str(), size.c_str(),
                      bounces, pre, 1e3 * shade, err);
          std::fflush(stdout);
          csv << '"' << m.name << "\",\"" << e.name << "\"," << (c.basis == mr::TransferBasis::kCube ? "cube" : "sh")
              << ',' << size << ',' << bounces << ',' << pre << ',' << shade << ',' << err << ',' << noise << '\n';
        }
      }
  return 0;
}
