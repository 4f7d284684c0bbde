"""Error-propagation models: what geometry and noise say the error should be (seed 001, section 3)."""
from vo.errorprop.range import range_sigma, planar_covariance, azimuth_sigma_from_pixels  # noqa: F401
from vo.errorprop.triangulation import triangulate, triangulation_covariance  # noqa: F401
from vo.errorprop.crosssite import (  # noqa: F401
    CrossSiteConfig, CrossSiteResult, cross_site_accuracy, cross_site_monte_carlo, CROSS_SITE_PRESETS,
)
from vo.errorprop.nees import nees, chi2_interval, NeesSummary, summarize_nees  # noqa: F401
