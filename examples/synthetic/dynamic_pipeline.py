"""The pipeline file of mr-synth --dynamic's capture (examples/run.sh): the
capture's room, video and trajectory, and its light captured per frame from
the light camera's video (a zenith fish-eye at its own clock, matched to the
plate's timestamps, each frame's exposure read), as a user would write it
beside the capture.  Usage: dynamic_pipeline.py CAPTURE/scene.json > pipeline.json"""
import json
import sys

s = json.load(open(sys.argv[1]))


def rebase(p):
    return "capture/" + p


json.dump({
    "version": 1,
    "comment": "examples/run.sh: the dynamic capture's chain (light captured per frame, a trajectory)",
    "work": "work",
    "camera": {"model": "capture/camera.cameramodel"},
    "lighting": {"light_video": {"frames": "capture/lightcam/frames.txt",
                                 "fisheye": "capture/lightcam/fisheye.cameramodel",
                                 "exposures": "capture/lightcam/exposures.txt",
                                 "options": {"width": 256, "time-constant": 0.1}},
                 "lights": rebase(s["lighting"]["lights"])},
    "room": {"real": [{"mesh": rebase(r["mesh"]), "material": r["material"]} for r in s["real"]]},
    "video": {"frames": rebase(s["camera"]["frames"]), "frames_transfer": "linear",
              "poses": {"tum": rebase(s["camera"]["poses"]["path"])}},
    "virtual": [dict(v, mesh=rebase(v["mesh"])) for v in s["virtual"]],
    "render": {"method": "pt", "spp": 16, "max_depth": 8, "seed": 1},
    "output": {"review": True},
    "reference": rebase(s["reference"]),
    "outputs": {"render": True},
}, sys.stdout, indent=1)
print()
