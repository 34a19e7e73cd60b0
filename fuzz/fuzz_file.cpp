// Fuzzes one reader of untrusted files, chosen at build time by
// MR_FUZZ_KIND: the bytes are written to a file with the reader's extension
// and read; every input must give a result or an mr::Error, never a crash, a
// hang or unbounded memory (libFuzzer's -rss_limit_mb and -timeout).
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "calib/board.h"
#include "calib/probe_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/video.h"
#include "hdr/exposures_file.h"
#include "light/environment.h"
#include "pipeline/pipeline.h"
#include "recon/rgbd.h"
#include "transfer/formfactor.h"

namespace {

#define MR_STR2(x) #x
#define MR_STR(x) MR_STR2(x)
const std::string kKind = MR_STR(MR_FUZZ_KIND);

std::string Extension() {
  if (kKind == "ffc") return ".ffc";
  if (kKind == "exr") return ".exr";
  if (kKind == "hdrenv") return ".hdr";
  if (kKind == "depth") return ".png";
  if (kKind == "video") return ".mkv";  // FFmpeg probes the bytes, whatever the name says
  if (kKind == "exposures") return ".txt";
  return ".json";  // probe, pipeline, board
}

// Images are capped at 4M pixels and 16M values here, not at ReadImage's
// 2^28 pixels: a 1134-byte WebP may truly hold 14114x984 pixels, whose
// decode took 13 s under the sanitizers (a libFuzzer timeout), and a PIZ
// file of 2 KB could truly hold 4M pixels of a hundred channels (1.6 GB,
// past libFuzzer's memory limit): slowness and size, not defects.  The
// header is read (and checked) either way.  The production caps are tested by
// Image.ExrHeaderClaimingMoreThanTheFileHoldsIsRefused.
constexpr int64_t kMaxPixels = int64_t{1} << 22, kMaxValues = int64_t{1} << 24;

void Read(const std::string& path) {
  if (kKind == "ffc") {
    mr::ReadTransfer(path);
  } else if (kKind == "probe") {
    mr::ReadProbe(path);
  } else if (kKind == "pipeline") {
    mr::PlanPipeline(path);
  } else if (kKind == "board") {
    mr::ReadBoard(path);
  } else if (kKind == "exposures") {
    mr::ReadExposures(path, {"a.png", "b.png", "c.png"});
  } else if (kKind == "exr") {
    mr::ImageReadOptions o;
    o.nonfinite = mr::NonFinite::kAllow;
    o.max_pixels = kMaxPixels;
    o.max_values = kMaxValues;
    const mr::Image img = mr::ReadImage(path, o);
    for (const std::string& l : img.LayerNames()) img.Layer(l);
  } else if (kKind == "hdrenv") {
    mr::ImageReadOptions o;
    o.max_pixels = kMaxPixels;
    o.max_values = kMaxValues;
    mr::EnvironmentMap env(mr::ReadImage(path, o), path);
  } else if (kKind == "depth") {
    mr::ReadDepth(path, mr::DepthReadOptions(), 0, 0);
  } else if (kKind == "video") {
    // As a video plate is read (scene/frames.cpp): the size, the count the
    // container claims, then frames in order and one going back (a reopen).
    mr::VideoReader video(path);
    (void)video.width();
    (void)video.height();
    const int n = std::min(video.frame_count(), 3);
    for (int i = 0; i < n; ++i) video.Frame(i);
    if (n > 1) video.Frame(0);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = "/tmp/mr-fuzz-" + std::to_string(getpid()) + "-" + kKind + Extension();
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    Read(path);
  } catch (const mr::Error&) {
  } catch (const mr::UsageError&) {
  }
  return 0;
}
