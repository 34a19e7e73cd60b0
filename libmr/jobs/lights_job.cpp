#include "jobs/lights_job.h"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <optional>
#include <sstream>

#include "core/error.h"
#include "core/file.h"
#include "core/hash.h"
#include "core/image.h"
#include "eval/plot.h"
#include "geometry/mesh.h"
#include "jobs/light_positions.h"
#include "light/environment.h"
#include "light/lights_file.h"
#include "probe/light_extraction.h"
#include "scene/frames.h"

namespace mr {

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
      throw UsageError(fmt::format("--counts: \"{}\" is not a positive integer", item));
    }
  }
  return out;
}

// An earlier run's lights file for this frame, when its key matches (and
// its residual map exists) and every light has an mr-lights name: nullopt
// otherwise.
std::optional<Json> KeptLights(const std::string& out, const std::string& residual, const std::string& key) {
  std::error_code ec;
  if (!fs::is_regular_file(out, ec) || (!residual.empty() && !fs::is_regular_file(residual, ec))) return std::nullopt;
  try {
    Json j = ReadJsonFile(out);
    ParseLights(j, out);
    if (j["source"].value("key", "") != key || !j["source"].contains("next_id")) return std::nullopt;
    for (const auto& l : j["lights"])
      if (LightNumber(l.value("name", "")) < 0) return std::nullopt;
    return j;
  } catch (const std::exception&) {
    return std::nullopt;  // unreadable: made again
  }
}

// What one map's lights miss of its irradiance: without and with the
// residual's spherical harmonics.
struct LightsError {
  IrradianceError lights, with_residual;
};

LightsError ErrorOf(const Extraction& ex, const std::vector<Eigen::Vector3d>& dirs, const std::vector<double>& ref) {
  return {CompareIrradiance(LightsIrradiance(ex, dirs, false), ref),
          CompareIrradiance(LightsIrradiance(ex, dirs, true), ref)};
}

class LightsJob {
 public:
  LightsJob(const LightsJobOptions& o, Report* report) : o_(o), report_(report), dirs_(SphereNormals(o.normals)) {}
  void OverTime();
  void Sweep(const Image& env, const std::vector<double>& ref);
  void Once(const Image& env, const std::vector<double>& ref);
  const std::vector<Eigen::Vector3d>& dirs() const { return dirs_; }

 private:
  LightsError WriteLights(const Image& env, const std::string& map_file, const std::string& out_file,
                          const std::string& res_file, const std::string& room_file, Extraction* ex,
                          const std::vector<double>& ref, const std::vector<int>* ids,
                          const Json& source_extra = Json::object());
  Image SplitRoomAndSky(bool keeps_room_map, Extraction* ex);
  void WriteMap(const std::string& file, const Image& map, bool make_dirs);
  std::vector<Light> Positioned(const Image& env, Extraction* ex, std::vector<Light> lights);
  std::vector<bool> dropped_;    // the last map's lights Positioned put back into the residual
  double positioned_share_ = 0;  // of the last map's lights' energy, placed in the room
  std::optional<Mesh> room_;
  const LightsJobOptions& o_;
  Report* report_;
  const std::vector<Eigen::Vector3d> dirs_;
};

