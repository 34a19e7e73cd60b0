// Merging the reports of mr-render shards (`mr-render --frames A:B` run on
// several machines) into one report and one composite video (mr-eval merge,
// docs/cluster.md).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/report.h"

namespace mr {

struct ShardMergeOptions {
  std::vector<fs::path> reports;  // one per shard, any order
  std::optional<fs::path> video;  // write the composites, in frame order, as this video
  double fps = 0;                 // 0: the plate's (the shards' plate_fps), else 30
  // A range that no shard rendered is an error unless allowed (a partial merge).
  bool allow_gaps = false;

  // UsageError: no reports, a negative --fps.
  void Check() const;
};

// Checks that the shards belong to one job (same tool, method and scene; no
// frame rendered twice; together they cover 0..scene_frames unless
// allow_gaps) and fills `report`: inputs, outputs, skipped parts and warnings
// of every shard; timings summed; metrics.frames in frame order; rmse,
// relmse, region_relmse and the error-vs-time curve averaged over frames as
// one run computes them.  Throws mr::Error naming the report at fault.
void MergeRenderReports(const ShardMergeOptions& options, Report* report);

}  // namespace mr
