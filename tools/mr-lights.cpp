// mr-lights: light sources from an environment map, and what they leave out.
#include "cli/tool.h"
#include "jobs/lights_job.h"

int main(int argc, char** argv) {
  CLI::App app;
  mr::LightsJobOptions o;
  mr::ExtractOptions& eo = o.extract;
  mr::ConfigureApp(
      app, "mr-lights",
      "Extracts light sources from a lat-long environment map (mr-probe's env.exr, or any lat-long\n"
      "EXR/HDR): median cut on a double-precision, solid-angle-weighted summed-area table; variance-\n"
      "minimising cut; hierarchical importance warping (N VPLs); or thresholded connected blobs as area\n"
      "lights. Writes lights.json (distant lights, real, with their solid angle and the residual's\n"
      "spherical harmonics) and with --residual the map minus what the lights took, downsampled keeping\n"
      "energy: lights + residual integrate to the map. The report gives the extraction time and the\n"
      "error of diffuse irradiance over all normal directions against the full map.\n"
      "--sweep runs every method at every count and writes the error-vs-count table (CSV) and plot (SVG).\n"
      "Over time: with printf patterns (env/%05d.exr, --out lights/%05d.json), one lights file per map,\n"
      "each light keeping its name (lightN) across frames while it stays within --match-deg of where it\n"
      "was, so that a renderer can tell a light that moved from one that appeared.",
      "  mr-lights env.exr --method median-cut --count 64 --out lights.json --residual residual.exr\n"
      "  mr-lights env.exr --method blobs --count 4 --threshold 20 --out sun.json --residual rest.exr\n"
      "  mr-lights pisa.hdr --sweep --table pisa.csv --plot pisa.svg\n"
      "  mr-lights 'env/%05d.exr' --method blobs --count 4 --out 'lights/%05d.json' --residual "
      "'residual/%05d.exr'");
  app.add_option("env", o.env, "Lat-long environment map (R G B first), or a printf pattern of one per frame")
      ->required();
  app.add_option("--match-deg", o.match_deg,
                 "Over time: a light within this angle of one of the last frame keeps its name")
      ->default_val(10)
      ->check(mr::kNonNegative);
  app.add_option("--out", o.out, "lights.json to write");
  app.add_option("--method", eo.method, "median-cut, variance-cut, importance or blobs")
      ->check(CLI::IsMember({"median-cut", "variance-cut", "importance", "blobs"}))
      ->default_val("median-cut");
  app.add_option("--count", eo.count, "Number of lights (blobs: at most)")->default_val(16);
  app.add_option("--threshold", eo.threshold, "blobs: pixels above this times the mean radiance")->default_val(8);
  app.add_option("--saddle", eo.saddle,
                 "blobs: two peaks of one bright region stay two lights where the light between them falls below "
                 "this fraction of the dimmer peak")
      ->default_val(0.5);
  app.add_option("--max-blob-sr", eo.max_blob_sr,
                 "blobs: a region whose core (the brightest pixels holding half its energy, twice over) is wider "
                 "than this stays in the map with its shape (a window, a panel), steradians")
      ->default_val(0.05);
  app.add_option("--sh-order", eo.sh_order, "Bands of the residual's spherical harmonics")->default_val(3);
  app.add_option("--room", o.room,
                 "blobs: the room's mesh; each light whose directions from the probe land on it becomes an area "
                 "light there (lights.json \"area\"), the rest stay at infinity")
      ->check(CLI::ExistingFile);
  app.add_option("--probe-at", o.probe_at, "The probe's centre X,Y,Z in the map's frame (metres), for --room")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--mirror-tolerance-deg", o.mirror_tolerance_deg,
                 "With --room: a light landing where a brighter one's mirror direction points within this angle (plus "
                 "its radius) is its reflection in a glossy surface, left to the room's own light, not placed")
      ->default_val(5)
      ->check(CLI::Range(0.0, 90.0));
  app.add_option("--residual", o.residual,
                 "Write the map minus what the lights took (EXR); with --room only the directions that leave the "
                 "room, the rest filled from the sky around them (the room's own light is --room-map's)");
  app.add_option("--room-map", o.room_map,
                 "With --room: write the map minus the lights at full size, what the probe saw of the room "
                 "(scene.json lighting.probes' map)");
  app.add_option("--residual-width", o.residual_width, "Width of the residual map (energy-preserving downsampling)")
      ->default_val(64);
  app.add_option("--normals", o.normals, "Normal directions for the irradiance error")->default_val(1024);
  app.add_flag("--sweep", o.sweep, "Error against count for every method (with --table, --plot)");
  app.add_option("--methods", o.methods, "Methods for --sweep")->delimiter(',');
  app.add_option("--counts", o.counts, "Counts for --sweep, comma-separated");
  app.add_option("--table", o.table, "--sweep: CSV table");
  app.add_option("--plot", o.plot, "--sweep: SVG plot of irradiance error against count");
  return mr::RunTool("mr-lights", app, argc, argv, [&] {
    o.command_line = mr::JoinCommandLine(argc, argv);
    mr::RunLights(o, &mr::ToolReport());
    return mr::kExitOk;
  });
}
