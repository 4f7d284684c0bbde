"""rigs.atomic_io: files appear whole under their final name or not at all; nothing is left behind."""
import dataclasses
import json

import cv2
import numpy as np
import pytest

from rigs.atomic_io import (atomic_write, atomic_write_bytes, atomic_write_json, atomic_write_npy, atomic_write_npz,
                            atomic_write_text)


def test_writers_round_trip_and_leave_only_the_file(tmp_path):
    atomic_write_text(tmp_path / "a" / "t.txt", "x\ny\n")
    atomic_write_bytes(tmp_path / "b.bin", b"\x00\x01")
    arr = np.arange(12.0).reshape(3, 4)
    atomic_write_npy(tmp_path / "c.npy", arr.T)
    atomic_write_npz(tmp_path / "d.npz", {"a": arr, "b": np.int64(7)})
    assert (tmp_path / "a" / "t.txt").read_bytes() == b"x\ny\n"
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\x01"
    np.testing.assert_array_equal(np.load(tmp_path / "c.npy"), arr.T)
    with np.load(tmp_path / "d.npz") as z:
        np.testing.assert_array_equal(z["a"], arr)
        assert int(z["b"]) == 7
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a", "b.bin", "c.npy", "d.npz", "t.txt"]


def test_json_handles_numpy_dataclasses_and_to_dict(tmp_path):
    @dataclasses.dataclass
    class Cfg:
        k: int = 3

    class Res:
        def to_dict(self):
            return {"r": 1}
    atomic_write_json(tmp_path / "x.json", {"b": np.float64(0.5), "a": np.arange(3), "c": Cfg(), "d": Res()},
                      sort_keys=True)
    text = (tmp_path / "x.json").read_text()
    assert text.endswith("}\n") and text.index('"a"') < text.index('"b"')
    assert json.loads(text) == {"a": [0, 1, 2], "b": 0.5, "c": {"k": 3}, "d": {"r": 1}}


def test_a_failed_write_keeps_the_old_file_and_removes_the_temporary(tmp_path):
    path = tmp_path / "m.yaml"
    atomic_write_text(path, "old\n")

    def broken(tmp):
        tmp.write_text("half")
        raise RuntimeError("disk full")
    with pytest.raises(RuntimeError, match="disk full"):
        atomic_write(path, broken)
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["m.yaml"]


def test_temporary_keeps_the_suffix_for_writers_that_need_it(tmp_path):
    img = np.arange(48, dtype=np.uint8).reshape(6, 8)
    seen = []

    def imwrite(tmp):
        seen.append(tmp)
        assert cv2.imwrite(str(tmp), img)
    atomic_write(tmp_path / "000001.png", imwrite)
    assert seen[0].suffix == ".png" and seen[0].parent == tmp_path and seen[0].name.startswith(".")
    np.testing.assert_array_equal(cv2.imread(str(tmp_path / "000001.png"), cv2.IMREAD_UNCHANGED), img)