// One map's lights (named by `ids` when given; over time the patterns'
// folders are made), checked as mr-render reads them before anything is
// written, and its residual map.  With --room, *ex loses the wide lights
// that go back into the residual.
// With --room: the lights that land on the room, placed there (the report
// says what became of each).
// A wide light that could not be placed (a window, the sky: its rays leave
// the room) goes back into the residual map, which keeps its shape, instead
// of becoming a disc at infinity.
std::vector<Light> LightsJob::Positioned(const Image& env, Extraction* ex, std::vector<Light> lights) {
  dropped_.assign(lights.size(), false);
  if (o_.room.empty()) return lights;
  if (!room_) {
    ScopedTimer t(report_, "read room");
    room_ = ReadMesh(o_.room);
    report_->AddInput(o_.room);
  }
  PositionOptions po;
  po.probe_centre = Eigen::Vector3d(o_.probe_at[0], o_.probe_at[1], o_.probe_at[2]);
  po.mirror_tolerance_deg = o_.mirror_tolerance_deg;
  PositionReport pr;
  {
    ScopedTimer t(report_, "position");
    lights = PositionLights(env, *ex, lights, *room_, po, &pr);
  }
  std::vector<bool> drop(lights.size(), false);
  std::vector<Light> kept;
  int returned = 0;
  for (size_t i : pr.reflections) drop[i] = true;
  for (size_t i = 0; i < lights.size(); ++i) {
    if (drop[i]) {
      ++returned;
      continue;
    }
    drop[i] = lights[i].type == LightType::kDistant && ex->lights[i].DiscSolidAngle() > o_.extract.max_blob_sr;
    if (!drop[i]) {
      kept.push_back(lights[i]);
      continue;
    }
    ++returned;
    pr.notes.push_back(
        fmt::format("{}: wider than --max-blob-sr and not in the room (a window, the sky): left in the "
                    "map with its shape",
                    lights[i].name));
  }
  if (returned > 0) ReturnToResidual(env, drop, o_.extract.sh_order, ex);
  // A placed lamp's glow (its blob outside its rectangle) takes the
  // radiance around it in the room's map (PositionReport::fills).
  int64_t filled = 0;
  for (size_t i = 0; i < pr.fills.size(); ++i)
    for (const auto& [p, rgb] : pr.fills[i]) {
      const int x = static_cast<int>(p % static_cast<size_t>(env.width())),
                y = static_cast<int>(p / static_cast<size_t>(env.width()));
      for (int c = 0; c < 3; ++c) ex->residual.at(x, y, c) = rgb[c];
      ++filled;
    }
  dropped_ = drop;
  positioned_share_ = pr.positioned_share;
  lights = std::move(kept);
  for (const std::string& n : pr.notes) spdlog::info("{}", n);
  const int reflections = static_cast<int>(pr.reflections.size());
  report_->SetMetric("positioned", {{"lights", pr.positioned},
                                    {"distant", pr.distant - (returned - reflections)},
                                    {"reflections", reflections},
                                    {"left_in_the_map", returned},
                                    {"positioned_share", pr.positioned_share},
                                    {"glow_pixels_filled", filled},
                                    {"distant_share", pr.distant_share},
                                    {"notes", pr.notes}});
  spdlog::info(
      "{} light(s) placed in the room ({:.0f}% of the lights' energy), {} left at infinity, {} left in the map "
      "({} of them reflections of another)",
      pr.positioned, 100 * pr.positioned_share, pr.distant - (returned - reflections), returned, reflections);
  return lights;
}

// With --room: the residual (lights taken out) is what the probe saw of the
// room, written whole to --room-map for lighting.probes, and the residual
// keeps only the directions that leave the room (SkyOnly).  The report
// says how the map's light was shared: placed lights, the room, infinity.
// Returns the room's map (the residual before); empty without --room.
Image LightsJob::SplitRoomAndSky(bool keeps_room_map, Extraction* ex) {
  if (o_.room.empty()) return Image();
  Image room_map = ex->residual;
  SkyReport sr;
  Image sky;
  {
    ScopedTimer t(report_, "sky");
    sky = SkyOnly(ex->residual, *room_, Eigen::Vector3d(o_.probe_at[0], o_.probe_at[1], o_.probe_at[2]), &sr);
  }
  ReplaceResidual(sky, o_.extract.sh_order, ex);
  const double rest = 1 - std::clamp(ex->taken_fraction, 0.0, 1.0);
  const double placed = std::clamp(ex->taken_fraction, 0.0, 1.0) * positioned_share_;
  report_->SetMetric("light_model", {{"placed", placed},
                                     {"room", rest * sr.room_share},
                                     {"infinity", std::max(0.0, 1 - placed - rest * sr.room_share)},
                                     {"room_pixels", sr.room_pixels}});
  spdlog::info(
      "of the map's light: {:.0f}% placed lights, {:.0f}% the room's own (seen from the probe{}), {:.0f}% at "
      "infinity",
      100 * placed, 100 * rest * sr.room_share, keeps_room_map ? "" : "; no --room-map keeps it",
      100 * std::max(0.0, 1 - placed - rest * sr.room_share));
  return room_map;
}

