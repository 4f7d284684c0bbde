"""The checked-in ``rigs/presets/*.yaml`` are what :func:`rigs.presets.write_preset_yamls` writes from the code
(the code is the source of truth), one file per preset, byte for byte."""
from rigs.presets import PRESET_DIR, rig_names, write_preset_yamls
from rigs.rig_yaml import load_rig


def test_preset_files_are_written_from_the_code(tmp_path):
    written = write_preset_yamls(tmp_path)
    assert sorted(p.name for p in written) == sorted(f"{n}.yaml" for n in rig_names())
    assert sorted(p.name for p in PRESET_DIR.glob("*.yaml")) == sorted(p.name for p in written)
    stale = [p.name for p in written if p.read_bytes() != (PRESET_DIR / p.name).read_bytes()]
    assert not stale, (f"stale preset files {stale}: regenerate with "
                       f"python -c 'from rigs.presets import write_preset_yamls; write_preset_yamls()'")
    for p in written:
        assert load_rig(p).name == p.stem
