"""``vo-testbed demo --scenario urban-dynamic|urban-static``: seed 002's Table 2/3 layout and Figs. 12-15 on one seed.

Generates the scenario into the cache with the documented table protocol (docs/studies/vins_tables.md, "Seed 002 Tables 2/3 on
the urban scene": 25 s, the ADIS16448 IMU, segmentation for the labels and the oracle), runs the four
configurations of the paper and ``vins-oracle`` (:mod:`vo.vins.tables`) from the monocular visual-inertial start
(estimator options, e.g. ``init=truth``, override :data:`START_OPTIONS`), prints the table and writes the
figures (:mod:`vo.vins.figures`) and each configuration's row (``<name>.json``) into the output folder. The
error rows are computed after each run's initialisation; a run that never initialises is printed without them.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from sim.app.check import scenario_dataset
from vo.dataset import open_dataset
from vo.errors import VoError
from vo.pipeline import prepare_out_dir
from vo.vins.tables import HEADERS, RPE_DELTA, TABLE_CONFIGS, format_table23, rpe_series, run_config, table23
from vo.vins.vins_config import VinsConfig

VINS_SCENARIOS = ("urban-static", "urban-dynamic")
PROTOCOL = ("duration_s=25", "imu=euroc-adis16448", "segmentation=true")
START_OPTIONS: dict = {}       # the estimator's defaults: init=vi, the monocular start (``--opt init=truth``: truth)
START_NOTES = {
    "vi": "init=vi: monocular visual-inertial initialisation (VINS-Mono); each configuration starts at its own "
          "first post-init frame",
    "truth": "init=truth: every configuration starts from the true states at keyframe {k} (for comparing "
             "back-ends without the start)",
}


@dataclass
class VinsDemo:
    scenario: str
    dataset: str
    out_dir: str
    options: dict
    rpe_delta_s: float
    rows: list = field(default_factory=list)         # vo.vins.tables rows, in configuration order
    errors: dict = field(default_factory=dict)       # configuration -> message (it failed on the data)
    plots: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "dataset": self.dataset, "out_dir": self.out_dir,
                "start": start_of(self.options), "options": self.options, "rpe_delta_frames": RPE_DELTA,
                "rpe_delta_s": self.rpe_delta_s, "rows": self.rows,
                "table": {label: dict(zip((r["name"] for r in self.rows), values))
                          for label, values in table23(shown_rows(self.rows))},
                "notes": {r["name"]: row_note(r) for r in self.rows if row_note(r)},
                "errors": self.errors, "plots": self.plots}

    def text(self) -> str:
        init = start_of(self.options)
        parts = [f"seed 002 Tables 2/3 on {self.scenario}: dataset {self.dataset}",
                 "start: " + START_NOTES.get(init, init).format(k=self.options.get("init_keyframes", 11)),
                 f"RPE: translation, evo's definition, delta {RPE_DELTA} frames ({self.rpe_delta_s:.1f} s), after "
                 f"initialisation, poses aligned at the first post-init frame; drift: end-point error / path",
                 "N < 10: the paper's outlier rule; true dynamic and the rule's two confusion rates: segmentation",
                 ""]
        if self.rows:
            parts.append(format_table23(shown_rows(self.rows)))
        parts += [f"{HEADERS.get(r['name'], r['name'])}: {row_note(r)}" for r in self.rows if row_note(r)]
        for name, msg in self.errors.items():
            parts += ["", f"=== {name} === FAILED: {msg}"]
        parts += ["", "plots: " + ", ".join(self.plots)]
        return "\n".join(parts)


def start_of(options: dict) -> str:
    """The start ``vins`` uses with estimator ``options`` (its ``init`` option, default included)."""
    return VinsConfig.from_options("base", options).init


def restarts(run) -> dict:
    """After the first post-init frame: the first re-initialisation (``reinit_frame``, None if none) and the
    number of frames in ``init``/``reinit`` (``restart_frames``), which the error rows score as they are."""
    status = [f.status for f in run.frames[run.row["init_frame"]:]]
    lost = [i for i, st in enumerate(status) if st in ("init", "reinit")]
    return {"reinit_frame": run.row["init_frame"] + lost[0] if lost else None, "restart_frames": len(lost)}


def row_note(row: dict) -> str:
    """Why a row has no error figures, or what its error figures include ("" when nothing to say): the run never
    left ``init``, too few frames remained after its initialisation (:data:`vo.vins.tables.MIN_AFTER_INIT`),
    or it re-initialised later (frames without an estimate hold the last pose and are scored)."""
    if "rpe10" in row:
        if row.get("reinit_frame") is None:
            return ""
        return (f"re-initialisation at frame {row['reinit_frame']}: {row['restart_frames']} frames from there "
                f"without an estimate (the last pose held; included in the error rows)")
    if row["init_frame"] >= row["n"]:
        return f"no initialisation in {row['n']} frames: no error figures"
    return f"initialised at frame {row['init_frame']} of {row['n']}, too few frames after it: no error figures"


def shown_rows(rows) -> list:
    """The rows as tabulated: a run that never initialised has no first post-init frame (printed "-", not the
    frame count)."""
    return [{**r, "init_frame": None} if r["init_frame"] >= r["n"] else r for r in rows]


def check_configs(configs) -> tuple:
    """The VINS configurations to run (VoError naming a name that is not one, before any work)."""
    configs = tuple(configs)
    if not configs:
        raise VoError("estimators: none given")
    bad = [c for c in configs if c not in HEADERS]
    if bad:
        raise VoError(f"estimators: {', '.join(bad)} not a VINS configuration (the urban demo prints seed 002's "
                      f"table); valid: {', '.join(HEADERS)}")
    return configs


def run_vins_demo(scenario: str, configs=None, out_dir="out/demo", progress: bool = True, max_frames=None,
                  overrides=(), options=None) -> VinsDemo:
    """Generate (cached) ``scenario`` with :data:`PROTOCOL` and ``overrides``, run ``configs`` (default: the
    paper's four and the oracle) with :data:`START_OPTIONS` updated by ``options``, tabulate and plot."""
    configs = check_configs(TABLE_CONFIGS if configs is None else configs)
    opts = {**START_OPTIONS, **(options or {})}
    start_of(opts)                              # a bad option raises here, before any work
    prepare_out_dir(out_dir)
    path = scenario_dataset(scenario, PROTOCOL + tuple(overrides), progress=progress)
    return run_on_dataset(scenario, path, configs, out_dir, opts, progress, max_frames)


def run_on_dataset(scenario: str, path, configs, out_dir, opts: dict, progress: bool = True,
                   max_frames=None) -> VinsDemo:
    """The table and figures of ``configs`` (checked names) with estimator options ``opts`` on the dataset
    folder ``path`` (generated from ``scenario``)."""
    out = prepare_out_dir(out_dir)
    ds = open_dataset(path)
    t_ns = np.asarray(ds.groundtruth_cam0().t_ns)
    demo = VinsDemo(scenario, str(path), str(out), opts, float(t_ns[min(RPE_DELTA, len(t_ns) - 1)] - t_ns[0]) * 1e-9)
    n = len(ds) if max_frames is None else min(len(ds), max_frames)
    runs = {}
    for name in configs:
        try:
            runs[name] = run_config(ds, name, n, opts, progress)
        except VoError as e:
            demo.errors[name] = str(e)
            continue
        runs[name].row.update(restarts(runs[name]))
        demo.rows.append(runs[name].row)
        (out / f"{name}.json").write_text(json.dumps(runs[name].row, indent=1))
    demo.plots = [str(p) for p in write_figures(ds, runs, out)]
    return demo


def write_figures(ds, runs: dict, out) -> list:
    """Figs. 12-15 of the runs that exist (name -> :class:`vo.vins.tables.ConfigRun`) into ``out``."""
    from vo.vins import figures
    gt = ds.groundtruth_cam0()
    gt_T, t_ns = np.linalg.inv(gt.T[0]) @ gt.T, np.asarray(gt.t_ns)
    series = {name: rpe_series(r.frames, gt_T, t_ns) for name, r in runs.items()}
    paths = []
    if series:
        paths.append(figures.plot_rpe_over_time({HEADERS[k]: v for k, v in series.items()}, out / "fig12_rpe.png"))
    labelled = next((runs[k] for k in runs if k != "vins-oracle" and "dynamic" in runs[k].diagnostics[0]), None)
    if labelled is not None:
        k = feature_frame(labelled)
        d = labelled.diagnostics[k]
        paths.append(figures.plot_features(ds.frame(k).left, d["px"], d["dynamic"], d["counts"],
                                           out / "fig13_features.png",
                                           f"frame {k} ({labelled.name} front-end): {int(d['n_dynamic'])} dynamic, "
                                           f"{int(d['n_static'])} static tracked features"))
    for name, fig, with_n in (("vins-ac-gf", "fig14_gf.png", False), ("vins-ac", "fig15_gf_n.png", True)):
        if name in runs:
            diag = runs[name].diagnostics
            t = (np.array([d["t_ns"] for d in diag]) - int(t_ns[0])) * 1e-9
            g_f = np.array([d["g_f"] for d in diag])
            mean_n = np.array([np.mean(d["counts"]) if len(d["counts"]) else np.nan for d in diag]) if with_n else None
            paths.append(figures.plot_weights_and_error(t, g_f, *series[name], HEADERS[name], out / fig, mean_n))
    return paths


def feature_frame(run) -> int:
    """The frame shown in Fig. 13: after initialisation, the one with the most dynamic tracked features
    (ties: the earliest); the last frame when the run never initialised."""
    first = run.row["init_frame"]
    if first >= len(run.diagnostics):
        return len(run.diagnostics) - 1
    n_dyn = [d["n_dynamic"] for d in run.diagnostics[first:]]
    return first + int(np.argmax(n_dyn))