void LightsJob::WriteMap(const std::string& file, const Image& map, bool make_dirs) {
  ImageWriteOptions wo;
  wo.tool = "mr-lights";
  wo.command_line = o_.command_line;
  wo.attributes["textureformat"] = "LatLong Environment";
  std::error_code ec;
  if (make_dirs && !fs::path(file).parent_path().empty()) fs::create_directories(fs::path(file).parent_path(), ec);
  WriteImage(file, map, wo);
  report_->AddOutput(file);
}

LightsError LightsJob::WriteLights(const Image& env, const std::string& map_file, const std::string& out_file,
                                   const std::string& res_file, const std::string& room_file, Extraction* exp,
                                   const std::vector<double>& ref, const std::vector<int>* ids,
                                   const Json& source_extra) {
  const bool make_dirs = ids != nullptr;
  std::vector<Light> lights = Positioned(env, exp, ToLights(*exp, "light", ids));
  const Image room_map = SplitRoomAndSky(!room_file.empty(), exp);
  const Extraction& ex = *exp;
  const LightsError e = ErrorOf(ex, dirs_, ref);
  Json j = LightsToJson(lights, "mr-lights: " + o_.command_line);
  j["source"] = {{"method", o_.extract.method}, {"count", o_.extract.count}, {"map", map_file}};
  for (auto& [k, v] : source_extra.items()) j["source"][k] = v;
  Json sh = Json::array();
  for (const auto& c : ex.residual_sh) sh.push_back({c.x(), c.y(), c.z()});
  j["residual"] = {
      {"taken_fraction", std::clamp(ex.taken_fraction, 0.0, 1.0)}, {"sh_order", o_.extract.sh_order}, {"sh", sh}};
  if (!res_file.empty())
    j["residual"]["map"] = fs::relative(fs::absolute(res_file), fs::absolute(out_file).parent_path()).generic_string();
  ParseLights(j, out_file);  // what mr-render will read; checked before anything is written
  if (!res_file.empty()) WriteMap(res_file, DownsampleEnergy(ex.residual, o_.residual_width), make_dirs);
  if (!room_file.empty()) WriteMap(room_file, room_map, make_dirs);
  std::error_code ec;
  if (make_dirs && !fs::path(out_file).parent_path().empty())
    fs::create_directories(fs::path(out_file).parent_path(), ec);
  WriteTextFile(out_file, j.dump(2) + "\n");
  report_->AddOutput(out_file);
  return e;
}

