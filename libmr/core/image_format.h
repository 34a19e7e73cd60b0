// The format of an image file by its first bytes, among those mr reads.
#pragma once

#include <string>

#include "core/file.h"

namespace mr {

// The formats mr reads: OpenEXR, Radiance HDR, PNG, JPEG, TIFF and PFM,
// told by their first bytes (a file's name does not choose its reader).
// Returns OpenImageIO's name of its reader ("openexr", "hdr", "png",
// "jpeg", "tiff", "pnm"); throws mr::Error naming the file for any other
// file, before a decoder sees it.  OpenImageIO alone would try every reader
// it has on a file its name's reader refuses (JPEG 2000, WebP, DICOM, ...:
// more decoders exposed to bad bytes, and a thread pool started per file).
std::string ImageFormatOf(const fs::path& path);

}  // namespace mr
