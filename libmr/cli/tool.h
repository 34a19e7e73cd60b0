// Conventions shared by every mr tool (docs/tools.md):
//  - one strict CLI11 parser: unknown flags and unparsable numbers are errors;
//  - --help prints the synopsis, a worked example, units and defaults, exit 0;
//  - errors are caught once, in RunTool, and printed as
//    "mr-TOOL: error: FILE: what is wrong";
//  - exit codes: 0 success, 1 failure (bad data), 2 usage error.
#pragma once

#include <functional>
#include <string>
#include <string_view>

#include <CLI/CLI.hpp>

#include "core/report.h"

namespace mr {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitUsage = 2;

// Number checks for options, with messages a person reads ("--spp 0: must be
// greater than 0"), unlike CLI11's, which print DBL_MAX in 309 digits.
extern const CLI::Validator kPositive;         // > 0
extern const CLI::Validator kNonNegative;      // >= 0
CLI::Validator InRange(double lo, double hi);  // lo <= x <= hi

// `s` with control bytes and bytes that are not well-formed UTF-8 written as
// \xNN, so that a message quoting a corrupt file never sends binary to a
// terminal; newlines, tabs and UTF-8 file names pass unchanged.
std::string PrintableMessage(std::string_view s);

// The command line as one shell-quoted string (for provenance).
std::string JoinCommandLine(int argc, char** argv);

// Sets up `app` with mr's conventions: description with an example, the
// common flags (--threads, --quiet, -v, --version).
void ConfigureApp(CLI::App& app, const std::string& tool, const std::string& description, const std::string& example);

// The run's report (docs/formats.md): the tool body adds inputs, outputs,
// timings, skipped parts, warnings and metrics; RunTool fills in the tool,
// version and command line, times the whole run ("total"), and writes it to
// --report FILE when the body returns (not when it throws: no report of a
// failed run is left behind).
Report& ToolReport();

// Parses argv with `app`, then runs `body`; maps exceptions to messages and
// exit codes.  `body` returns the exit code.
int RunTool(const std::string& tool, CLI::App& app, int argc, char** argv, const std::function<int()>& body);

}  // namespace mr
