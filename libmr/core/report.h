// The one JSON report format of every tool (docs/formats.md):
// {tool, version, command_line, inputs, outputs, timings: {part: seconds},
//  skipped: [{what, why}], warnings: [...], metrics: {...}}
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/file.h"

namespace mr {

class Report {
 public:
  Report() = default;
  Report(std::string tool, std::string command_line);

  void AddInput(const std::string& path) { inputs_.push_back(path); }
  void AddOutput(const std::string& path) { outputs_.push_back(path); }
  // Adds to the time spent in `part` (parts repeat across frames).
  void AddTiming(const std::string& part, double seconds);
  void Skip(const std::string& what, const std::string& why);
  // Kept in the report and logged as a warning on stderr.
  void Warn(const std::string& message);
  // metrics["a"]["b"] = v for key "a.b".
  void SetMetric(const std::string& dotted_key, const nlohmann::json& value);

  const std::vector<std::string>& warnings() const { return warnings_; }
  const nlohmann::json& metrics() const { return metrics_; }
  const nlohmann::json& skipped() const { return skipped_; }

  nlohmann::json ToJson() const;
  // Atomic write, 2-space indented.
  void Write(const fs::path& path) const;

 private:
  std::string tool_, command_line_;
  std::vector<std::string> inputs_, outputs_, warnings_;
  nlohmann::json timings_ = nlohmann::json::object();
  nlohmann::json skipped_ = nlohmann::json::array();
  nlohmann::json metrics_ = nlohmann::json::object();
};

// Adds the time from construction to destruction to report->AddTiming(part).
class ScopedTimer {
 public:
  ScopedTimer(Report* report, std::string part)
      : report_(report), part_(std::move(part)), start_(std::chrono::steady_clock::now()) {}
  ~ScopedTimer() {
    if (report_) report_->AddTiming(part_, Seconds());
  }
  double Seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  Report* report_;
  std::string part_;
  std::chrono::steady_clock::time_point start_;
};

// Checks that `j` has the report layout; throws mr::Error naming `file`.
void ValidateReportJson(const nlohmann::json& j, const std::string& file);

}  // namespace mr
