// Running another program (the mr tools from mr-pipeline, colmap from
// mr-register) with its stdout and stderr into a log file.
#pragma once

#include <string>
#include <vector>

#include "core/file.h"

namespace mr {

// Exit status RunProcess returns when the time limit ended the program (as
// timeout(1) does).
inline constexpr int kProcessTimedOut = 124;

// Runs argv[0] (searched on PATH) with argv, its output (stdout and stderr)
// written to `log` (appended or truncated); returns its exit status: 127 when
// it cannot be started, 128 + N when signal N ends it, kProcessTimedOut when
// it ran past `timeout_s` (> 0): it is then sent SIGTERM, and SIGKILL 5 s
// later if it has not ended.
int RunProcess(const std::vector<std::string>& argv, const fs::path& log, bool append = false, double timeout_s = 0);

// "exit 3", "killed by signal 11 (Segmentation fault)", "timed out" or
// "not found" for a RunProcess status.
std::string DescribeExitStatus(int status);

}  // namespace mr
