#!/usr/bin/python3
"""Error against time plots from a CSV of runs (bench_transfer_error's, or any CSV
with the columns mesh, environment, basis, bounces, precompute_s, relative_rms).

    /usr/bin/python3 scripts/plot_error_time.py runs.csv out.svg
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    panels = sorted({(r["mesh"], r["environment"]) for r in rows})
    cols = min(3, len(panels))
    nrows = (len(panels) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(4.2 * cols, 3.6 * nrows), squeeze=False)
    flat = [a for row in axes for a in row]
    for ax in flat[len(panels):]:
        ax.axis("off")
    for ax, (mesh, env) in zip(flat, panels):
        lines = defaultdict(list)
        for r in rows:
            if (r["mesh"], r["environment"]) == (mesh, env):
                lines[(r["basis"], r["bounces"])].append((float(r["precompute_s"]), float(r["relative_rms"]), r["size"]))
        for (basis, bounces), pts in sorted(lines.items()):
            # in the CSV's order: increasing resolution or order
            style = "-" if bounces == "0" else "--"
            ax.plot([p[0] for p in pts], [p[1] for p in pts], style, marker="o" if basis == "cube" else "s",
                    label=f"{basis}, {bounces} bounces")
        noise = [float(r["reference_noise"]) for r in rows if (r["mesh"], r["environment"]) == (mesh, env)]
        if noise:
            ax.axhline(max(noise), color="grey", lw=0.8, ls=":", label="reference noise")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(f"{mesh}\n{env}", fontsize=9)
        ax.set_xlabel("precomputation (s, 2 threads)")
        ax.grid(True, which="both", lw=0.3)
    for row in axes:
        row[0].set_ylabel("relative RMS error of vertex radiance")
    flat[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
