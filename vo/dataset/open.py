"""``open_dataset(path)``: detect the layout of a folder and return a :class:`Dataset`.

Recognised: our EuRoC folder (``mav0/`` + ``rig.yaml``/``metadata.yaml``), a real EuRoC recording
(a folder holding ``mav0/``, or ``mav0`` itself), our KITTI folder (``sequences/NN`` + ``poses/``),
and a real KITTI ``sequences/NN`` folder. The root of ``generate --format both`` opens its ``euroc/``.
A folder marked ``INCOMPLETE`` is refused.
"""
from __future__ import annotations

import logging
from pathlib import Path

from vo.errors import DatasetError

MARKER = "INCOMPLETE"
_ANNOUNCED: set = set()


def _refuse_incomplete(*folders: Path, allow: bool = False) -> None:
    for f in folders if not allow else ():
        if (f / MARKER).exists():
            raise DatasetError(f"{f}: dataset is incomplete (INCOMPLETE marker: writing was interrupted); "
                               f"rerun the same generate command to resume it, or regenerate with overwrite")


def _is_ours(root: Path) -> bool:
    return (root / "metadata.yaml").is_file() or (root / "rig.yaml").is_file()


def _kitti_sequence(path: Path) -> Path | None:
    """``path`` itself if it is a sequence folder, or its only / ``00`` sequence under ``sequences/``."""
    if (path / "calib.txt").is_file() or (path / "image_0").is_dir():
        return path
    seqs_dir = path / "sequences"
    if not seqs_dir.is_dir():
        return None
    seqs = sorted(p for p in seqs_dir.iterdir() if p.is_dir())
    if len(seqs) == 1:
        return seqs[0]
    if not seqs:
        raise DatasetError(f"{seqs_dir}: no sequence folders (expected sequences/NN)")
    names = ", ".join(p.name for p in seqs)
    raise DatasetError(f"{path}: holds several KITTI sequences ({names}); open one: {seqs_dir}/NN")


def _both_root_to_euroc(path: Path) -> Path:
    """The root of ``generate --format both`` (``euroc/`` + ``kitti/``) -> its ``euroc/`` copy, said once
    per folder on the ``vo.dataset`` logger (printed to stderr when logging is not configured)."""
    if (path / "mav0").is_dir() or not (path / "euroc" / "mav0").is_dir():
        return path
    if path not in _ANNOUNCED:
        _ANNOUNCED.add(path)
        logging.getLogger("vo.dataset").warning(
            f"{path}: holds euroc/ and kitti/ (generate --format both); reading {path / 'euroc'}")
    return path / "euroc"


def open_dataset(path, allow_incomplete: bool = False):
    """Open a dataset folder -> ``EurocDataset`` or ``KittiDataset`` (both :class:`Dataset`).
    ``allow_incomplete``: read a folder still marked ``INCOMPLETE`` (the generator's own bag step only)."""
    path = Path(path).expanduser()
    if not path.is_dir():
        raise DatasetError(f"{path}: dataset folder not found" if not path.exists() else
                           f"{path}: not a folder (give the dataset folder)")
    if path.name == "mav0" and (path / "cam0").is_dir():
        path = path.parent
    path = _both_root_to_euroc(path)
    if (path / "mav0").is_dir():
        from vo.dataset.euroc_reader import EurocDataset
        _refuse_incomplete(path, allow=allow_incomplete)
        return EurocDataset(path / "mav0", path, ours=_is_ours(path))
    seq = _kitti_sequence(path)
    if seq is not None:
        from vo.dataset.kitti_reader import KittiDataset
        root = seq.parent.parent
        _refuse_incomplete(path, root, allow=allow_incomplete)
        return KittiDataset(seq, root, ours=_is_ours(root))
    _refuse_incomplete(path)
    raise DatasetError(f"{path}: not a recognised dataset (expected mav0/ for EuRoC, or sequences/NN or "
                       f"calib.txt + image_0/ for KITTI)")