// A map per frame.  Each frame's key chains the options and every map up to
// it (a light's name depends on the frames before): a re-run keeps the
// files whose key matches and redoes the rest.
void LightsJob::OverTime() {
  ExtractOptions eo = o_.extract;
  eo.keep_wide = !o_.room.empty();
  Json frames = Json::array();
  std::vector<ExtractedLight> prev;
  std::vector<int> prev_ids;
  int next_id = 0, f = 0, kept = 0;
  // With --room the residual is the sky alone ("sky").
  const std::string options =
      fmt::format("{} {} {} {} {} {} {} {} {} {} {} {}{}", eo.method, eo.count, eo.threshold, eo.saddle, eo.max_blob_sr,
                  eo.sh_order, eo.seed, o_.residual_width, o_.match_deg, o_.residual.empty(), o_.room,
                  fmt::join(o_.probe_at, ","), o_.room.empty() ? "" : " sky");
  uint64_t key = HashCombine(0x6c6967687473ULL, HashString(options));
  for (;; ++f) {
    const std::string map_file = FramePath(o_.env, f).string();
    if (!fs::exists(map_file)) break;
    key = HashCombine(key, ContentHash(map_file));
    const std::string key_hex = fmt::format("{:016x}", key);
    const std::string out_file = FramePath(o_.out, f).string();
    const std::string res_file = o_.residual.empty() ? "" : FramePath(o_.residual, f).string();
    const std::string room_file = o_.room_map.empty() ? "" : FramePath(o_.room_map, f).string();
    std::optional<Json> done = KeptLights(out_file, res_file, key_hex);
    if (done && !room_file.empty() && !fs::is_regular_file(room_file)) done.reset();
    if (done) {
      // Up to date: its lights carry the identities on.
      prev.clear();
      prev_ids.clear();
      for (const Light& l : ParseLights(*done, out_file)) {
        ExtractedLight e;
        e.direction = l.direction;
        prev.push_back(e);
        prev_ids.push_back(LightNumber(l.name));
      }
      next_id = (*done)["source"]["next_id"].get<int>();
      report_->AddInput(map_file);
      report_->AddOutput(out_file);
      frames.push_back({{"frame", f}, {"kept", true}, {"lights", prev.size()}, {"ids", prev_ids}});
      ++kept;
      continue;
    }
    Image env;
    {
      ScopedTimer t(report_, "read");
      env = ReadImage(map_file);
      CheckEnvironmentImage(env, map_file);
    }
    report_->AddInput(map_file);
    Extraction ex;
    {
      ScopedTimer t(report_, "extract");
      ex = ExtractLights(env, eo);
    }
    int matched = 0;
    const std::vector<int> ids = MatchLights(prev, prev_ids, ex.lights, o_.match_deg, &next_id, &matched);
    std::vector<double> ref;
    {
      ScopedTimer t(report_, "reference irradiance");
      ref = MapIrradiance(env, dirs_);
    }
    const LightsError e = WriteLights(env, map_file, out_file, res_file, room_file, &ex, ref, &ids,
                                      Json{{"key", key_hex}, {"next_id", next_id}});
    std::vector<int> kept_ids;  // of the lights written (a window left in the map is not)
    for (size_t i = 0; i < ids.size(); ++i)
      if (!dropped_[i]) kept_ids.push_back(ids[i]);
    frames.push_back({{"frame", f},
                      {"lights", ex.lights.size()},
                      {"kept_identity", matched},
                      {"new", static_cast<int>(ex.lights.size()) - matched},
                      {"gone", static_cast<int>(prev.size()) - matched},
                      {"ids", kept_ids},
                      {"taken_fraction", ex.taken_fraction},
                      {"irradiance_rms_relative", e.lights.rms_relative},
                      {"irradiance_rms_relative_with_residual_sh", e.with_residual.rms_relative}});
    prev = ex.lights;
    prev_ids = kept_ids;
  }
  if (f == 0) ThrowErrorAt(FileLoc{FramePath(o_.env, 0).string()}, "no such file");
  if (kept > 0)
    report_->Skip("extraction", fmt::format("{} of {} frames: their lights files are up to date (same maps and "
                                            "options, as their keys say)",
                                            kept, f));
  report_->SetMetric("frames_kept", kept);
  report_->SetMetric("method", eo.method);
  report_->SetMetric("frames", frames);
  report_->SetMetric("identities", next_id);
  spdlog::info("{} maps: {} light identities", f, next_id);
}

