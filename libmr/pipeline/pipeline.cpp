#include "pipeline/pipeline.h"
#include "core/check.h"

#include <unistd.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/hash.h"
#include "core/json_node.h"
#include "core/process.h"
#include "core/version.h"
#include "core/video.h"
#include "geometry/mesh.h"
#include "render/method.h"
#include "scene/frames.h"
#include "scene/scene.h"

namespace mr {

namespace {

// A content hash (ContentHash, core/file.h) as the stage files write it.
std::string Hex(uint64_t v) { return fmt::format("{:016x}", v); }

}  // namespace

// Planning is in plan.cpp: a table of stages, one plan function each.

namespace {

fs::path ToolPath(const std::string& tool, const fs::path& bin_dir) {
  if (!bin_dir.empty()) return bin_dir / tool;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec && fs::exists(self.parent_path() / tool)) return self.parent_path() / tool;
  return tool;  // PATH
}

// The tool's own error lines from its log (the last few).
std::string ErrorLines(const fs::path& log) {
  std::ifstream in(log);
  std::vector<std::string> lines, errors;
  for (std::string l; std::getline(in, l);) {
    lines.push_back(l);
    if (l.find("error") != std::string::npos) errors.push_back(l);
  }
  const auto& pick = errors.empty() ? lines : errors;
  std::string out;
  for (size_t i = pick.size() > 3 ? pick.size() - 3 : 0; i < pick.size(); ++i) {
    if (!out.empty()) out += "\n  ";
    out += pick[i];
  }
  return out;
}

std::string Quote(const std::string& s) {
  if (s.find_first_of(" \t'\"$\\*?") == std::string::npos && !s.empty()) return s;
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// What the radiometry stage (mr-eval plate: the room alone through the
// plate's poses) reads of the scene: all but the virtual objects, the
// outputs, the reference and the render settings other than the seed, so
// that its up-to-date key does not change when only an object moves.
Json PlateScene(const Json& scene) {
  Json plate = scene;
  for (const char* k : {"virtual", "output", "reference"}) plate.erase(k);
  Json render = Json::object();
  if (scene.contains("render") && scene["render"].contains("seed")) render["seed"] = scene["render"]["seed"];
  plate["render"] = render;
  plate["comment"] = "written by mr-pipeline: scene.json as the radiometry stage reads it (no virtual objects)";
  return plate;
}

// The scene stage: scene.json, with the fused room's own albedo (its
// vertex colours, mr-fuse's de-lit albedo) for every render method.
void WriteSceneJson(const Pipeline& p) {
  Json scene = p.scene;
  if (!p.fused_room.empty()) {
    Json& r = scene["real"][0];
    const Mesh m = ReadMesh(p.fused_room);
    if (m.colors.size() != m.positions.size())
      ThrowErrorAt(FileLoc{p.fused_room.string()}, "the fused room has no vertex colours (albedo)");
    r["material"]["albedo_from_vertex_colors"] = true;
  }
  CheckRenderSettings(ParseScene(scene, p.work, (p.work / "scene.json").string(), true));
  const Json plate = PlateScene(scene);
  // The refined poses do not exist yet (the radiometry stage makes them).
  if (!p.refined_poses.empty()) scene["camera"]["poses"] = {{"format", "tum"}, {"path", p.refined_poses}};
  WriteTextFile(p.work / "scene.json", scene.dump(2) + "\n");
  WriteTextFile(p.work / "scene-plate.json", plate.dump(2) + "\n");
}

}  // namespace

namespace {

// The work folder's .mr-pipeline, reports and logs, and no temporaries a
// killed run left.
void PrepareWorkFolder(const Pipeline& p, Report* report) {
  std::error_code ec;
  fs::create_directories(p.work / ".mr-pipeline", ec);
  fs::create_directories(p.work / "reports", ec);
  fs::create_directories(p.work / "logs", ec);
  if (!fs::is_directory(p.work / "logs"))
    ThrowErrorAt(FileLoc{p.work.string()}, "cannot create the work folder{}", ec ? ": " + ec.message() : "");
  // A stage killed before it could clean up (SIGKILL, power loss) leaves
  // temporaries beside its outputs; its outputs themselves are whole (every
  // write is atomic) and the stage is not recorded as done, so it runs again.
  int stale = 0;
  for (auto it = fs::recursive_directory_iterator(p.work, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_directory()) stale += RemoveStaleTemporaries(it->path());
  stale += RemoveStaleTemporaries(p.work);
  if (stale > 0)
    report->Warn(fmt::format("removed {} temporary files that killed runs left in {}", stale, p.work.string()));
}

// The stage's up-to-date key: mr's version, the stage, the tool's bytes and
// arguments (or the scene mr-pipeline writes), its inputs' names and
// contents; *inputs_ready is false when an input does not exist yet.
std::string StageKey(const Pipeline& p, const PipelineStage& s, const std::vector<std::string>& argv,
                     bool* inputs_ready) {
  std::error_code ec;
  Hasher key;
  key.String(kVersion);
  key.String(s.name);
  *inputs_ready = true;
  if (!s.tool.empty()) {
    const fs::path tool = argv[0];
    if (fs::exists(tool, ec)) HashFile(tool, &key);
    for (const auto& a : s.args) key.String(a);
    if (!s.writes_first.empty()) key.String(s.writes_first_json.dump());
  } else {
    key.String(p.scene.dump());
  }
  for (const auto& in : s.inputs) {
    key.String(in.string());
    if (fs::exists(in, ec))
      key.Word(ContentHash(in));
    else
      *inputs_ready = false;
  }
  return Hex(key.Final());
}

// Why the stage must run ("" when it is up to date): --force, inputs an
// earlier stage makes or re-makes, no record of a run, a changed key, an
// output missing or changed since.
std::string WhyRun(const PipelineStage& s, const fs::path& stamp, const std::string& key_hex, bool forced,
                   bool inputs_ready, const std::string& upstream) {
  std::error_code ec;
  std::string why_run;
  Json old;
  if (fs::exists(stamp, ec)) {
    try {
      old = Json::parse(ReadTextFile(stamp));
    } catch (const std::exception&) {
      old = Json();
    }
  }
  if (forced) {
    why_run = "--force";
  } else if (!inputs_ready || !upstream.empty()) {
    why_run = upstream.empty() ? "inputs are made by an earlier stage" : "an input is re-made: " + upstream;
  } else if (!old.is_object()) {
    why_run = "not run before";
  } else if (old.value("key", "") != key_hex) {
    why_run = "inputs, options or the tool changed";
  } else {
    for (const auto& out : s.outputs) {
      const std::string k = out.string();
      if (!fs::exists(out, ec)) {
        why_run = "output missing: " + k;
        break;
      }
      if (!old["outputs"].contains(k) || old["outputs"][k] != Hex(ContentHash(out))) {
        why_run = "output changed since: " + k;
        break;
      }
    }
  }
  return why_run;
}

// Runs the stage (or writes the scene), checks it wrote its outputs, and
// records them in its stamp; `sj` gets its time, why it ran and its report.
// `stages` (the finished ones) goes into the report when it fails.
double RunStage(const Pipeline& p, const PipelineStage& s, const std::vector<std::string>& argv, const std::string& cmd,
                const std::string& key_hex, const std::string& why_run, const fs::path& stamp, const Json& stages,
                Json* sj_out, Report* report) {
  Json& sj = *sj_out;
  MR_CHECK(s.tool.empty() ? !s.outputs.empty() : !argv.empty());  // the scene it writes, or a command line
  std::error_code ec;
  const auto t0 = std::chrono::steady_clock::now();
  const fs::path log = p.work / "logs" / (s.name + ".log");
  fs::remove(stamp, ec);
  if (s.tool.empty()) {
    WriteSceneJson(p);
  } else {
    if (!s.writes_first.empty()) WriteTextFile(s.writes_first, s.writes_first_json.dump(2) + "\n");
    const int rc = RunProcess(argv, log);
    if (rc != 0) {
      report->SetMetric("stages", stages);
      throw Error(FileLoc{p.file.string(), 0, 0, s.name},
                  fmt::format("stage {} failed ({} {}):\n  {}\n  full log: {}; finished stages' outputs are kept",
                              s.name, s.tool, rc < 127 ? fmt::format("exited with {}", rc) : DescribeExitStatus(rc),
                              ErrorLines(log), log.string()));
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  report->AddTiming(s.name, seconds);
  sj["seconds"] = seconds;
  sj["why_run"] = why_run;
  if (fs::exists(s.report, ec)) {
    sj["report"] = Json::parse(ReadTextFile(s.report));
    for (const auto& w : sj["report"]["warnings"]) report->Warn(s.name + ": " + w.get<std::string>());
  }
  Json stamp_json = {{"key", key_hex}, {"command", cmd}, {"outputs", Json::object()}};
  for (const auto& out : s.outputs) {
    if (!fs::exists(out, ec))
      throw Error(FileLoc{p.file.string(), 0, 0, s.name},
                  fmt::format("stage {} finished but did not write {}", s.name, out.string()));
    stamp_json["outputs"][out.string()] = Hex(ContentHash(out));
    report->AddOutput(out.string());
  }
  WriteTextFile(stamp, stamp_json.dump(2) + "\n");
  return seconds;
}

}  // namespace

void PipelineRunOptions::Check() const {
  const auto& names = PipelineStageNames();
  auto known = [&](const std::string& s, const char* flag) {
    if (std::find(names.begin(), names.end(), s) == names.end())
      throw UsageError(fmt::format("{} {}: no such stage (stages: {})", flag, s, fmt::join(names, ", ")));
  };
  if (!until.empty()) known(until, "--until");
  for (const auto& f : force) known(f, "--force");
  if (threads < 0) throw UsageError(fmt::format("--threads {} must not be negative", threads));
}

void RunPipeline(const Pipeline& p, const PipelineRunOptions& o, Report* report) {
  o.Check();
  report->AddInput(p.file.string());
  std::error_code ec;
  if (!o.dry_run) PrepareWorkFolder(p, report);
  Json stages = Json::array();
  std::set<std::string> remade;  // outputs of stages that run (or would) in this invocation
  bool past_until = false;
  int ran = 0, current = 0, skipped = 0;
  for (const PipelineStage& s : p.stages) {
    ++current;
    Json sj = {{"stage", s.name}, {"tool", s.tool.empty() ? "mr-pipeline" : s.tool}};
    auto finish = [&](const std::string& status, const std::string& why) {
      sj["status"] = status;
      if (!why.empty()) sj["why"] = why;
      stages.push_back(sj);
      if (o.dry_run)
        std::printf("%-11s %-11s %s\n", s.name.c_str(), status.c_str(), why.c_str());
      else if (!o.quiet)
        spdlog::info("[{}/{}] {}: {}{}", current, p.stages.size(), s.name, status, why.empty() ? "" : " (" + why + ")");
    };
    // --until STAGE holds even when STAGE itself is left out.
    const bool after_until = past_until;
    if (s.name == o.until) past_until = true;
    if (!s.skip.empty()) {
      report->Skip(s.name, s.skip);
      ++skipped;
      finish("skipped", s.skip);
      continue;
    }
    if (after_until) {
      const std::string why = fmt::format("after --until {}", o.until);
      report->Skip(s.name, why);
      finish("skipped", why);
      continue;
    }
    std::vector<std::string> argv;
    if (!s.tool.empty()) {
      argv.push_back(ToolPath(s.tool, o.bin_dir).string());
      argv.insert(argv.end(), s.args.begin(), s.args.end());
      argv.insert(argv.end(), {"--report", s.report.string()});
      if (o.threads > 0) argv.insert(argv.end(), {"--threads", std::to_string(o.threads)});
    }
    std::string cmd;
    for (const auto& a : argv) {
      if (!cmd.empty()) cmd += ' ';
      cmd += Quote(a);
    }
    sj["command"] = s.tool.empty() ? "(mr-pipeline writes " + s.outputs.front().string() + ")" : cmd;
    sj["does"] = s.does;
    // Up to date?
    const bool forced = std::find(o.force.begin(), o.force.end(), s.name) != o.force.end();
    // An input an earlier stage re-makes: a dry run cannot know its new
    // content, so the stage would run; a real run has made it by now, and
    // the key (by content) decides (moving an object re-makes scene.json
    // and scene-plate.json, whose content the radiometry stage reads is the
    // same).
    std::string upstream;
    if (o.dry_run)
      for (const auto& in : s.inputs)
        if (remade.count(in.string())) upstream = in.string();
    const fs::path stamp = p.work / ".mr-pipeline" / (s.name + ".json");
    bool inputs_ready = true;
    const std::string key_hex = StageKey(p, s, argv, &inputs_ready);
    const std::string why_run = WhyRun(s, stamp, key_hex, forced, inputs_ready, upstream);
    if (why_run.empty()) {
      if (fs::exists(s.report, ec)) {
        try {
          sj["report"] = Json::parse(ReadTextFile(s.report));
        } catch (const std::exception&) {
        }
      }
      finish("up to date", "");
      continue;
    }
    for (const auto& out : s.outputs) remade.insert(out.string());
    if (o.dry_run) {
      finish("would run", why_run);
      std::printf("%-23s %s\n", "", s.tool.empty() ? s.does.c_str() : cmd.c_str());
      continue;
    }
    if (!o.quiet) spdlog::info("[{}/{}] {}: running ({}): {}", current, p.stages.size(), s.name, why_run, s.does);
    const double seconds = RunStage(p, s, argv, cmd, key_hex, why_run, stamp, stages, &sj, report);
    ++ran;
    finish("ran", fmt::format("{:.1f} s", seconds));
  }
  report->SetMetric("stages", stages);
  report->SetMetric("ran", ran);
  report->SetMetric("left_out", skipped);
  report->SetMetric("work", p.work.string());
}

}  // namespace mr
