#include "synth/board_view.h"

#include <cmath>

#include "core/check.h"
#include "core/error.h"
#include "core/file.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"

namespace mr {

BoardViewRenderer::BoardViewRenderer(const CameraModel& camera, int supersample)
    : width_(camera.width()), height_(camera.height()), supersample_(std::max(1, supersample)) {
  const int S = supersample_, WS = width_ * S;
  rays_.assign(static_cast<size_t>(WS) * height_ * S, Eigen::Vector3d::Constant(NAN));
  ParallelFor(0, static_cast<int64_t>(height_) * S, [&](int64_t row) {
    const int y = static_cast<int>(row / S), sy = static_cast<int>(row % S);
    Eigen::Vector3d prev;  // the last ray along the row: the next one starts from it
    bool have_prev = false;
    for (int x = 0; x < width_; ++x)
      for (int sx = 0; sx < S; ++sx) {
        const Eigen::Vector2d q(x - 0.5 + (sx + 0.5) / S, static_cast<double>(y) - 0.5 + (sy + 0.5) / S);
        Eigen::Vector3d d;
        have_prev = have_prev ? camera.UnprojectNear(q, prev, &d) : camera.Unproject(q, &d);
        if (!have_prev) continue;
        prev = d;
        rays_[static_cast<size_t>(row) * WS + x * S + sx] = d;
      }
  });
}

Image BoardViewRenderer::Render(const BoardSpec& b, const Rigid3& cam_from_board, const BoardViewOptions& o) const {
  MR_CHECK_MSG(std::max(1, o.supersample) == supersample_, "BoardViewRenderer: made for supersample {}, asked for {}",
               supersample_, o.supersample);
  const int W = width_, H = height_, S = supersample_, WS = W * S;
  const Rigid3 board_from_cam = cam_from_board.Inverse();
  const Eigen::Matrix3d R = board_from_cam.rotation.toRotationMatrix();
  const Eigen::Vector3d c = board_from_cam.translation;  // camera centre in the board frame
  const double sq = b.square_m;
  const double paper = std::min(1.0, 0.9 * o.exposure), ink = std::min(1.0, 0.05 * o.exposure);
  // Board frame: inner corner (0, 0) at the origin; squares from -1 to inner+0 squares, margin one more.
  auto shade = [&](double x, double y) {
    const double u = x / sq + 1, v = y / sq + 1;  // in squares, 0 at the outer edge of the printed grid
    if (u < -1 || v < -1 || u > b.squares_x() + 1 || v > b.squares_y() + 1) return o.background * o.exposure;
    if (u < 0 || v < 0 || u >= b.squares_x() || v >= b.squares_y()) return paper;
    const int i = static_cast<int>(std::floor(u)), j = static_cast<int>(std::floor(v));
    return ((i + j) % 2 == 0) ? ink : paper;  // the top-left square is black
  };
  Image img = Image::Gray(W, H);
  ParallelFor(0, H, [&](int64_t y) {
    for (int x = 0; x < W; ++x) {
      double sum = 0;
      for (int sy = 0; sy < S; ++sy)
        for (int sx = 0; sx < S; ++sx) {
          const Eigen::Vector3d& d = rays_[static_cast<size_t>(y * S + sy) * WS + x * S + sx];
          if (std::isnan(d.x())) continue;  // outside the lens: black
          const Eigen::Vector3d db = R * d;
          double value = o.background * o.exposure;
          if (std::abs(db.z()) > 1e-12) {
            const double t = -c.z() / db.z();
            if (t > 0) value = shade(c.x() + t * db.x(), c.y() + t * db.y());
          }
          sum += std::min(1.0, value);
        }
      img.at(x, static_cast<int>(y), 0) = static_cast<float>(sum / (S * S));
    }
  });
  GaussianBlur(&img, o.blur_sigma_px);
  if (o.noise_sigma > 0)
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        Pcg32 rng(o.seed, static_cast<uint64_t>(y) * W + x);
        const double u1 = std::max(1e-12, rng.NextDouble()), u2 = rng.NextDouble();
        const double g = std::sqrt(-2 * std::log(u1)) * std::cos(kTwoPi * u2);
        img.at(x, y, 0) = static_cast<float>(Clamp(img.at(x, y, 0) + o.noise_sigma * g, 0.0, 1.0));
      }
  return img;
}

Image RenderBoardView(const BoardSpec& b, const CameraModel& camera, const Rigid3& cam_from_board,
                      const BoardViewOptions& o) {
  return BoardViewRenderer(camera, o.supersample).Render(b, cam_from_board, o);
}

std::vector<Rigid3> CalibrationBoardPoses(const BoardSpec& b, int n) {
  std::vector<Rigid3> out;
  const Eigen::Vector3d centre(0.5 * (b.inner_x - 1) * b.square_m, 0.5 * (b.inner_y - 1) * b.square_m, 0);
  for (int i = 0; i < n; ++i) {
    const double a = kTwoPi * i / n;
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.15 * std::sin(3 * a), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(0.45 * std::cos(a), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.45 * std::sin(a), Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    const Eigen::Vector3d at(0.09 * std::cos(a) * (i % 2 ? 1.0 : 0.4), 0.07 * std::sin(a) * (i % 2 ? 1.0 : 0.4),
                             0.32 + 0.1 * (i % 3));
    out.emplace_back(Eigen::Quaterniond(R), at - R * centre);
  }
  return out;
}

std::vector<Rigid3> FisheyeBoardPoses(const BoardSpec& b, double distance) {
  std::vector<Rigid3> out;
  const Eigen::Vector3d centre(0.5 * (b.inner_x - 1) * b.square_m, 0.5 * (b.inner_y - 1) * b.square_m, 0);
  int n = 0;
  for (double theta : {0.0, 30.0, 55.0, 78.0})
    for (int az = 0; az < (theta == 0 ? 2 : 5); ++az, ++n) {
      const double phi = kTwoPi * (az + 0.5 * (theta > 50)) / 5;
      const Eigen::Vector3d u(std::sin(theta * kDegToRad) * std::cos(phi), std::sin(theta * kDegToRad) * std::sin(phi),
                              std::cos(theta * kDegToRad));
      // The board faces the camera (its z along u), turned about u and tilted.
      const Eigen::Matrix3d face = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), u).toRotationMatrix();
      const Eigen::Matrix3d R = face * Eigen::AngleAxisd(0.3 * az, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                                Eigen::AngleAxisd(0.35 * ((n % 3) - 1), Eigen::Vector3d::UnitX()).toRotationMatrix();
      out.emplace_back(Eigen::Quaterniond(R), distance * u - R * centre);
    }
  return out;
}

