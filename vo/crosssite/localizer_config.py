"""``CrossSiteConfig``: every knob of the cross-site localizer; YAML keys are the field names."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from rigs.typed_config import check_fields, from_mapping, knob
from vo.errors import VoError


@dataclass(frozen=True)
class CrossSiteConfig:
    """Options of the stages (units in the names). ``mode`` ``ff`` (forward-forward regions by
    back-projection) or ``fb`` (forward-backward: ground-plane overlap). Checked by
    :func:`rigs.typed_config.check_fields`: bad values raise one-line :class:`VoError` naming ``crosssite.<field>``."""

    mode: Literal["ff", "fb"] = "ff"
    # prior of a leg (added to the dead reckoning's own leg covariance)
    prior_leg_fraction: float = knob(0.15, ge=0)     # translation sigma per axis, fraction of the leg length
    prior_rot_sigma_rad: float = knob(0.03, ge=0)    # rotation sigma per axis
    # regions (§2.1)
    region_sigma: float = knob(3.0, ge=0)            # extend predicted regions by this many prior sigmas
    region_max_range_m: float = knob(40.0, gt=0)     # ground coverage of an image: rays cut at this range
    use_regions: bool = True
    # Wallis filter (eq. 1)
    use_wallis: bool = False                         # off by default: costs true ties under equal lighting (docs)
    wallis_window_px: int = knob(31, ge=3, odd=True)
    wallis_b: float = knob(1.0, ge=0)                # brightness forcing constant
    wallis_c: float = knob(4.0, gt=0)                # contrast expansion constant
    # zoom of the previous images (§2.2): none, scale (the paper's), plane (ground-plane homography),
    # ortho (both images onto one ground-plane grid per region pair, vo.crosssite.ortho)
    zoom: Literal["none", "scale", "plane", "ortho"] = "plane"
    # ASIFT (§2.2)
    use_asift: bool = True
    asift_fallback_ties: int = knob(20, ge=0)        # SIFT first; ASIFT only below this many eq. 2 ties (0: ASIFT only)
    asift_max_tilt: float = knob(4.0, ge=0)          # the full ASIFT set goes to tilt 4 (sqrt 2 ** 4)
    sift_features: int = knob(0, ge=0)               # SIFT nfeatures, 0: all
    sift_contrast: float = knob(0.01, gt=0)          # SIFT contrast threshold (OpenCV's default 0.04)
    ratio: float = knob(0.8, gt=0)                   # Lowe's ratio test
    workers: int = knob(2, ge=1)                     # threads for detection and matching per pointing / region pair
    # stereo ZNCC + LSM (§2.2)
    zncc_half_px: int = knob(7, ge=1)
    zncc_min: float = knob(0.8, ge=0)
    range_min_m: float = knob(1.5, gt=0)
    range_max_m: float = knob(40.0, ge=0)            # the overlap lies 10-35 m from the previous site
    median_k: int = knob(8, ge=1)
    median_abs_px: float = knob(2.0, ge=0)
    median_rel: float = knob(0.15, ge=0)
    lsm_half_px: int = knob(7, ge=1)
    lsm_max_shift_px: float = knob(1.0, ge=0)
    # least-squares matching of the cross-site ties (beyond seed 001, which applies LSM to stereo only):
    # each eq. 2 tie's current-image position refined against the previous image (vo.crosssite.ties.refine_cross_site);
    # on by default: on the lunar pair it removes ASIFT's common v error and cuts the BA's spread (docs/crosssite.md)
    xsite_lsm: bool = True
    xsite_lsm_half_px: int = knob(10, ge=2)
    xsite_lsm_max_shift_px: float = knob(2.0, gt=0)   # a tie the refinement moves farther is dropped
    # distance consistency (eq. 2)
    consistency_abs_m: float = knob(0.05, ge=0)
    consistency_k_sigma: float = knob(3.0, ge=0)
    sigma_p_px: float = knob(1.0 / 3.0, gt=0)
    weight_fraction: float = knob(0.2, gt=0, le=1)   # a point is kept with weight >= fraction * (n - 1)
    consistency_iterations: int = knob(3, ge=1)
    # initial values and BA (eq. 3-5)
    min_tie_points: int = knob(6, ge=4)              # at least 4 for the resection
    min_ba_ties: int = knob(10, ge=4)                # fewer ties agree with the resection: prior kept
    ambiguity_px: float = knob(20.0, ge=0)           # a second resection consensus this far (median px) from the first: ambiguous; 0 off
    pnp_reproj_px: float = knob(2.0, ge=0)
    ba_sigma_px: float = knob(1.0 / 3.0, gt=0)
    ba_huber_k: float = knob(1.345, ge=0)
    ba_xsite_sigma_px: float = knob(0.0, ge=0)       # sigma_theta of the current ties, added to sigma_p; 0 off
    mast_sigma_rad: float = knob(0.0, ge=0)          # 0: mast rotations as hard constraints (eq. 5)
    mast_sigma_m: float = knob(0.0, ge=0)
    max_ba_points: int = knob(400, ge=1)
    # fallback
    prior_gate_chi2: float = knob(36.0, ge=0)        # BA pose vs prior: squared Mahalanobis limit (chi2(6) tail 3e-6)
    inflate: float = knob(4.0, ge=1)                 # covariance factor on a kept prior (>= 1: never more certain)

    def __post_init__(self):
        check_fields(self, VoError, "crosssite.")
        if not self.range_min_m < self.range_max_m:
            raise VoError(f"crosssite.range_min_m: must be below range_max_m ({self.range_max_m!r}), "
                          f"got {self.range_min_m!r}")

    @classmethod
    def from_dict(cls, d: dict) -> "CrossSiteConfig":
        """Mapping of field names -> :class:`CrossSiteConfig` (unknown keys name the valid ones)."""
        return from_mapping(cls, d, VoError, "crosssite")
