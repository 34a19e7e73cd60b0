// mr-render's frame files: the photographs decoded as scene.json's
// camera.frames_transfer says, the composite made in the matching space, and
// the outputs (layered EXR, PNG, video) written as output.* says.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "camera/camera_model.h"
#include "core/color_management.h"
#include "core/image.h"
#include "core/report.h"
#include "core/video.h"
#include "hdr/response.h"
#include "render/composite.h"
#include "render/method.h"
#include "render/radiometry.h"
#include "scene/scene.h"

namespace mr {

// How one photograph was stored, so that the 8/16-bit outputs can be
// encoded back the same way (FrameDecoding::ToCodes).
struct PhotoEncoding {
  // False for float files (EXR, HDR, PFM) and synthetic composites: there are
  // no code values to keep, and the outputs are an sRGB view.
  bool has_codes = false;
  Transfer transfer = Transfer::kSrgb;  // how its integer codes were decoded (the file's tag, else frames_transfer)
  PixelType type = PixelType::kUint8;   // kUint8 or kUint16
};

// How the photographs relate to radiance.
//  - "srgb", "linear": decoded to radiance; the composite is linear.
//  - "display": the camera response is unknown, so the photograph stays in
//    display values and the renders are brought to display space by the tone
//    map TM(L) = sRGB(clamp(exposure L)); the composite is
//    M TM(I_m) + (1 - M)(I_c + TM(I_m) - TM(I_r)), stored back as radiance.
//  - "response": raw codes through the camera's response (mr-hdr), over the
//    frames' exposure time; the composite is linear.
struct FrameDecoding {
  bool photograph = false;     // the scene names camera frames
  bool display_space = false;  // "display"
  bool raw_codes = false;      // "display", "response" or a colour space: files read as code values
  Transfer file_transfer = Transfer::kSrgb;
  std::optional<CameraResponse> response;
  // camera.frames_colorspace: the codes to the working space and back
  // (OpenColorIO), both built before any frame is read.
  std::shared_ptr<const ColorTransform> ocio_decode, ocio_encode;
  double exposure = 1;
  // The render-to-plate gain of the frame (ForFrame), per channel: the plate's
  // linear values P (display: the sRGB-decoded codes; response: through the
  // response over the exposure time; otherwise as decoded) are gain x the
  // render.  camera.gains' value for the frame, else exposure (display) or 1.
  // The outputs' radiance is P / exposure (display) or P: the plate's units.
  Rgb gain{1, 1, 1};
  // The gain of the objects' own pixels (M I_m) and of the plate seen in
  // reflections: `gain` when camera.gains_scale is "render"; with "room"
  // (the plate in the light's units, the gains correcting the room's albedo
  // scale) exposure (display) or 1.
  Rgb object_gain{1, 1, 1};
  bool gains_scale_room = false;
  std::vector<FrameGain> frame_gains;  // camera.gains (mr-eval plate); empty: none
  std::string gains_file;

  // A copy for frame `f`, its gain set; throws mr::Error naming the gains
  // file when it has no entry for `f`.
  FrameDecoding ForFrame(int f) const;
  // Whether ForFrame(f) has a gain (always, without a gains file).
  bool HasGain(int f) const;

