// Files: atomic writes and whole-file reads with clear errors.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

namespace mr {

namespace fs = std::filesystem;

// Writes `path` atomically: `write` receives a temporary path in the same
// folder (with the same extension, so extension-driven writers work), and on
// success the temporary replaces `path` by rename.  If `write` throws, the
// temporary is removed and `path` is untouched: no half-written output.
void WriteAtomically(const fs::path& path, const std::function<void(const fs::path& tmp)>& write);

// The name of a temporary file for an output whose name (without extension)
// is `stem`: ".mr-tmp-PID@HOST@COUNTER-STEM", so that RemoveStaleTemporaries
// can tell whose it is.
std::string TemporaryName(const std::string& stem, unsigned counter);

// Removes the temporaries that runs killed before they could clean up
// (SIGKILL, power loss) left in `dir`: those of this host whose process no
// longer exists.  Returns how many were removed.  A running process's, and
// another host's (a render farm writing to a shared folder), are left alone.
int RemoveStaleTemporaries(const fs::path& dir);

// Atomic write of a whole string (text or bytes).
void WriteTextFile(const fs::path& path, std::string_view text);

// A file open for writing whose every write is checked: a short write, a
// full disk (ENOSPC), a file-size limit (EFBIG; RunTool ignores SIGXFSZ so
// that the limit arrives as this error) or a failed close throws mr::Error
// naming `name` (the final path, not the temporary) with the system's reason.
class OutputFile {
 public:
  OutputFile(const fs::path& path, const std::string& name);
  ~OutputFile();  // closes unchecked: only reached without Close() after an error
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;
  void Write(const void* data, size_t bytes);
  void WriteAt(uint64_t offset, const void* data, size_t bytes);  // pwrite
  void Close();

 private:
  [[noreturn]] void Fail(const char* what);
  int fd_ = -1;
  std::string name_;
};

// Reads a whole file; throws mr::Error naming the file when it cannot.
std::string ReadTextFile(const fs::path& path);

// Throws mr::Error naming the file when it does not exist or is not a
// regular file.  `what` says what the file is for ("camera model").
void RequireFile(const fs::path& path, const std::string& what = "");

// Lower-case extension with the dot (".exr"); empty when none.
std::string LowerExtension(const fs::path& path);

// A 64-bit content hash of a file, or of a folder's files (names and
// contents, in sorted order): FNV-1a over 8-byte words with a final
// avalanche (splitmix64), fast enough for gigabytes of recordings, and any
// changed byte changes the hash.  For change detection, not security;
// throws mr::Error naming a file it cannot read.
uint64_t ContentHash(const fs::path& path);
struct Hasher;
// Adds a file's bytes and length to `h` (ContentHash's per-file step).
void HashFile(const fs::path& path, Hasher* h);

}  // namespace mr
