// Form-factor transfer: the bases against closed forms, the transfer
// against a path-traced reference, the .ffc file, and the stiff cases.
#include "eval/transfer_reference.h"
#include "transfer/formfactor.h"

#include "geometry/primitives.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/math.h"
#include "core/sh.h"
#include "test_util.h"
#include "transfer/cube.h"

namespace mr {
namespace {

Mesh Quad() {
  Mesh m;
  m.positions = {{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};  // normal +y
  return m;
}

Mesh Sphere(float r, int n) { return UvSphere(r, n); }
Mesh Box(float h) { return mr::Box(Eigen::Vector3f::Constant(-h), Eigen::Vector3f::Constant(h)); }

Image ConstantEnv(float v) { return Image::Rgb(64, 33, v); }

TEST(Cube, SolidAnglesSumToTheSphereAndCellsRoundTrip) {
  const int n = 5;
  double sum = 0;
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const double a0 = -1 + 2.0 * i / n, b0 = -1 + 2.0 * j / n;
        sum += CubeRectSolidAngle(a0, b0, a0 + 2.0 / n, b0 + 2.0 / n);
        EXPECT_EQ(CubeCell(CubeDirection(f, a0 + 1.0 / n, b0 + 1.0 / n), n), (f * n + j) * n + i);
      }
  EXPECT_NEAR(sum, 4 * kPi, 1e-12);
}

// Orthonormality over the sphere by a fine cube quadrature (midpoint rule:
// error ~1e-4 for bands up to 7 at 64 x 64 x 6 cells).
TEST(SphericalHarmonics, OrthonormalAndKnownValues) {
  const int order = 8, c = ShCount(order), n = 64;
  std::vector<double> gram(static_cast<size_t>(c * c), 0.0), y(static_cast<size_t>(c));
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const double a0 = -1 + 2.0 * i / n, b0 = -1 + 2.0 * j / n;
        const double w = CubeRectSolidAngle(a0, b0, a0 + 2.0 / n, b0 + 2.0 / n);
        ShEvaluate(CubeDirection(f, a0 + 1.0 / n, b0 + 1.0 / n), order, y.data());
        for (int a = 0; a < c; ++a)
          for (int b = 0; b < c; ++b)
            gram[static_cast<size_t>(a * c + b)] += w * y[static_cast<size_t>(a)] * y[static_cast<size_t>(b)];
      }
  for (int a = 0; a < c; ++a)
    for (int b = 0; b < c; ++b)
      EXPECT_NEAR(gram[static_cast<size_t>(a * c + b)], a == b ? 1.0 : 0.0, 2e-3) << a << " " << b;
  ShEvaluate(Eigen::Vector3d(0, 0, 1), order, y.data());
  EXPECT_NEAR(y[0], 0.5 / std::sqrt(kPi), 1e-15);
  EXPECT_NEAR(y[2], std::sqrt(3 / (4 * kPi)), 1e-15);  // Y_1^0 = sqrt(3/4pi) cos(theta)
  EXPECT_NEAR(y[1], 0, 1e-15);
  EXPECT_NEAR(y[3], 0, 1e-15);
}

// An unoccluded vertex under a constant environment L reflects albedo * L:
// sum over cells of T_c = (1/pi) integral of cos over the hemisphere = 1.
// The cube quadrature decides each sub-cell by its centre, so cells across
// the horizon are half-counted: 0.5% at 8 x 8 cells and 2 x 2 sub-cells.
// SH: T_0 L_0 = (1/pi)(pi Y00)(4 pi Y00) L = L exactly; higher bands of a
// constant are zero, so the same 0.5%.
TEST(Transfer, UnoccludedVertexUnderConstantSkyIsAlbedoTimesSky) {
  for (TransferBasis basis : {TransferBasis::kCube, TransferBasis::kSh}) {
    TransferOptions o;
    o.basis = basis;
    TransferStats st;
    VertexTransfer t = ComputeTransfer(Quad(), o, &st);
    EXPECT_EQ(st.normals_computed, 4);
    EXPECT_EQ(st.fully_occluded, 0);
    auto env = ProjectEnvironment(ConstantEnv(2.0f), "const", t.header, Eigen::Matrix3d::Identity());
    int64_t clamped = 0;
    auto l = ShadeVertices(t, env, Eigen::Vector3d(0.5, 0.25, 1.0), &clamped);
    EXPECT_EQ(clamped, 0);
    for (const auto& v : l) {
      EXPECT_NEAR(v.x(), 1.0, 0.005);
      EXPECT_NEAR(v.y(), 0.5, 0.0025);
      EXPECT_NEAR(v.z(), 2.0, 0.01);
    }
    // Per-vertex albedo (vertex colours): each vertex its own.
    const std::vector<Eigen::Vector3f> colours = {{0.1f, 0.2f, 0.3f}, {1, 1, 1}, {0, 0, 0}, {0.5f, 0.5f, 0.5f}};
    auto lv = ShadeVertices(t, env, Eigen::Vector3d::Ones(), nullptr, nullptr, &colours);
    for (size_t k = 0; k < 4; ++k)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(lv[k][c], 2.0 * colours[k][c], 0.01);
  }
}

// A convex sphere under a sky with a sun: no self-occlusion, so the
// reference is albedo/pi times the cosine-weighted integral of the map over
// each vertex's hemisphere.  The path-traced reference must match it; the
// cube transfer converges to it as the cells shrink.
TEST(Transfer, ConvergesToThePathTracedReferenceAsCellsShrink) {
  Mesh sphere = Sphere(0.5f, 12);
  Image env = Image::Rgb(64, 33, 0.5f);
  for (int c = 0; c < 3; ++c) env.at(20, 8, c) = 5000.0f;
  const auto ref = ReferenceVertexRadiance(sphere, env, "sun", Eigen::Matrix3d::Identity(), 0.7, 0, 256, 7);
  auto error_at = [&](int resolution) {
    TransferOptions o;
    o.resolution = resolution;
    TransferStats st;
    VertexTransfer t = ComputeTransfer(sphere, o, &st);
    auto l = ShadeVertices(t, ProjectEnvironment(env, "sun", t.header, Eigen::Matrix3d::Identity()),
                           Eigen::Vector3d::Constant(0.7), nullptr);
    double num = 0, den = 0;
    for (size_t v = 0; v < l.size(); ++v) {
      num += (l[v] - ref[v]).squaredNorm();
      den += ref[v].squaredNorm();
    }
    return std::sqrt(num / den);  // relative RMS error over the vertices
  };
  const double e4 = error_at(4), e16 = error_at(16);
  EXPECT_LT(e16, 0.5 * e4) << e4 << " " << e16;
  EXPECT_LT(e16, 0.15) << e16;
}

// Each vertex of a box inside a closed box sees nothing: transfer zero, counted.
TEST(Transfer, VerticesInsideClosedGeometryAreFullyOccluded) {
  Mesh m = Box(2.0f);
  Mesh inner = Box(0.5f);
  const int base = static_cast<int>(m.positions.size());
  for (auto& p : inner.positions) m.positions.push_back(p);
  for (auto t : inner.triangles) m.triangles.push_back(t + Eigen::Vector3i::Constant(base));
  TransferOptions o;
  o.resolution = 4;
  TransferStats st;
  VertexTransfer t = ComputeTransfer(m, o, &st);
  // The inner box's 8 vertices face outwards into the closed outer box; the
  // outer box's vertices face outwards into the open sky.
  EXPECT_EQ(st.fully_occluded, 8);
  for (int v = base; v < base + 8; ++v)
    for (int k = 0; k < t.header.coefficients; ++k) ASSERT_EQ(t.vertex(v)[k], 0.0f);
}

// Interreflection: inside an open-topped box the floor sees the walls, so
// with bounces it receives more light, as the path-traced reference does.
TEST(Transfer, BouncesAddLightFromTheObjectItselfAsTheReferenceDoes) {
  Mesh cup;  // floor and four walls of a unit box, open at the top (y = 1)
  cup.positions = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1}};
  cup.triangles = {{0, 2, 1}, {0, 3, 2}, {0, 1, 5}, {0, 5, 4}, {1, 2, 6},
                   {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  // Floor vertex normals up (+y), wall normals inwards: give them explicitly
  // at a floor-centre vertex by adding one.
  cup.positions.push_back({0.5f, 0.0f, 0.5f});
  cup.triangles[0] = {0, 8, 1};
  cup.triangles[1] = {1, 8, 2};
  cup.triangles.push_back({2, 8, 3});
  cup.triangles.push_back({3, 8, 0});
  Image env = ConstantEnv(1.0f);
  TransferOptions o;
  o.resolution = 8;
  o.albedo = 0.8;
  TransferStats st;
  o.bounces = 0;
  auto t0 = ComputeTransfer(cup, o, &st);
  o.bounces = 3;
  auto t3 = ComputeTransfer(cup, o, &st);
  auto shade = [&](const VertexTransfer& t) {
    return ShadeVertices(t, ProjectEnvironment(env, "c", t.header, Eigen::Matrix3d::Identity()),
                         Eigen::Vector3d::Constant(0.8), nullptr)[8];
  };
  const double l0 = shade(t0).x(), l3 = shade(t3).x();
  const double r0 = ReferenceVertexRadiance(cup, env, "c", Eigen::Matrix3d::Identity(), 0.8, 0, 4096, 1)[8].x();
  const double r3 = ReferenceVertexRadiance(cup, env, "c", Eigen::Matrix3d::Identity(), 0.8, 3, 4096, 1)[8].x();
  EXPECT_GT(l3, l0 * 1.05);
  // 4096 samples: ~1% noise; the cell quadrature and vertex interpolation ~3%.
  EXPECT_NEAR(l0, r0, 0.05 * r0);
  EXPECT_NEAR(l3, r3, 0.05 * r3);
}

TEST(Transfer, NormalsFlippedMissingAndDegenerateFacesAreReported) {
  Mesh m = Quad();
  m.normals = {{0, 1, 0}, {0, -1, 0}, {0, 1, 0}, {0, 1, 0}};  // one flipped
  m.positions.push_back({5, 5, 5});                           // a vertex used only by a zero-area face
  m.triangles.push_back({4, 4, 0});
  m.normals.push_back({0, 1, 0});
  m.positions.push_back({0, 1, 0});  // a fin standing on the diagonal 0-2: that edge has three faces
  m.normals.push_back({-0.7071f, 0, 0.7071f});
  m.triangles.push_back({0, 2, 5});
  TransferOptions o;
  o.resolution = 2;
  TransferStats st;
  ComputeTransfer(m, o, &st);
  EXPECT_EQ(st.normals_flipped, 1);
  EXPECT_EQ(st.degenerate_faces, 1);
  EXPECT_EQ(st.vertices_without_normal, 1);
  EXPECT_EQ(st.nonmanifold_edges, 1);
}

// A sun 1e6 times the sky in SH of order 8: the truncated series rings to
// negative values on the far side; the Lanczos window damps that, and what
// stays negative is clamped to zero and counted.
TEST(Transfer, ShRingingUnderASunIsWindowedAndClamped) {
  Mesh sphere = Sphere(0.5f, 16);
  Image env = Image::Rgb(128, 65, 1e-3f);
  for (int c = 0; c < 3; ++c) env.at(40, 16, c) = 1e3f;
  TransferOptions o;
  o.basis = TransferBasis::kSh;
  o.order = 8;
  TransferStats st;
  VertexTransfer t = ComputeTransfer(sphere, o, &st);
  int64_t raw = 0, windowed = 0;
  double raw_min = 0, windowed_min = 0;
  auto l_raw = ShadeVertices(t, ProjectEnvironment(env, "sun", t.header, Eigen::Matrix3d::Identity(), 1, false),
                             Eigen::Vector3d::Ones(), &raw, &raw_min);
  auto l_win = ShadeVertices(t, ProjectEnvironment(env, "sun", t.header, Eigen::Matrix3d::Identity(), 1, true),
                             Eigen::Vector3d::Ones(), &windowed, &windowed_min);
  EXPECT_GT(raw, 0);  // the truncated series does ring below zero, and it is counted
  // The window shrinks the negative lobes (measured: -0.0075 -> -0.0049 of a
  // peak of 0.56); it cannot remove them for a source this small.
  EXPECT_LT(raw_min, 1.3 * windowed_min) << raw_min << " " << windowed_min;
  for (const auto& v : l_win) EXPECT_TRUE(v.allFinite() && v.minCoeff() >= 0);
}

// A constant sky is band 0 only: order 1 suffices (the lat-long quadrature
// leaves ~1e-6 of its energy in higher bands, below the 1e-5 tolerance).  A
// sky with a sun needs every band.
TEST(Transfer, EffectiveShOrderFollowsTheEnvironmentsContent) {
  TransferHeader h;
  h.basis = TransferBasis::kSh;
  h.order = 8;
  h.resolution = 8;
  h.coefficients = 64;
  EXPECT_EQ(EffectiveShOrder(ProjectEnvironment(ConstantEnv(3.0f), "c", h, Eigen::Matrix3d::Identity()), 8, 1e-5), 1);
  Image sun = ConstantEnv(0.1f);
  for (int c = 0; c < 3; ++c) sun.at(20, 10, c) = 1e4f;
  EXPECT_EQ(EffectiveShOrder(ProjectEnvironment(sun, "s", h, Eigen::Matrix3d::Identity()), 8, 1e-5), 8);
}

TEST(FfcFile, RoundTripAndRefusals) {
  test::TempDir dir;
  Mesh m = Sphere(1.0f, 6);
  TransferOptions o;
  o.basis = TransferBasis::kSh;
  o.order = 3;
  TransferStats st;
  VertexTransfer t = ComputeTransfer(m, o, &st);
  const fs::path p = dir.path() / "o.ffc";
  WriteTransfer(p, t);
  VertexTransfer back = ReadTransfer(p);
  EXPECT_EQ(back.data, t.data);
  EXPECT_EQ(back.header.order, 3);
  EXPECT_EQ(back.header.mesh_hash, MeshHash(m));
  CheckTransferMatches(back, m, "o.ffc", "sphere.ply");
  Mesh moved = m;
  moved.positions[3].x() += 1e-3f;
  try {
    CheckTransferMatches(back, moved, "o.ffc", "sphere.ply");
    ADD_FAILURE() << "a changed mesh was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("another mesh"), std::string::npos) << e.what();
  }
  // Truncated and foreign files.
  fs::resize_file(p, fs::file_size(p) - 4);
  EXPECT_THROW(ReadTransfer(p), Error);
  WriteTextFile(dir.path() / "x.ffc", "not a form factor file at all, but long enough to have a header..........");
  EXPECT_THROW(ReadTransfer(dir.path() / "x.ffc"), Error);
}

// Streaming in chunks writes the same bytes as computing all at once, for
// a chunk size that does not divide the vertex count; with bounces too.
TEST(FfcFile, ChunkedStreamingWritesTheSameBytes) {
  test::TempDir dir;
  Mesh m = Sphere(1.0f, 9);
  for (int bounces : {0, 1}) {
    TransferOptions o;
    o.resolution = 3;
    o.bounces = bounces;
    o.chunk = 7;
    TransferStats a, b;
    WriteTransfer(dir.path() / "all.ffc", ComputeTransfer(m, o, &a));
    ComputeTransferToFile(m, o, dir.path() / "chunked.ffc", &b);
    EXPECT_EQ(ReadTextFile(dir.path() / "all.ffc"), ReadTextFile(dir.path() / "chunked.ffc")) << bounces;
    EXPECT_EQ(a.rays, b.rays);
  }
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {
// The .ffc header's mesh hash is part of the format: files already written
// carry it, and a reader refuses a mismatch.  Pinned on one triangle (the
// value of the hash as every earlier mr wrote it).
TEST(Transfer, MeshHashIsStable) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}};
  EXPECT_EQ(MeshHash(m), 0x37b4d1896a9e0f22ULL);
}
}  // namespace
}  // namespace mr
