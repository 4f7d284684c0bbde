"""Range-error validation on rendered images (issue 4): exact disparity, eq. 7 agreement, noise."""
import os

os.environ["MUJOCO_GL"] = "egl"

import numpy as np
import pytest

from rigs.overrides import apply_overrides
from rigs.presets import get_rig
from sim.errors import SimError
from sim.app.validation.range_check import (board_mask, disparity_from_depth, measure_range_errors,
                                        render_board_frames)
from sim.app.validation.targets import board_layout


def _project(rig, T_w_b, p_w, k):
    T_w_c = T_w_b @ rig.cameras[k].T_b_c_array
    p_c = np.linalg.inv(T_w_c) @ np.append(p_w, 1.0)
    return (rig.cameras[k].K @ p_c[:3])[:2] / p_c[2], p_c[2]


def test_depth_disparity_matches_projection_of_board_points():
    rig = apply_overrides(get_rig("stereo27"), ["baseline=0.27"])
    f, b, r = rig.cameras[0].fx, rig.baseline, 5.0
    boards, poses = board_layout(rig, [r, 12.0])
    (left, right, depth), _ = render_board_frames(rig, [r, 12.0])
    corners = boards[0].face_corners_w()
    uv0, Z0 = zip(*[_project(rig, poses[0], p, 0) for p in corners])
    uv1, Z1 = zip(*[_project(rig, poses[0], p, 1) for p in corners])
    # geometry: every face corner is at depth r in both cameras and has disparity f b / r
    assert np.allclose(Z0, r, atol=1e-9) and np.allclose(Z1, r, atol=1e-9)
    assert np.allclose(np.array(uv0)[:, 0] - np.array(uv1)[:, 0], f * b / r, atol=1e-9)
    # rendering: the board's pixels (depth within 0.1 % of r) fill the projected face rectangle;
    # 1.5 px allows the rasteriser's pixel-centre coverage rule at the edges
    mask = board_mask(depth, r, margin_px=0)
    v, u = np.nonzero(mask)
    uv0 = np.array(uv0)
    assert abs(u.min() - uv0[:, 0].min()) < 1.5 and abs(u.max() - uv0[:, 0].max()) < 1.5
    assert abs(v.min() - uv0[:, 1].min()) < 1.5 and abs(v.max() - uv0[:, 1].max()) < 1.5
    # exact disparity from depth: 0.01 px at d = 24.7 px is 4e-4 relative, i.e. 2 mm of depth
    d = disparity_from_depth(depth[mask], f, b)
    assert mask.sum() > 5000
    assert np.max(np.abs(d - f * b / r)) < 0.01


def test_klt_range_error_matches_eq7_with_measured_sigma_p():
    res = measure_range_errors(baselines=(0.27,), ranges=(3.0, 8.0), matchers=("klt",), image_noise=2.0,
                               seed=3, phases=4)
    fit = res.fit(0.27, "klt")
    assert fit.outlier_rate < 0.05
    for b in res.bins_for(0.27, "klt"):
        # n ~ 500 corners per bin (4 phases); a MAD scale has relative standard error 1.17/sqrt(n) = 5 %
        # for independent samples, but corners 7 px apart share most of their 21x21 LK windows (and so
        # their image noise), which cuts the effective n by ~5x -> ~12 %; 25 % is ~2 sigma of that.
        assert b.n >= 300
        assert abs(b.ratio - 1.0) < 0.25, (b.range_m, b.ratio)
        # first-order consistency: the bin's own disparity scale reproduces its range scale
        assert b.measured_sigma_r_m == pytest.approx(b.range_m ** 2 * b.sigma_p_bin_px / (0.27 * res.f_px), rel=0.1)


def test_image_noise_increases_measured_sigma_p():
    kw = dict(baselines=(0.27,), ranges=(4.0,), matchers=("klt",), seed=1, phases=2)
    clean = measure_range_errors(image_noise=0.0, **kw).fit(0.27, "klt").sigma_p_px
    noisy = measure_range_errors(image_noise=8.0, **kw).fit(0.27, "klt").sigma_p_px
    # Clean renders still carry a deterministic resampling error (~0.02 px). LK's noise-induced
    # disparity error is ~ sqrt(2) sigma_n / sqrt(sum Ix^2) ~ sqrt(2) * 8 / (21 * ~20 grey/px) ~ 0.03-0.05 px
    # for 8 grey levels, which adds in quadrature: at least twice the clean value.
    assert noisy > 2.0 * clean > 0


def test_bad_arguments_raise_one_line_sim_errors():
    with pytest.raises(SimError, match="matcher"):
        measure_range_errors(matchers=("orb",))
    with pytest.raises(SimError, match="ranges"):
        measure_range_errors(ranges=(0.0, 5.0))


def test_cli_validate_range_writes_json_and_plot(tmp_path):
    import json
    from click.testing import CliRunner
    from sim.app.cli.cmd_validate import validate
    out = tmp_path / "val"
    r = CliRunner().invoke(validate, ["range", "--baselines", "0.27", "--ranges", "4", "--matchers", "klt",
                                      "--phases", "1", "--out", str(out), "--json"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.output)
    assert (out / "range_validation.png").stat().st_size > 1000
    on_disk = json.loads((out / "range_validation.json").read_text())
    assert on_disk["bins"][0]["range_m"] == 4.0 and data["bins"][0]["n"] == on_disk["bins"][0]["n"] > 30
    bad = CliRunner().invoke(validate, ["range", "--baselines", "a,b"])
    assert bad.exit_code == 2 and "--baselines" in bad.output