  // From the scene; reads the response file (added to the report's inputs)
  // and states the compositing space in the report.
  static FrameDecoding FromScene(const Scene& scene, Report* report);
  // `photo` (as Photo() gives it) as linear radiance in the outputs' units.
  Image ToRadiance(const Image& photo) const;
  // `photo` in the render's units (P / gain): prt's background.
  Image ToRenderUnits(const Image& photo) const;
  // The plate's linear values P (display: sRGB-decoded codes; otherwise
  // ToRadiance): what the radiometric fit compares with the render.
  Image ToPlateLinear(const Image& photo) const;
  // The composite of a rendered frame over `photo` (null: over its own I_r),
  // in the compositing space, returned as radiance.
  CompositeResult Compose(const FrameMethod& frame, const Image* photo) const;
  // A composite (radiance, as Compose gives it) as the code values in [0, 1]
  // of a photograph stored as `enc` says: the exact inverse of the decoding
  // (sRGB or linear codes; display: sRGB and exposure; response: the
  // camera's response and exposure), so that a pixel the composite leaves
  // unchanged gets back the photograph's code value (docs/formats.md).
  // Without codes (float frames, synthetic composites): sRGB(clamp(L)).
  Image ToCodes(const Image& radiance, const PhotoEncoding& enc) const;
  // Code values (as ToCodes gives them) back to radiance: ToCodes' inverse
  // within [0, 1] (grain is added to the codes and brought back this way).
  Image FromCodes(const Image& codes, const PhotoEncoding& enc) const;
  // The colour space ToCodes' values are in, as image files tag it: "sRGB"
  // (display-referred codes: srgb, display, response) or "Linear".
  std::string CodesColorSpace(const PhotoEncoding& enc) const;
};

// Where `composite` is the decoded plate `photo` itself (every channel, bit
// for bit), `codes` takes the plate's own code values `plate_codes`: an
// untouched pixel keeps its code whatever the precision of the decoding's
// inverse (OpenColorIO's float32 log curves are within 2e-5 of it: exact at
// 8 and 10 bits, not always at 16).  Returns the pixels kept.
int64_t KeepPlateCodes(const Image& photo, const Image& composite, const Image& plate_codes, Image* codes);

// Frame `f`'s shutter interval and lens (scene camera.shutter, camera.lens):
// the camera's poses at shutter open and close, between its neighbours'
// poses (the first and last frames blur over the half they have); `moves`
// is false where the camera does not move over the interval.
CameraExposure FrameExposure(const Scene& scene, const std::vector<Rigid3>& poses, int f);

// The scene's photographs, frame by frame: an image sequence or a video.
class FrameReader {
 public:
  FrameReader(const Scene& scene, const CameraModel& camera, const FrameDecoding& decoding);
  ~FrameReader();
  bool is_video() const { return video_ != nullptr; }
  double fps() const;
  // Frame `f` in the compositing space (radiance, or display code values),
  // checked against the camera's size; nullopt when the scene names none.
  // `enc`, when given, receives how the frame was stored.
  // `codes`, when given, receives the file's code values before decoding
  // (as read with raw codes).
  std::optional<Image> Photo(int f, PhotoEncoding* enc = nullptr, Image* codes = nullptr);

 private:
  const Scene& scene_;
  int width_, height_;
  const FrameDecoding& decoding_;
  std::unique_ptr<VideoReader> video_;
};

// A reference (ground-truth) frame, checked against the camera's size.
Image ReadReferenceFrame(const fs::path& path, int width, int height);

// OUT/NNNNN-review.png, what a user looks at first: the plate | the
// composite | the difference the composite made to the plate (code values,
// signed, mid-grey = unchanged, scaled to fill the range with what the
// object does around it: its shadow and bounce light) | the mask, labelled.  The plate
// and composite are code values (ToCodes); without a photograph the plate
// is the rendered room I_r.  Returns its path.
// `note`: added to the composite's caption (the objects' swim against the
// plate).
fs::path WriteReviewSheet(const fs::path& out_dir, int frame, const Image& plate_codes, const Image& composite_codes,
                          const Image& mask, bool photograph, const std::string& tool, Report* report,
                          const std::string& note = "");

// True when frame `frame`'s files (EXR, and PNG when the scene writes it) are
// in `out_dir` and the EXR was written with `provenance` (WriteFrameFiles'
// "mr:render" attribute).  Files are written atomically, so present means
// complete.
bool FrameComplete(const fs::path& out_dir, int frame, const SceneOutput& output, const std::string& provenance);

// Every layer a frame file can hold, in the order they are written.
const std::vector<std::string>& FrameLayerNames();

// What a frame file holds.
struct FrameLayers {
  const Image* composite = nullptr;
  const Image* codes = nullptr;  // the composite as the photograph's code values (ToCodes): the PNG
  const Image *mixed = nullptr, *real = nullptr, *mask = nullptr, *difference = nullptr, *variance = nullptr,
              *samples = nullptr, *photo = nullptr;  // photo: null when the scene names no frames
  const Image* objects = nullptr;                    // M x I_m with alpha M (CompositeResult::objects)
};

// Writes OUT/NNNNN.exr (the layers output.layers names, composite always)
// and, with output.png, OUT/NNNNN.png (layers.codes, of `enc`'s integer
// type, tagged with `color_space`); adds them to the report.
// `provenance` goes into the files' mr:render attribute.
void WriteFrameFiles(const fs::path& out_dir, int frame, const FrameLayers& layers, const PhotoEncoding& enc,
                     const std::string& color_space, const SceneOutput& output, const std::string& tool,
                     const std::string& provenance, Report* report);

}  // namespace mr
