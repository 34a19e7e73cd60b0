"""The pipeline file of mr-synth --dynamic's capture (examples/run.sh): the
capture's room, video and trajectory, and its light captured per frame from
the light camera's video (a zenith fish-eye at its own clock, matched to the
plate's timestamps, each frame's exposure read), as a user would write it
beside the capture.  With "sphere" after it, the light is the mirror sphere
seen in the plate itself (mr-synth --plate-sphere; plate-sphere.json says
where it stands), unwrapped from each frame's pose, into work-sphere/.
Usage: dynamic_pipeline.py CAPTURE/scene.json [sphere] > pipeline.json"""
import json
import os
import sys

s = json.load(open(sys.argv[1]))
sphere = len(sys.argv) > 2 and sys.argv[2] == "sphere"


def rebase(p):
    return "capture/" + p


if sphere:
    ps = json.load(open(os.path.join(os.path.dirname(sys.argv[1]), "plate-sphere.json")))
    light = {"sphere_in_plate": {"centre": ps["centre"], "radius": ps["radius"], "reflectance": ps["reflectance"],
                                 "options": {"width": 256, "time-constant": 0.1}}}
else:
    light = {"light_video": {"frames": "capture/lightcam/frames.txt",
                             "fisheye": "capture/lightcam/fisheye.cameramodel",
                             "exposures": "capture/lightcam/exposures.txt",
                             "options": {"width": 256, "time-constant": 0.1}}}
# The lamp is a spot light with no body: no probe sees it, its file is given.
light["lights"] = rebase(s["lighting"]["lights"])

json.dump({
    "version": 1,
    "comment": "examples/run.sh: the dynamic capture's chain (light captured per frame, a trajectory)",
    "work": "work-sphere" if sphere else "work",
    "camera": {"model": "capture/camera.cameramodel"},
    "lighting": light,
    "room": {"real": [{"mesh": rebase(r["mesh"]), "material": r["material"]} for r in s["real"]]},
    "video": {"frames": rebase(s["camera"]["frames"]), "frames_transfer": "linear",
              "poses": {"tum": rebase(s["camera"]["poses"]["path"])}},
    "virtual": [dict(v, mesh=rebase(v["mesh"])) for v in s["virtual"]],
    "render": {"method": "pt", "spp": 16, "max_depth": 8, "seed": 1},
    "output": {"review": True},
    "reference": rebase(s["reference"]),
    # Error against run time on this capture too (the light, the lamp and
    # the object change every frame): which method reaches pt's errors first.
    "outputs": {"render": True} if sphere else {
        "render": True,
        "sweep": {"options": {"methods": "pt,ic,vpl,vct", "pt-spp": "16,64", "ic-rays": 128, "ic-spp": "1,4",
                              "vpl-paths": 1024, "vpl-spp": 1, "vct-resolution": 32, "vct-spp": 4}}},
}, sys.stdout, indent=1)
print()