// Every method at every count: the CSV table (also on stdout) and the plot.
void LightsJob::Sweep(const Image& env, const std::vector<double>& ref) {
  const std::vector<int> counts = ParseCounts(o_.counts);
  std::string csv =
      "method,count,lights,seconds,irradiance_rms,irradiance_max,irradiance_rms_with_residual,taken_fraction\n";
  std::vector<PlotSeries> series;
  Json rows = Json::array();
  for (const std::string& m : o_.methods) {
    ExtractOptions o = o_.extract;
    o.method = m;
    PlotSeries s{m, {}};
    for (int n : counts) {
      o.count = n;
      ScopedTimer t(report_, "sweep");
      const Extraction ex = ExtractLights(env, o);
      const LightsError e = ErrorOf(ex, dirs_, ref);
      csv += fmt::format("{},{},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", m, n, ex.lights.size(), ex.seconds,
                         e.lights.rms_relative, e.lights.max_relative, e.with_residual.rms_relative, ex.taken_fraction);
      rows.push_back({{"method", m},
                      {"count", n},
                      {"lights", ex.lights.size()},
                      {"seconds", ex.seconds},
                      {"irradiance_rms", e.lights.rms_relative},
                      {"irradiance_max", e.lights.max_relative},
                      {"irradiance_rms_with_residual", e.with_residual.rms_relative},
                      {"taken_fraction", ex.taken_fraction}});
      s.points.push_back({static_cast<double>(n), std::max(e.lights.rms_relative, 1e-9)});
    }
    series.push_back(s);
  }
  report_->SetMetric("sweep", rows);
  if (!o_.table.empty()) {
    WriteTextFile(o_.table, csv);
    report_->AddOutput(o_.table);
  }
  if (!o_.plot.empty()) {
    PlotOptions po;
    po.title = "Diffuse irradiance error against the number of lights: " + fs::path(o_.env).filename().string();
    po.x_label = "lights";
    po.y_label = "relative RMS error of irradiance over all normals";
    WriteSvgPlot(o_.plot, series, po);
    report_->AddOutput(o_.plot);
  }
  std::fputs(csv.c_str(), stdout);
}

// One map: its lights, residual and error.
void LightsJob::Once(const Image& env, const std::vector<double>& ref) {
  ExtractOptions eo = o_.extract;
  eo.keep_wide = !o_.room.empty();  // a panel or a window is placed in the room, not left in the map
  Extraction ex;
  {
    ScopedTimer t(report_, "extract");
    ex = ExtractLights(env, eo);
  }
  const LightsError e = WriteLights(env, o_.env, o_.out, o_.residual, o_.room_map, &ex, ref, nullptr);
  if (!o_.residual.empty() && ex.taken_fraction > 1 - 1e-12)
    report_->Skip("residual energy", "the lights took all of the map's energy (" + eo.method +
                                         "): the residual map is black and its SH zero");
  if (o_.residual.empty() && ex.taken_fraction < 1 - 1e-9)
    report_->Warn(
        fmt::format("the lights leave {:.1f}% of the map's energy out and no --residual keeps it (lights.json "
                    "holds its spherical harmonics)",
                    100 * (1 - ex.taken_fraction)));
  const size_t n_lights = ex.lights.size();
  report_->SetMetric("method", eo.method);
  report_->SetMetric("lights", n_lights);
  report_->SetMetric("extraction_seconds", ex.seconds);
  report_->SetMetric("taken_fraction", ex.taken_fraction);
  report_->SetMetric("irradiance_error", {{"rms_relative", e.lights.rms_relative},
                                          {"max_relative", e.lights.max_relative},
                                          {"rms_relative_with_residual_sh", e.with_residual.rms_relative},
                                          {"normals", o_.normals}});
  {
    Json bounds = Json::array();
    const std::vector<Light> named = ToLights(ex);
    for (size_t i = 0; i < named.size(); ++i)
      if (!named[i].strength_note.empty()) {
        bounds.push_back({{"light", named[i].name}, {"clipped_share", ex.lights[i].clipped_share}});
        report_->Warn(fmt::format("{}: {} (at {:.1f}, {:.1f}, {:.1f}): its strength is {}", o_.env, named[i].name,
                                  ex.lights[i].direction.x(), ex.lights[i].direction.y(), ex.lights[i].direction.z(),
                                  named[i].strength_note));
      }
    if (!bounds.empty()) report_->SetMetric("lower_bounds", bounds);
  }
  if (eo.method == "blobs") {
    report_->SetMetric("split_components", ex.split_components);
    report_->SetMetric("wide_regions", ex.wide_regions);
    if (ex.wide_regions > 0)
      spdlog::info("{} region(s) wider than --max-blob-sr {:g} sr left in the map with their shape (windows, panels)",
                   ex.wide_regions, eo.max_blob_sr);
    if (MapEnergy(env) <= 0)
      report_->Warn(fmt::format("{}: the map holds no light (every pixel is black): no lights", o_.env));
    else if (n_lights == 0 && ex.wide_regions > 0)
      report_->Warn(
          fmt::format("{}: its {} bright region(s) are wider than --max-blob-sr {:g} sr (windows, sky, "
                      "panels): they stay in the map with their shape, and no lights are written",
                      o_.env, ex.wide_regions, eo.max_blob_sr));
    else if (n_lights == 0)
      report_->Warn(
          fmt::format("{}: no region brighter than --threshold {:g} x the map's mean radiance: no lights "
                      "(a lower threshold finds dimmer ones)",
                      o_.env, eo.threshold));
    else
      spdlog::info(
          "{} light(s), at most {} asked for: the map has {} regions brighter than --threshold {:g} x its "
          "mean radiance{}{}",
          n_lights, eo.count, ex.regions, eo.threshold,
          ex.regions > static_cast<int>(n_lights) ? " (the dimmer ones stay in the residual)" : "",
          ex.split_components > 0
              ? fmt::format(", {} of them split where the light between two peaks falls below --saddle {:g}",
                            ex.split_components, eo.saddle)
              : std::string());
  } else if (static_cast<int>(n_lights) < eo.count) {
    report_->Warn(fmt::format("{} lights asked for, {} found: the map holds fewer distinct sources for method {}",
                              eo.count, n_lights, eo.method));
  }
  spdlog::info(
      "{}: {} lights ({}) in {:.3f} s take {:.1f}% of the energy; irradiance error {:.3g} (RMS), {:.3g} "
      "with the residual's SH",
      o_.env, n_lights, eo.method, ex.seconds, 100 * ex.taken_fraction, e.lights.rms_relative,
      e.with_residual.rms_relative);
}

}  // namespace

