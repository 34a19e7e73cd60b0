#include "hdr/exposures_file.h"

#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "core/error.h"

namespace mr {

namespace {

// "0.125", "1/8" or "8" (seconds).
double ParseTime(const std::string& s, const std::string& where) {
  try {
    size_t used = 0;
    const size_t slash = s.find('/');
    double v;
    if (slash != std::string::npos) {
      const double a = std::stod(s.substr(0, slash), &used);
      if (used != slash) throw std::invalid_argument(s);
      const double b = std::stod(s.substr(slash + 1), &used);
      if (used != s.size() - slash - 1) throw std::invalid_argument(s);
      v = a / b;
    } else {
      v = std::stod(s, &used);
      if (used != s.size()) throw std::invalid_argument(s);
    }
    if (!(v > 0) || !std::isfinite(v)) throw std::invalid_argument(s);
    return v;
  } catch (const std::exception&) {
    ThrowErrorAt(FileLoc{where}, "\"{}\" is not a positive exposure time (seconds, or a fraction like 1/8)", s);
  }
}

}  // namespace

std::vector<double> ReadExposures(const std::string& path, const std::vector<std::string>& images) {
  const std::string text = ReadTextFile(path);
  std::istringstream in(text);
  std::string line;
  std::vector<double> ordered;
  std::map<std::string, double> named;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (const size_t h = line.find('#'); h != std::string::npos) line.resize(h);
    std::istringstream ls(line);
    std::vector<std::string> words;
    for (std::string w; ls >> w;) words.push_back(w);
    const std::string where = fmt::format("{}:{}", path, n);
    if (words.empty()) continue;
    if (words.size() == 1)
      ordered.push_back(ParseTime(words[0], where));
    else if (words.size() == 2)
      named[words[0]] = ParseTime(words[1], where);
    else
      ThrowErrorAt(FileLoc{where}, "expected TIME or FILENAME TIME, got {} words", words.size());
  }
  if (!ordered.empty() && !named.empty()) ThrowErrorAt(FileLoc{path}, "mixes TIME lines and FILENAME TIME lines");
  std::vector<double> out;
  if (!ordered.empty()) {
    if (ordered.size() != images.size())
      ThrowErrorAt(FileLoc{path}, "has {} exposure times for {} images", ordered.size(), images.size());
    return ordered;
  }
  for (const std::string& img : images) {
    const std::string f = fs::path(img).filename().string();
    auto it = named.find(f);
    if (it == named.end()) ThrowErrorAt(FileLoc{path}, "gives no exposure time for {}", f);
    out.push_back(it->second);
  }
  return out;
}

void WriteExposures(const fs::path& path, const std::vector<std::pair<std::string, double>>& times,
                    const std::string& comment) {
  std::string text = "# " + comment + "\n";
  for (const auto& [name, t] : times) text += fmt::format("{} {}\n", name, t);
  WriteTextFile(path, text);
}

}  // namespace mr
