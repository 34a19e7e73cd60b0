#include "core/report.h"

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/version.h"

namespace mr {

Report::Report(std::string tool, std::string command_line)
    : tool_(std::move(tool)), command_line_(std::move(command_line)) {}

void Report::AddTiming(const std::string& part, double seconds) {
  double prev = timings_.contains(part) ? timings_[part].get<double>() : 0.0;
  timings_[part] = prev + seconds;
}

void Report::Skip(const std::string& what, const std::string& why) {
  skipped_.push_back({{"what", what}, {"why", why}});
}

void Report::Warn(const std::string& message) {
  spdlog::warn("{}", message);  // said where the user is, not only in the report
  warnings_.push_back(message);
}

void Report::SetMetric(const std::string& dotted_key, const nlohmann::json& value) {
  nlohmann::json* node = &metrics_;
  size_t start = 0;
  for (;;) {
    size_t dot = dotted_key.find('.', start);
    std::string part = dotted_key.substr(start, dot == std::string::npos ? dot : dot - start);
    if (dot == std::string::npos) {
      (*node)[part] = value;
      return;
    }
    node = &(*node)[part];
    start = dot + 1;
  }
}

nlohmann::json Report::ToJson() const {
  return {{"tool", tool_},       {"version", kVersion},   {"command_line", command_line_},
          {"inputs", inputs_},   {"outputs", outputs_},   {"timings", timings_},
          {"skipped", skipped_}, {"warnings", warnings_}, {"metrics", metrics_}};
}

void Report::Write(const fs::path& path) const { WriteTextFile(path, ToJson().dump(2) + "\n"); }

void ValidateReportJson(const nlohmann::json& j, const std::string& file) {
  auto fail = [&](const std::string& key, const std::string& what) { throw Error(FileLoc{file, 0, 0, key}, what); };
  if (!j.is_object()) fail("", "a report must be a JSON object");
  static const char* kStrings[] = {"tool", "version", "command_line"};
  for (const char* k : kStrings)
    if (!j.contains(k) || !j[k].is_string()) fail(k, "missing or not a string");
  for (const char* k : {"inputs", "outputs", "warnings", "skipped"})
    if (!j.contains(k) || !j[k].is_array()) fail(k, "missing or not an array");
  for (const char* k : {"timings", "metrics"})
    if (!j.contains(k) || !j[k].is_object()) fail(k, "missing or not an object");
  for (auto& [k, v] : j["timings"].items())
    if (!v.is_number() || v.get<double>() < 0) fail("timings." + k, "expected seconds >= 0");
  for (size_t i = 0; i < j["skipped"].size(); ++i) {
    const auto& s = j["skipped"][i];
    if (!s.is_object() || !s.contains("what") || !s.contains("why"))
      fail(fmt::format("skipped[{}]", i), "expected {what, why}");
  }
  for (auto& [k, v] : j.items())
    if (!(k == "tool" || k == "version" || k == "command_line" || k == "inputs" || k == "outputs" || k == "timings" ||
          k == "skipped" || k == "warnings" || k == "metrics"))
      fail(k, "unknown key");
}

}  // namespace mr
