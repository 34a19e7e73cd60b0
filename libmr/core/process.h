// Running another program (the mr tools from mr-pipeline, colmap from
// mr-register) with its stdout and stderr into a log file.
#pragma once

#include <string>
#include <vector>

#include "core/file.h"

namespace mr {

// Runs argv[0] (searched on PATH) with argv, its output (stdout and stderr)
// written to `log` (appended or truncated); returns its exit status: 127 when
// it cannot be started, 128 + N when signal N ends it.
int RunProcess(const std::vector<std::string>& argv, const fs::path& log, bool append = false);

}  // namespace mr
