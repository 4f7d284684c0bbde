"""The README's main job: generate a scenario, run the estimators, print seed 000's Table 4, plot."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from sim.app.check import scenario_dataset
from sim.app.demo_vins import VINS_SCENARIOS, run_vins_demo
from sim.generate_traverse import generate_traverse
from sim.cache_dir import cache_root
from sim.scenarios import get_scenario, traverse_scenarios
from vo.dataset import open_dataset
from vo.errors import VoError
from vo.estimators.registry import check_spec
from vo.pipeline import prepare_out_dir, run_and_evaluate

DEFAULT_ESTIMATORS = ("rop", "klt-pnp", "orb-pnp")


@dataclass
class DemoResult:
    scenario: str
    dataset: str
    out_dir: str
    results: dict = field(default_factory=dict)      # estimator -> vo.pipeline.Evaluated
    errors: dict = field(default_factory=dict)       # estimator -> message (an estimator that failed)
    plots: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "dataset": self.dataset, "out_dir": self.out_dir,
                "results": {k: v.to_dict() for k, v in self.results.items()}, "errors": self.errors,
                "plots": self.plots}

    def text(self) -> str:
        parts = [f"scenario {self.scenario}: dataset {self.dataset}"]
        for name, res in self.results.items():
            ev = res.evaluation
            parts += ["", f"=== {name} ({len(res.run.frames)} frames, {res.run.n_lost} lost, "
                      f"{res.run.timings_ms.get('total', 0.0):.1f} ms/frame) ===", ev.table()]
        for name, msg in self.errors.items():
            parts += ["", f"=== {name} === FAILED: {msg}"]
        parts += ["", "plots: " + ", ".join(self.plots)]
        return "\n".join(parts)


def run_demo(scenario: str = "campus", estimators=DEFAULT_ESTIMATORS, out_dir="out/demo", progress: bool = True,
             max_frames=None, options=None) -> DemoResult:
    """Generate (cached) ``scenario``, run each estimator, evaluate, and plot all against the truth.

    Unknown estimator names and an unwritable ``out_dir`` raise before anything is generated; an
    estimator that fails on the data is reported in ``errors`` and the others still run. A traverse
    scenario (``yutu-traverse``) is localized site by site instead (:func:`run_traverse_demo`); ``urban-static``
    and ``urban-dynamic`` print seed 002's Tables 2/3 for the VINS configurations
    (:func:`sim.app.demo_vins.run_vins_demo`, with the estimator ``options``: VINS scenarios only)."""
    if options and scenario not in VINS_SCENARIOS:
        raise VoError(f"--opt {', '.join(options)}: estimator options are for the VINS demos "
                      f"({', '.join(VINS_SCENARIOS)}) only, not {scenario}")
    if scenario in traverse_scenarios():
        return run_traverse_demo(scenario, out_dir, progress)
    if scenario in VINS_SCENARIOS:       # the stereo default list means "the paper's configurations"
        configs = None if tuple(estimators) == DEFAULT_ESTIMATORS else estimators
        return run_vins_demo(scenario, configs, out_dir, progress, max_frames, options=options)
    from vo.eval.plots import plot_error_vs_distance, plot_topdown

    if not estimators:
        raise VoError("estimators: none given")
    for name in estimators:            # every name checked before anything is rendered
        check_spec(name)
    out = prepare_out_dir(out_dir)
    path = scenario_dataset(scenario, progress=progress)
    ds = open_dataset(path)
    demo = DemoResult(scenario, str(path), str(out))
    for name in estimators:
        try:
            demo.results[name] = run_and_evaluate(ds, name, out_dir=out / name, progress=progress,
                                                  max_frames=max_frames)
        except VoError as e:
            demo.errors[name] = str(e)
    if demo.results:
        gt = next(iter(demo.results.values())).evaluation.gt_matched
        ests = {k: v.evaluation.aligned_est for k, v in demo.results.items()}
        demo.plots.append(str(plot_topdown(ests, ds.groundtruth_cam0(), ds.gcps, out / "topdown.png")))
        demo.plots.append(str(plot_error_vs_distance(gt, ests, out / "error_vs_distance.png")))
    return demo


@dataclass
class TraverseDemo:
    """Summary of ``vo-testbed localize`` on a cached traverse (:func:`vo.crosssite.traverse_eval.summary`)."""
    summary: dict
    errors: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return self.summary

    def text(self) -> str:
        from vo.crosssite.traverse_eval import format_table
        s = self.summary
        return "\n".join([f"traverse {s['dataset']} (cross-site BA, {s['mode']})", format_table(s["sites"]),
                          f"mean per-site error: DR {s['dr_mean_err_pct']:.2f} %, BA {s['ba_mean_err_pct']:.2f} % "
                          f"of distance", "plots: " + ", ".join(s["files"].values())])


def run_traverse_demo(scenario: str, out_dir, progress: bool = True) -> TraverseDemo:
    """Generate the traverse ``scenario`` into the scenario cache (once), then localize it."""
    from vo.crosssite.traverse_eval import run_and_write
    config = get_scenario(scenario)
    path = cache_root() / f"traverse-{scenario}-{config.config_hash()}"
    if not (path / "metadata.yaml").is_file():             # written last: the traverse is complete
        generate_traverse(config, traverse_scenarios()[scenario], path, progress=progress, overwrite=True)
    return TraverseDemo(run_and_write(path, out_dir, progress=progress))
