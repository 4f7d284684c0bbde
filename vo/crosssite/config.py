"""``CrossSiteConfig``: every knob of the cross-site localizer; YAML keys are the field names."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

from vo.errors import VoError


@dataclass(frozen=True)
class CrossSiteConfig:
    """Options of the stages (units in the names). ``mode`` ``ff`` (forward-forward regions by
    back-projection) or ``fb`` (forward-backward: ground-plane overlap)."""

    mode: str = "ff"
    # regions (§2.1)
    region_sigma: float = 3.0          # extend predicted regions by this many prior sigmas
    region_max_range_m: float = 25.0   # ground coverage of an image: rays cut at this range
    use_regions: bool = True
    # Wallis filter (eq. 1)
    use_wallis: bool = True
    wallis_window_px: int = 31
    wallis_b: float = 1.0              # brightness forcing constant
    wallis_c: float = 4.0              # contrast expansion constant
    # ASIFT (§2.2)
    use_asift: bool = True
    asift_max_tilt: float = 4.0        # the full ASIFT set goes to tilt 4 (sqrt 2 ** 4)
    sift_features: int = 1000
    ratio: float = 0.8                 # Lowe's ratio test
    # stereo ZNCC + LSM (§2.2)
    zncc_half_px: int = 7
    zncc_min: float = 0.8
    range_min_m: float = 1.5
    range_max_m: float = 20.0
    median_k: int = 8
    median_abs_px: float = 2.0
    median_rel: float = 0.15
    lsm_half_px: int = 7
    lsm_max_shift_px: float = 1.0
    # distance consistency (eq. 2)
    consistency_abs_m: float = 0.05
    consistency_k_sigma: float = 3.0
    sigma_p_px: float = 1.0 / 3.0
    weight_fraction: float = 0.2       # a point is kept with weight >= fraction * (n - 1)
    consistency_iterations: int = 3
    # initial values and BA (eq. 3-5)
    min_tie_points: int = 6
    pnp_reproj_px: float = 2.0
    ba_sigma_px: float = 1.0 / 3.0
    ba_huber_k: float = 1.345
    mast_sigma_rad: float = 0.0        # 0: mast rotations as hard constraints (eq. 5)
    mast_sigma_m: float = 0.0
    max_ba_points: int = 400
    # fallback
    prior_gate_chi2: float = 36.0      # BA pose vs prior: chi2(6) squared Mahalanobis limit
    inflate: float = 4.0               # covariance factor when the prior is kept

    def __post_init__(self):
        if self.mode not in ("ff", "fb"):
            raise VoError(f"crosssite.mode: expected 'ff' or 'fb', got {self.mode!r}")
        for f in fields(self):
            v = getattr(self, f.name)
            if f.type in ("float", float):
                if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v) or v < 0:
                    raise VoError(f"crosssite.{f.name}: must be a non-negative finite number, got {v!r}")
                object.__setattr__(self, f.name, float(v))
            elif f.type in ("int", int):
                if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                    raise VoError(f"crosssite.{f.name}: must be a positive integer, got {v!r}")
            elif f.type in ("bool", bool) and not isinstance(v, bool):
                raise VoError(f"crosssite.{f.name}: must be true or false, got {v!r}")
        for f in ("ba_sigma_px", "sigma_p_px", "range_min_m", "wallis_c", "ratio", "region_max_range_m"):
            if getattr(self, f) <= 0:
                raise VoError(f"crosssite.{f}: must be positive, got {getattr(self, f)!r}")
        if self.inflate < 1:
            raise VoError(f"crosssite.inflate: must be >= 1 (the kept prior is never more certain), got {self.inflate!r}")
        if self.wallis_window_px < 3 or self.wallis_window_px % 2 == 0:
            raise VoError(f"crosssite.wallis_window_px: expected an odd size >= 3, got {self.wallis_window_px!r}")
        if not self.range_min_m < self.range_max_m:
            raise VoError(f"crosssite.range_min_m: {self.range_min_m} must be below range_max_m {self.range_max_m}")
        if not 0 < self.weight_fraction <= 1:
            raise VoError(f"crosssite.weight_fraction: must be in (0, 1], got {self.weight_fraction!r}")
        if self.min_tie_points < 4:
            raise VoError(f"crosssite.min_tie_points: at least 4 needed for resection, got {self.min_tie_points}")

    @classmethod
    def from_dict(cls, d: dict) -> "CrossSiteConfig":
        names = {f.name for f in fields(cls)}
        bad = sorted(set(d) - names)
        if bad:
            raise VoError(f"crosssite: unknown key {bad[0]!r}; valid: {', '.join(sorted(names))}")
        return cls(**d)
