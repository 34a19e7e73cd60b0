#include "render/frame_io.h"

#include <algorithm>
#include <cmath>

#include "core/check.h"
#include "core/contact_sheet.h"
#include "core/error.h"
#include "core/image_metrics.h"
#include "core/math.h"
#include "scene/frames.h"

namespace mr {

FrameDecoding FrameDecoding::FromScene(const Scene& scene, Report* report) {
  FrameDecoding d;
  d.photograph = scene.camera.frames.has_value();
  d.display_space = d.photograph && scene.camera.frames_transfer == "display";
  d.file_transfer = scene.camera.frames_transfer == "srgb" ? Transfer::kSrgb : Transfer::kLinear;
  d.exposure = scene.camera.exposure;
  if (d.photograph && scene.camera.frames_transfer == "response") {
    d.response = ReadResponse(*scene.camera.response);
    report->AddInput(scene.camera.response->string());
  }
  if (d.photograph && !scene.camera.frames_colorspace.empty()) {
    // Both ways before any work: a space the config lacks, or one whose
    // inverse it cannot build, is refused here.
    const std::string config = scene.camera.ocio_config ? scene.camera.ocio_config->string() : "";
    d.ocio_decode = std::make_shared<const ColorTransform>(config, scene.camera.frames_colorspace,
                                                           scene.camera.ocio_working, "camera.frames_colorspace");
    d.ocio_encode = std::make_shared<const ColorTransform>(config, scene.camera.ocio_working,
                                                           scene.camera.frames_colorspace, "camera.frames_colorspace");
    if (scene.camera.ocio_config) report->AddInput(config);
  }
  d.raw_codes = d.display_space || d.response.has_value() || d.ocio_decode != nullptr;
  d.gains_scale_room = scene.camera.gains_scale == "room";
  if (d.photograph && scene.camera.gains) {
    d.gains_file = scene.camera.gains->string();
    d.frame_gains = ReadPlateGains(*scene.camera.gains);
    report->AddInput(d.gains_file);
    report->SetMetric("gains_scale", d.gains_scale_room ? "room (the plate in the light's units: the gains correct "
                                                          "the room's albedo scale)"
                                                        : "render (everything rendered into the plate's units)");
  }
  if (d.photograph)
    report->SetMetric("compositing",
                      d.display_space ? "display space (camera response unknown)"
                      : d.response    ? "linear radiance (frames through the camera's response)"
                      : d.ocio_decode
                          ? fmt::format("linear radiance (frames from \"{}\" to \"{}\" through {})",
                                        d.ocio_decode->from(), d.ocio_decode->to(), d.ocio_decode->config_name())
                          : "linear radiance");
  return d;
}

bool FrameDecoding::HasGain(int f) const {
  if (frame_gains.empty()) return true;
  const auto it = std::lower_bound(frame_gains.begin(), frame_gains.end(), f,
                                   [](const FrameGain& g, int frame) { return g.frame < frame; });
  return it != frame_gains.end() && it->frame == f;
}

FrameDecoding FrameDecoding::ForFrame(int f) const {
  FrameDecoding d = *this;
  const Rgb nominal = display_space ? Rgb{exposure, exposure, exposure} : Rgb{1, 1, 1};
  d.gain = d.object_gain = nominal;
  if (frame_gains.empty()) return d;
  const auto it = std::lower_bound(frame_gains.begin(), frame_gains.end(), f,
                                   [](const FrameGain& g, int frame) { return g.frame < frame; });
  if (it == frame_gains.end() || it->frame != f)
    ThrowErrorAt(FileLoc{gains_file},
                 "has no gain for frame {} (it covers frames {} to {}): run mr-eval plate "
                 "over every frame to render",
                 f, frame_gains.front().frame, frame_gains.back().frame);
  d.gain = it->gain;
  if (!gains_scale_room) d.object_gain = it->gain;
  return d;
}

namespace {

// img * gain per channel (RGB).
Image Scaled(Image img, const Rgb& gain) {
  const int n = img.channels();
  std::vector<float>& v = img.values();
  for (size_t i = 0; i < v.size(); ++i) v[i] *= static_cast<float>(gain[i % static_cast<size_t>(n) % 3]);
  return img;
}

}  // namespace

Image FrameDecoding::ToRadiance(const Image& photo) const {
  Image out = photo;
  if (display_space)
    for (float& v : out.values()) v = SrgbToLinear(Clamp(v, 0.0f, 1.0f)) / static_cast<float>(exposure);
  return out;
}

Image FrameDecoding::ToPlateLinear(const Image& photo) const {
  Image out = photo;
  if (display_space)
    for (float& v : out.values()) v = SrgbToLinear(Clamp(v, 0.0f, 1.0f));
  return out;
}

Image FrameDecoding::ToRenderUnits(const Image& photo) const {
  return Scaled(ToPlateLinear(photo), {1 / object_gain[0], 1 / object_gain[1], 1 / object_gain[2]});
}

CompositeResult FrameDecoding::Compose(const FrameMethod& frame, const Image* photo) const {
  Image real = frame.Real(), mixed = frame.Mixed();
  if (!photo) return Composite(real, mixed, real, frame.Mask());  // synthetic: the render's own units
  if (!display_space)
    return Composite(*photo, Scaled(mixed, gain), Scaled(real, gain), frame.Mask(), Scaled(mixed, object_gain));
  const float e = static_cast<float>(exposure);
  auto tm = [](Image img, const Rgb& g) {
    const int n = img.channels();
    std::vector<float>& v = img.values();
    for (size_t i = 0; i < v.size(); ++i)
      v[i] = LinearToSrgb(Clamp(v[i] * static_cast<float>(g[i % static_cast<size_t>(n) % 3]), 0.0f, 1.0f));
    return img;
  };
  CompositeResult r = Composite(*photo, tm(mixed, gain), tm(real, gain), frame.Mask(), tm(mixed, object_gain));
  for (float& v : r.composite.values()) v = SrgbToLinear(Clamp(v, 0.0f, 1.0f)) / e;
  return r;
}

Image FrameDecoding::ToCodes(const Image& radiance, const PhotoEncoding& enc) const {
  Image codes = radiance;
  const float e = static_cast<float>(exposure);
  if (ocio_encode) {
    ocio_encode->Apply(&codes);
    for (float& v : codes.values()) v = Clamp(v, 0.0f, 1.0f);
  } else if (display_space) {
    for (float& v : codes.values()) v = LinearToSrgb(Clamp(v * e, 0.0f, 1.0f));
  } else if (response) {
    for (float& v : codes.values()) v *= e;
    codes = Delinearise(codes, *response);
  } else if (enc.has_codes && enc.transfer == Transfer::kLinear) {
    for (float& v : codes.values()) v = Clamp(v, 0.0f, 1.0f);
  } else {
    for (float& v : codes.values()) v = LinearToSrgb(Clamp(v, 0.0f, 1.0f));
  }
  for (float& v : codes.values())
    if (!std::isfinite(v)) v = 0;  // cannot happen for a checked composite; never an unencodable pixel
  return codes;
}

Image FrameDecoding::FromCodes(const Image& codes, const PhotoEncoding& enc) const {
  Image out = codes;
  for (float& v : out.values()) v = Clamp(v, 0.0f, 1.0f);
  if (ocio_decode) {
    ocio_decode->Apply(&out);
  } else if (response) {
    out = Linearise(out, *response);
    for (float& v : out.values()) v /= static_cast<float>(exposure);
  } else if (display_space) {
    for (float& v : out.values()) v = SrgbToLinear(v) / static_cast<float>(exposure);
  } else if (!(enc.has_codes && enc.transfer == Transfer::kLinear)) {
    for (float& v : out.values()) v = SrgbToLinear(v);
  }
  return out;
}

std::string FrameDecoding::CodesColorSpace(const PhotoEncoding& enc) const {
  if (ocio_encode) return ocio_encode->to();
  return !display_space && !response && enc.has_codes && enc.transfer == Transfer::kLinear ? "Linear" : "sRGB";
}

namespace {

// A photograph or reference, checked against the camera's size.
Image ReadRgb(const fs::path& path, int w, int h, const Transfer transfer, bool raw = false,
              ImageFileInfo* info = nullptr) {
  Image img = ReadRgbForComparison(path, transfer, raw, info);
  if (img.width() != w || img.height() != h)
    ThrowErrorAt(FileLoc{path.string()}, "image is {}x{}, the camera model says {}x{}", img.width(), img.height(), w,
                 h);
  return img;
}

}  // namespace

FrameReader::FrameReader(const Scene& scene, const CameraModel& camera, const FrameDecoding& decoding)
    : scene_(scene), width_(camera.width()), height_(camera.height()), decoding_(decoding) {
  if (scene.camera.frames && scene.camera.frames_are_video) {
    video_ = std::make_unique<VideoReader>(*scene.camera.frames);
    if (video_->width() != width_ || video_->height() != height_)
      ThrowErrorAt(FileLoc{scene.camera.frames->string()}, "video is {}x{}, the camera model says {}x{}",
                   video_->width(), video_->height(), width_, height_);
  }
}

FrameReader::~FrameReader() = default;

double FrameReader::fps() const { return video_ && video_->fps() > 0 ? video_->fps() : 30.0; }

int64_t KeepPlateCodes(const Image& photo, const Image& composite, const Image& plate_codes, Image* codes) {
  MR_CHECK(photo.width() == composite.width() && photo.height() == composite.height() &&
           plate_codes.width() == photo.width() && plate_codes.height() == photo.height() &&
           codes->width() == photo.width() && codes->height() == photo.height());
  int64_t kept = 0;
  for (int y = 0; y < photo.height(); ++y)
    for (int x = 0; x < photo.width(); ++x) {
      bool same = true;
      for (int c = 0; c < 3; ++c) same = same && photo.at(x, y, c) == composite.at(x, y, c);
      if (!same) continue;
      for (int c = 0; c < 3; ++c) codes->at(x, y, c) = plate_codes.at(x, y, c);
      ++kept;
    }
  return kept;
}

std::optional<Image> FrameReader::Photo(int f, PhotoEncoding* enc, Image* codes) {
  std::optional<Image> photo;
  PhotoEncoding e;
  if (video_) {
    photo = video_->Frame(f);  // decoded through sRGB
    if (decoding_.raw_codes)
      for (float& v : photo->values()) v = LinearToSrgb(v);  // back to code values
    e.has_codes = true;
  } else if (scene_.camera.frames) {
    ImageFileInfo info;
    photo = ReadRgb(FramePath(*scene_.camera.frames, f), width_, height_, decoding_.file_transfer, decoding_.raw_codes,
                    &info);
    e.has_codes = info.decoded_from_ldr;
    e.transfer = info.transfer;
    e.type = info.pixel_type == "uint16" ? PixelType::kUint16 : PixelType::kUint8;
  }
  if (enc) *enc = e;
  if (photo && codes) *codes = *photo;
  if (photo && decoding_.ocio_decode) decoding_.ocio_decode->Apply(&*photo);
  if (photo && decoding_.response) {
    *photo = Linearise(*photo, *decoding_.response);
    for (float& v : photo->values()) v /= static_cast<float>(decoding_.exposure);
  }
  return photo;
}

CameraExposure FrameExposure(const Scene& scene, const std::vector<Rigid3>& poses, int f) {
  CameraExposure e;
  e.aperture_radius = scene.camera.aperture_radius;
  e.focus_distance = scene.camera.focus_distance;
  const double s = scene.camera.shutter;
  const size_t i = static_cast<size_t>(f);
  if (s <= 0 || i >= poses.size()) return e;
  const Rigid3& pose = poses[i];
  e.open = i > 0 ? InterpolatePose(poses[i - 1], pose, 1 - s / 2) : pose;
  e.close = i + 1 < poses.size() ? InterpolatePose(pose, poses[i + 1], s / 2) : pose;
  auto moved = [](const Rigid3& a, const Rigid3& b) {
    return (a.translation - b.translation).norm() > 1e-9 || a.rotation.angularDistance(b.rotation) > 1e-9;
  };
  e.moves = moved(e.open, pose) || moved(pose, e.close);
  return e;
}

Image ReadReferenceFrame(const fs::path& path, int width, int height) {
  return ReadRgb(path, width, height, Transfer::kLinear);
}

const std::vector<std::string>& FrameLayerNames() {
  static const std::vector<std::string> names = {"composite", "mixed",   "real",  "mask",   "difference",
                                                 "variance",  "samples", "photo", "objects"};
  return names;
}

void WriteFrameFiles(const fs::path& out_dir, int frame, const FrameLayers& l, const PhotoEncoding& enc,
                     const std::string& color_space, const SceneOutput& output, const std::string& tool,
                     const std::string& provenance, Report* report) {
  auto wanted = [&](const char* name) {
    return std::find(output.layers.begin(), output.layers.end(), name) != output.layers.end();
  };
  std::vector<std::pair<std::string, const Image*>> chosen;
  const std::pair<const char*, const Image*> all[] = {
      {"composite", l.composite}, {"mixed", l.mixed},           {"real", l.real},
      {"mask", l.mask},           {"difference", l.difference}, {"variance", l.variance},
      {"samples", l.samples},     {"photo", l.photo},           {"objects", l.objects}};
  for (const auto& [name, img] : all)
    if (img && (wanted(name) || std::string(name) == "composite")) chosen.emplace_back(name, img);
  const Image layers = Image::Stack(chosen);
  ImageWriteOptions wo;
  wo.tool = tool;
  // A frame's provenance is what decides its pixels, not how the job was
  // split: no command line (it names --frames), so that a frame rendered in
  // a shard is byte-identical to the same frame rendered in one run
  // (docs/cluster.md).  The report keeps the command line.
  wo.attributes["mr:render"] = provenance;
  wo.pixel_type = output.half ? PixelType::kHalf : PixelType::kFloat;
  const fs::path exr = out_dir / fmt::format("{:05d}.exr", frame);
  WriteImage(exr, layers, wo);
  report->AddOutput(exr.string());
  if (output.png) {
    const fs::path png = out_dir / fmt::format("{:05d}.png", frame);
    // The code values as they are (ToCodes encoded them), at the
    // photograph's bit depth: an unchanged pixel keeps its code exactly.
    ImageWriteOptions po = wo;
    po.pixel_type = enc.has_codes ? enc.type : PixelType::kUint8;
    if (l.codes) {
      po.ldr_transfer = Transfer::kLinear;
      po.attributes["oiio:ColorSpace"] = color_space;
    }
    WriteImage(png, l.codes ? *l.codes : *l.composite, po);
    report->AddOutput(png.string());
  }
}

fs::path WriteReviewSheet(const fs::path& out_dir, int frame, const Image& plate, const Image& composite,
                          const Image& mask, bool photograph, const std::string& tool, Report* report,
                          const std::string& note) {
  Image d = composite;
  for (size_t i = 0; i < d.values().size(); ++i) d.values()[i] -= plate.values()[i];
  // Scaled to what the object does to the plate around it (its shadow and
  // bounce light): the 99th percentile of the changes on pixels it does not
  // cover, so that a few noise spikes do not flatten the rest; the object
  // itself and the spikes clip.
  std::vector<float> changes;
  for (int y = 0; y < d.height(); ++y)
    for (int x = 0; x < d.width(); ++x)
      if (mask.at(x, y, 0) == 0)
        for (int c = 0; c < d.channels(); ++c)
          if (d.at(x, y, c) != 0.0f && std::isfinite(d.at(x, y, c))) changes.push_back(std::abs(d.at(x, y, c)));
  float around = 0;
  if (!changes.empty()) {
    const size_t k = changes.size() * 99 / 100;
    std::nth_element(changes.begin(), changes.begin() + static_cast<std::ptrdiff_t>(k), changes.end());
    around = changes[k];
  }
  double scale = 0;
  const Image diff = SignedDifferencePanel(d, around, &scale);
  const Image sheet = ContactSheet({{&plate, photograph ? "plate" : "I_r (no plate: rendered room)"},
                                    {&composite, note.empty() ? std::string("composite") : "composite; " + note},
                                    {&diff, fmt::format("composite - plate, x{:.3g}", 0.5 / scale)},
                                    {&mask, "mask (virtual object)"}},
                                   2);
  ImageWriteOptions wo;
  wo.tool = tool;
  wo.pixel_type = PixelType::kUint8;
  wo.ldr_transfer = Transfer::kLinear;  // already display values
  wo.attributes["oiio:ColorSpace"] = "sRGB";
  const fs::path path = out_dir / fmt::format("{:05d}-review.png", frame);
  WriteImage(path, sheet, wo);
  report->AddOutput(path.string());
  return path;
}

bool FrameComplete(const fs::path& out_dir, int frame, const SceneOutput& output, const std::string& provenance) {
  std::error_code ec;
  const fs::path exr = out_dir / fmt::format("{:05d}.exr", frame);
  if (!fs::is_regular_file(exr, ec)) return false;
  if (output.png && !fs::is_regular_file(out_dir / fmt::format("{:05d}.png", frame), ec)) return false;
  if (output.review && !fs::is_regular_file(out_dir / fmt::format("{:05d}-review.png", frame), ec)) return false;
  try {
    const ImageFileInfo info = ReadImageHeader(exr, nullptr, nullptr, nullptr);
    const auto it = info.attributes.find("mr:render");
    return it != info.attributes.end() && it->second == provenance;
  } catch (const Error&) {
    return false;  // unreadable: rendered again
  }
}

}  // namespace mr