int LightNumber(const std::string& name) {
  if (name.size() <= 5 || name.size() > 14 || name.compare(0, 5, "light") != 0) return -1;
  int n = 0;
  for (size_t i = 5; i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9') return -1;
    n = 10 * n + (name[i] - '0');
  }
  return n;
}

void LightsJobOptions::Check() const {
  if (!sweep && out.empty()) throw UsageError("give --out lights.json (or --sweep)");
  if (sweep && table.empty() && plot.empty()) throw UsageError("--sweep needs --table or --plot");
  if (residual_width < 8 || residual_width % 2) throw UsageError("--residual-width must be even and at least 8");
  if (normals < 1) throw UsageError("--normals must be at least 1");
  if (match_deg < 0) throw UsageError("--match-deg must be 0 or more");
  extract.Check();
  if (!room.empty() && probe_at.size() != 3) throw UsageError("--room needs --probe-at X,Y,Z (the probe's centre)");
  if (!probe_at.empty() && room.empty()) throw UsageError("--probe-at needs --room MESH");
  if (!room.empty() && extract.method != "blobs") throw UsageError("--room places blobs' lights: give --method blobs");
  if (!room_map.empty() && room.empty()) throw UsageError("--room-map needs --room MESH and --probe-at");
  if (sweep) (void)ParseCounts(counts);
  if (over_time()) {
    if (sweep) throw UsageError("--sweep takes one map, not a pattern");
    if (out.find('%') == std::string::npos || (!residual.empty() && residual.find('%') == std::string::npos) ||
        (!room_map.empty() && room_map.find('%') == std::string::npos))
      throw UsageError("a pattern of maps needs patterns for --out, --residual and --room-map (lights/%05d.json)");
  }
}

void RunLights(const LightsJobOptions& o, Report* report) {
  o.Check();
  LightsJob job(o, report);
  if (o.over_time()) {
    job.OverTime();
    return;
  }
  if (!fs::exists(o.env)) ThrowErrorAt(FileLoc{o.env}, "no such file");
  Image env;
  {
    ScopedTimer t(report, "read");
    env = ReadImage(o.env);
    CheckEnvironmentImage(env, o.env);
  }
  report->AddInput(o.env);
  std::vector<double> ref;
  {
    ScopedTimer t(report, "reference irradiance");
    ref = MapIrradiance(env, job.dirs());
  }
  if (o.sweep) {
    job.Sweep(env, ref);
  } else {
    job.Once(env, ref);
  }
}

}  // namespace mr
