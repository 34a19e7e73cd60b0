#include "core/image.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/check.h"
#include "core/error.h"
#include "core/math.h"

namespace mr {

Image::Image(int width, int height, std::vector<std::string> channel_names, float fill)
    : width_(width), height_(height), names_(std::move(channel_names)) {
  MR_CHECK(width >= 0 && height >= 0);
  MR_CHECK(!names_.empty());
  data_.assign(static_cast<size_t>(width) * static_cast<size_t>(height) * names_.size(), fill);
}

Image Image::Rgb(int width, int height, float fill) { return Image(width, height, {"R", "G", "B"}, fill); }
Image Image::Rgba(int width, int height, float fill) { return Image(width, height, {"R", "G", "B", "A"}, fill); }
Image Image::Gray(int width, int height, float fill) { return Image(width, height, {"Y"}, fill); }

int Image::ChannelIndex(const std::string& name) const {
  for (size_t i = 0; i < names_.size(); ++i)
    if (names_[i] == name) return static_cast<int>(i);
  return -1;
}

namespace {
std::pair<std::string, std::string> SplitLayer(const std::string& name) {
  auto dot = name.rfind('.');
  if (dot == std::string::npos) return {"", name};
  return {name.substr(0, dot), name.substr(dot + 1)};
}
}  // namespace

std::vector<std::string> Image::LayerNames() const {
  std::vector<std::string> layers;
  for (const auto& n : names_) {
    auto layer = SplitLayer(n).first;
    if (std::find(layers.begin(), layers.end(), layer) == layers.end()) layers.push_back(layer);
  }
  return layers;
}

Image Image::Layer(const std::string& layer) const {
  std::vector<int> idx;
  std::vector<std::string> names;
  for (size_t i = 0; i < names_.size(); ++i) {
    auto [l, c] = SplitLayer(names_[i]);
    if (l == layer) {
      idx.push_back(static_cast<int>(i));
      names.push_back(c);
    }
  }
  if (idx.empty()) ThrowError("image has no layer \"{}\"", layer);
  Image out(width_, height_, names);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x)
      for (size_t k = 0; k < idx.size(); ++k) out.at(x, y, static_cast<int>(k)) = at(x, y, idx[k]);
  return out;
}

void Image::AppendLayer(const std::string& layer, const Image& img) {
  if (names_.empty()) {  // the first layer sets the size
    width_ = img.width();
    height_ = img.height();
  }
  MR_CHECK(img.width() == width_ && img.height() == height_);
  const int old_c = channels();
  std::vector<std::string> names = names_;
  for (const auto& n : img.channel_names()) names.push_back(layer.empty() ? n : layer + "." + n);
  std::vector<float> data(static_cast<size_t>(width_) * height_ * names.size());
  const int new_c = static_cast<int>(names.size());
  for (int64_t p = 0; p < pixel_count(); ++p) {
    for (int c = 0; c < old_c; ++c) data[p * new_c + c] = data_[p * old_c + c];
    for (int c = 0; c < img.channels(); ++c) data[p * new_c + old_c + c] = img.data()[p * img.channels() + c];
  }
  names_ = std::move(names);
  data_ = std::move(data);
}

Image Image::Stack(const std::vector<std::pair<std::string, const Image*>>& layers) {
  MR_CHECK(!layers.empty());
  Image out;
  out.width_ = layers.front().second->width();
  out.height_ = layers.front().second->height();
  for (const auto& [layer, img] : layers) {
    MR_CHECK(img->width() == out.width_ && img->height() == out.height_);
    for (const auto& n : img->channel_names()) out.names_.push_back(layer.empty() ? n : layer + "." + n);
  }
  const size_t nc = out.names_.size();
  out.data_.resize(static_cast<size_t>(out.width_) * out.height_ * nc);
  size_t first = 0;
  for (const auto& [layer, img] : layers) {
    const size_t c = static_cast<size_t>(img->channels());
    const float* src = img->data();
    float* dst = out.data_.data() + first;
    for (int64_t p = 0; p < out.pixel_count(); ++p, src += c, dst += nc) std::copy(src, src + c, dst);
    first += c;
  }
  return out;
}

std::vector<ChannelStats> ComputeStats(const Image& img) {
  std::vector<ChannelStats> stats(static_cast<size_t>(img.channels()));
  const int nc = img.channels();
  for (int c = 0; c < nc; ++c) {
    ChannelStats& s = stats[static_cast<size_t>(c)];
    s.name = img.channel_names()[static_cast<size_t>(c)];
    s.min = std::numeric_limits<double>::infinity();
    s.max = -std::numeric_limits<double>::infinity();
    CompensatedSum<double> sum;
    int64_t n = 0;
    for (int64_t p = 0; p < img.pixel_count(); ++p) {
      float v = img.data()[p * nc + c];
      if (std::isnan(v)) {
        ++s.nan_count;
      } else if (std::isinf(v)) {
        ++s.inf_count;
      } else {
        s.min = std::min(s.min, static_cast<double>(v));
        s.max = std::max(s.max, static_cast<double>(v));
        sum += v;
        ++n;
      }
    }
    if (n == 0) s.min = s.max = 0;
    s.mean = n > 0 ? sum.Value() / static_cast<double>(n) : 0.0;
  }
  return stats;
}

int64_t CountNonFinite(const Image& img) {
  int64_t n = 0;
  for (float v : img.values()) n += std::isfinite(v) ? 0 : 1;
  return n;
}

const char* ToString(Transfer t) { return t == Transfer::kSrgb ? "sRGB" : "linear"; }

void GaussianBlur(Image* img, double sigma_px) {
  if (!(sigma_px > 0)) return;
  const int r = static_cast<int>(std::ceil(3 * sigma_px));
  std::vector<double> k(static_cast<size_t>(2 * r + 1));
  double ks = 0;
  for (int i = -r; i <= r; ++i) ks += k[static_cast<size_t>(i + r)] = std::exp(-0.5 * i * i / (sigma_px * sigma_px));
  for (auto& v : k) v /= ks;
  const int W = img->width(), H = img->height(), C = img->channels();
  for (int pass = 0; pass < 2; ++pass) {
    const Image src = *img;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        for (int c = 0; c < C; ++c) {
          double s = 0;
          for (int i = -r; i <= r; ++i) {
            const int xx = pass == 0 ? std::clamp(x + i, 0, W - 1) : x,
                      yy = pass == 1 ? std::clamp(y + i, 0, H - 1) : y;
            s += k[static_cast<size_t>(i + r)] * src.at(xx, yy, c);
          }
          img->at(x, y, c) = static_cast<float>(s);
        }
  }
}

}  // namespace mr
