"""rigs.geometry.skew: skew(a) @ b = a x b, for one vector and for stacks of them; antisymmetric."""
import numpy as np

from rigs.geometry import skew


def test_skew_is_the_cross_product_single_and_batched():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(4, 5, 3)), rng.normal(size=(4, 5, 3))
    S = skew(a)
    assert S.shape == (4, 5, 3, 3)
    assert np.allclose((S @ b[..., None])[..., 0], np.cross(a, b), atol=1e-14)
    assert np.array_equal(S, -np.swapaxes(S, -1, -2))
    assert np.allclose(skew(a[1, 2]) @ b[1, 2], np.cross(a[1, 2], b[1, 2]), atol=1e-14)
    assert skew([1, 2, 3]).shape == (3, 3)
