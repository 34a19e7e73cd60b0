#include "core/file.h"

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace mr {

namespace {
fs::path TemporaryBeside(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  fs::path dir = path.parent_path();
  std::string name = fmt::format(".mr-tmp-{}-{}-{}", getpid(), counter++, path.stem().string());
  return dir / (name + path.extension().string());
}
}  // namespace

void WriteAtomically(const fs::path& path, const std::function<void(const fs::path& tmp)>& write) {
  if (path.empty()) ThrowError("empty output path");
  fs::path dir = path.parent_path();
  if (!dir.empty() && !fs::is_directory(dir))
    ThrowErrorAt(FileLoc{path.string()}, "cannot write: folder {} does not exist", dir.string());
  fs::path tmp = TemporaryBeside(path);
  try {
    write(tmp);
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) ThrowErrorAt(FileLoc{path.string()}, "cannot write: {}", ec.message());
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

void WriteTextFile(const fs::path& path, const std::string& text) {
  WriteAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) ThrowErrorAt(FileLoc{path.string()}, "cannot open for writing");
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    out.close();
    if (!out) ThrowErrorAt(FileLoc{path.string()}, "write failed (disk full?)");
  });
}

void RequireFile(const fs::path& path, const std::string& what) {
  std::error_code ec;
  auto st = fs::status(path, ec);
  std::string prefix = what.empty() ? "" : what + " ";
  if (ec || !fs::exists(st)) ThrowErrorAt(FileLoc{path.string()}, "{}file does not exist", prefix);
  if (!fs::is_regular_file(st)) ThrowErrorAt(FileLoc{path.string()}, "{}is not a regular file", prefix);
}

std::string ReadTextFile(const fs::path& path) {
  RequireFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowErrorAt(FileLoc{path.string()}, "cannot open for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) ThrowErrorAt(FileLoc{path.string()}, "read failed");
  return ss.str();
}

std::string LowerExtension(const fs::path& path) {
  std::string e = path.extension().string();
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

}  // namespace mr
