"""rigs.image.to_gray: RGB channel order, OpenCV's luma weights, grey and non-uint8 input."""
import numpy as np

from rigs.image import to_gray


def test_rgb_order_and_weights():
    img = np.zeros((2, 3, 3), np.uint8)
    img[0, 0] = (255, 0, 0)       # red
    img[0, 1] = (0, 255, 0)       # green
    img[0, 2] = (0, 0, 255)       # blue
    img[1, :] = (40, 120, 200)
    g = to_gray(img)
    assert g.dtype == np.uint8 and g.shape == (2, 3) and g.flags.c_contiguous
    # 0.299 R + 0.587 G + 0.114 B, rounded: a BGR reading would swap the first and last values
    assert g[0].tolist() == [76, 150, 29]
    assert g[1, 0] == round(0.299 * 40 + 0.587 * 120 + 0.114 * 200)


def test_grey_and_float_inputs():
    grey = np.arange(12, dtype=np.uint8).reshape(3, 4)
    assert to_gray(grey) is grey                                       # contiguous uint8 grey: no copy
    np.testing.assert_array_equal(to_gray(grey[:, ::2]), grey[:, ::2])  # strided view -> contiguous copy
    assert to_gray(grey[:, ::2]).flags.c_contiguous
    f = np.array([[-5.0, 12.7, 300.0]])
    assert to_gray(f).tolist() == [[0, 12, 255]]                       # clipped, truncated
