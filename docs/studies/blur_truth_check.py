"""The figures of docs/sensor_effects.md ("Time: what a timestamp means") behind tests/test_blur_truth.py.

Generates the test's two datasets (sharp and 80 ms blurred, 0.35 s of indoor-short, --ideal) into --work and
prints, for frames k = 1, 2 tracked into k+1 (sharp and blurred): features, half blur, offset of the tracks
along the image motion from the mid-exposure and start-of-exposure projections, PnP residual sigma,
Mahalanobis distances to the written / start / end poses, camera-centre and rotation errors.

    MUJOCO_GL=egl .venv/bin/python docs/studies/blur_truth_check.py --work /tmp/blur_truth
"""
import argparse
from pathlib import Path

import cv2
import numpy as np

import blur_tracks as T                 # the sibling module: the test's settings and measurements
from sim.generate import generate, resolve
from sim.scenarios import get_scenario
from vo.dataset.open import open_dataset


def rot_deg(x, y) -> float:
    R = cv2.Rodrigues(x[:3])[0] @ cv2.Rodrigues(y[:3])[0].T
    return float(np.degrees(np.linalg.norm(cv2.Rodrigues(R)[0])))


def check(sharp, other, k, setup, name) -> str:
    cam = sharp.rig.cameras[0]
    K, dist = T.K_matrix(cam), np.asarray(cam.dist)
    px, p_w = T.lifted_features(sharp, k)
    q, ok = T.track(sharp.frame(k).left, other.frame(k + 1).left, px)
    x_mid = T.rt(other.groundtruth_cam0().T[k + 1])
    proj = lambda x: cv2.projectPoints(p_w, x[:3], x[3:], K, dist)[0].reshape(-1, 2)   # noqa: E731
    p_mid = proj(x_mid)
    t = int(other.frame_times_ns[k + 1]) + np.array([-1, 1]) * int(T.EXPOSURE_MS * 5e5)
    T_ends = setup.trajectory.states(t).T_w_b @ setup.rig.cameras[0].T_b_c_array
    p_start = proj(T.rt(T_ends[0]))
    u = (p_mid - p_start)[ok]
    half = np.linalg.norm(u, axis=1)
    u /= half[:, None]
    x, info, sigma = T.pnp(p_w[ok], q[ok], cam, x_mid)
    d = lambda xr: float(np.sqrt((x - xr) @ info @ (x - xr)))   # noqa: E731
    return (f"k={k} -> {name} k+1: n={ok.sum()}, half blur median {np.median(half):.2f} max {half.max():.2f} px; "
            f"along motion from mid {np.mean(np.sum((q - p_mid)[ok] * u, 1)):+.3f} px, from start "
            f"{np.mean(np.sum((q - p_start)[ok] * u, 1)):+.3f} px; sigma {sigma:.3f} px; d(mid) {d(x_mid):.2f}, "
            f"d(start) {d(T.rt(T_ends[0])):.1f}, d(end) {d(T.rt(T_ends[1])):.1f}; centre error "
            f"{1e3 * np.linalg.norm(T.camera_centre(x) - T.camera_centre(x_mid)):.2f} mm (start is "
            f"{1e3 * np.linalg.norm(T_ends[0][:3, 3] - T.camera_centre(x_mid)):.1f} mm away); "
            f"rotation error {rot_deg(x, x_mid):.4f} deg")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work", type=Path, default=Path("/tmp/blur_truth"))
    a = p.parse_args()
    ds = {}
    for name, extra in (("sharp", []), ("blurred", T.BLUR)):
        generate(get_scenario("indoor-short", T.COMMON + extra), a.work / name, progress=False, overwrite=True)
        ds[name] = open_dataset(a.work / name)
    print((a.work / "blurred" / "frame_effects.csv").read_text())
    setup = resolve(get_scenario("indoor-short", T.COMMON + T.BLUR))
    for k in (1, 2):
        for name in ("sharp", "blurred"):
            print(check(ds["sharp"], ds[name], k, setup, name))


if __name__ == "__main__":
    main()
