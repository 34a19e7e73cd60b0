#include "core/color_management.h"

#include <OpenColorIO/OpenColorIO.h>

#include <sstream>

#include "core/error.h"

namespace mr {

namespace OCIO = OCIO_NAMESPACE;

struct ColorTransform::Impl {
  OCIO::ConstCPUProcessorRcPtr cpu;
};

namespace {

OCIO::ConstConfigRcPtr LoadConfig(const std::string& path, const std::string& name, const std::string& key) {
  try {
    OCIO::ConstConfigRcPtr config;
    if (path.empty()) {
      std::istringstream in(MrOcioConfig());
      config = OCIO::Config::CreateFromStream(in);
    } else {
      config = OCIO::Config::CreateFromFile(path.c_str());
    }
    config->validate();
    return config;
  } catch (const OCIO::Exception& e) {
    throw Error(fmt::format("{} (for {}): not a usable OpenColorIO config: {}", name, key, e.what()));
  }
}

std::string SpacesOf(const OCIO::ConstConfigRcPtr& config) {
  std::string all;
  for (int i = 0; i < config->getNumColorSpaces(); ++i)
    all += (i ? ", \"" : "\"") + std::string(config->getColorSpaceNameByIndex(i)) + "\"";
  return all;
}

}  // namespace

ColorTransform::ColorTransform(const std::string& config_path, const std::string& from, const std::string& to,
                               const std::string& key)
    : impl_(std::make_unique<Impl>()),
      from_(from),
      to_(to),
      config_name_(config_path.empty() ? "mr.ocio" : config_path) {
  const OCIO::ConstConfigRcPtr config = LoadConfig(config_path, config_name_, key);
  for (const std::string& space : {from, to})
    if (!config->getColorSpace(space.c_str()))
      throw Error(fmt::format("{}: \"{}\" is not a colour space of {} (it has {})", key, space, config_name_,
                              SpacesOf(config)));
  try {
    impl_->cpu = config->getProcessor(from.c_str(), to.c_str())
                     ->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F32, OCIO::BIT_DEPTH_F32, OCIO::OPTIMIZATION_LOSSLESS);
  } catch (const OCIO::Exception& e) {
    throw Error(fmt::format("{}: {} cannot convert \"{}\" to \"{}\": {}", key, config_name_, from, to, e.what()));
  }
}

ColorTransform::~ColorTransform() = default;

void ColorTransform::ApplyRgb(float rgb[3]) const { impl_->cpu->applyRGB(rgb); }

void ColorTransform::Apply(Image* img) const {
  if (img->channels() < 3) throw Error("a colour transform needs RGB");
  const int n = img->channels();
  std::vector<float>& v = img->values();
  if (n == 3) {
    OCIO::PackedImageDesc desc(v.data(), img->width(), img->height(), 3);
    impl_->cpu->apply(desc);
    return;
  }
  for (size_t i = 0; i + 2 < v.size(); i += static_cast<size_t>(n)) impl_->cpu->applyRGB(&v[i]);
}

}  // namespace mr
