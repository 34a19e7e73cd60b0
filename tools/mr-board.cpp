// mr-board: a printable calibration board (SVG at physical size).
#include <spdlog/spdlog.h>

#include "calib/board.h"
#include "cli/tool.h"
#include "core/error.h"
#include "core/file.h"

int main(int argc, char** argv) {
  CLI::App app;
  std::string board_file, out;
  int nx = 0, ny = 0;
  double square_mm = 0, margin_mm = 5;
  mr::ConfigureApp(app, "mr-board",
                   "Writes a calibration board as an SVG at its physical size, to print at 100% scale.\n"
                   "Give a board definition (calib/boards/*.json: chessboard or ChArUco) or\n"
                   "--inner-corners and --square-mm for a chessboard.",
                   "  mr-board calib/boards/mrgingham-10x10-30mm.json --out board.svg\n"
                   "  mr-board calib/boards/charuco-8x11-A4.json --out charuco.svg\n"
                   "  mr-board --inner-corners 9x6 --square-mm 24.23 --out board.svg");
  app.add_option("board", board_file, "Board definition (JSON)")->check(CLI::ExistingFile);
  app.add_option_function<std::string>(
      "--inner-corners",
      [&](const std::string& s) {
        if (std::sscanf(s.c_str(), "%dx%d", &nx, &ny) != 2)
          throw CLI::ValidationError("--inner-corners", "expected NxM");
      },
      "Inner corners, NxM (e.g. 10x10)");
  app.add_option("--square-mm", square_mm, "Square side in millimetres")->check(mr::kPositive);
  app.add_option("--margin-mm", margin_mm, "White margin around the board, millimetres")
      ->default_val(5)
      ->check(mr::kNonNegative);
  double ppmm = 20;
  app.add_option("--charuco-ppmm", ppmm, "ChArUco raster resolution, pixels per millimetre")
      ->default_val(20)
      ->check(mr::InRange(1.0, 100.0));
  app.add_option("--out", out, "Output SVG")->required();
  return mr::RunTool("mr-board", app, argc, argv, [&] {
    mr::BoardSpec b;
    if (!board_file.empty()) {
      b = mr::ReadBoard(board_file);
    } else {
      if (nx == 0 || square_mm == 0) throw mr::UsageError("give a board file, or --inner-corners and --square-mm");
      mr::Json j = {{"name", fmt::format("chessboard-{}x{}-{}mm", nx, ny, square_mm)},
                    {"inner_corners", {nx, ny}},
                    {"square_mm", square_mm}};
      b = mr::ParseBoard(j, "command line");
    }
    if (!board_file.empty()) mr::ToolReport().AddInput(board_file);
    mr::WriteTextFile(out, mr::BoardSvg(b, margin_mm / 1000.0, ppmm));
    mr::ToolReport().AddOutput(out);
    mr::ToolReport().SetMetric("board.inner_corners", {b.inner_x, b.inner_y});
    mr::ToolReport().SetMetric("board.square_mm", b.square_m * 1000.0);
    // The page at 100 %, and the smallest ISO A sheet that holds it.
    const auto [w, h] = mr::BoardPageMm(b, margin_mm);
    const std::string paper = mr::SmallestIsoA(w, h);
    mr::ToolReport().SetMetric("page_mm", {w, h});
    mr::ToolReport().SetMetric("paper", paper);
    spdlog::info("wrote {} ({} x {} inner corners, {} mm squares; the page is {:.0f} x {:.0f} mm: {})", out, b.inner_x,
                 b.inner_y, b.square_m * 1000, w, h, paper.empty() ? "larger than A0" : "fits " + paper);
    if (paper != "A4")
      mr::ToolReport().Warn(fmt::format(
          "the page is {:.0f} x {:.0f} mm, larger than A4 (210 x 297 mm): print it on {} at 100 %, or use a board "
          "made for A4 (calib/boards/charuco-8x11-A4.json, or --inner-corners and --square-mm)",
          w, h, paper.empty() ? "a plotter" : paper));
    return mr::kExitOk;
  });
}
