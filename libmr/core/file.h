// Files: atomic writes and whole-file reads with clear errors.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

namespace mr {

namespace fs = std::filesystem;

// Writes `path` atomically: `write` receives a temporary path in the same
// folder (with the same extension, so extension-driven writers work), and on
// success the temporary replaces `path` by rename.  If `write` throws, the
// temporary is removed and `path` is untouched: no half-written output.
void WriteAtomically(const fs::path& path, const std::function<void(const fs::path& tmp)>& write);

// Atomic write of a whole string.
void WriteTextFile(const fs::path& path, const std::string& text);

// Reads a whole file; throws mr::Error naming the file when it cannot.
std::string ReadTextFile(const fs::path& path);

// Throws mr::Error naming the file when it does not exist or is not a
// regular file.  `what` says what the file is for ("camera model").
void RequireFile(const fs::path& path, const std::string& what = "");

// Lower-case extension with the dot (".exr"); empty when none.
std::string LowerExtension(const fs::path& path);

}  // namespace mr
