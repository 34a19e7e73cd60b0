#!/usr/bin/python3
"""python3-mrcal as a test-time oracle for mr-calibrate: reads the solved problem
(CalibrationResult::problem as JSON) and a list of pixels, and prints, per pixel, mrcal's
worst-direction projection uncertainty at infinity (with mr's observation noise), and the RMS
of mrcal's own residuals at mr's solution.

    /usr/bin/python3 mrcal_oracle.py problem.json
"""
import json
import sys

import mrcal
import numpy as np


def main():
    d = json.load(open(sys.argv[1]))
    nx, ny = d["nx"], d["ny"]
    obs = np.array(d["observations_board"], dtype=float).reshape(-1, ny, nx, 3)
    n = obs.shape[0]
    inputs = dict(
        intrinsics=np.array([d["intrinsics"]], dtype=float),
        extrinsics_rt_fromref=np.zeros((0, 6)),
        frames_rt_toref=np.array(d["frames_rt_toref"], dtype=float).reshape(-1, 6),
        points=None,
        observations_board=obs,
        indices_frame_camintrinsics_camextrinsics=np.array([[i, 0, -1] for i in range(n)], dtype=np.int32),
        observations_point=None,
        indices_point_camintrinsics_camextrinsics=None,
        lensmodel=d["lensmodel"],
        imagersizes=np.array([d["imagersize"]], dtype=np.int32),
        calobject_warp=None,
        do_optimize_intrinsics_core=True,
        do_optimize_intrinsics_distortions=True,
        do_optimize_extrinsics=True,  # no extrinsics here: the same problem; mrcal requires the flag for uncertainty
        do_optimize_frames=True,
        do_optimize_calobject_warp=False,
        do_apply_regularization=True,
        do_apply_outlier_rejection=False,
        calibration_object_spacing=d["spacing"],
        point_min_range=-1.0,
        point_max_range=-1.0,
        verbose=False,
    )
    model = mrcal.cameramodel(optimization_inputs=inputs, icam_intrinsics=0)
    x = mrcal.optimizer_callback(**inputs)[1]
    nobs = n * nx * ny * 2
    w = obs[..., 2].ravel()
    inl = np.repeat(w > 0, 2)
    print("rms_per_coordinate %.6f" % np.sqrt(np.mean(x[:nobs][inl] ** 2)))
    for q in d["pixels"]:
        v = mrcal.unproject(np.array(q, dtype=float), *model.intrinsics())
        s = mrcal.projection_uncertainty(v, model, atinfinity=True, what="worstdirection-stdev",
                                         observed_pixel_uncertainty=d["noise_px"])
        print("%.3f %.3f %.6f" % (q[0], q[1], s))


if __name__ == "__main__":
    main()
