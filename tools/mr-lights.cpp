// mr-lights: light sources from an environment map, and what they leave out.
#include <spdlog/spdlog.h>

#include <optional>
#include <sstream>

#include "cli/tool.h"
#include "core/error.h"
#include "core/hash.h"
#include "core/image.h"
#include "core/report.h"
#include "eval/plot.h"
#include "light/environment.h"
#include "light/lights_file.h"
#include "pipeline/pipeline.h"
#include "probe/light_extraction.h"
#include "scene/frames.h"

namespace {

std::vector<int> ParseCounts(const std::string& s) {
  std::vector<int> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) {
    try {
      size_t used = 0;
      const int v = std::stoi(item, &used);
      if (used != item.size() || v < 1) throw std::invalid_argument(item);
      out.push_back(v);
    } catch (const std::exception&) {
      throw mr::UsageError(fmt::format("--counts: \"{}\" is not a positive integer", item));
    }
  }
  return out;
}

// An earlier run's lights file for this frame, when its key matches (and
// its residual map exists): nullopt otherwise.
std::optional<mr::Json> KeptLights(const std::string& out, const std::string& residual, const std::string& key) {
  std::error_code ec;
  if (!mr::fs::is_regular_file(out, ec) || (!residual.empty() && !mr::fs::is_regular_file(residual, ec)))
    return std::nullopt;
  try {
    mr::Json j = mr::ReadJsonFile(out);
    mr::ParseLights(j, out);
    if (j["source"].value("key", "") != key || !j["source"].contains("next_id")) return std::nullopt;
    for (const auto& l : j["lights"])
      if (l.value("name", "").rfind("light", 0) != 0) return std::nullopt;
    return j;
  } catch (const std::exception&) {
    return std::nullopt;  // unreadable: made again
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app;
  std::string env_file, out, residual_file, table, plot, counts_text = "1,2,4,8,16,32,64,128,256,512,1024";
  std::vector<std::string> methods = {"median-cut", "variance-cut", "importance", "blobs"};
  mr::ExtractOptions eo;
  int residual_width = 64, normals = 1024;
  bool sweep = false;
  mr::ConfigureApp(
      app, "mr-lights",
      "Extracts light sources from a lat-long environment map (mr-probe's env.exr, or any lat-long\n"
      "EXR/HDR): median cut on a double-precision, solid-angle-weighted summed-area table; variance-\n"
      "minimising cut; hierarchical importance warping (N VPLs); or thresholded connected blobs as area\n"
      "lights. Writes lights.json (distant lights, real, with their solid angle and the residual's\n"
      "spherical harmonics) and with --residual the map minus what the lights took, downsampled keeping\n"
      "energy: lights + residual integrate to the map. The report gives the extraction time and the\n"
      "error of diffuse irradiance over all normal directions against the full map.\n"
      "--sweep runs every method at every count and writes the error-vs-count table (CSV) and plot (SVG).\n"
      "Over time: with printf patterns (env/%05d.exr, --out lights/%05d.json), one lights file per map,\n"
      "each light keeping its name (lightN) across frames while it stays within --match-deg of where it\n"
      "was, so that a renderer can tell a light that moved from one that appeared.",
      "  mr-lights env.exr --method median-cut --count 64 --out lights.json --residual residual.exr\n"
      "  mr-lights env.exr --method blobs --count 4 --threshold 20 --out sun.json --residual rest.exr\n"
      "  mr-lights pisa.hdr --sweep --table pisa.csv --plot pisa.svg\n"
      "  mr-lights 'env/%05d.exr' --method blobs --count 4 --out 'lights/%05d.json' --residual "
      "'residual/%05d.exr'");
  double match_deg = 10;
  app.add_option("env", env_file, "Lat-long environment map (R G B first), or a printf pattern of one per frame")
      ->required();
  app.add_option("--match-deg", match_deg,
                 "Over time: a light within this angle of one of the last frame keeps its name")
      ->default_val(10)
      ->check(mr::kNonNegative);
  app.add_option("--out", out, "lights.json to write");
  app.add_option("--method", eo.method, "median-cut, variance-cut, importance or blobs")
      ->check(CLI::IsMember({"median-cut", "variance-cut", "importance", "blobs"}))
      ->default_val("median-cut");
  app.add_option("--count", eo.count, "Number of lights (blobs: at most)")->default_val(16);
  app.add_option("--threshold", eo.threshold, "blobs: pixels above this times the mean radiance")->default_val(8);
  app.add_option("--max-blob-sr", eo.max_blob_sr, "blobs: larger components split (steradians)")->default_val(0.05);
  app.add_option("--sh-order", eo.sh_order, "Bands of the residual's spherical harmonics")->default_val(3);
  app.add_option("--residual", residual_file, "Write the map minus what the lights took (EXR)");
  app.add_option("--residual-width", residual_width, "Width of the residual map (energy-preserving downsampling)")
      ->default_val(64);
  app.add_option("--normals", normals, "Normal directions for the irradiance error")->default_val(1024);
  app.add_flag("--sweep", sweep, "Error against count for every method (with --table, --plot)");
  app.add_option("--methods", methods, "Methods for --sweep")->delimiter(',');
  app.add_option("--counts", counts_text, "Counts for --sweep, comma-separated");
  app.add_option("--table", table, "--sweep: CSV table");
  app.add_option("--plot", plot, "--sweep: SVG plot of irradiance error against count");
  return mr::RunTool("mr-lights", app, argc, argv, [&] {
    mr::Report& report = mr::ToolReport();
    if (!sweep && out.empty()) throw mr::UsageError("give --out lights.json (or --sweep)");
    if (sweep && table.empty() && plot.empty()) throw mr::UsageError("--sweep needs --table or --plot");
    if (residual_width < 8 || residual_width % 2) throw mr::UsageError("--residual-width must be even and at least 8");
    eo.Check();
    const bool over_time = env_file.find('%') != std::string::npos;
    if (over_time) {
      if (sweep) throw mr::UsageError("--sweep takes one map, not a pattern");
      if (out.find('%') == std::string::npos ||
          (!residual_file.empty() && residual_file.find('%') == std::string::npos))
        throw mr::UsageError("a pattern of maps needs patterns for --out and --residual (lights/%05d.json)");
    } else if (!mr::fs::exists(env_file)) {
      mr::ThrowErrorAt(mr::FileLoc{env_file}, "no such file");
    }
    const std::vector<Eigen::Vector3d> dirs = mr::SphereNormals(normals);
    const std::string command_line = mr::JoinCommandLine(argc, argv);
    // One map: its lights (named by `ids` when given), residual and error.
    auto extract_one = [&](const std::string& map_file, const std::string& out_file, const std::string& res_file,
                           const mr::Extraction& ex, const std::vector<double>& ref, const std::vector<int>* ids,
                           const mr::Json& source_extra = mr::Json::object()) {
      const bool make_dirs = ids != nullptr;  // over time the patterns' folders are made
      const mr::IrradianceError e = mr::CompareIrradiance(mr::LightsIrradiance(ex, dirs, false), ref);
      const mr::IrradianceError er = mr::CompareIrradiance(mr::LightsIrradiance(ex, dirs, true), ref);
      std::vector<mr::Light> lights = mr::ToLights(ex, "light", ids);
      mr::Json j = mr::LightsToJson(lights, "mr-lights: " + command_line);
      j["source"] = {{"method", eo.method}, {"count", eo.count}, {"map", map_file}};
      for (auto& [k, v] : source_extra.items()) j["source"][k] = v;
      mr::Json sh = mr::Json::array();
      for (const auto& c : ex.residual_sh) sh.push_back({c.x(), c.y(), c.z()});
      j["residual"] = {
          {"taken_fraction", std::clamp(ex.taken_fraction, 0.0, 1.0)}, {"sh_order", eo.sh_order}, {"sh", sh}};
      if (!res_file.empty())
        j["residual"]["map"] =
            mr::fs::relative(mr::fs::absolute(res_file), mr::fs::absolute(out_file).parent_path()).generic_string();
      mr::ParseLights(j, out_file);  // what mr-render will read; checked before anything is written
      if (!res_file.empty()) {
        mr::ImageWriteOptions wo;
        wo.tool = "mr-lights";
        wo.command_line = command_line;
        wo.attributes["textureformat"] = "LatLong Environment";
        std::error_code ec;
        if (make_dirs && !mr::fs::path(res_file).parent_path().empty())
          mr::fs::create_directories(mr::fs::path(res_file).parent_path(), ec);
        mr::WriteImage(res_file, mr::DownsampleEnergy(ex.residual, residual_width), wo);
        report.AddOutput(res_file);
      }
      std::error_code ec;
      if (make_dirs && !mr::fs::path(out_file).parent_path().empty())
        mr::fs::create_directories(mr::fs::path(out_file).parent_path(), ec);
      mr::WriteTextFile(out_file, j.dump(2) + "\n");
      report.AddOutput(out_file);
      return std::make_pair(e, er);
    };
    if (over_time) {
      mr::Json frames = mr::Json::array();
      std::vector<mr::ExtractedLight> prev;
      std::vector<int> prev_ids;
      int next_id = 0, f = 0, kept = 0;
      // Each frame's key chains the options and every map up to it (a
      // light's name depends on the frames before): a re-run keeps the
      // files whose key matches and redoes the rest.
      const std::string options =
          fmt::format("{} {} {} {} {} {} {} {} {}", eo.method, eo.count, eo.threshold, eo.max_blob_sr, eo.sh_order,
                      eo.seed, residual_width, match_deg, residual_file.empty());
      uint64_t key = mr::HashCombine(0x6c6967687473ULL, mr::HashString(options));
      for (;; ++f) {
        const std::string map_file = mr::FramePath(env_file, f).string();
        if (!mr::fs::exists(map_file)) break;
        key = mr::HashCombine(key, mr::ContentHash(map_file));
        const std::string key_hex = fmt::format("{:016x}", key);
        const std::string out_file = mr::FramePath(out, f).string();
        const std::string res_file = residual_file.empty() ? "" : mr::FramePath(residual_file, f).string();
        if (std::optional<mr::Json> done = KeptLights(out_file, res_file, key_hex)) {
          // Up to date: its lights carry the identities on.
          prev.clear();
          prev_ids.clear();
          for (const mr::Light& l : mr::ParseLights(*done, out_file)) {
            mr::ExtractedLight e;
            e.direction = l.direction;
            prev.push_back(e);
            prev_ids.push_back(std::stoi(l.name.substr(5)));
          }
          next_id = (*done)["source"]["next_id"].get<int>();
          report.AddInput(map_file);
          report.AddOutput(out_file);
          frames.push_back({{"frame", f}, {"kept", true}, {"lights", prev.size()}, {"ids", prev_ids}});
          ++kept;
          continue;
        }
        mr::Image env;
        {
          mr::ScopedTimer t(&report, "read");
          env = mr::ReadImage(map_file);
          mr::CheckEnvironmentImage(env, map_file);
        }
        report.AddInput(map_file);
        mr::Extraction ex;
        {
          mr::ScopedTimer t(&report, "extract");
          ex = mr::ExtractLights(env, eo);
        }
        int matched = 0;
        const std::vector<int> ids = mr::MatchLights(prev, prev_ids, ex.lights, match_deg, &next_id, &matched);
        std::vector<double> ref;
        {
          mr::ScopedTimer t(&report, "reference irradiance");
          ref = mr::MapIrradiance(env, dirs);
        }
        const auto [e, er] =
            extract_one(map_file, out_file, res_file, ex, ref, &ids, mr::Json{{"key", key_hex}, {"next_id", next_id}});
        frames.push_back({{"frame", f},
                          {"lights", ex.lights.size()},
                          {"kept_identity", matched},
                          {"new", static_cast<int>(ex.lights.size()) - matched},
                          {"gone", static_cast<int>(prev.size()) - matched},
                          {"ids", ids},
                          {"taken_fraction", ex.taken_fraction},
                          {"irradiance_rms_relative", e.rms_relative},
                          {"irradiance_rms_relative_with_residual_sh", er.rms_relative}});
        prev = ex.lights;
        prev_ids = ids;
      }
      if (f == 0) mr::ThrowErrorAt(mr::FileLoc{mr::FramePath(env_file, 0).string()}, "no such file");
      if (kept > 0)
        report.Skip("extraction", fmt::format("{} of {} frames: their lights files are up to date (same maps and "
                                              "options, as their keys say)",
                                              kept, f));
      report.SetMetric("frames_kept", kept);
      report.SetMetric("method", eo.method);
      report.SetMetric("frames", frames);
      report.SetMetric("identities", next_id);
      spdlog::info("{} maps: {} light identities", f, next_id);
      return mr::kExitOk;
    }
    mr::Image env;
    {
      mr::ScopedTimer t(&report, "read");
      env = mr::ReadImage(env_file);
      mr::CheckEnvironmentImage(env, env_file);
    }
    report.AddInput(env_file);
    std::vector<double> ref;
    {
      mr::ScopedTimer t(&report, "reference irradiance");
      ref = mr::MapIrradiance(env, dirs);
    }
    if (sweep) {
      const std::vector<int> counts = ParseCounts(counts_text);
      std::string csv =
          "method,count,lights,seconds,irradiance_rms,irradiance_max,irradiance_rms_with_residual,taken_fraction\n";
      std::vector<mr::PlotSeries> series;
      nlohmann::json rows = nlohmann::json::array();
      for (const std::string& m : methods) {
        mr::ExtractOptions o = eo;
        o.method = m;
        mr::PlotSeries s{m, {}};
        for (int n : counts) {
          o.count = n;
          mr::ScopedTimer t(&report, "sweep");
          const mr::Extraction ex = mr::ExtractLights(env, o);
          const mr::IrradianceError e = mr::CompareIrradiance(mr::LightsIrradiance(ex, dirs, false), ref);
          const mr::IrradianceError er = mr::CompareIrradiance(mr::LightsIrradiance(ex, dirs, true), ref);
          csv += fmt::format("{},{},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", m, n, ex.lights.size(), ex.seconds,
                             e.rms_relative, e.max_relative, er.rms_relative, ex.taken_fraction);
          rows.push_back({{"method", m},
                          {"count", n},
                          {"lights", ex.lights.size()},
                          {"seconds", ex.seconds},
                          {"irradiance_rms", e.rms_relative},
                          {"irradiance_max", e.max_relative},
                          {"irradiance_rms_with_residual", er.rms_relative},
                          {"taken_fraction", ex.taken_fraction}});
          s.points.push_back({static_cast<double>(n), std::max(e.rms_relative, 1e-9)});
        }
        series.push_back(s);
      }
      report.SetMetric("sweep", rows);
      if (!table.empty()) {
        mr::WriteTextFile(table, csv);
        report.AddOutput(table);
      }
      if (!plot.empty()) {
        mr::PlotOptions po;
        po.title =
            "Diffuse irradiance error against the number of lights: " + mr::fs::path(env_file).filename().string();
        po.x_label = "lights";
        po.y_label = "relative RMS error of irradiance over all normals";
        mr::WriteSvgPlot(plot, series, po);
        report.AddOutput(plot);
      }
      std::fputs(csv.c_str(), stdout);
      return mr::kExitOk;
    }
    mr::Extraction ex;
    {
      mr::ScopedTimer t(&report, "extract");
      ex = mr::ExtractLights(env, eo);
    }
    const auto [e, er] = extract_one(env_file, out, residual_file, ex, ref, nullptr);
    if (!residual_file.empty() && ex.taken_fraction > 1 - 1e-12)
      report.Skip("residual energy", "the lights took all of the map's energy (" + eo.method +
                                         "): the residual map is black and its SH zero");
    if (residual_file.empty() && ex.taken_fraction < 1 - 1e-9)
      report.Warn(
          fmt::format("the lights leave {:.1f}% of the map's energy out and no --residual keeps it (lights.json "
                      "holds its spherical harmonics)",
                      100 * (1 - ex.taken_fraction)));
    const size_t n_lights = ex.lights.size();
    report.SetMetric("method", eo.method);
    report.SetMetric("lights", n_lights);
    report.SetMetric("extraction_seconds", ex.seconds);
    report.SetMetric("taken_fraction", ex.taken_fraction);
    report.SetMetric("irradiance_error", {{"rms_relative", e.rms_relative},
                                          {"max_relative", e.max_relative},
                                          {"rms_relative_with_residual_sh", er.rms_relative},
                                          {"normals", normals}});
    if (static_cast<int>(n_lights) < eo.count)
      report.Warn(fmt::format("{} lights asked for, {} found", eo.count, n_lights));
    spdlog::info(
        "{}: {} lights ({}) in {:.3f} s take {:.1f}% of the energy; irradiance error {:.3g} (RMS), {:.3g} "
        "with the residual's SH",
        env_file, n_lights, eo.method, ex.seconds, 100 * ex.taken_fraction, e.rms_relative, er.rms_relative);
    return mr::kExitOk;
  });
}
