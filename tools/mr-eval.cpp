// mr-eval: image comparison (and, with later issues, error-vs-time tables).
#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/image.h"
#include "eval/metrics.h"
#include "tool/cli.h"

int main(int argc, char** argv) {
  CLI::App app;
  std::string a, b, region, diff;
  double scale = 10;
  mr::ConfigureApp(app, "mr-eval", "Evaluates renders against references.",
                   "  mr-eval compare render/00000.exr capture/truth/00000.exr --diff diff.png --scale 10 "
                   "--report compare.json");
  app.require_subcommand(1);
  CLI::App* cmp = app.add_subcommand(
      "compare",
      "RMSE, relative MSE, PSNR and SSIM of A against the reference B (metric definitions in\n"
      "docs/formats.md), over the image or the pixels where --region is > 0. EXR renders are\n"
      "compared by their composite layer.");
  cmp->fallthrough();  // --report, --threads ... after the subcommand
  cmp->add_option("A", a, "Estimate (image, or mr-render EXR)")->required()->check(CLI::ExistingFile);
  cmp->add_option("B", b, "Reference")->required()->check(CLI::ExistingFile);
  cmp->add_option("--region", region, "One-channel image: compare where > 0")->check(CLI::ExistingFile);
  cmp->add_option("--diff", diff, "Write |A - B| x scale (e.g. diff.png or diff.exr)");
  cmp->add_option("--scale", scale, "Scale of the difference image")->default_val(10)->check(CLI::PositiveNumber);
  return mr::RunTool("mr-eval", app, argc, argv, [&] {
    mr::Image ia = mr::ReadRgbForComparison(a), ib = mr::ReadRgbForComparison(b);
    std::optional<mr::Image> reg;
    if (!region.empty()) {
      mr::Image r = mr::ReadImage(region);
      reg = r.channels() == 1 ? r : r.Layer(r.LayerNames().front());
    }
    mr::ImageMetrics m = mr::CompareImages(ia, ib, reg ? &*reg : nullptr);
    auto& rep = mr::ToolReport();
    rep.AddInput(a);
    rep.AddInput(b);
    rep.SetMetric("rmse", m.rmse);
    rep.SetMetric("relmse", m.relmse);
    rep.SetMetric("psnr", m.psnr);
    rep.SetMetric("ssim", m.ssim);
    rep.SetMetric("pixels", m.pixels);
    std::printf("rmse %.6g relmse %.6g psnr %.4g dB ssim %.6g (%lld pixels)\n", m.rmse, m.relmse, m.psnr, m.ssim,
                static_cast<long long>(m.pixels));
    if (!diff.empty()) {
      mr::WriteImage(diff, mr::ScaledDifference(ia, ib, scale));
      rep.AddOutput(diff);
    }
    return mr::kExitOk;
  });
}
