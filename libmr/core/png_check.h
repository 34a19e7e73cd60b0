// A structural check of PNG files before libpng reads them.
#pragma once

#include "core/file.h"

namespace mr {

// For a file that starts with the PNG signature: walks its chunks and throws
// mr::Error naming the file when a chunk's declared length runs past the end
// of the file (a truncated or corrupt PNG), before libpng sees it: libpng
// allocates and clears a chunk's declared length first (a 358-byte file
// claiming a 2 GB text chunk took 10 s in OpenCV's and OpenImageIO's
// readers; found by fuzz/fuzz_depth).  Other files pass unchecked.
void CheckPngChunks(const fs::path& path);

}  // namespace mr
