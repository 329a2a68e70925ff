"""_validate.abs_max_per_row (Snapshot's product checks) against np.abs(x).max(axis=1), bit for bit,
including NaN, inf, -0 and subnormals, for 1 to 4 columns and no rows."""
import numpy as np
import pytest

from cgbound._validate import abs_max_per_row

SPECIAL = np.array([0.0, -0.0, 5e-324, -5e-324, 1.0, -1.0, np.inf, -np.inf, np.nan, -np.nan, 1.7976931348623157e308])


@pytest.mark.parametrize("columns", [1, 2, 3, 4])
@pytest.mark.parametrize("seed", range(5))
def test_equals_numpys_row_maximum(columns, seed):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(500, columns)) * 10.0 ** rng.integers(-300, 300, size=(500, columns))
    special = rng.random((500, columns)) < 0.3
    x[special] = rng.choice(SPECIAL, size=int(special.sum()))
    want = np.abs(x).max(axis=1)
    got = abs_max_per_row(x)
    assert got.dtype == want.dtype and got.shape == want.shape
    np.testing.assert_array_equal(got.view(np.uint64) | (np.isnan(got) * np.uint64(1 << 63)),
                                  want.view(np.uint64) | (np.isnan(want) * np.uint64(1 << 63)))
    assert np.array_equal(np.isnan(got), np.isnan(want))


def test_nan_in_any_column_is_nan():
    for k in range(3):
        x = np.ones((2, 3))
        x[1, k] = np.nan
        assert np.isnan(abs_max_per_row(x)[1]) and abs_max_per_row(x)[0] == 1.0


def test_strided_views_and_no_rows():
    x = np.arange(48.0).reshape(6, 8) - 20.0
    np.testing.assert_array_equal(abs_max_per_row(x[::2, 1:7:2]), np.abs(x[::2, 1:7:2]).max(axis=1))
    assert abs_max_per_row(np.zeros((0, 3))).shape == (0,)
    x.setflags(write=False)
    abs_max_per_row(x)        # a read-only input is left alone
