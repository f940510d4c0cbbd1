"""Tolerances for comparing today's results with arrays stored on another machine.

Floating-point results are not bit-identical across machines (numpy builds, SIMD paths of the
transcendental functions, BLAS summation order): measured differences between two machines are
≤ 3.1e-13 on every pinned quantity. Stored arrays are therefore compared with tolerances that
still catch any real change of behaviour; determinism (same seed → identical results) is tested
bit for bit within one process, where it must hold exactly.
"""

from __future__ import annotations

import numpy as np

#: Relative tolerance for kinematics, statics and observations (analytic model).
RTOL_MODEL = 1e-9
#: Absolute floor beside it, for quantities that are (near) zero: 1 pm, 1 pN, 1e-12 rad.
ATOL_MODEL = 1e-12
#: Physics trajectories (pybullet, MuJoCo) after up to 20 control steps: a last-bit difference
#: at step 1 is amplified by the integrator but stays many orders below anything observable.
RTOL_PHYSICS = 1e-9
ATOL_PHYSICS = 1e-9


def close(got, want, rtol: float = RTOL_MODEL, atol: float = ATOL_MODEL) -> bool:
    """Same shape and ``|got − want| ≤ atol + rtol·|want|`` elementwise (NaN matches NaN)."""
    got, want = np.asarray(got), np.asarray(want)
    if got.shape != want.shape:
        return False
    if got.dtype.kind == "b" or want.dtype.kind == "b":
        return bool(np.array_equal(got, want))
    return bool(np.allclose(got, want, rtol=rtol, atol=atol, equal_nan=True))
