// Where a scene's frames are: frame paths from printf patterns and the
// camera poses the scene names (docs/formats.md, scene.json "camera").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "camera/pose.h"
#include "core/file.h"
#include "scene/scene.h"

namespace mr {

// Frame `i` of a printf-style pattern ("frames/%05d.exr"), or the path itself
// when it has no conversion.
fs::path FramePath(const fs::path& pattern, int i);

// The file of per-frame pattern `pattern` for frame `f`: frame f's own, or
// else the latest earlier frame's that exists (a frame without its own light
// reuses the last one); *from receives the frame it belongs to.  nullopt
// when no frame from 0 to f has one.  A path without a conversion is itself.
std::optional<fs::path> PerFrameFile(const fs::path& pattern, int f, int* from);

// The 8/16-bit image files of a video's frames (for tools that read images,
// as COLMAP does): a folder's images (PNG, JPEG, TIFF) in name order, a printf
// pattern's frames (0, 1, ... while they exist; EXR/HDR refused), or a video
// file's frames written as PNG into workspace/frames.
std::vector<fs::path> ListFrameFiles(const std::string& frames, const fs::path& workspace);

// A frame range: "A:B" is [A, B), "A:" from A to the end (*end = -1), "A"
// frame A alone.  False when malformed or empty, with the message in *why
// ("\"5:2\": the range is empty").
bool ParseFrameRange(const std::string& text, int* begin, int* end, std::string* why = nullptr);

// The camera poses (world_from_cam) of the scene's frames, by the one
// convention every tool follows (docs/conventions.md, "A camera model's
// extrinsics"): the model's extrinsics are cam_from_ref; without
// camera.poses the reference is the world, one frame at
// world_from_cam = ref_from_cam; with poses of the camera they are used as
// they are (the extrinsics unused); with poses of the rig each is
// world_from_ref and world_from_cam = world_from_ref * ref_from_cam.
std::vector<Rigid3> LoadScenePoses(const Scene& scene);
// Which of the three it was, in words, for reports.
std::string ScenePoseSource(const Scene& scene);

// The largest camera mr renders: 1e8 pixels (a 12K cinema frame is 8e7).  A
// larger imager size is a corrupt or mistaken camera model, refused before
// any buffer is allocated.
inline constexpr int64_t kMaxCameraPixels = 100'000'000;

// What CheckSceneInputs found.
struct SceneInputCheck {
  int poses = 0;
  int frames = -1;                    // frames the scene's camera.frames holds; -1 when it names none
  std::vector<std::string> warnings;  // frames and poses that differ in number
};

// Checks a scene's inputs before any frame is rendered, so that a bad one
// fails at once instead of mid-render with earlier frames written: the
// camera's size (at most kMaxCameraPixels); every frame of camera.frames
// (pattern) and of the reference pattern in [begin, end) exists and has the
// camera's size; a video holds a frame for every pose in [begin, end).
// `end` < 0 means every pose.  Throws mr::Error naming the first bad file;
// more frames than poses, or a range cut by the poses, are warnings.
SceneInputCheck CheckSceneInputs(const Scene& scene, int camera_width, int camera_height, int begin = 0, int end = -1);

}  // namespace mr
