// mr-info's logic: what a file is and whether it is sound.
#pragma once

#include <string>
#include <vector>

#include "core/file.h"
#include "core/json.h"

namespace mr {

struct FileInfo {
  std::string path;
  std::string kind;                // "camera model", "image", "mesh", "scene", "trajectory", "report", ...
  bool sound = true;               // false: the file is unreadable or has bad values
  std::vector<std::string> lines;  // human-readable summary
  std::vector<std::string> problems;
  Json json = Json::object();
};

// Never throws for bad data: problems go into the result (sound = false).
FileInfo DescribeFile(const fs::path& path);

}  // namespace mr
