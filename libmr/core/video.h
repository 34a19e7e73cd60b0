// Video files through OpenCV's videoio (FFmpeg backend), kept out of public
// headers.  Frames are 8-bit sRGB on disk and linear float RGB in memory.
#pragma once

#include <memory>

#include "core/file.h"
#include "core/image.h"

namespace mr {

// Whether `path` names a video by its extension (.mp4, .avi, .mkv, .mov,
// .m4v, .webm; any case): where a key takes an image or a video.
bool IsVideoFile(const fs::path& path);

class VideoReader {
 public:
  explicit VideoReader(const fs::path& path);
  ~VideoReader();
  int width() const;
  int height() const;
  int frame_count() const;  // as the container reports it (may be approximate; 0: unknown)
  double fps() const;
  // Frame `index` (0-based), decoded as sRGB.  Sequential access is fastest;
  // going backwards reopens the file.  Throws mr::Error past the end.
  Image Frame(int index);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Writes frames to a temporary file beside `path` and renames it on Close():
// an interrupted run leaves no half-written video.  By extension: .mp4
// (MPEG-4 part 2, lossy), .avi (MJPG, lossy) or .mkv (FFV1: lossless, every
// code value kept).
class VideoWriter {
 public:
  VideoWriter(const fs::path& path, int width, int height, double fps);
  ~VideoWriter();
  void Write(const Image& linear_rgb);  // encoded as sRGB 8-bit, clamped to [0,1]
  void WriteCodes(const Image& codes);  // code values in [0,1] as they are: round(255 v)
  void Close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mr
