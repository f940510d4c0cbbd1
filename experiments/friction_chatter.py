"""Friction chatter probe (issue 21 item 4): does a load–unload cycle settle at every hold?

``python -m experiments.friction_chatter [--backend mujoco|bullet|both] [--hold N]
[--mu MU] [--damping-ratio Z]``: paper robot, gravity off, cable 1 loaded 10 → 80 N in 10 N
steps and unloaded to 0 N, each level held ``--hold`` control steps (default 600). Per hold it
prints the tip x (mm), the *motion* — the peak-to-peak tip x over the last 20 control steps of
the hold (mm; a settled robot: 0) —, the anchor tension (N) and the slip state of cable 1.
``docs/physics_reference.md`` (friction) and ``docs/mujoco_backend.md`` §4 quote its output.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from cdcr_gym.backends.bullet import BulletBackend
from cdcr_gym.backends.mujoco import MuJoCoBackend
from training.run.argtypes import non_negative_float, positive_float, positive_int

#: The protocol's tension levels (N) on cable 1: loading 10 → 80, then unloading 70 → 0.
LEVELS = tuple(float(t) for t in range(10, 90, 10)) + tuple(float(t) for t in range(70, -10, -10))
#: Control steps at the end of a hold over which the motion is measured.
WINDOW = 20


@dataclass(frozen=True)
class Hold:
    """One hold of the protocol (SI units)."""

    tension: float  # N on cable 1
    loading: bool  # on the loading branch (else unloading)
    tip_x: float  # m, at the end of the hold
    motion: float  # m, peak-to-peak tip x over the last WINDOW control steps
    anchor: float  # N, cable 1's anchor tension at the end of the hold
    slip: float  # cable 1's slip state at the end of the hold


def _slip(backend) -> float:
    s = np.asarray(backend.slip)
    return float(s.reshape(-1, s.shape[-1])[0, 0])


def load_unload(backend, hold: int = 600, levels=LEVELS) -> list[Hold]:
    """Run the protocol on a one-robot ``backend`` (reset to rest first)."""
    if hold <= WINDOW:
        raise ValueError(f"hold must exceed {WINDOW} control steps, got {hold}")
    c = backend.params.n_cables
    backend.reset(np.zeros((1, c)))
    out = []
    peak = max(levels)
    loading = True
    for t in levels:
        tensions = np.zeros((1, c))
        tensions[0, 0] = t
        xs = []
        for k in range(hold):
            backend.apply_tensions(tensions)
            if k >= hold - WINDOW:
                xs.append(backend.read().tip[0, 0])
        r = backend.read()
        anchor = t if r.anchor_tensions is None else float(r.anchor_tensions[0, 0])
        slip = _slip(backend) if backend.friction_coefficient > 0.0 else 0.0
        out.append(Hold(t, loading, float(xs[-1]), float(np.ptp(xs)), anchor, slip))
        if t == peak:
            loading = False
    return out


def frictionless_tips(backend, levels=LEVELS) -> dict[float, float]:
    """Tip x (m) of the frictionless static equilibrium at each positive level (cable 1)."""
    c = backend.params.n_cables
    out = {}
    for t in sorted({t for t in levels if t > 0.0}):
        tensions = np.zeros((1, c))
        tensions[0, 0] = t
        out[t] = float(backend.equilibrium(tensions).tip[0, 0])
    return out


def branch_violations(holds: list[Hold], frictionless: dict[float, float]) -> list[str]:
    """What a friction model that settles on its branches must satisfy, as a list of the
    holds that do not (empty: all good):

    * every hold settled: motion < 0.01 mm over the last :data:`WINDOW` control steps;
    * loading: anchor ≤ actuator, and the tip bends less than without friction (by > 0.1 mm);
    * unloading: the tip bends more than on the loading branch at the same tension (the loop
      is open); the anchor ≥ actuator, except at the first step back, where the cable sticks
      (|s| < 1) and the anchor only has to lie above the loading branch's.
    """
    bad = []
    loading_x: dict[float, float] = {}
    loading_anchor: dict[float, float] = {}
    first_back = True
    for h in holds:
        if h.motion >= 1e-5:
            bad.append(f"not settled: {h}")
        if h.tension == 0.0:
            continue
        if h.loading:
            loading_x[h.tension], loading_anchor[h.tension] = h.tip_x, h.anchor
            if h.anchor > h.tension:
                bad.append(f"loading anchor above the actuator: {h}")
            if not h.tip_x < frictionless[h.tension] - 1e-4:
                bad.append(f"loading tip not below frictionless: {h}")
            continue
        if h.tension in loading_x and not h.tip_x > loading_x[h.tension]:
            bad.append(f"unloading tip not above loading: {h}")
        if first_back:
            if h.tension in loading_anchor and not h.anchor > loading_anchor[h.tension]:
                bad.append(f"first unloading anchor not above loading: {h}")
            first_back = False
        elif h.anchor < h.tension:
            bad.append(f"unloading anchor below the actuator: {h}")
    return bad


def _backend(name: str, mu: float, damping_ratio: float):
    if name == "mujoco":
        return MuJoCoBackend(gravity=False, friction_coefficient=mu, damping_ratio=damping_ratio)

    return BulletBackend(gravity=False, friction_coefficient=mu, damping_ratio=damping_ratio)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m experiments.friction_chatter", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--backend", choices=("mujoco", "bullet", "both"), default="both")
    ap.add_argument("--hold", type=positive_int, default=600)
    ap.add_argument("--mu", type=non_negative_float, default=0.2)
    ap.add_argument("--damping-ratio", type=positive_float, default=0.7)
    args = ap.parse_args(argv)
    names = ("mujoco", "bullet") if args.backend == "both" else (args.backend,)
    for name in names:
        b = _backend(name, args.mu, args.damping_ratio)
        try:
            holds = load_unload(b, args.hold)
            print(
                f"{name}: T (N), branch, tip x (mm), motion over {WINDOW} steps (mm), "
                "anchor (N), slip"
            )
            for h in holds:
                branch = "load  " if h.loading else "unload"
                print(
                    f"{name:7s} {h.tension:5.0f} {branch} {h.tip_x * 1e3:8.2f} "
                    f"{h.motion * 1e3:8.4f} {h.anchor:7.1f} {h.slip:+.2f}"
                )
            plain = _backend(name, 0.0, args.damping_ratio)
            try:
                for line in branch_violations(holds, frictionless_tips(plain)):
                    print(f"{name}: {line}")
            finally:
                plain.close()
        finally:
            b.close()


if __name__ == "__main__":
    main()
