// exposures.txt: the exposure times of a bracket (docs/formats.md): one time
// per line in the order the images are given, or "FILENAME TIME" lines;
// times in seconds or as fractions ("1/8"); '#' starts a comment.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/file.h"

namespace mr {

// The times of `images` (matched by file name for FILENAME TIME lines).
// Errors name the file and line.
std::vector<double> ReadExposures(const std::string& path, const std::vector<std::string>& images);

// FILENAME TIME lines, after a comment line.  Atomic.
void WriteExposures(const fs::path& path, const std::vector<std::pair<std::string, double>>& times,
                    const std::string& comment);

}  // namespace mr