std::vector<fs::path> WriteBoardSet(const std::string& lens, const BoardSpec& b, const fs::path& out, uint64_t seed,
                                    const std::string& note) {
  struct Cam {
    std::string name;
    CameraModel model;
    Rigid3 cam_from_ref;
  };
  std::vector<Cam> cams;
  std::vector<Rigid3> poses;
  if (lens == "pinhole") {
    cams.push_back({"camera", CameraModel("LENSMODEL_PINHOLE", {500, 500, 319.5, 239.5}, 640, 480), Rigid3()});
    poses = CalibrationBoardPoses(b, 14);
  } else if (lens == "opencv8" || lens == "rig") {
    cams.push_back(
        {lens == "rig" ? "cam0" : "camera",
         CameraModel("LENSMODEL_OPENCV8", {440, 442, 321, 238, 0.08, -0.05, 0.001, -0.0015, 0, 0, 0, 0}, 640, 480),
         Rigid3()});
    poses = CalibrationBoardPoses(b, 16);
    if (lens == "rig") {
      const Rigid3 cam1_from_cam0(
          Eigen::Quaterniond(Eigen::AngleAxisd(4 * kDegToRad, Eigen::Vector3d(0.2, 1, 0.1).normalized())),
          Eigen::Vector3d(-0.11, 0.004, 0.002));
      cams.push_back({"cam1",
                      CameraModel("LENSMODEL_OPENCV8", {400, 401, 316, 242, 0.05, -0.02, -0.001, 0.001, 0, 0, 0, 0},
                                  640, 480, cam1_from_cam0),
                      cam1_from_cam0});
      for (Rigid3& p : poses) p.translation += Eigen::Vector3d(0.055, 0, 0.05);  // both cameras see most boards
    }
  } else if (lens == "fisheye190") {
    // 2 f tan(95 deg / 2) = 320 px: 190 degrees across; a smooth distortion on the knots.
    const std::string name = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=8_fov_x_deg=200";
    std::vector<double> k = {146.6, 146.6, 319.5, 319.5};
    for (int i = 0; i < 2 * 8 * 8; ++i) k.push_back(0.01 * std::sin(0.7 * i));
    cams.push_back({"camera", CameraModel(name, k, 640, 640), Rigid3()});
    poses = FisheyeBoardPoses(b, 0.3);
  } else if (LowerExtension(lens) == ".cameramodel") {
    // Any camera, e.g. a capture's (mr-synth --preset medium writes
    // camera.cameramodel): the same views as the pinhole set.
    cams.push_back({"camera", CameraModel::Read(lens), Rigid3()});
    poses = CalibrationBoardPoses(b, 14);
  } else {
    throw UsageError(
        fmt::format("unknown --boards lens \"{}\" (pinhole, opencv8, fisheye190, rig or a .cameramodel)", lens));
  }
  std::vector<fs::path> written;
  std::error_code ec;
  fs::create_directories(out / "truth", ec);
  fs::create_directories(out / "photos", ec);
  if (!fs::is_directory(out / "photos")) ThrowErrorAt(FileLoc{out.string()}, "cannot create the folder");
  WriteTextFile(out / "board.json", BoardToJson(b).dump(2) + "\n");
  written.push_back(out / "board.json");
  // The views the calibration must leave out: blurred, over-exposed, and
  // the board pushed half out of the frame.
  const Rigid3 half_out(poses[0].rotation,
                        poses[0].translation + Eigen::Vector3d(0.6 * poses[0].translation.z(), 0, 0));
  for (const Cam& c : cams) {
    c.model.Write(out / "truth" / (c.name + ".cameramodel"), note);
    const BoardViewRenderer renderer(c.model, 2);
    written.push_back(out / "truth" / (c.name + ".cameramodel"));
    for (size_t i = 0; i < poses.size() + 3; ++i) {
      BoardViewOptions vo;
      vo.supersample = 2;
      vo.noise_sigma = 0.01;
      vo.seed = HashCombine(seed, i * 7 + static_cast<uint64_t>(&c - cams.data()));
      Rigid3 pose = i < poses.size() ? poses[i] : poses[i - poses.size()];
      if (i == poses.size()) vo.blur_sigma_px = 6;
      if (i == poses.size() + 1) vo.exposure = 20;
      if (i == poses.size() + 2) pose = half_out;
      const fs::path f = out / "photos" / fmt::format("{}-{:02d}.png", c.name, i);
      WriteImage(f, renderer.Render(b, c.cam_from_ref * pose, vo));
      written.push_back(f);
    }
  }
  return written;
}

}  // namespace mr
