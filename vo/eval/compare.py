"""Several estimates against one ground truth: one table (and :func:`vo.eval.plots.plot_comparison`)."""
from __future__ import annotations

from pathlib import Path

from vo.eval.align import alignment_header

COLUMNS = (("matched", "{:d}"), ("ATE t rmse (m)", "{:.4f}"), ("ATE r rmse (deg)", "{:.4f}"),
           ("RPE/frame t (m)", "{:.4f}"), ("RPE/frame r (deg)", "{:.4f}"), ("drift (%)", "{:.2f}"),
           ("KITTI t_err (%)", "{:.3f}"))


def estimate_names(paths) -> list[str]:
    """Short unique labels for estimate files: the file names, or the paths where names repeat."""
    names = [Path(p).name for p in paths]
    return [str(p) if names.count(n) > 1 else n for n, p in zip(names, paths)]


def row_values(result) -> tuple:
    """The figures of one :class:`vo.eval.EvalResult` in :data:`COLUMNS` order."""
    return (result.n_matched, result.ape.trans.rmse, result.ape.rot_deg.rmse, result.rpe_frame.trans.rmse,
            result.rpe_frame.rot_deg.rmse, result.drift.drift_ratio_pct, result.kitti.t_err_pct)


def compare_table(results: dict, align: str, scale_note: bool = True) -> str:
    """Plain-text table, one row per estimate (name -> EvalResult), headed by the alignment used and
    eval's default; a Sim(3) alignment lists each estimate's scale."""
    w = max([len("estimate")] + [len(n) for n in results]) + 2
    cols = [c for c, _ in COLUMNS] + (["scale"] if align == "sim3" and scale_note else [])
    lines = [f"alignment: {alignment_header(align)}",
             f"{'estimate':<{w}}" + "".join(f"{c:>19}" for c in cols)]
    for name, r in results.items():
        cells = [fmt.format(v) for (_, fmt), v in zip(COLUMNS, row_values(r))]
        if len(cols) > len(COLUMNS):
            cells.append(f"{r.alignment.s:.6f}")
        lines.append(f"{name:<{w}}" + "".join(f"{c:>19}" for c in cells))
    for name, r in results.items():
        lines += [f"warning ({name}): {w}" for w in r.warnings]
    return "\n".join(lines)


def compare_to_dict(results: dict, align: str) -> dict:
    """``{"alignment": ..., "estimates": {name: EvalResult.to_dict()}}``."""
    return {"alignment": align, "estimates": {n: r.to_dict() for n, r in results.items()}}
