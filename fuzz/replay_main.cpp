// A main() for the fuzz targets in ordinary builds (GCC or clang, with or
// without sanitizers): `fuzz_replay TARGET FILE|FOLDER...` feeds each file
// of the given files and folders to the target once, in name order (the
// targets are fuzz/'s harnesses, linked together with their entry points
// renamed: replay_targets.h), so that every corpus input,
// and above all every input a fuzzer once found a defect with, stays a
// regression test of the suite (and of its AddressSanitizer/UBSan build).
// A crash, a sanitizer report or a hang (CTest's TIMEOUT) fails the test; so
// does an empty corpus, which would otherwise pass without checking anything.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "replay_targets.h"

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  const ReplayTarget* target = nullptr;
  for (const ReplayTarget& t : kReplayTargets)
    if (argc > 1 && std::strcmp(argv[1], t.name) == 0) target = &t;
  if (!target) {
    std::fprintf(stderr, "usage: %s TARGET FILE|FOLDER...: no target \"%s\"\n", argv[0], argc > 1 ? argv[1] : "");
    return 2;
  }
  std::vector<fs::path> inputs;
  for (int i = 2; i < argc; ++i) {
    const fs::path arg = argv[i];
    if (fs::is_directory(arg)) {
      for (const fs::directory_entry& e : fs::directory_iterator(arg))
        if (e.is_regular_file()) inputs.push_back(e.path());
    } else {
      inputs.push_back(arg);
    }
  }
  std::sort(inputs.begin(), inputs.end());
  if (inputs.empty()) {
    std::fprintf(stderr, "usage: %s TARGET FILE|FOLDER...: no inputs found\n", argv[0]);
    return 2;
  }
  for (const fs::path& p : inputs) {
    std::ifstream in(p, std::ios::binary);
    if (!in) {
      std::fprintf(stderr, "%s: cannot read\n", p.c_str());
      return 2;
    }
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    target->run(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("%s: %zu inputs replayed\n", target->name, inputs.size());
  return 0;
}
