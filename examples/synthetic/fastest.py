"""Prints mr-eval sweep's table of the fastest method to each of pt's
errors (examples/run.sh, for each capture).
Usage: fastest.py SWEEP_REPORT.json"""
import json
import sys

for x in json.load(open(sys.argv[1]))["metrics"].get("fastest", []):
    n = x.get("nearest")
    print("  pt %-7s %.3g in %.2f s a frame: %s" % (
        x["pt_setting"], x["error"], x["pt_seconds"],
        ("pt itself is the fastest" + ("; nearest: %s %s, %.2fx its error in %.2fx its time" % (
            n["method"], n["setting"], n["error_ratio"], n["time_ratio"]) if n else ""))
        if x["method"] == "pt"
        else "%s %s in %.2f s, %.1fx faster" % (x["method"], x["setting"], x["seconds"], x["speedup"])))
