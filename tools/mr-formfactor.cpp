// mr-formfactor: per-vertex form-factor transfer of a virtual object, and
// shading with it.
#include <spdlog/spdlog.h>

#include <chrono>

#include "cli/tool.h"
#include "core/error.h"
#include "core/image.h"
#include "core/math.h"
#include "core/report.h"
#include "core/spherical.h"
#include "eval/transfer_reference.h"
#include "render/prt.h"
#include "scene/scene.h"
#include "transfer/formfactor.h"

namespace {

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app;
  std::string mesh_file, out, basis = "cube", ffc, shade, scene_file, object;
  mr::TransferOptions o;
  std::vector<double> color = {0.8, 0.8, 0.8};
  double env_rotation = 0;
  int reference_rays = 0, spp = 0;
  bool no_window = false;
  mr::ConfigureApp(
      app, "mr-formfactor",
      "Precomputes per-vertex form-factor transfer of a virtual object: for each vertex, the delta\n"
      "form factors of a cube map of directions (6 x N x N cells) or their spherical-harmonic\n"
      "projection, with the object's self-occlusion (Embree rays) and optionally B bounces of its\n"
      "own interreflection. Writes OBJECT.ffc (docs/formats.md).\n"
      "With --ffc and --shade ENV.exr it shades the mesh instead: per-vertex radiance\n"
      "albedo x (transfer . environment), written as a PLY with vertex colours; --reference-rays K\n"
      "path-traces a per-vertex reference and reports the error.\n"
      "With --scene and --object, vertices that mr-render's camera samples cannot see are skipped.",
      "  mr-formfactor bunny.ply --resolution 8 --out bunny.ffc\n"
      "  mr-formfactor bunny.ply --ffc bunny.ffc --shade env.exr --out bunny-lit.ply --reference-rays 256");
  app.add_option("mesh", mesh_file, "The object's mesh (PLY/OBJ/OFF/STL)")->required()->check(CLI::ExistingFile);
  app.add_option("--out", out, "OBJECT.ffc, or with --shade the shaded PLY")->required();
  app.add_option("--basis", basis, "cube or sh")->check(CLI::IsMember({"cube", "sh"}))->default_val("cube");
  app.add_option("--resolution", o.resolution, "Cube cells per face edge (also the SH quadrature's)")->default_val(8);
  app.add_option("--order", o.order, "SH bands (order^2 coefficients), 1..8")->default_val(4);
  app.add_option("--supersample", o.supersample, "Rays per cell edge (S x S per cell)")->default_val(2);
  app.add_option("--bounces", o.bounces, "Interreflection bounces on the object")->default_val(0);
  app.add_option("--albedo", o.albedo, "The object's albedo, for the bounces")->default_val(0.8);
  app.add_option("--scene", scene_file, "Skip vertices this scene's camera cannot see (with --object)")
      ->check(CLI::ExistingFile);
  app.add_option("--object", object, "The virtual object's name in --scene");
  app.add_option("--spp", spp, "With --scene: the samples per pixel the renders will take (default: the scene's)");
  app.add_option("--ffc", ffc, "Shade with this transfer (with --shade)")->check(CLI::ExistingFile);
  app.add_option("--shade", shade, "Environment map (lat-long) to shade with")->check(CLI::ExistingFile);
  app.add_option("--color", color, "Albedo R G B for shading")->expected(3);
  app.add_option("--env-rotation-deg", env_rotation, "Rotation of the map about +y (as scene.json)");
  app.add_flag("--no-window", no_window, "Do not window SH coefficients");
  bool vertex_albedo = false;
  app.add_flag("--vertex-albedo", vertex_albedo, "Shade with the mesh's vertex colours as albedo");
  app.add_option("--reference-rays", reference_rays, "Path-traced reference with K rays per vertex; reports the error");
  return mr::RunTool("mr-formfactor", app, argc, argv, [&] {
    mr::Report& report = mr::ToolReport();
    const std::string command_line = mr::JoinCommandLine(argc, argv);
    mr::MeshReadReport mrr;
    mr::Mesh mesh = mr::ReadMesh(mesh_file, {}, &mrr);
    report.AddInput(mesh_file);
    if (!shade.empty()) {
      if (ffc.empty()) throw mr::UsageError("--shade needs --ffc");
      mr::VertexTransfer t = mr::ReadTransfer(ffc);
      mr::CheckTransferMatches(t, mesh, ffc, mesh_file);
      report.AddInput(ffc);
      report.AddInput(shade);
      mr::ImageReadOptions ro;
      ro.nonfinite = mr::NonFinite::kAllow;
      const mr::Image env = mr::ReadImage(shade, ro);
      const Eigen::Matrix3d world_from_env =
          Eigen::AngleAxisd(env_rotation * mr::kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix();
      auto t0 = std::chrono::steady_clock::now();
      const mr::EnvironmentCoefficients ec =
          mr::ProjectEnvironment(env, shade, t.header, world_from_env, 1.0, !no_window);
      report.AddTiming("project environment", Seconds(t0));
      t0 = std::chrono::steady_clock::now();
      int64_t clamped = 0;
      const Eigen::Vector3d albedo(color[0], color[1], color[2]);
      if (vertex_albedo && mesh.colors.size() != mesh.positions.size())
        throw mr::Error(mr::FileLoc{mesh_file}, "--vertex-albedo: the mesh has no vertex colours");
      const std::vector<Eigen::Vector3f> colours = mesh.colors;
      const auto radiance = mr::ShadeVertices(t, ec, albedo, &clamped, nullptr, vertex_albedo ? &colours : nullptr);
      report.AddTiming("shade", Seconds(t0));
      if (clamped > 0) report.Warn(fmt::format("{} negative vertex values (SH ringing) clamped to 0", clamped));
      report.SetMetric("clamped_negative", clamped);
      if (reference_rays > 0) {
        t0 = std::chrono::steady_clock::now();
        // The reference's surfaces have the albedo the bounces were computed
        // with; its vertex radiance is rescaled to the shading colour.
        const double a = t.header.bounces > 0 ? t.header.albedo : 1.0;
        auto ref =
            mr::ReferenceVertexRadiance(mesh, env, shade, world_from_env, a, t.header.bounces, reference_rays, 1);
        for (auto& r : ref) r /= a;
        report.AddTiming("reference", Seconds(t0));
        for (size_t v = 0; v < ref.size(); ++v)
          ref[v] = ref[v].cwiseProduct(vertex_albedo ? colours[v].cast<double>() : albedo);
        const mr::VertexError e = mr::CompareVertexRadiance(radiance, ref);
        report.SetMetric("vertex_relative_rms", e.relative_rms);
        report.SetMetric("vertex_relmse", e.relmse);
        spdlog::info("error against the {}-ray reference: relative RMS {:.4g}", reference_rays, e.relative_rms);
      }
      report.SetMetric("color_exposure", mr::ColorVerticesByRadiance(radiance, &mesh));
      mr::WritePly(out, mesh, "shaded by " + command_line);
      report.AddOutput(out);
      return mr::kExitOk;
    }
    o.basis = basis == "sh" ? mr::TransferBasis::kSh : mr::TransferBasis::kCube;
    std::vector<char> needed;
    int valid_spp = 0;
    if (!scene_file.empty()) {
      if (object.empty()) throw mr::UsageError("--scene needs --object NAME");
      if (o.bounces > 0) {
        report.Skip("vertex skipping", "with bounces every vertex can light a visible one: all are computed");
      } else {
        const mr::Scene scene = mr::ReadScene(scene_file);
        valid_spp = spp > 0 ? spp : scene.render.spp;
        int64_t frames = 0;
        auto t0 = std::chrono::steady_clock::now();
        needed = mr::VerticesSeenByCamera(scene, object, valid_spp, &frames);
        report.AddTiming("camera visibility", Seconds(t0));
        int64_t n = 0;
        for (char c : needed) n += c;
        report.Skip(fmt::format("{} of {} vertices", static_cast<int64_t>(needed.size()) - n, needed.size()),
                    fmt::format("no camera sample of {} ({} spp) sees them: with no bounces their transfer "
                                "changes no pixel",
                                scene_file, valid_spp));
        report.AddInput(scene_file);
      }
    }
    mr::TransferStats st;
    auto t0 = std::chrono::steady_clock::now();
    const mr::TransferHeader header =
        mr::ComputeTransferToFile(mesh, o, out, &st, needed.empty() ? nullptr : &needed, valid_spp);
    const double seconds = Seconds(t0);
    report.AddTiming("transfer", seconds);
    report.AddOutput(out);
    report.SetMetric("vertices", st.vertices);
    report.SetMetric("coefficients", header.coefficients);
    report.SetMetric("rays", st.rays);
    report.SetMetric("rays_per_second", seconds > 0 ? static_cast<double>(st.rays) / seconds : 0.0);
    report.SetMetric("normals_computed", st.normals_computed);
    report.SetMetric("normals_flipped", st.normals_flipped);
    report.SetMetric("vertices_without_normal", st.vertices_without_normal);
    report.SetMetric("degenerate_faces", st.degenerate_faces);
    report.SetMetric("nonmanifold_edges", st.nonmanifold_edges);
    report.SetMetric("fully_occluded", st.fully_occluded);
    report.SetMetric("skipped_vertices", st.skipped_vertices);
    if (st.normals_flipped > 0)
      report.Warn(fmt::format("{} vertex normals disagreed with their faces and were replaced", st.normals_flipped));
    if (st.vertices_without_normal > 0)
      report.Warn(
          fmt::format("{} vertices lie only on zero-area faces (or none): transfer zero", st.vertices_without_normal));
    if (st.fully_occluded > 0)
      report.Warn(fmt::format("{} vertices see nothing but the object (inside closed geometry?): transfer zero",
                              st.fully_occluded));
    if (st.nonmanifold_edges > 0) report.Warn(fmt::format("{} non-manifold edges", st.nonmanifold_edges));
    spdlog::info("{} vertices x {} coefficients, {} rays in {:.3f} s ({:.3g} rays/s)", st.vertices, header.coefficients,
                 st.rays, seconds, seconds > 0 ? static_cast<double>(st.rays) / seconds : 0.0);
    return mr::kExitOk;
  });
}
