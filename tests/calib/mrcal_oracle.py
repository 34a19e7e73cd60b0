#!/usr/bin/python3
"""python3-mrcal as a test-time oracle for mr-calibrate: reads a .cameramodel written by mr (with
its optimisation inputs) the way mrcal's own tools do, and prints

    rms_per_coordinate R          mrcal's inlier residuals at mr's solution
    default_noise S               the observation noise mrcal assumes by default
    x y ux uy uz sigma sigma_def  per pixel: mrcal's unprojection (unit vector) and its worst-direction
                                  projection uncertainty at infinity, with mr's noise and with mrcal's

    /usr/bin/python3 mrcal_oracle.py CAMERA.cameramodel NOISE_PX x0 y0 x1 y1 ...
"""
import sys

import mrcal
import numpy as np


def main():
    model = mrcal.cameramodel(sys.argv[1])
    noise = float(sys.argv[2])
    q = np.array([float(v) for v in sys.argv[3:]]).reshape(-1, 2)
    inputs = model.optimization_inputs()
    x = mrcal.optimizer_callback(**inputs)[1]
    r = mrcal.residuals_chessboard(inputs, residuals=x)
    w = inputs["observations_board"][..., 2].ravel()
    nobs = w.size * 2
    inl = np.repeat(w > 0, 2)
    print("rms_per_coordinate %.6f" % np.sqrt(np.mean(x[:nobs][inl] ** 2)))
    print("default_noise %.6f" % np.std(r.ravel()))
    for p in q:
        v = mrcal.unproject(p, *model.intrinsics(), normalize=True)
        s = mrcal.projection_uncertainty(v, model, atinfinity=True, what="worstdirection-stdev",
                                         observed_pixel_uncertainty=noise)
        s_def = mrcal.projection_uncertainty(v, model, atinfinity=True, what="worstdirection-stdev")
        print("%.3f %.3f %.12f %.12f %.12f %.6f %.6f" % (p[0], p[1], v[0], v[1], v[2], s, s_def))


if __name__ == "__main__":
    main()
