#include "core/video.h"

#include <limits>
#include <opencv2/videoio.hpp>

#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <cctype>
#include <limits>
#include <string>

#include "core/error.h"
#include "core/math.h"
#include "core/stderr_capture.h"

namespace mr {

bool IsVideoFile(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* v : {".mp4", ".avi", ".mkv", ".mov", ".m4v", ".webm"})
    if (ext == v) return true;
  return false;
}

struct VideoReader::Impl {
  fs::path path;
  cv::VideoCapture cap;
  int next = 0;
  void Open() {
    cap.release();
    StderrCapture ffmpeg_lines;  // FFmpeg prints why before mr's message could
    if (!cap.open(path.string(), cv::CAP_FFMPEG)) {
      const std::string why = ffmpeg_lines.Take();
      ThrowErrorAt(FileLoc{path.string()}, "cannot open video (not a video file, or a codec FFmpeg lacks){}",
                   why.empty() ? "" : ": FFmpeg says: " + why);
    }
    next = 0;
  }
};

VideoReader::VideoReader(const fs::path& path) : impl_(std::make_unique<Impl>()) {
  RequireFile(path, "video");
  impl_->path = path;
  impl_->Open();
  // The container's claim, checked before a frame is decoded into floats
  // (12 bytes a pixel): 2^26 pixels is twice 8K UHD.
  const double pixels = std::max(0.0, impl_->cap.get(cv::CAP_PROP_FRAME_WIDTH)) *
                        std::max(0.0, impl_->cap.get(cv::CAP_PROP_FRAME_HEIGHT));
  if (pixels > double(1 << 26))
    ThrowErrorAt(FileLoc{path.string()}, "the video claims {} x {} pixels a frame (at most 2^26 are read)",
                 impl_->cap.get(cv::CAP_PROP_FRAME_WIDTH), impl_->cap.get(cv::CAP_PROP_FRAME_HEIGHT));
}
VideoReader::~VideoReader() = default;

namespace {
// A container property as a count: a damaged file can claim NaN, a negative
// number or -2^63 (0 then: unknown), or more than an int holds.
int CountProperty(double v) {
  if (!(v > 0)) return 0;
  return v >= double(std::numeric_limits<int>::max()) ? std::numeric_limits<int>::max() : static_cast<int>(v);
}
}  // namespace

int VideoReader::width() const { return CountProperty(impl_->cap.get(cv::CAP_PROP_FRAME_WIDTH)); }
int VideoReader::height() const { return CountProperty(impl_->cap.get(cv::CAP_PROP_FRAME_HEIGHT)); }
int VideoReader::frame_count() const { return CountProperty(impl_->cap.get(cv::CAP_PROP_FRAME_COUNT)); }
double VideoReader::fps() const { return impl_->cap.get(cv::CAP_PROP_FPS); }

Image VideoReader::Frame(int index) {
  if (index < 0) ThrowErrorAt(FileLoc{impl_->path.string()}, "negative frame index {}", index);
  if (index < impl_->next) impl_->Open();
  cv::Mat m;
  while (impl_->next <= index) {
    if (!impl_->cap.read(m) || m.empty())
      ThrowErrorAt(FileLoc{impl_->path.string()}, "the video has no frame {} (it ends after {} frames)", index,
                   impl_->next);
    ++impl_->next;
  }
  if (m.total() > (size_t{1} << 26))  // a stream may change its size after the header
    ThrowErrorAt(FileLoc{impl_->path.string()}, "frame {} has {} x {} pixels (at most 2^26 are read)", index, m.cols,
                 m.rows);
  if (m.type() != CV_8UC3)
    ThrowErrorAt(FileLoc{impl_->path.string()}, "unsupported pixel format (expected 8-bit colour)");
  Image img = Image::Rgb(m.cols, m.rows);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) {
      const cv::Vec3b& p = m.at<cv::Vec3b>(y, x);  // OpenCV order: B, G, R
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = SrgbToLinear(p[2 - c] / 255.0f);
    }
  return img;
}

