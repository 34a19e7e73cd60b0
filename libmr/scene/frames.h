// Where a scene's frames are: frame paths from printf patterns and the
// camera poses the scene names (docs/formats.md, scene.json "camera").
#pragma once

#include <string>
#include <vector>

#include "camera/pose.h"
#include "core/file.h"
#include "scene/scene.h"

namespace mr {

// Frame `i` of a printf-style pattern ("frames/%05d.exr"), or the path itself
// when it has no conversion.
fs::path FramePath(const fs::path& pattern, int i);

// The 8/16-bit image files of a video's frames (for tools that read images,
// as COLMAP does): a folder's images (PNG, JPEG, TIFF) in name order, a printf
// pattern's frames (0, 1, ... while they exist; EXR/HDR refused), or a video
// file's frames written as PNG into workspace/frames.
std::vector<fs::path> ListFrameFiles(const std::string& frames, const fs::path& workspace);

// A frame range: "A:B" is [A, B), "A:" from A to the end (*end = -1), "A"
// frame A alone.  False when malformed or empty, with the message in *why
// ("\"5:2\": the range is empty").
bool ParseFrameRange(const std::string& text, int* begin, int* end, std::string* why = nullptr);

// The camera poses (world_from_cam) of the scene's frames; one identity pose
// when the scene names none.
std::vector<Rigid3> LoadScenePoses(const Scene& scene);

}  // namespace mr
