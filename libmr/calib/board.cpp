#include "calib/board.h"

#include <algorithm>
#include <sstream>

#include "core/error.h"

namespace mr {

std::vector<Eigen::Vector3d> BoardSpec::ObjectPoints() const {
  std::vector<Eigen::Vector3d> p;
  p.reserve(static_cast<size_t>(inner_x) * static_cast<size_t>(inner_y));
  for (int y = 0; y < inner_y; ++y)
    for (int x = 0; x < inner_x; ++x) p.emplace_back(x * square_m, y * square_m, 0.0);
  return p;
}

BoardSpec ParseBoard(const Json& j, const std::string& name) {
  auto fail = [&](const std::string& key, const std::string& what) { throw Error(FileLoc{name, 0, 0, key}, what); };
  if (!j.is_object()) fail("", "a board definition must be a JSON object");
  for (auto& [k, v] : j.items())
    if (k != "name" && k != "type" && k != "inner_corners" && k != "square_mm" && k != "marker_mm" &&
        k != "dictionary" && k != "detector" && k != "comment")
      fail(k, "unknown key");
  // The string keys checked before they are read (found by fuzz/fuzz_board:
  // "type": 1 ended the process with nlohmann's type_error).
  for (const char* key : {"name", "type", "detector", "comment"})
    if (j.contains(key) && !j[key].is_string()) fail(key, "expected a string");
  BoardSpec b;
  b.name = j.value("name", name);
  b.type = j.value("type", "chessboard");
  if (b.type != "chessboard" && b.type != "charuco") fail("type", "expected \"chessboard\" or \"charuco\"");
  if (!j.contains("inner_corners") || !j["inner_corners"].is_array() || j["inner_corners"].size() != 2 ||
      !j["inner_corners"][0].is_number_integer() || !j["inner_corners"][1].is_number_integer())
    fail("inner_corners", "expected 2 integers [per row, per column]");
  b.inner_x = j["inner_corners"][0].get<int>();
  b.inner_y = j["inner_corners"][1].get<int>();
  if (b.inner_x < 2 || b.inner_y < 2 || b.inner_x > 1000 || b.inner_y > 1000)
    fail("inner_corners", "expected integers in [2, 1000]");
  if (!j.contains("square_mm") || !j["square_mm"].is_number() || !(j["square_mm"].get<double>() > 0))
    fail("square_mm", "expected a positive number (millimetres)");
  b.square_m = j["square_mm"].get<double>() / 1000.0;
  b.detector = j.value("detector", b.type == "charuco" ? "opencv" : "mrgingham");
  if (b.detector != "mrgingham" && b.detector != "opencv") fail("detector", "expected \"mrgingham\" or \"opencv\"");
  if (b.type == "charuco") {
    if (!j.contains("marker_mm") || !j["marker_mm"].is_number() || !(j["marker_mm"].get<double>() > 0) ||
        j["marker_mm"].get<double>() >= j["square_mm"].get<double>())
      fail("marker_mm", "expected a positive number smaller than square_mm");
    b.marker_m = j["marker_mm"].get<double>() / 1000.0;
    if (!j.contains("dictionary") || !j["dictionary"].is_string())
      fail("dictionary", "expected an ArUco dictionary name");
    b.dictionary = j["dictionary"].get<std::string>();
    if (b.detector != "opencv") fail("detector", "ChArUco boards are detected with OpenCV");
  }
  return b;
}

BoardSpec ReadBoard(const fs::path& path) { return ParseBoard(ReadJsonFile(path), path.string()); }

Json BoardToJson(const BoardSpec& b) {
  Json j = {{"name", b.name},
            {"type", b.type},
            {"inner_corners", {b.inner_x, b.inner_y}},
            {"square_mm", b.square_m * 1000.0},
            {"detector", b.detector}};
  if (b.type == "charuco") {
    j["marker_mm"] = b.marker_m * 1000.0;
    j["dictionary"] = b.dictionary;
  }
  return j;
}

namespace {

std::string Base64(const std::string& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    uint32_t v = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8) | uint8_t(in[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out += k[(v >> s) & 63];
  }
  if (i < in.size()) {
    uint32_t v = uint8_t(in[i]) << 16;
    if (i + 1 < in.size()) v |= uint8_t(in[i + 1]) << 8;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < in.size() ? k[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace

namespace {
constexpr double kCaptionMm = 6.0;  // the line under the board giving its size
}  // namespace

std::pair<double, double> BoardPageMm(const BoardSpec& b, double margin_mm) {
  return {b.squares_x() * b.square_m * 1000 + 2 * margin_mm,
          b.squares_y() * b.square_m * 1000 + 2 * margin_mm + kCaptionMm};
}

std::string SmallestIsoA(double w_mm, double h_mm) {
  const double lo = std::min(w_mm, h_mm), hi = std::max(w_mm, h_mm);
  const std::pair<const char*, std::pair<double, double>> sheets[] = {
      {"A4", {210, 297}}, {"A3", {297, 420}}, {"A2", {420, 594}}, {"A1", {594, 841}}, {"A0", {841, 1189}}};
  for (const auto& [name, size] : sheets)
    if (lo <= size.first + 1e-9 && hi <= size.second + 1e-9) return name;
  return "";
}

std::string BoardSvg(const BoardSpec& b, double margin_m, double charuco_pixels_per_mm) {
  const double sq = b.square_m * 1000.0, margin = margin_m * 1000.0;
  const double bw = b.squares_x() * sq, bh = b.squares_y() * sq;
  const auto [w, h] = BoardPageMm(b, margin);
  std::ostringstream s;
  s.imbue(std::locale::classic());
  s << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "mm\" height=\"" << h << "mm\" viewBox=\"0 0 " << w
    << ' ' << h << "\">\n"
    << "<!-- mr board " << b.name << ": " << b.inner_x << "x" << b.inner_y << " inner corners, " << sq
    << " mm squares. Print at 100% (no scaling). -->\n"
    << "<rect x=\"0\" y=\"0\" width=\"" << w << "\" height=\"" << h << "\" fill=\"white\"/>\n";
  if (b.type == "charuco") {
    const std::string png = EncodePng8(CharucoImage(b, charuco_pixels_per_mm));
    s << "<image x=\"" << margin << "\" y=\"" << margin << "\" width=\"" << bw << "\" height=\"" << bh
      << "\" preserveAspectRatio=\"none\" style=\"image-rendering:pixelated\" href=\"data:image/png;base64,"
      << Base64(png) << "\"/>\n";
  } else {
    s << "<g fill=\"black\">\n";
    for (int y = 0; y < b.squares_y(); ++y)
      for (int x = 0; x < b.squares_x(); ++x)
        if ((x + y) % 2 == 0)
          s << "<rect x=\"" << margin + x * sq << "\" y=\"" << margin + y * sq << "\" width=\"" << sq << "\" height=\""
            << sq << "\"/>\n";
    s << "</g>\n";
  }
  s << "<text x=\"" << margin << "\" y=\"" << h - 2 << "\" font-family=\"sans-serif\" font-size=\"3\">" << b.name
    << ": " << b.inner_x << "x" << b.inner_y << " inner corners, squares " << sq << " mm";
  if (b.type == "charuco") s << ", markers " << b.marker_m * 1000.0 << " mm " << b.dictionary;
  s << "; check: " << bw << " mm across</text>\n</svg>\n";
  return s.str();
}

}  // namespace mr
