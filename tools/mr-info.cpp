// mr-info: what a file is and whether it is sound.
#include <cstdio>

#include "cli/info.h"
#include "cli/tool.h"
#include "core/json.h"

int main(int argc, char** argv) {
  CLI::App app;
  std::vector<std::string> files;
  bool json = false;
  mr::ConfigureApp(app, "mr-info",
                   "Says what each file that mr reads or writes is, and whether it is sound.\n"
                   "Kinds: .cameramodel (lens model, image size, field of view); images .exr .hdr .png\n"
                   ".jpg .tif .pfm (size, layers, min/max/mean per channel, NaN/Inf counts); meshes .ply .obj\n"
                   ".off .stl (vertices, faces, bounds, degenerate faces); assets .gltf .glb, and .obj with\n"
                   "an mtllib (parts, triangles, materials, images and their sizes, extensions, what mr\n"
                   "ignores); scene.json (full validation);\n"
                   "report.json; calibration boards (.json); TUM trajectories and 7-Scenes poses (.txt);\n"
                   "COLMAP text models (a folder with cameras.txt and images.txt).\n"
                   "Exit code 1 when any file is unreadable or unsound (NaN/Inf pixels, bad values).",
                   "  mr-info scene.json room.ply env.exr scene.cameramodel\n"
                   "  mr-info chair.glb\n"
                   "  mr-info --json render-report.json > summary.json\n"
                   "  mr-info --report info-report.json frames/*.exr");
  app.add_option("files", files, "Files or folders to describe")->required();
  app.add_flag("--json", json, "Print one JSON array on stdout instead of text");
  return mr::RunTool("mr-info", app, argc, argv, [&] {
    int unsound = 0;
    mr::Json all = mr::Json::array();
    for (const auto& f : files) {
      mr::FileInfo fi = mr::DescribeFile(f);
      if (!fi.sound) ++unsound;
      mr::ToolReport().AddInput(f);
      for (const auto& p : fi.problems) mr::ToolReport().Warn(p);
      if (json) {
        all.push_back(fi.json);
        continue;
      }
      std::printf("%s: %s%s\n", fi.path.c_str(), fi.kind.c_str(), fi.sound ? "" : " (NOT SOUND)");
      for (const auto& l : fi.lines) std::printf("  %s\n", l.c_str());
      for (const auto& p : fi.problems) std::fprintf(stderr, "mr-info: error: %s\n", mr::PrintableMessage(p).c_str());
    }
    if (json) std::printf("%s\n", all.dump(2).c_str());
    mr::ToolReport().SetMetric("files", static_cast<int64_t>(files.size()));
    mr::ToolReport().SetMetric("unsound_files", unsound);
    return unsound ? mr::kExitFailure : mr::kExitOk;
  });
}
