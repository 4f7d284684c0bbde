# compat re-export: removed at merge (grey conversion lives in rigs.image)
from rigs.image import to_gray  # noqa: F401

__all__ = ["to_gray"]
