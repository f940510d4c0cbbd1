"""The softened copies of the FTDCR v4 files (experiments/ftdcr_v4_softened_commands.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cdcr_gym.calibration import read_csv
from experiments.ftdcr_v4_softened_commands import DATA, soften_file


def test_pulls_saturate_and_everything_else_is_copied(tmp_path):
    out = tmp_path / "val.csv"
    assert soften_file(DATA / "val.csv", out, 37.0) == 443
    before, after = read_csv(DATA / "val.csv"), read_csv(out)
    d, s = before.displacements, after.displacements
    pulled = d > 0.0
    assert pulled.any() and (~pulled).any()
    np.testing.assert_allclose(s[pulled], 0.037 * np.tanh(d[pulled] / 0.037), rtol=1e-12)
    np.testing.assert_array_equal(s[~pulled], d[~pulled])
    assert np.all(s[pulled] < d[pulled])
    np.testing.assert_array_equal(after.tip, before.tip)
    np.testing.assert_array_equal(after.labels, before.labels)
    # 12.4 mm, the largest held-out pull, loses 3.6 %
    assert math.isclose(37.0 * math.tanh(12.4 / 37.0) / 12.4, 0.964, abs_tol=1e-3)


@pytest.mark.parametrize("bad", [0.0, -5.0, float("nan")])
def test_a_bad_length_is_refused(tmp_path, bad):
    with pytest.raises(ValueError, match="d_s_mm"):
        soften_file(DATA / "val.csv", tmp_path / "v.csv", bad)
