"""Seed 001 cross-site rover localization (Wan et al., §2): site k is localized against site k-1,
whose pose is held fixed, by tie points between the two sites' Navcam stereo panoramas and a bundle
adjustment. One module per stage (see ``docs/crosssite.md``); consumes plain records
(:mod:`vo.crosssite.types`), never sim, scenes or mujoco.
"""
from vo.crosssite.types import SiteResult, Site, StereoCal, StereoPair  # noqa: F401
from vo.crosssite.localizer_config import CrossSiteConfig  # noqa: F401
from vo.crosssite.localizer import localize_site, localize_traverse  # noqa: F401
