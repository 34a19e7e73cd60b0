// mr-hdr: merges bracketed exposures into linear radiance with its variance.
#include "cli/tool.h"
#include "hdr/hdr_job.h"

int main(int argc, char** argv) {
  CLI::App app;
  mr::HdrJobOptions o;
  mr::ExposureMergeOptions& mo = o.merge;
  mr::ResponseOptions& ro = o.response;
  mr::ConfigureApp(
      app, "mr-hdr",
      "Merges bracketed exposures of a still scene (a mirror sphere, a fish-eye view of the room) into\n"
      "linear radiance. Exposure times come from EXIF (ExposureTime, with FNumber and ISO when present)\n"
      "or from --exposures FILE. 8- and 16-bit inputs go through the camera's response: recovered from\n"
      "the bracket (Debevec-Malik or Robertson; --save-response keeps it) or read with --response.\n"
      "Float inputs (EXR, float TIFF) and --linear inputs are linear already.\n"
      "Samples are weighted by their noise (read, shot and quantisation noise through the response),\n"
      "saturated and black samples are left out, things that moved are detected and taken from one\n"
      "exposure, and pixels saturated in every exposure (the sun) are censored: flagged, given a lower\n"
      "bound, and filled from a fit of the blurred source in the shortest exposure.\n"
      "Output: float32 EXR with R G B (radiance in the response's units per second), variance.R/G/B,\n"
      "saturated.Y and ghost.Y (docs/formats.md).",
      "  mr-hdr memorial*.png --exposures shutter_times.txt --save-response response.json --out memorial.exr\n"
      "  mr-hdr ball_*.JPG --align --response response.json --out probe-raw.exr --report hdr.json");
  app.add_option("images", o.images, "The bracket's photographs, any order")->required()->check(CLI::ExistingFile);
  app.add_option("--out", o.out, "Merged EXR")->required();
  app.add_option("--exposures", o.exposures,
                 "Exposure times: one per line in the images' order, or FILENAME TIME lines")
      ->check(CLI::ExistingFile);
  app.add_option("--response", o.response_in, "Use this response.json (from --save-response) instead of recovering one")
      ->check(CLI::ExistingFile);
  app.add_option("--save-response", o.response_out, "Write the recovered response here");
  app.add_option("--method", ro.method, "Response recovery: debevec or robertson")
      ->check(CLI::IsMember({"debevec", "robertson"}))
      ->default_val("debevec");
  app.add_option("--smoothness", ro.smoothness, "Debevec's lambda")->default_val(50);
  app.add_flag("--linear", o.linear, "8/16-bit inputs are linear (no response)");
  app.add_flag("--align", o.align, "Align hand-held brackets (median threshold bitmaps); crops of different sizes too");
  app.add_option("--low", mo.low, "Normalised codes at or below this are too dark to use")->default_val(0.02);
  app.add_option("--high", mo.high, "Normalised codes at or above this are saturated")->default_val(0.97);
  app.add_option("--ghost-sigma", mo.ghost_sigma, "Samples this many sigma apart mark a ghost")->default_val(5);
  bool no_ghosts = false, no_fit = false;
  app.add_flag("--no-ghosts", no_ghosts, "Do not detect ghosts");
  app.add_flag("--no-censored-fit", no_fit, "Censored pixels keep their lower bound");
  app.add_flag("--half", o.half, "Write half floats (refused when a value exceeds 65504)");
  return mr::RunTool("mr-hdr", app, argc, argv, [&] {
    mo.ghosts = !no_ghosts;
    mo.fit_censored = !no_fit;
    o.command_line = mr::JoinCommandLine(argc, argv);
    mr::RunHdrMerge(o, &mr::ToolReport());
    return mr::kExitOk;
  });
}
