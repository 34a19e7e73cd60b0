// A structural check of OpenEXR files before OpenEXR reads them.
#pragma once

#include <cstdint>

#include "core/file.h"

namespace mr {

// The most pixels and values (pixels x channels) OpenEXR's buffers span on
// reading a part: its data window padded to whole chunks (a scanline chunk's
// lines are allocated however few the image has).
struct ExrBuffers {
  int64_t pixels = 0, values = 0;
  int64_t width = 0, height = 0, channels = 0;  // the part's data window and channels
};

// For a file that starts with the OpenEXR magic number: reads its (first
// part's) header and throws mr::Error naming the file when the header runs
// past the end of the file, or when the pixels it claims cannot fit in the
// file: every chunk (a block of scanlines or a tile) takes an 8-byte entry
// of the offset table and an 8-byte chunk header, and where the
// compression's ratio is bounded (none 1, RLE 64: a run of 128 bytes in 2;
// the deflate-based ZIP and ZIPS about 1032, PXR24 4/3 of that; B44 and
// B44A 32/3; PIZ and DWA bounded far above what they reach on a constant
// image: docs/formats.md) at least the pixels' bytes over that ratio.
// OpenEXR allocates its offset table and line buffers from the header on
// opening (645 bytes claiming 2^28 pixels took 1.9 GB and a second; found
// by fuzz/fuzz_exr).  Returns the buffers' extent, for the caller's limits
// (zero for other files).  Deep files are not checked past their header;
// other files pass unchecked.
ExrBuffers CheckExrHeader(const fs::path& path);

}  // namespace mr
