#include "core/file.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <sstream>
#include <vector>

#include "core/check.h"
#include "core/error.h"
#include "core/hash.h"

namespace mr {

namespace {
std::string HostName() {
  char host[256] = {0};
  if (gethostname(host, sizeof(host) - 1) != 0 || host[0] == '\0') return "host";
  std::string h = host;
  for (char& c : h)
    if (c == '@' || c == '/') c = '_';
  return h;
}

fs::path TemporaryBeside(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  fs::path dir = path.parent_path();
  return dir / (TemporaryName(path.stem().string(), counter++) + path.extension().string());
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

std::string TemporaryName(const std::string& stem, unsigned counter) {
  static const std::string host = HostName();
  return fmt::format(".mr-tmp-{}@{}@{}-{}", getpid(), host, counter, stem);
}

int RemoveStaleTemporaries(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return 0;
  int removed = 0;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    // ".mr-tmp-PID@HOST@...": only this host's, and only a process's that is gone
    // (another host sharing the folder, a render farm's, may be writing it).
    static const std::string host = HostName();
    const std::string name = e.path().filename().string();
    if (name.rfind(".mr-tmp-", 0) != 0) continue;
    char* end = nullptr;
    const long pid = std::strtol(name.c_str() + 8, &end, 10);
    if (pid <= 0 || pid == getpid() || *end != '@' ||
        name.compare(end + 1 - name.c_str(), host.size() + 1, host + "@") != 0)
      continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to judge)
    std::error_code rm;
    if (fs::remove(e.path(), rm)) ++removed;
  }
  return removed;
}

void WriteTextFile(const fs::path& path, std::string_view text) {
  WriteAtomically(path, [&](const fs::path& tmp) {
    OutputFile out(tmp, path.string());
    out.Write(text.data(), text.size());
    out.Close();
  });
}

OutputFile::OutputFile(const fs::path& path, const std::string& name) : name_(name) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd_ < 0) Fail("cannot open for writing");
}

OutputFile::~OutputFile() {
  if (fd_ >= 0) ::close(fd_);
}

void OutputFile::Fail(const char* what) {
  const int err = errno;
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  ThrowErrorAt(FileLoc{name_}, "{}: {}", what, std::strerror(err));
}

void OutputFile::Write(const void* data, size_t bytes) {
  MR_CHECK(fd_ >= 0);
  const char* p = static_cast<const char*>(data);
  while (bytes > 0) {
    const ssize_t n = ::write(fd_, p, bytes);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = ENOSPC;
      Fail("write failed");
    }
    p += n;
    bytes -= static_cast<size_t>(n);
  }
}

void OutputFile::WriteAt(uint64_t offset, const void* data, size_t bytes) {
  MR_CHECK(fd_ >= 0);
  const char* p = static_cast<const char*>(data);
  while (bytes > 0) {
    const ssize_t n = ::pwrite(fd_, p, bytes, static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = ENOSPC;
      Fail("write failed");
    }
    p += n;
    offset += static_cast<uint64_t>(n);
    bytes -= static_cast<size_t>(n);
  }
}

void OutputFile::Close() {
  MR_CHECK(fd_ >= 0);
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {
    const int err = errno;
    ThrowErrorAt(FileLoc{name_}, "write failed: {}", std::strerror(err));
  }
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

void HashFile(const fs::path& path, Hasher* h) {
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowErrorAt(FileLoc{path.string()}, "cannot read");
  std::vector<char> buf(1 << 16);
  uint64_t total = 0;
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    const auto n = static_cast<size_t>(in.gcount());
    if (n == 0) break;
    h->Bytes(buf.data(), n);
    total += n;
  }
  h->Word(total);
}

uint64_t ContentHash(const fs::path& path) {
  Hasher h;
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    std::vector<fs::path> files;
    for (const auto& e : fs::recursive_directory_iterator(path))
      if (e.is_regular_file()) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const fs::path& f : files) {
      h.String(f.lexically_relative(path).generic_string());
      HashFile(f, &h);
    }
    h.Word(files.size());
  } else {
    HashFile(path, &h);
  }
  return h.Final();
}

}  // namespace mr
