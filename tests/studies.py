"""Import a study driver of docs/studies/ by its module name (the folder is no package; a study imports its
sibling studies by plain name, as when run as ``python docs/studies/NAME.py``)."""
import importlib
import sys
from pathlib import Path

STUDIES = Path(__file__).resolve().parents[1] / "docs" / "studies"


def load_study(name: str):
    """The module ``docs/studies/<name>.py``."""
    if str(STUDIES) not in sys.path:
        sys.path.insert(0, str(STUDIES))
    return importlib.import_module(name)
