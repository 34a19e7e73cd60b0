#include "jobs/formfactor_job.h"

#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <chrono>

#include "core/error.h"
#include "core/image.h"
#include "core/math.h"
#include "eval/transfer_reference.h"
#include "geometry/asset.h"
#include "geometry/mesh.h"
#include "render/prt.h"
#include "scene/scene.h"

namespace mr {

namespace {

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The error of `radiance` against a path-traced reference, into the report.
void CompareWithReference(const FormfactorJobOptions& o, const Mesh& mesh, const Image& env,
                          const Eigen::Matrix3d& world_from_env, const TransferHeader& header,
                          const std::vector<Eigen::Vector3d>& radiance, Report* report) {
  const auto t0 = std::chrono::steady_clock::now();
  // The reference's surfaces have the albedo the bounces were computed
  // with; its vertex radiance is rescaled to the shading colour.
  const double a = header.bounces > 0 ? header.albedo : 1.0;
  auto ref = ReferenceVertexRadiance(mesh, env, o.shade, world_from_env, a, header.bounces, o.reference_rays, 1);
  for (auto& r : ref) r /= a;
  report->AddTiming("reference", Seconds(t0));
  const Eigen::Vector3d albedo(o.color[0], o.color[1], o.color[2]);
  for (size_t v = 0; v < ref.size(); ++v)
    ref[v] = ref[v].cwiseProduct(o.vertex_albedo ? mesh.colors[v].cast<double>() : albedo);
  const VertexError e = CompareVertexRadiance(radiance, ref);
  report->SetMetric("vertex_relative_rms", e.relative_rms);
  report->SetMetric("vertex_relmse", e.relmse);
  spdlog::info("error against the {}-ray reference: relative RMS {:.4g}", o.reference_rays, e.relative_rms);
}

void Shade(const FormfactorJobOptions& o, Mesh mesh, Report* report) {
  VertexTransfer t = ReadTransfer(o.ffc);
  CheckTransferMatches(t, mesh, o.ffc, o.mesh);
  report->AddInput(o.ffc);
  report->AddInput(o.shade);
  ImageReadOptions ro;
  ro.nonfinite = NonFinite::kAllow;
  const Image env = ReadImage(o.shade, ro);
  const Eigen::Matrix3d world_from_env =
      Eigen::AngleAxisd(o.env_rotation_deg * kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  auto t0 = std::chrono::steady_clock::now();
  const EnvironmentCoefficients ec = ProjectEnvironment(env, o.shade, t.header, world_from_env, 1.0, !o.no_window);
  report->AddTiming("project environment", Seconds(t0));
  t0 = std::chrono::steady_clock::now();
  int64_t clamped = 0;
  const Eigen::Vector3d albedo(o.color[0], o.color[1], o.color[2]);
  if (o.vertex_albedo && mesh.colors.size() != mesh.positions.size())
    throw Error(FileLoc{o.mesh}, "--vertex-albedo: the mesh has no vertex colours");
  const std::vector<Eigen::Vector3f> colours = mesh.colors;
  const auto radiance = ShadeVertices(t, ec, albedo, &clamped, nullptr, o.vertex_albedo ? &colours : nullptr);
  report->AddTiming("shade", Seconds(t0));
  if (clamped > 0) report->Warn(fmt::format("{} negative vertex values (SH ringing) clamped to 0", clamped));
  report->SetMetric("clamped_negative", clamped);
  if (o.reference_rays > 0) CompareWithReference(o, mesh, env, world_from_env, t.header, radiance, report);
  report->SetMetric("color_exposure", ColorVerticesByRadiance(radiance, &mesh));
  WritePly(o.out, mesh, "shaded by " + o.command_line);
  report->AddOutput(o.out);
}

// The vertices some camera sample of the scene sees (empty: all), and the
// samples per pixel that decided it.
std::vector<char> VerticesNeeded(const FormfactorJobOptions& o, int* valid_spp, Report* report) {
  if (o.scene.empty()) return {};
  if (o.transfer.bounces > 0) {
    report->Skip("vertex skipping", "with bounces every vertex can light a visible one: all are computed");
    return {};
  }
  const Scene scene = ReadScene(o.scene);
  *valid_spp = o.spp > 0 ? o.spp : scene.render.spp;
  int64_t frames = 0;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<char> needed = VerticesSeenByCamera(scene, o.object, *valid_spp, &frames);
  report->AddTiming("camera visibility", Seconds(t0));
  int64_t n = 0;
  for (char c : needed) n += c;
  report->Skip(fmt::format("{} of {} vertices", static_cast<int64_t>(needed.size()) - n, needed.size()),
               fmt::format("no camera sample of {} ({} spp) sees them: with no bounces their transfer "
                           "changes no pixel",
                           o.scene, *valid_spp));
  report->AddInput(o.scene);
  return needed;
}

void ReportTransfer(const TransferStats& st, const TransferHeader& header, double seconds, Report* report) {
  report->SetMetric("vertices", st.vertices);
  report->SetMetric("coefficients", header.coefficients);
  report->SetMetric("rays", st.rays);
  report->SetMetric("rays_per_second", seconds > 0 ? static_cast<double>(st.rays) / seconds : 0.0);
  report->SetMetric("normals_computed", st.normals_computed);
  report->SetMetric("normals_flipped", st.normals_flipped);
  report->SetMetric("vertices_without_normal", st.vertices_without_normal);
  report->SetMetric("degenerate_faces", st.degenerate_faces);
  report->SetMetric("nonmanifold_edges", st.nonmanifold_edges);
  report->SetMetric("fully_occluded", st.fully_occluded);
  report->SetMetric("skipped_vertices", st.skipped_vertices);
  if (st.normals_flipped > 0)
    report->Warn(fmt::format("{} vertex normals disagreed with their faces and were replaced", st.normals_flipped));
  if (st.vertices_without_normal > 0)
    report->Warn(
        fmt::format("{} vertices lie only on zero-area faces (or none): transfer zero", st.vertices_without_normal));
  if (st.fully_occluded > 0)
    report->Warn(fmt::format("{} vertices see nothing but the object (inside closed geometry?): transfer zero",
                             st.fully_occluded));
  if (st.nonmanifold_edges > 0) report->Warn(fmt::format("{} non-manifold edges", st.nonmanifold_edges));
  spdlog::info("{} vertices x {} coefficients, {} rays in {:.3f} s ({:.3g} rays/s)", st.vertices, header.coefficients,
               st.rays, seconds, seconds > 0 ? static_cast<double>(st.rays) / seconds : 0.0);
}

}  // namespace

void FormfactorJobOptions::Check() const {
  if (basis != "cube" && basis != "sh") throw UsageError(fmt::format("--basis \"{}\": cube or sh", basis));
  if (color.size() != 3) throw UsageError("--color: give R G B");
  if (reference_rays < 0 || spp < 0) throw UsageError("--reference-rays and --spp must not be negative");
  if (shading()) {
    if (ffc.empty()) throw UsageError("--shade needs --ffc");
    return;
  }
  if (!scene.empty() && object.empty()) throw UsageError("--scene needs --object NAME");
  transfer.Check();
}

void RunFormfactor(const FormfactorJobOptions& o, Report* report) {
  o.Check();
  MeshReadReport mrr;
  Mesh mesh = o.mtl ? MergeParts(ReadAsset(o.mesh)) : ReadMesh(o.mesh, {}, &mrr);
  report->AddInput(o.mesh);
  if (o.shading()) return Shade(o, std::move(mesh), report);
  TransferOptions to = o.transfer;
  to.basis = o.basis == "sh" ? TransferBasis::kSh : TransferBasis::kCube;
  int valid_spp = 0;
  const std::vector<char> needed = VerticesNeeded(o, &valid_spp, report);
  TransferStats st;
  const auto t0 = std::chrono::steady_clock::now();
  const TransferHeader header =
      ComputeTransferToFile(mesh, to, o.out, &st, needed.empty() ? nullptr : &needed, valid_spp);
  const double seconds = Seconds(t0);
  report->AddTiming("transfer", seconds);
  report->AddOutput(o.out);
  ReportTransfer(st, header, seconds, report);
}

}  // namespace mr
