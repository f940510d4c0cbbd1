"""ObservationSpec: one source for the Box, the docstring table and the decoders."""

from __future__ import annotations

import numpy as np
import pytest

from cdcr_gym.tasks.observation import Field, ObservationSpec


def _spec():
    return ObservationSpec(
        [
            Field.uniform("tip", 3, -1.0, 1.0, "m", "tip", ("x", "y", "z")),
            Field.uniform("tensions", 6, 0.0, 1.0, "–", "tensions / max"),
        ]
    )


def test_slices_box_and_decode_follow_the_field_order():
    spec = _spec()
    assert spec.size == 9 and spec.slices["tensions"] == slice(3, 9)
    box = spec.box()
    assert box.shape == (9,) and box.dtype == np.float32
    assert box.low[3] == 0.0 and box.high[0] == 1.0
    obs = np.arange(18, dtype=np.float32).reshape(2, 9)
    assert np.array_equal(spec.decode(obs, "tensions"), obs[:, 3:9])
    assert spec.decode(obs, "tip").dtype == np.float64


def test_table_lists_every_field_with_its_indices():
    table = _spec().table()
    assert "| 0–2 | tip | -1 | 1 | m |" in table
    assert "| 3–8 | tensions / max | 0 | 1 | – |" in table


def test_bad_field_name_and_shape_raise_value_error():
    spec = _spec()
    with pytest.raises(ValueError, match="goal"):
        spec.decode(np.zeros(9), "goal")
    with pytest.raises(ValueError, match="obs"):
        spec.decode(np.zeros(8), "tip")
    with pytest.raises(ValueError, match="unique"):
        ObservationSpec([Field.uniform("a", 1, 0, 1, "m", "a")] * 2)
