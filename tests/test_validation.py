"""cdcr_gym.validation: every check names the argument and shows the value."""

from __future__ import annotations

import numpy as np
import pytest

from cdcr_gym import validation as V


def test_real_array_accepts_real_numbers_and_refuses_the_rest():
    assert V.real_array([1, 2.5], "x").dtype == np.float64
    assert V.real_array(np.array([True]), "x").tolist() == [1.0]
    for bad in ("a", [1j], [[1, 2], [3]], {"a": 1}, [np.nan], [np.inf]):
        with pytest.raises(ValueError, match="x must"):
            V.real_array(bad, "x")
    with pytest.raises(ValueError, match="x must be an array of real numbers"):
        V.real_array(np.array([True]), "x", allow_bool=False)
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        V.real_array([1.0, 2.0], "x", (3,))


def test_per_cable_checks_shape_and_range():
    assert V.per_cable([[0.0, 1.0, 2.0]], "t", 3, 0.0, 2.0).shape == (1, 3)
    with pytest.raises(ValueError, match=r"t must have shape \(\.\.\., 3\)"):
        V.per_cable([0.0, 1.0], "t", 3)
    with pytest.raises(ValueError, match="t must be >= 0"):
        V.per_cable([-1.0, 1.0, 1.0], "t", 3, 0.0)
    with pytest.raises(ValueError, match="t must be <= 2"):
        V.per_cable([3.0, 1.0, 1.0], "t", 3, 0.0, 2.0)


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.int64])
def test_actions_of_real_numbers_are_clipped(dtype):
    a = np.array([2, -3, 0], dtype=dtype)
    assert V.clipped_action(a, (3,)).tolist() == [1.0, -1.0, 0.0]
    assert V.clipped_action(a.tolist(), (3,)).tolist() == [1.0, -1.0, 0.0]


@pytest.mark.parametrize(
    "action",
    [
        np.array([True, False, True]),
        [0.0, np.nan, 0.0],
        "abc",
        [1j, 0, 0],
        [0.0, 0.0],
        np.zeros(2, np.float32),
        np.zeros((1, 3)),
        np.array([0.0, np.inf, 0.0]),
    ],
)
def test_bad_actions_name_action(action):
    with pytest.raises(ValueError, match="action"):
        V.clipped_action(action, (3,))


def test_scalars():
    assert V.positive(2, "x") == 2.0
    assert V.positive(0, "x", allow_zero=True) == 0.0
    with pytest.raises(ValueError, match=r"x must be finite, > 0 and <= 1.0 \(s\), got 2.0"):
        V.positive(2.0, "x", 1.0, unit="s")
    with pytest.raises(ValueError, match=r"x must be a real number \(kg\)"):
        V.positive(True, "x", unit="kg")
    assert V.flag(np.bool_(True), "f") is True
    with pytest.raises(ValueError, match="f must be a bool"):
        V.flag(1, "f")
    assert V.integer(np.int64(3), "n", 1) == 3
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        V.integer(True, "n", 1)
    assert V.choice("a", "c", ("a", "b")) == "a"
    with pytest.raises(ValueError, match=r"c must be one of \('a', 'b'\)"):
        V.choice("z", "c", ("a", "b"))
