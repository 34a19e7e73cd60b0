// ChArUco boards through OpenCV's aruco module (kept out of public headers).
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgcodecs.hpp>

#include <map>

#include "calib/board.h"
#include "core/error.h"

namespace mr {

namespace {

cv::Ptr<cv::aruco::Dictionary> Dictionary(const std::string& name) {
  static const std::map<std::string, cv::aruco::PREDEFINED_DICTIONARY_NAME> kNames = {
      {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
      {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
      {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
      {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
      {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
      {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
      {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
      {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
      {"DICT_6X6_50", cv::aruco::DICT_6X6_50},
      {"DICT_6X6_100", cv::aruco::DICT_6X6_100},
      {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
      {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
      {"DICT_7X7_50", cv::aruco::DICT_7X7_50},
      {"DICT_7X7_100", cv::aruco::DICT_7X7_100},
      {"DICT_7X7_250", cv::aruco::DICT_7X7_250},
      {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
      {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL}};
  auto it = kNames.find(name);
  if (it == kNames.end()) ThrowError("unknown ArUco dictionary \"{}\"", name);
  return cv::aruco::getPredefinedDictionary(it->second);
}

cv::Ptr<cv::aruco::CharucoBoard> MakeBoard(const BoardSpec& b) {
  if (b.type != "charuco") ThrowError("board \"{}\" is not a ChArUco board", b.name);
  auto dict = Dictionary(b.dictionary);
  const int markers = (b.squares_x() * b.squares_y()) / 2;
  if (markers > dict->bytesList.rows)
    ThrowError("board \"{}\" needs {} markers, but {} has only {}", b.name, markers, b.dictionary,
               dict->bytesList.rows);
  return cv::aruco::CharucoBoard::create(b.squares_x(), b.squares_y(), static_cast<float>(b.square_m),
                                         static_cast<float>(b.marker_m), dict);
}

}  // namespace

Image CharucoImage(const BoardSpec& b, double pixels_per_mm) {
  auto board = MakeBoard(b);
  const int w = static_cast<int>(std::lround(b.squares_x() * b.square_m * 1000.0 * pixels_per_mm));
  const int h = static_cast<int>(std::lround(b.squares_y() * b.square_m * 1000.0 * pixels_per_mm));
  if (w < b.squares_x() * 8 || h < b.squares_y() * 8 || static_cast<int64_t>(w) * h > (int64_t{1} << 28))
    ThrowError("board \"{}\": {} pixels/mm gives a {}x{} image; choose a resolution with 8 to ~16000 pixels per side",
               b.name, pixels_per_mm, w, h);
  cv::Mat img;
  board->draw(cv::Size(w, h), img, 0, 1);
  Image out = Image::Gray(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) out.at(x, y, 0) = img.at<uint8_t>(y, x) / 255.0f;
  return out;
}

std::string EncodePng8(const Image& gray) {
  cv::Mat m(gray.height(), gray.width(), CV_8U);
  for (int y = 0; y < gray.height(); ++y)
    for (int x = 0; x < gray.width(); ++x)
      m.at<uint8_t>(y, x) = static_cast<uint8_t>(std::lround(std::clamp(gray.at(x, y, 0), 0.0f, 1.0f) * 255.0f));
  std::vector<uint8_t> buf;
  if (!cv::imencode(".png", m, buf)) ThrowError("cannot encode a PNG");
  return std::string(buf.begin(), buf.end());
}

CharucoDetection DetectCharuco(const BoardSpec& b, const Image& gray) {
  auto board = MakeBoard(b);
  cv::Mat m(gray.height(), gray.width(), CV_8U);
  for (int y = 0; y < gray.height(); ++y)
    for (int x = 0; x < gray.width(); ++x)
      m.at<uint8_t>(y, x) = static_cast<uint8_t>(std::lround(std::clamp(gray.at(x, y, 0), 0.0f, 1.0f) * 255.0f));
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(m, board->dictionary, marker_corners, marker_ids);
  CharucoDetection d;
  d.markers = static_cast<int>(marker_ids.size());
  if (marker_ids.empty()) return d;
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, m, board, corners, ids);
  for (size_t i = 0; i < ids.size(); ++i) {
    d.ids.push_back(ids[i]);
    d.corners.emplace_back(corners[i].x, corners[i].y);
  }
  return d;
}

}  // namespace mr