struct VideoWriter::Impl {
  fs::path path, tmp;
  cv::VideoWriter writer;
  int width = 0, height = 0;
  int64_t frames = 0;
  bool closed = false;
};

VideoWriter::VideoWriter(const fs::path& path, int width, int height, double fps) : impl_(std::make_unique<Impl>()) {
  static std::atomic<unsigned> counter{0};
  impl_->path = path;
  impl_->width = width;
  impl_->height = height;
  impl_->tmp = path.parent_path() / TemporaryName(path.filename().string(), counter++);
  const std::string ext = LowerExtension(path);
  int fourcc;
  if (ext == ".mp4")
    fourcc = cv::VideoWriter::fourcc('m', 'p', '4', 'v');
  else if (ext == ".avi")
    fourcc = cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  else if (ext == ".mkv")
    fourcc = cv::VideoWriter::fourcc('F', 'F', 'V', '1');
  else
    ThrowErrorAt(FileLoc{path.string()}, "unsupported video extension \"{}\" (use .mp4, .avi or .mkv)", ext);
  if (!impl_->writer.open(impl_->tmp.string(), cv::CAP_FFMPEG, fourcc, fps, cv::Size(width, height), true))
    ThrowErrorAt(FileLoc{path.string()}, "cannot open a video writer (FFmpeg backend)");
}

VideoWriter::~VideoWriter() {
  if (!impl_->closed) {
    impl_->writer.release();
    std::error_code ec;
    fs::remove(impl_->tmp, ec);  // not closed: an error happened; leave nothing behind
  }
}

void VideoWriter::Write(const Image& img) {
  Image codes = img;
  for (float& v : codes.values()) v = LinearToSrgb(Clamp(std::isfinite(v) ? v : 0.0f, 0.0f, 1.0f));
  WriteCodes(codes);
}

void VideoWriter::WriteCodes(const Image& img) {
  if (img.width() != impl_->width || img.height() != impl_->height || img.channels() < 3)
    ThrowErrorAt(FileLoc{impl_->path.string()}, "frame is {}x{}, the video {}x{}", img.width(), img.height(),
                 impl_->width, impl_->height);
  cv::Mat m(img.height(), img.width(), CV_8UC3);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      cv::Vec3b& p = m.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) {
        float v = img.at(x, y, c);
        if (!std::isfinite(v)) v = 0;
        p[2 - c] = static_cast<uint8_t>(std::lround(Clamp(v, 0.0f, 1.0f) * 255.0f));
      }
    }
  impl_->writer.write(m);
  ++impl_->frames;
}

void VideoWriter::Close() {
  if (impl_->closed) return;
  impl_->writer.release();
  // OpenCV's FFmpeg writer does not report failed writes (a full disk, a
  // file-size limit): read the file back, and refuse one that does not hold
  // every frame written.
  {
    cv::VideoCapture check(impl_->tmp.string(), cv::CAP_FFMPEG);
    const double n = check.isOpened() ? check.get(cv::CAP_PROP_FRAME_COUNT) : -1.0;
    if (!check.isOpened() || std::llround(n) != impl_->frames) {
      std::error_code ignored;
      fs::remove(impl_->tmp, ignored);
      impl_->closed = true;
      ThrowErrorAt(FileLoc{impl_->path.string()},
                   "write failed: the video holds {} of the {} frames written (disk full or a file-size limit?)",
                   check.isOpened() ? std::to_string(std::llround(n)) : std::string("none"), impl_->frames);
    }
  }
  std::error_code ec;
  fs::rename(impl_->tmp, impl_->path, ec);
  if (ec) ThrowErrorAt(FileLoc{impl_->path.string()}, "cannot write: {}", ec.message());
  impl_->closed = true;
}

}  // namespace mr
