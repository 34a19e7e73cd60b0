#include "cli/info.h"

#include "calib/board.h"
#include "camera/camera_model.h"
#include "camera/colmap_text.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "core/report.h"
#include "geometry/asset.h"
#include "geometry/mesh.h"
#include "hdr/response.h"
#include "light/lights_file.h"
#include "probe/unwrap.h"
#include "render/method.h"
#include "scene/frames.h"
#include "scene/scene.h"
#include "transfer/formfactor.h"

namespace mr {

namespace {

void DescribeCamera(const fs::path& path, FileInfo* fi) {
  fi->kind = "camera model";
  CameraModel m = CameraModel::Read(path);
  fi->lines.push_back(fmt::format("lens model: {}", m.lensmodel()));
  fi->lines.push_back(fmt::format("image size: {} x {}", m.width(), m.height()));
  auto c = m.Core();
  fi->lines.push_back(fmt::format("focal length: {:.3f} {:.3f} px, centre: {:.3f} {:.3f} px", c[0], c[1], c[2], c[3]));
  const double hfov = m.HorizontalFovDeg(), vfov = m.VerticalFovDeg();
  fi->lines.push_back(fmt::format("field of view: {:.2f} x {:.2f} deg", hfov, vfov));
  fi->json = {{"lensmodel", m.lensmodel()},
              {"width", m.width()},
              {"height", m.height()},
              {"intrinsics", m.intrinsics()},
              {"fov_deg", {hfov, vfov}}};
}

void DescribeImage(const fs::path& path, FileInfo* fi) {
  fi->kind = "image";
  ImageReadOptions opt;
  opt.nonfinite = NonFinite::kAllow;
  ImageFileInfo info;
  Image img = ReadImage(path, opt, &info);
  fi->lines.push_back(fmt::format(
      "{} {} x {}, {} channels, stored as {}{}", info.format, img.width(), img.height(), img.channels(),
      info.pixel_type, info.decoded_from_ldr ? fmt::format(" (decoded as {})", ToString(info.transfer)) : ""));
  auto layers = img.LayerNames();
  std::string ls;
  for (auto& l : layers) ls += (ls.empty() ? "" : ", ") + (l.empty() ? std::string("(default)") : l);
  fi->lines.push_back("layers: " + ls);
  Json chans = Json::array();
  int64_t bad = 0;
  for (const auto& s : ComputeStats(img)) {
    fi->lines.push_back(fmt::format("  {:<14} min {:<12.6g} max {:<12.6g} mean {:<12.6g} NaN {} Inf {}", s.name, s.min,
                                    s.max, s.mean, s.nan_count, s.inf_count));
    chans.push_back({{"name", s.name},
                     {"min", s.min},
                     {"max", s.max},
                     {"mean", s.mean},
                     {"nan", s.nan_count},
                     {"inf", s.inf_count}});
    bad += s.nan_count + s.inf_count;
  }
  for (const auto& [k, v] : info.attributes) fi->lines.push_back(fmt::format("  {}: {}", k, v));
  if (bad > 0) fi->problems.push_back(fmt::format("{}: {} NaN/Inf values", path.string(), bad));
  fi->json = {{"format", info.format},         {"width", img.width()}, {"height", img.height()},
              {"pixel_type", info.pixel_type}, {"channels", chans},    {"attributes", info.attributes}};
}

void DescribeMesh(const fs::path& path, FileInfo* fi) {
  fi->kind = "mesh";
  MeshReadOptions opt;
  opt.nonfinite = BadVertices::kReject;
  MeshReadReport rep;
  Mesh m = ReadMesh(path, opt, &rep);
  auto b = m.Bounds();
  fi->lines.push_back(fmt::format("{}: {} vertices, {} triangles", rep.format, m.vertex_count(), m.triangle_count()));
  fi->lines.push_back(fmt::format("bounds: [{:.6g} {:.6g} {:.6g}] .. [{:.6g} {:.6g} {:.6g}]", b.min().x(), b.min().y(),
                                  b.min().z(), b.max().x(), b.max().y(), b.max().z()));
  fi->lines.push_back(fmt::format("surface area: {:.6g}", m.SurfaceArea()));
  fi->lines.push_back(fmt::format("attributes: normals {}, colours {}, uvs {}", m.normals.empty() ? "no" : "yes",
                                  m.colors.empty() ? "no" : "yes", m.uvs.empty() ? "no" : "yes"));
  fi->lines.push_back(fmt::format("degenerate faces dropped: {}", rep.degenerate_faces_dropped));
  for (const auto& n : rep.notes) fi->lines.push_back("note: " + n);
  fi->json = {{"format", rep.format},
              {"vertices", m.vertex_count()},
              {"triangles", m.triangle_count()},
              {"degenerate_faces_dropped", rep.degenerate_faces_dropped},
              {"faces_rejected_by_reader", rep.faces_rejected_by_reader},
              {"comment_lines_skipped", rep.comment_lines_skipped},
              {"bounds", {{b.min().x(), b.min().y(), b.min().z()}, {b.max().x(), b.max().y(), b.max().z()}}}};
}

// A glTF asset, or an OBJ's materials (mtllib) after its mesh.
void DescribeAssetFile(const fs::path& path, FileInfo* fi) {
  const Asset a = ReadAsset(path);
  if (fi->kind.empty()) fi->kind = "asset";
  for (std::string& l : DescribeAsset(a)) fi->lines.push_back(std::move(l));
  Json materials = Json::array();
  for (const AssetMaterial& m : a.materials) materials.push_back(m.name);
  fi->json["asset"] = {{"format", a.report.format},
                       {"parts", a.parts.size()},
                       {"triangles", a.triangle_count()},
                       {"materials", materials},
                       {"images", a.images.size()},
                       {"extensions_used", a.report.extensions_used},
                       {"extensions_required", a.report.extensions_required},
                       {"ignored", a.report.ignored}};
}

void DescribeTrajectory(const Trajectory& t, FileInfo* fi, const std::string& format) {
  fi->kind = "trajectory";
  fi->lines.push_back(fmt::format("{} trajectory: {} poses, span {:.3f} s, path length {:.4f} m", format, t.size(),
                                  t.Duration(), t.PathLength()));
  if (t.max_orthonormality_error > 0)
    fi->lines.push_back(
        fmt::format("re-orthonormalised rotations: largest correction {:.3g}", t.max_orthonormality_error));
  fi->json = {{"format", format}, {"poses", t.size()}, {"span", t.Duration()}, {"path_length_m", t.PathLength()}};
}

void DescribeJson(const fs::path& path, FileInfo* fi) {
  Json j = ReadJsonFile(path);
  if (j.is_object() && j.contains("timings") && j.contains("tool")) {
    fi->kind = "report";
    ValidateReportJson(j, path.string());
    fi->lines.push_back(fmt::format("report of {} {}", j["tool"].get<std::string>(), j["version"].get<std::string>()));
    double total = 0;
    for (auto& [k, v] : j["timings"].items()) total += v.get<double>();
    fi->lines.push_back(fmt::format("timings: {} parts, {:.3f} s in all", j["timings"].size(), total));
    fi->lines.push_back(fmt::format("skipped: {}, warnings: {}", j["skipped"].size(), j["warnings"].size()));
    for (auto& s : j["skipped"])
      fi->lines.push_back(fmt::format("  skipped {}: {}", s["what"].dump(), s["why"].dump()));
    fi->lines.push_back("metrics: " + j["metrics"].dump());
    fi->json = {{"tool", j["tool"]}, {"total_seconds", total}};
  } else if (j.is_object() && j.value("format", "") == "mr-response") {
    fi->kind = "response";
    const CameraResponse r = ParseResponse(j, path.string());
    fi->lines.push_back(
        fmt::format("camera response ({}): {} channels, {} levels", r.method, r.channels.size(), r.levels()));
    for (size_t c = 0; c < r.channels.size(); ++c)
      fi->lines.push_back(fmt::format("  {}: code 0.5 is {:.4g} of the saturating exposure", r.channels[c],
                                      r.Exposure(static_cast<int>(c), 0.5)));
    fi->json = {{"method", r.method}, {"channels", r.channels}, {"levels", r.levels()}};
  } else if (j.is_object() && j.value("format", "") == "mr-probe") {
    fi->kind = "probe";
    const ProbeGeometry g = ReadProbe(path);
    fi->lines.push_back(fmt::format("mirror sphere of radius {} m at ({:.4f}, {:.4f}, {:.4f}) m in camera {} ({})",
                                    g.radius_m, g.centre_cam.x(), g.centre_cam.y(), g.centre_cam.z(),
                                    g.camera.lensmodel(), j["camera"].get<std::string>()));
    fi->json = {{"radius_m", g.radius_m}, {"centre_cam_m", {g.centre_cam.x(), g.centre_cam.y(), g.centre_cam.z()}}};
  } else if (j.is_object() && j.contains("inner_corners")) {
    fi->kind = "board";
    BoardSpec b = ParseBoard(j, path.string());
    fi->lines.push_back(fmt::format("{} {}: {} x {} inner corners, {} mm squares, detector {}", b.type, b.name,
                                    b.inner_x, b.inner_y, b.square_m * 1000, b.detector));
    fi->json = BoardToJson(b);
  } else if (j.is_object() && j.contains("lights")) {
    fi->kind = "lights";
    const std::vector<Light> lights = ParseLights(j, path.string());
    int n_virtual = 0;
    for (const Light& l : lights) {
      static const char* kTypes[] = {"point", "spot", "distant"};
      n_virtual += l.is_virtual;
      fi->lines.push_back(
          fmt::format("  {}: {} {}", l.name, l.is_virtual ? "virtual" : "real", kTypes[static_cast<int>(l.type)]));
    }
    fi->lines.insert(fi->lines.begin(), fmt::format("lights: {} ({} virtual)", lights.size(), n_virtual));
    fi->json = {{"lights", lights.size()}, {"virtual", n_virtual}};
  } else {
    fi->kind = "scene";
    fs::path base = path.parent_path().empty() ? fs::path(".") : path.parent_path();
    Scene s = ParseScene(j, base, path.string(), true);
    CheckRenderSettings(s);  // render.method and every render.<method> block
    fi->lines.push_back(fmt::format("scene: camera {}", s.camera.model.string()));
    fi->lines.push_back(fmt::format("real geometry: {} meshes", s.reals.size()));
    for (const auto& r : s.reals) fi->lines.push_back(fmt::format("  {}", r.mesh.string()));
    fi->lines.push_back(fmt::format("virtual objects: {}", s.virtuals.size()));
    for (const auto& v : s.virtuals) fi->lines.push_back(fmt::format("  {}: {}", v.name, v.mesh.string()));
    fi->lines.push_back(fmt::format("render: method {}, {} spp, max depth {}, seed {}", s.render.method, s.render.spp,
                                    s.render.max_depth, s.render.seed));
    const CameraModel camera = CameraModel::Read(s.camera.model);
    const int n_frames = static_cast<int>(LoadScenePoses(s).size());
    if (s.render.frame_begin >= n_frames)
      ThrowErrorAt(FileLoc{path.string(), 0, 0, "render.frame_begin"}, "frame {} is past the scene's {} frames",
                   s.render.frame_begin, n_frames);
    const SceneInputCheck inputs =
        CheckSceneInputs(s, camera.width(), camera.height(), s.render.frame_begin, s.render.frame_end);
    const int end = s.render.frame_end < 0 || s.render.frame_end > n_frames ? n_frames : s.render.frame_end;
    fi->lines.push_back(fmt::format("frames: {} (rendered: {}:{})", n_frames, s.render.frame_begin, end));
    for (const std::string& w : inputs.warnings) fi->lines.push_back("warning: " + w);
    fi->lines.push_back("valid");
    fi->json = {{"virtual_objects", s.virtuals.size()},
                {"method", s.render.method},
                {"frames", n_frames},
                {"frame_begin", s.render.frame_begin},
                {"frame_end", end}};
  }
}

void Describe(const fs::path& path, FileInfo* fi) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    if (fs::exists(path / "cameras.txt") && fs::exists(path / "images.txt")) {
      fi->kind = "COLMAP model";
      ColmapModel m = ReadColmapText(path);
      fi->lines.push_back(fmt::format("COLMAP text model: {} cameras, {} images, {} points", m.cameras.size(),
                                      m.images.size(), m.points3d.size()));
      fi->json = {{"cameras", m.cameras.size()}, {"images", m.images.size()}, {"points", m.points3d.size()}};
      return;
    }
    DescribeTrajectory(Read7ScenesFolder(path), fi, "7-Scenes");
    return;
  }
  RequireFile(path);
  const std::string ext = LowerExtension(path);
  const std::string fname = path.filename().string();
  if (ext == ".cameramodel") return DescribeCamera(path, fi);
  if (ext == ".exr" || ext == ".hdr" || ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" ||
      ext == ".tiff" || ext == ".pfm")
    return DescribeImage(path, fi);
  if (ext == ".gltf" || ext == ".glb") return DescribeAssetFile(path, fi);
  if (ext == ".obj") {
    DescribeMesh(path, fi);
    if (ReadTextFile(path).find("mtllib") != std::string::npos) DescribeAssetFile(path, fi);
    return;
  }
  if (ext == ".ply" || ext == ".off" || ext == ".stl") return DescribeMesh(path, fi);
  if (ext == ".json") return DescribeJson(path, fi);
  if (ext == ".ffc") {
    fi->kind = "form factors";
    const VertexTransfer t = ReadTransfer(path);
    const TransferHeader& h = t.header;
    const std::string basis = h.basis == TransferBasis::kCube ? fmt::format("cube {}x{}x6", h.resolution, h.resolution)
                                                              : fmt::format("SH order {}", h.order);
    fi->lines.push_back(fmt::format("form factors: {}, {} coefficients per vertex, {} vertices", basis, h.coefficients,
                                    h.vertex_count));
    fi->lines.push_back(fmt::format(
        "supersample {}, bounces {} (albedo {}), mesh hash {:016x}{}", h.supersample, h.bounces, h.albedo, h.mesh_hash,
        h.valid_spp > 0 ? fmt::format(", seen vertices only (up to {} spp)", h.valid_spp) : ""));
    fi->json = {{"basis", h.basis == TransferBasis::kCube ? "cube" : "sh"},
                {"resolution", h.resolution},
                {"order", h.order},
                {"coefficients", h.coefficients},
                {"vertices", h.vertex_count},
                {"bounces", h.bounces},
                {"valid_spp", h.valid_spp}};
    return;
  }
  if (fname == "cameras.txt" || fname == "images.txt" || fname == "points3D.txt") {
    fi->kind = "COLMAP " + fname;
    std::string text = ReadTextFile(path);
    size_t n = fname == "cameras.txt"  ? ParseColmapCameras(text, path.string()).size()
               : fname == "images.txt" ? ParseColmapImages(text, path.string()).size()
                                       : ParseColmapPoints3D(text, path.string()).size();
    fi->lines.push_back(fmt::format("{} entries", n));
    fi->json = {{"entries", n}};
    return;
  }
  if (ext == ".txt") {
    std::string f = DetectPoseFormat(path);
    if (f == "tum") return DescribeTrajectory(ReadTum(path), fi, "TUM");
    if (f == "7scenes") {
      Trajectory t;
      double err = 0;
      t.poses.push_back({0, Read7ScenesPose(path, &err)});
      t.max_orthonormality_error = err;
      return DescribeTrajectory(t, fi, "7-Scenes pose");
    }
    ThrowErrorAt(FileLoc{path.string()}, "text file is neither a TUM trajectory nor a 4x4 pose");
  }
  ThrowErrorAt(FileLoc{path.string()}, "unknown file kind \"{}\" (mr-info --help lists the kinds)", ext);
}

}  // namespace

FileInfo DescribeFile(const fs::path& path) {
  FileInfo fi;
  fi.path = path.string();
  try {
    Describe(path, &fi);
  } catch (const Error& e) {
    fi.problems.push_back(e.what());
  } catch (const std::exception& e) {
    fi.problems.push_back(fmt::format("{}: {}", path.string(), e.what()));
  }
  fi.sound = fi.problems.empty();
  if (fi.kind.empty()) fi.kind = "unknown";
  fi.json["path"] = fi.path;
  fi.json["kind"] = fi.kind;
  fi.json["sound"] = fi.sound;
  fi.json["problems"] = fi.problems;
  return fi;
}

}  // namespace mr
