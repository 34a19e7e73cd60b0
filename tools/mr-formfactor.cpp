// mr-formfactor: per-vertex form-factor transfer of a virtual object, and
// shading with it.
#include "cli/tool.h"
#include "jobs/formfactor_job.h"

int main(int argc, char** argv) {
  CLI::App app;
  mr::FormfactorJobOptions job;
  mr::TransferOptions& o = job.transfer;
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
  app.add_option("mesh", job.mesh, "The object's mesh (PLY/OBJ/OFF/STL)")->required()->check(CLI::ExistingFile);
  app.add_option("--out", job.out, "OBJECT.ffc, or with --shade the shaded PLY")->required();
  app.add_option("--basis", job.basis, "cube or sh")->check(CLI::IsMember({"cube", "sh"}))->default_val("cube");
  app.add_option("--resolution", o.resolution, "Cube cells per face edge (also the SH quadrature's)")->default_val(8);
  app.add_option("--order", o.order, "SH bands (order^2 coefficients), 1..8")->default_val(4);
  app.add_option("--supersample", o.supersample, "Rays per cell edge (S x S per cell)")->default_val(2);
  app.add_option("--bounces", o.bounces, "Interreflection bounces on the object")->default_val(0);
  app.add_option("--albedo", o.albedo, "The object's albedo, for the bounces")->default_val(0.8);
  app.add_option("--scene", job.scene, "Skip vertices this scene's camera cannot see (with --object)")
      ->check(CLI::ExistingFile);
  app.add_option("--object", job.object, "The virtual object's name in --scene");
  app.add_option("--spp", job.spp, "With --scene: the samples per pixel the renders will take (default: the scene's)");
  app.add_option("--ffc", job.ffc, "Shade with this transfer (with --shade)")->check(CLI::ExistingFile);
  app.add_option("--shade", job.shade, "Environment map (lat-long) to shade with")->check(CLI::ExistingFile);
  app.add_option("--color", job.color, "Albedo R G B for shading")->expected(3);
  app.add_option("--env-rotation-deg", job.env_rotation_deg, "Rotation of the map about +y (as scene.json)");
  app.add_flag("--mtl", job.mtl,
               "Read an OBJ with its MTL materials, its vertices as mr-render reads it with \"material\": \"mtl\"");
  app.add_flag("--no-window", job.no_window, "Do not window SH coefficients");
  app.add_flag("--vertex-albedo", job.vertex_albedo, "Shade with the mesh's vertex colours as albedo");
  app.add_option("--reference-rays", job.reference_rays,
                 "Path-traced reference with K rays per vertex; reports the error");
  return mr::RunTool("mr-formfactor", app, argc, argv, [&] {
    job.command_line = mr::JoinCommandLine(argc, argv);
    mr::RunFormfactor(job, &mr::ToolReport());
    return mr::kExitOk;
  });
}
