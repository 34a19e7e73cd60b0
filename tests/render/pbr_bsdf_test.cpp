#include "render/pbr_bsdf.h"

#include <gtest/gtest.h>

#include "core/math.h"
#include "core/sampling.h"

namespace mr {
namespace {

// The directional albedo int f cos dwi at wo, estimated with the BSDF's own
// sampling (n samples; PCG32, fixed seed).
Eigen::Vector3d Albedo(const PbrBsdf& b, double mu, int n = 1 << 17) {
  const Eigen::Vector3d wo(std::sqrt(1 - mu * mu), 0, mu);
  Pcg32 rng(7, 11);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    BsdfSample s;
    if (b.Sample(wo, rng.NextDouble(), rng.NextDouble(), rng.NextDouble(), &s)) sum += s.f * s.wi.z() / s.pdf;
  }
  return sum / n;
}

PbrBsdf Make(const Eigen::Vector3d& base, double metallic, double roughness, double ior = 1.5) {
  return PbrBsdf(PbrParams{.base_color = base, .metallic = metallic, .roughness = roughness, .ior = ior});
}

TEST(PbrBsdf, FresnelDielectricLimits) {
  EXPECT_NEAR(FresnelDielectric(1, 1.5), 0.04, 1e-12);  // ((n - 1) / (n + 1))^2
  EXPECT_NEAR(FresnelDielectric(1, 2.4), std::pow(1.4 / 3.4, 2), 1e-12);
  EXPECT_NEAR(FresnelDielectric(0.3, 1.0), 0, 1e-12);  // ior 1: no interface
  EXPECT_NEAR(FresnelDielectric(0, 1.5), 1, 1e-12);    // grazing
  // Brewster's angle: p-polarised reflectance vanishes, R = rs^2 / 2.
  const double tb = std::atan(1.5), ct = std::cos(std::asin(std::sin(tb) / 1.5));
  const double rs = (std::cos(tb) - 1.5 * ct) / (std::cos(tb) + 1.5 * ct);
  EXPECT_NEAR(FresnelDielectric(std::cos(tb), 1.5), rs * rs / 2, 1e-12);
}

// A white metal reflects everything at every roughness and angle once the
// multiple-scattering lobe puts back what single scattering loses (without
// it, roughness 1 at grazing loses ~40 %).  Measured 0.998 to 1.001 over
// these cases and the next test's; tolerance 0.5 %: the tables'
// interpolation (32 x 32 nodes) and 2^17 samples (standard error ~0.1 %).
TEST(PbrBsdf, WhiteFurnaceMetal) {
  for (double rough : {0.05, 0.3, 0.6, 1.0})
    for (double mu : {0.1, 0.4, 0.8, 1.0}) {
      const Eigen::Vector3d a = Albedo(Make(Eigen::Vector3d::Ones(), 1, rough), mu);
      EXPECT_NEAR(a.x(), 1, 0.005) << "roughness " << rough << " mu " << mu;
    }
}

// A white base under the dielectric coat: what the coat does not reflect
// reaches the base, which returns it: the albedo is 1 at any roughness and ior.
TEST(PbrBsdf, WhiteFurnaceDielectricOverWhiteBase) {
  for (double ior : {1.0, 1.5, 2.4})
    for (double rough : {0.05, 0.5, 1.0})
      for (double mu : {0.1, 0.5, 1.0}) {
        const Eigen::Vector3d a = Albedo(Make(Eigen::Vector3d::Ones(), 0, rough, ior), mu);
        EXPECT_NEAR(a.x(), 1, 0.005) << "ior " << ior << " roughness " << rough << " mu " << mu;
      }
}

// A smooth black dielectric reflects Fresnel's reflectance alone.
TEST(PbrBsdf, SmoothDielectricReflectsFresnel) {
  for (double mu : {1.0, 0.5, 0.2}) {
    const double a = Albedo(Make(Eigen::Vector3d::Zero(), 0, 0.02, 1.5), mu).x();
    EXPECT_NEAR(a, FresnelDielectric(mu, 1.5), 0.1 * FresnelDielectric(mu, 1.5) + 2e-3) << mu;
  }
}

// A polished metal's colour is its base colour at normal incidence and
// whitens towards grazing (Schlick), never exceeding 1.
TEST(PbrBsdf, MetalColourAtNormalAndGrazingIncidence) {
  const Eigen::Vector3d gold(1.0, 0.766, 0.336);
  const Eigen::Vector3d normal = Albedo(Make(gold, 1, 0.05), 1.0);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(normal[c], gold[c], 0.02) << c;
  const Eigen::Vector3d grazing = Albedo(Make(gold, 1, 0.05), 0.1);
  EXPECT_GT(grazing.z(), 0.45);  // blue rises from 0.34 towards 1
  EXPECT_LE(grazing.maxCoeff(), 1.01);
}

TEST(PbrBsdf, ReciprocalAndPdfIntegratesToOne) {
  const PbrBsdf b = Make(Eigen::Vector3d(0.8, 0.3, 0.1), 0.4, 0.45);
  Pcg32 rng(1, 2);
  for (int i = 0; i < 200; ++i) {
    const auto a = SampleCosineHemisphere(rng.NextDouble(), rng.NextDouble());
    const auto c = SampleCosineHemisphere(rng.NextDouble(), rng.NextDouble());
    const Eigen::Vector3d wo(a[0], a[1], a[2]), wi(c[0], c[1], c[2]);
    EXPECT_TRUE(b.Eval(wo, wi).isApprox(b.Eval(wi, wo), 1e-12));
  }
  const Eigen::Vector3d wo = Eigen::Vector3d(0.5, 0.1, 0.6).normalized();
  double integral = 0;
  const int n = 1 << 17;
  for (int i = 0; i < n; ++i) {  // uniform hemisphere: pdf / (1 / 2 pi)
    const double z = rng.NextDouble(), phi = kTwoPi * rng.NextDouble(), r = std::sqrt(1 - z * z);
    integral += b.Pdf(wo, Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z)) * kTwoPi;
  }
  EXPECT_NEAR(integral / n, 1, 0.02);  // the specular lobe's few directions below the horizon
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// The embedded tables (render/pbr_tables_data.inc) are what their definition
// computes: regenerated with bench/gen_pbr_tables.cpp when it changes.  Equal
// to 1e-12 (hexadecimal floats round-trip exactly; the margin is for another
// machine's libm in the last bits).
TEST(PbrTables, EmbeddedAreTheirDefinition) {
  const std::vector<double> embedded = ComputePbrTableValues(true), computed = ComputePbrTableValues(false);
  ASSERT_EQ(embedded.size(), computed.size());
  for (size_t i = 0; i < embedded.size(); ++i)
    ASSERT_NEAR(embedded[i], computed[i], 1e-12) << "value " << i << ": regenerate libmr/render/pbr_tables_data.inc";
}

}  // namespace
}  // namespace mr
