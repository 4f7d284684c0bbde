"""The vectorized robust losses equal gtsam's mEstimators (weight and loss, inside and outside the threshold)."""
import gtsam
import numpy as np
import pytest

from vo.vins.robust import loss, weight

E = np.array([0.0, 0.3, 0.99, 1.0, 1.7, 4.0, 25.0])


@pytest.mark.parametrize("kind, make", [("cauchy", gtsam.noiseModel.mEstimator.Cauchy.Create),
                                        ("huber", gtsam.noiseModel.mEstimator.Huber.Create)])
@pytest.mark.parametrize("c", [0.02, 1.0, 2.5])
def test_weight_and_loss_match_gtsam(kind, make, c):
    m = make(c)
    cs = np.full(len(E), c)
    assert np.allclose(weight(kind, cs, E), [m.weight(e) for e in E], rtol=1e-12, atol=0)
    assert np.allclose(loss(kind, cs, E), [m.loss(e) for e in E], rtol=1e-12, atol=1e-300)


def test_none_is_gaussian():
    assert np.all(weight("none", np.ones(len(E)), E) == 1.0)
    assert np.allclose(loss("none", np.ones(len(E)), E), 0.5 * E * E)
