// Colour helpers shared by every layer: Rec. 709 luminance and the sRGB
// transfer curve (IEC 61966-2-1).
#pragma once

#include <Eigen/Core>

namespace mr {

// Rec. 709 / sRGB primaries' luminance weights.
inline constexpr double kLumaR = 0.2126, kLumaG = 0.7152, kLumaB = 0.0722;

inline double Luminance(double r, double g, double b) { return kLumaR * r + kLumaG * g + kLumaB * b; }
inline double Luminance(const Eigen::Vector3d& c) { return Luminance(c.x(), c.y(), c.z()); }
// In single precision, for float images (not the same rounding as the double form).
inline float LuminanceF(float r, float g, float b) {
  return static_cast<float>(kLumaR) * r + static_cast<float>(kLumaG) * g + static_cast<float>(kLumaB) * b;
}

// The sRGB curve: code value in [0,1] -> linear, and back.
float SrgbToLinear(float v);
float LinearToSrgb(float v);

}  // namespace mr
