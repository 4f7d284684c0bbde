"""Imperfect calibration: the rig written for estimators differs from the one the images are rendered with.

Per camera, in rig order, 13 standard normals are drawn from the ``calib_error`` stream (always all 13,
so changing one magnitude never changes another's draw) and scaled by the :class:`sim.generate_config.CalibError`
magnitudes: ``fx, fy`` times ``1 + focal_ppm 1e-6 z``; ``cx, cy`` plus ``principal_px z``; each of
``k1 k2 p1 p2 k3`` times ``1 + dist_rel z`` (zero coefficients stay zero); and ``T_b_c`` right-multiplied
by ``[R(extrinsic_rot_deg z_3) | extrinsic_trans_mm 1e-3 z_3]`` (a rotation vector in degrees and a
translation in the camera's own frame). Errors of ``T_b_c0`` are camera-IMU extrinsic errors; the
stereo extrinsic error is the combination of both cameras'. ``stereo_disparity_px`` (not drawn) lowers the
last camera's written ``cx`` by that many pixels: a constant disparity offset, every stereo depth
``f b / (d - offset)`` (the error measured on the real KITTI excerpt, docs/estimators.md).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from rigs.geometry import make_T

N_DRAWS = 15


def draw_errors(n_cameras: int, rng: np.random.Generator) -> np.ndarray:
    """(n_cameras, 15) standard normals, camera by camera: fx fy | cx cy | k1 k2 p1 p2 k3 | rot xyz | trans xyz."""
    return rng.standard_normal((n_cameras, N_DRAWS))


def perturb_camera(cam, z: np.ndarray, err):
    """``cam`` (rigs.model.Camera) with the errors ``z`` (15,) scaled by ``err`` (sim.generate_config.CalibError)."""
    from scipy.spatial.transform import Rotation
    f = 1.0 + err.focal_ppm * 1e-6 * z[0:2]
    dist = np.asarray(cam.dist, float)            # radtan k1 k2 p1 p2 k3, or equidistant k1..k4 (first 4 draws)
    dist = dist * (1.0 + err.dist_rel * z[4:4 + len(dist)])
    dR = Rotation.from_rotvec(np.deg2rad(err.extrinsic_rot_deg * z[9:12])).as_matrix()
    T_b_c = cam.T_b_c_array @ make_T(dR, err.extrinsic_trans_mm * 1e-3 * z[12:15])
    return dataclasses.replace(cam, fx=cam.fx * f[0], fy=cam.fy * f[1], cx=cam.cx + err.principal_px * z[2],
                               cy=cam.cy + err.principal_px * z[3], dist=tuple(dist.tolist()),
                               T_b_c=tuple(tuple(r) for r in T_b_c.tolist()))


def perturb_rig(rig, err, rng: np.random.Generator):
    """(the rig with every camera perturbed, the (n_cameras, 15) draws); ``rig`` itself when ``err`` is all zero
    (nothing drawn)."""
    if not err.active:
        return rig, np.zeros((len(rig.cameras), N_DRAWS))
    z = draw_errors(len(rig.cameras), rng)
    cams = [perturb_camera(c, zk, err) for c, zk in zip(rig.cameras, z)]
    if err.stereo_disparity_px and len(cams) > 1:
        cams[-1] = dataclasses.replace(cams[-1], cx=cams[-1].cx - err.stereo_disparity_px)
    return dataclasses.replace(rig, cameras=tuple(cams)), z
