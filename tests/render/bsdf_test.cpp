#include "render/bsdf.h"

#include <gtest/gtest.h>

#include "core/math.h"
#include "core/sampling.h"

namespace mr {
namespace {

Material Mat(double albedo, double specular, double roughness) {
  Material m;
  m.albedo = Eigen::Vector3d::Constant(albedo);
  m.specular = Eigen::Vector3d::Constant(specular);
  m.roughness = roughness;
  return m;
}

TEST(Bsdf, LambertianSamplingWeightIsTheAlbedo) {
  Bsdf b(Mat(0.7, 0, 0.5));
  Pcg32 rng(3, 3);
  Eigen::Vector3d wo = Eigen::Vector3d(0.3, -0.2, 0.9).normalized();
  for (int i = 0; i < 1000; ++i) {
    BsdfSample s;
    ASSERT_TRUE(b.Sample(wo, rng.NextDouble(), rng.NextDouble(), rng.NextDouble(), &s));
    // f cos / pdf = albedo exactly for cosine sampling.
    ASSERT_NEAR(s.f.x() * s.wi.z() / s.pdf, 0.7, 1e-12);
  }
}

// Energy: the directional albedo of albedo + specular <= 1 never exceeds 1,
// and the sampling pdf matches Pdf() and integrates to at most 1.
TEST(Bsdf, GlossyLobeConservesEnergyAndPdfsAgree) {
  for (double rough : {0.05, 0.3, 0.8}) {
    Bsdf b(Mat(0.4, 0.6, rough));
    for (double theta_deg : {0.0, 45.0, 80.0, 89.0}) {
      const double th = theta_deg * kDegToRad;
      Eigen::Vector3d wo(std::sin(th), 0, std::cos(th));
      const int n = 1 << 16;
      CompensatedSum<double> albedo, pdf_integral;
      for (int i = 0; i < n; ++i) {
        auto u = Sobol2D(static_cast<uint32_t>(i), 11, true);
        BsdfSample s;
        if (b.Sample(wo, RadicalInverse(1, static_cast<uint64_t>(i)), u[0], u[1], &s)) {
          ASSERT_NEAR(b.Pdf(wo, s.wi), s.pdf, 1e-9 * s.pdf);
          albedo += s.f.x() * s.wi.z() / s.pdf;
        }
        auto d = SampleUniformSphere(u[0], u[1]);
        pdf_integral += b.Pdf(wo, Eigen::Vector3d(d[0], d[1], d[2])) / kUniformSpherePdf;
      }
      // Single-scattering GGX loses energy at grazing angles and high
      // roughness, never gains: 1 + 2% for the estimator's noise.
      EXPECT_LE(albedo.Value() / n, 1.02) << rough << " " << theta_deg;
      EXPECT_GT(albedo.Value() / n, 0.35) << rough << " " << theta_deg;  // the diffuse part alone gives 0.4
      EXPECT_LE(pdf_integral.Value() / n, 1.03) << rough << " " << theta_deg;
    }
  }
}

// Visible-normal sampling: a pure glossy lobe's weight f cos / pdf is
// G2 / G1 <= 1 for every sample, at grazing angles too (D(h) cos sampling
// reached ~2 / alpha there); and Pdf() is the sampler's density: its
// integral over the sphere equals the share of samples that leave above
// the horizon (2^16 stratified directions, roughness 0.5 and 1: within 1%).
TEST(Bsdf, GlossySamplingWeightIsAtMostOneAndPdfIsTheSamplersDensity) {
  for (double rough : {0.05, 0.25, 0.5, 1.0}) {
    Bsdf b(Mat(0, 1, rough));
    for (double theta_deg : {0.0, 60.0, 85.0, 89.5}) {
      const double th = theta_deg * kDegToRad;
      const Eigen::Vector3d wo(std::sin(th), 0, std::cos(th));
      const int n = 1 << 16;
      int above = 0;
      CompensatedSum<double> pdf_integral;
      double max_weight = 0;
      for (int i = 0; i < n; ++i) {
        const auto u = Sampler::Stratified(5, static_cast<uint32_t>(i)).Next2D();
        BsdfSample s;
        if (b.Sample(wo, 0.5, u[0], u[1], &s)) {
          ++above;
          max_weight = std::max(max_weight, s.f.x() * s.wi.z() / s.pdf);
        }
        auto d = SampleUniformSphere(u[0], u[1]);
        pdf_integral += b.Pdf(wo, Eigen::Vector3d(d[0], d[1], d[2])) / kUniformSpherePdf;
      }
      EXPECT_LE(max_weight, 1 + 1e-9) << rough << " " << theta_deg;
      if (rough >= 0.5) {  // sharper lobes are too narrow for uniform directions to integrate
        EXPECT_NEAR(pdf_integral.Value() / n, static_cast<double>(above) / n, 0.01) << rough << " " << theta_deg;
      }
    }
  }
}

TEST(Bsdf, NothingBelowTheHorizon) {
  Bsdf b(Mat(0.5, 0.5, 0.3));
  EXPECT_EQ(b.Eval({0, 0, 1}, {0, 0.6, -0.8}), Eigen::Vector3d::Zero());
  EXPECT_EQ(b.Pdf({0, 0, -1}, {0, 0, 1}), 0.0);
  BsdfSample s;
  EXPECT_FALSE(b.Sample({0, 0, -1}, 0.5, 0.5, 0.5, &s));
  EXPECT_TRUE(Bsdf(Mat(0, 0, 0.5)).IsBlack());
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// The light trees' bounds (vpl lightcuts) hold for every wi and stay finite
// however grazing wo is (1e-320: the first bound alone, 1/wo.z, would be
// infinite there; a NaN weight would poison every cluster above the VPL),
// and the BSDF itself is finite there (4 wo.z wi.z underflowed to 0 and
// gave 0/0).
TEST(Bsdf, ProjectedBoundsHoldAndStayFiniteAtGrazingAngles) {
  for (const double rough : {0.0, 0.01, 0.1, 0.5, 1.0}) {
    Material m;
    m.albedo = Eigen::Vector3d(0.3, 0.2, 0.1);
    m.specular = Eigen::Vector3d(0.6, 0.7, 0.8);
    m.roughness = rough;
    const Bsdf b(m);
    for (const double z : {1.0, 0.5, 1e-3, 1e-8, 1e-320}) {
      const Eigen::Vector3d wo(std::sqrt(1 - z * z), 0, z);
      const Eigen::Vector3d gb = b.GlossyBound(wo), db = b.DiffuseBound();
      ASSERT_TRUE(gb.allFinite()) << rough << " " << z;
      Sampler rng = Sampler::Random(7, 0);
      for (int k = 0; k < 20000; ++k) {
        // Half uniform over the hemisphere, half near the mirror direction.
        Eigen::Vector3d wi;
        if (k % 2 == 0) {
          const auto d = SampleUniformSphere(rng.NextDouble(), rng.NextDouble());
          wi = Eigen::Vector3d(d[0], d[1], std::abs(d[2]));
        } else {
          wi = Eigen::Vector3d(-wo.x(), 0, wo.z()) +
               0.05 * Eigen::Vector3d(rng.NextDouble() - 0.5, rng.NextDouble() - 0.5, rng.NextDouble());
          wi.normalize();
        }
        if (wi.z() <= 0) continue;
        const Eigen::Vector3d fc = b.Eval(wo, wi) * wi.z();
        ASSERT_TRUE(fc.allFinite()) << rough << " " << z;
        for (int c = 0; c < 3; ++c) EXPECT_LE(fc[c], (db[c] * wi.z() + gb[c]) * (1 + 1e-9)) << rough << " " << z;
      }
    }
  }
}

}  // namespace
}  // namespace mr
