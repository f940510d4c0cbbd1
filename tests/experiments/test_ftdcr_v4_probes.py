"""The tip frames of the FTDCR v4 probes (experiments/ftdcr_v4_probes.py)."""

from __future__ import annotations

import numpy as np

from experiments.ftdcr_v4_probes import tip_frames


def test_tip_frames_turn_the_base_axis_onto_the_tangent():
    rng = np.random.default_rng(1)
    t = rng.normal(size=(20, 3))
    t[0] = [0.0, 0.0, 1.0]
    r = tip_frames(t)
    unit = t / np.linalg.norm(t, axis=1, keepdims=True)
    np.testing.assert_allclose(r[:, :, 2], unit, atol=1e-12)
    np.testing.assert_allclose(
        np.einsum("mij,mik->mjk", r, r), np.broadcast_to(np.eye(3), r.shape), atol=1e-12
    )
    np.testing.assert_allclose(np.linalg.det(r), 1.0, atol=1e-12)
    np.testing.assert_array_equal(r[0], np.eye(3))
