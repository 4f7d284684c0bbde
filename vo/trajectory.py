# compat re-export: removed at merge (the trajectory type lives in rigs.trajectory)
from rigs.trajectory import Trajectory  # noqa: F401

__all__ = ["Trajectory"]
