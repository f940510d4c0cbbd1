"""Physics backends side by side: speed (env steps/s, as ratios to bullet in one run) and
accuracy (tip error against a converged reference, per discretisation).

Usage::

    cdcr-gym bench-physics [--robot paper|tdcr2] [--repeats K] [--steps S]
    cdcr-gym bench-physics --accuracy [--quick]

**Speed** (default mode). Env steps per second through ``gymnasium.make`` (the registered
wrappers), random actions from a fixed pool, the env reset when its episode ends; every row is
the median of K repeats, the rows interleaved repeat by repeat so that a shared machine's load
falls on all of them alike. Rows: ``BulletReach-v0(links_per_span=1)`` (the reference of the
ratios), ``MuJoCoReach-v0`` as made by default, MuJoCo at bullet's discretisation
(``links_per_span=1, joint="cardan", routing="disk"``, at MuJoCo's default timestep and at
bullet's 0.01 s) and the batched ``make_vec(..., num_envs=64, vectorization_mode=
"vector_entry_point")`` (env steps = 64 × vector steps). Targets of issue 21: ≥ 3×, ≥ 8×, ≥ 6×.

**Accuracy** (``--accuracy``). The settled tip (each backend's static equilibrium, which its
dynamics reach exactly) against a reference, for the paper robot and tdcr2, gravity off and
on. The reference is the Cosserat-rod JSON (``docs/figures/physics/cosserat_reference.json``,
its cases' ``robot``, ``gravity``, ``tensions`` and ``tip``; another file with
``--reference FILE.json``) when it exists; else (or with ``--reference chain``) the converged
discrete-disk chain (eight
ball-jointed links per span, cable straight between pinholes, ≈ 0.5 mm from the rod on the
paper robot) under held tensions — one cable at 25/50/75/100 % of ``max_tension``, and a pair
(100 % and 50 %). Rows: ``BulletReach-v0``'s backend as made by default (``routing="corrected"``)
and with ``routing="disk"``, then MuJoCo discretisations (joint, routing, links per span), each
with its steps/s on the paper robot's Reach env.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.params import RobotParams
from training.run.argtypes import positive_int

__all__ = ["main", "speed_table", "accuracy_table", "load_reference", "CASES_DOC"]

CASES_DOC = "one cable at 25/50/75/100 % of max_tension, and a pair at 100 % + 50 %"


def _steps_per_second(
    make: Callable[[], Any], steps: int, vector: bool = False
) -> Callable[[], float]:
    """A timer of ``steps`` env steps of one env made by ``make`` (made once, reused)."""
    env = make()
    rng = np.random.default_rng(0)
    pool = rng.uniform(-1, 1, (64,) + env.action_space.shape).astype(env.action_space.dtype)
    env.reset(seed=0)
    per_step = env.num_envs if vector else 1

    def run() -> float:
        t0 = time.perf_counter()
        for k in range(steps):
            out = env.step(pool[k % 64])
            if not vector and (out[2] or out[3]):
                env.reset()
        return steps * per_step / (time.perf_counter() - t0)

    return run


def speed_table(robot: str = "paper", repeats: int = 7, steps: int = 400) -> list[dict[str, Any]]:
    """Rows (name, kwargs, median steps/s, min, max, ratio to bullet)."""
    rows: dict[str, tuple[str, Callable[[], float]]] = {
        "BulletReach-v0(links_per_span=1)": (
            "bullet's default",
            _steps_per_second(
                lambda: gym.make("cdcr_gym/BulletReach-v0", robot=robot, links_per_span=1), steps
            ),
        ),
        "MuJoCoReach-v0 (default)": (
            "target ≥ 3×",
            _steps_per_second(lambda: gym.make("cdcr_gym/MuJoCoReach-v0", robot=robot), steps),
        ),
        "MuJoCo, bullet's discretisation": (
            "target ≥ 8×",
            _steps_per_second(
                lambda: gym.make(
                    "cdcr_gym/MuJoCoReach-v0",
                    robot=robot,
                    links_per_span=1,
                    joint="cardan",
                    routing="disk",
                ),
                steps,
            ),
        ),
        "MuJoCo, bullet's discretisation and timestep (0.01 s)": (
            "",
            _steps_per_second(
                lambda: gym.make(
                    "cdcr_gym/MuJoCoReach-v0",
                    robot=robot,
                    links_per_span=1,
                    joint="cardan",
                    routing="disk",
                    physics_timestep=0.01,
                ),
                steps,
            ),
        ),
        "MuJoCo vector env, 64 envs (default physics)": (
            "target ≥ 6×",
            _steps_per_second(
                lambda: gym.make_vec(
                    "cdcr_gym/MuJoCoReach-v0",
                    num_envs=64,
                    vectorization_mode="vector_entry_point",
                    robot=robot,
                ),
                max(steps // 16, 10),
                vector=True,
            ),
        ),
    }
    samples: dict[str, list[float]] = {name: [] for name in rows}
    for _ in range(repeats):
        for name, (_, timer) in rows.items():
            samples[name].append(timer())
    base = statistics.median(samples["BulletReach-v0(links_per_span=1)"])
    out = []
    for name, (note, _) in rows.items():
        med = statistics.median(samples[name])
        out.append(
            {
                "name": name,
                "note": note,
                "median": med,
                "min": min(samples[name]),
                "max": max(samples[name]),
                "ratio": med / base,
            }
        )
    return out


#: Discretisations of the accuracy table: (joint, routing, links_per_span).
CONFIGS = [
    ("cardan", "disk", 1),
    ("cardan", "disk", 2),
    ("cardan", "disk", 4),
    ("ball", "disk", 1),
    ("ball", "disk", 2),
    ("ball", "disk", 4),
    ("cardan", "corrected", 1),
    ("cardan", "corrected", 2),
    ("ball", "corrected", 1),
    ("ball", "corrected", 2),
    ("ball", "corrected", 3),
]


#: pybullet rows of the accuracy table: (routing, links_per_span); the default first.
BULLET_CONFIGS = [("corrected", 1), ("disk", 1)]


def tension_cases(params: RobotParams) -> np.ndarray:
    """Held tensions (M, C) N: :data:`CASES_DOC`, for the first cable of every section (a
    cable of the last section bends all sections) and a pair of neighbouring cables."""
    c, t_max = params.n_cables, params.max_tension
    rows = []
    for cable in sorted({0, c - 1}):
        for f in (0.25, 0.5, 0.75, 1.0):
            t = np.zeros(c)
            t[cable] = f * t_max
            rows.append(t)
    pair = np.zeros(c)
    pair[c - 2], pair[c - 1] = t_max, 0.5 * t_max
    rows.append(pair)
    return np.array(rows)


def _reference_tips(params: RobotParams, gravity: bool, cases: np.ndarray) -> np.ndarray:
    from cdcr_gym.backends.mujoco import MuJoCoBackend

    ref = MuJoCoBackend(params, gravity=gravity, links_per_span=8, joint="ball", routing="disk")
    try:
        return ref.equilibrium(cases).tip
    finally:
        ref.close()


#: The Cosserat reference of the repository (written by ``python -m experiments.cosserat``);
#: this file is ``training/studies/bench_physics.py``, so the repository root is ``parents[2]``.
REFERENCE_PATH = (
    Path(__file__).resolve().parents[2] / "docs/figures/physics/cosserat_reference.json"
)


def load_reference(
    path: Path,
) -> dict[tuple[str, bool], tuple[RobotParams, np.ndarray, np.ndarray]]:
    """The reference cases of a JSON file grouped by (robot, gravity): (params, tensions (M, C)
    N, tips (M, 3) m)."""
    cases = json.loads(Path(path).read_text())["cases"]
    groups: dict[tuple[str, bool], list[dict[str, Any]]] = {}
    for case in cases:
        groups.setdefault((case["robot"], bool(case["gravity"])), []).append(case)
    return {
        key: (
            RobotParams.preset(key[0]),
            np.array([c["tensions"] for c in group], dtype=float),
            np.array([c["tip"] for c in group], dtype=float),
        )
        for key, group in sorted(groups.items())
    }


def chain_reference() -> dict[tuple[str, bool], tuple[RobotParams, np.ndarray, np.ndarray]]:
    """The fallback reference: :func:`tension_cases` on the converged chain."""
    refs = {}
    for robot in ("paper", "tdcr2"):
        params = RobotParams.preset(robot)
        cases = tension_cases(params)
        for gravity in (False, True):
            refs[robot, gravity] = (params, cases, _reference_tips(params, gravity, cases))
    return refs


def accuracy_table(
    quick: bool = False, repeats: int = 7, steps: int = 1200, reference: Path | None = None
) -> tuple[str, list[dict[str, Any]]]:
    """(reference name, rows): per discretisation the max tip error (m and % of ℓ) per (robot,
    gravity), and the paper robot's Reach steps/s."""
    from cdcr_gym.backends.mujoco import MuJoCoBackend

    configs = CONFIGS[::2] if quick else CONFIGS
    if reference is None and REFERENCE_PATH.exists():
        reference = REFERENCE_PATH
    if reference is not None and str(reference) != "chain":
        refs = load_reference(reference)
        name = f"Cosserat rod, {reference}"
    else:
        refs = chain_reference()
        name = f"ball joints, 8 links per span, straight routing; tensions: {CASES_DOC}"
    from cdcr_gym.backends.bullet import BulletBackend

    rows = []
    timers = {}
    for routing, m in BULLET_CONFIGS:
        row = {"backend": "pybullet", "joint": "cardan", "routing": routing, "links_per_span": m}
        for (robot, gravity), (params, cases, ref) in refs.items():
            bb = BulletBackend(params, gravity=gravity, links_per_span=m, routing=routing)
            err = np.linalg.norm(bb.equilibrium(cases).tip - ref, axis=1).max()
            bb.close()
            row[f"{robot} g={'on' if gravity else 'off'}"] = (
                float(err),
                float(err / params.length),
            )
        rows.append(row)
        timers["pybullet", routing, m] = _steps_per_second(
            lambda r=routing, m=m: gym.make("cdcr_gym/BulletReach-v0", links_per_span=m, routing=r),
            steps,
        )
    for joint, routing, m in configs:
        row = {"backend": "mujoco", "joint": joint, "routing": routing, "links_per_span": m}
        for (robot, gravity), (params, cases, ref) in refs.items():
            b = MuJoCoBackend(
                params, gravity=gravity, links_per_span=m, joint=joint, routing=routing
            )
            err = np.linalg.norm(b.equilibrium(cases).tip - ref, axis=1).max()
            b.close()
            row[f"{robot} g={'on' if gravity else 'off'}"] = (
                float(err),
                float(err / params.length),
            )
        rows.append(row)
        timers[joint, routing, m] = _steps_per_second(
            lambda j=joint, r=routing, m=m: gym.make(
                "cdcr_gym/MuJoCoReach-v0", links_per_span=m, joint=j, routing=r
            ),
            steps,
        )
    samples: dict[Any, list[float]] = {key: [] for key in timers}
    for _ in range(repeats):
        for key, timer in timers.items():
            samples[key].append(timer())
    default = (
        statistics.median(samples["ball", "corrected", 1])
        if ("ball", "corrected", 1) in samples
        else None
    )
    for row in rows:
        joint = "pybullet" if row["backend"] == "pybullet" else row["joint"]
        row["steps/s"] = statistics.median(samples[joint, row["routing"], row["links_per_span"]])
        row["speed"] = row["steps/s"] / default if default else float("nan")
    return name, rows


def _machine() -> str:
    import mujoco
    import pybullet  # noqa: F401

    load = "n/a"
    try:
        import os

        load = " ".join(f"{v:.1f}" for v in os.getloadavg())
    except OSError:
        pass
    return (
        f"{platform.processor() or platform.machine()}, {platform.python_version()}, "
        f"mujoco {mujoco.__version__}, load average {load}"
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="cdcr-gym bench-physics", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--robot", default="paper", choices=["paper", "tdcr2"])
    parser.add_argument("--repeats", type=positive_int, default=7)
    parser.add_argument("--steps", type=positive_int, default=400)
    parser.add_argument("--accuracy", action="store_true", help="the convergence table")
    parser.add_argument("--quick", action="store_true", help="fewer rows (accuracy)")
    parser.add_argument(
        "--reference",
        type=Path,
        default=None,
        help="reference JSON, or 'chain' for the converged chain (accuracy; default: the "
        "repository's Cosserat JSON if present)",
    )
    args = parser.parse_args(argv)
    print(f"machine: {_machine()}")
    if args.accuracy:
        name, rows = accuracy_table(args.quick, args.repeats, 3 * args.steps, args.reference)
        keys = [k for k in rows[0] if " g=" in k]
        print(f"reference: {name}")
        print(
            "| backend | joint | routing | links/span | "
            + " | ".join(keys)
            + " | steps/s (paper) | speed vs default |"
        )
        print("|---|---|---|---|" + "---|" * len(keys) + "---|---|")
        for row in rows:
            cells = [f"{row[k][0] * 1e3:.2f} mm ({row[k][1] * 100:.2f} %)" for k in keys]
            print(
                f"| {row['backend']} | {row['joint']} | {row['routing']} | "
                f"{row['links_per_span']} | "
                + " | ".join(cells)
                + f" | {row['steps/s']:.0f} | {row['speed']:.2f}× |"
            )
        return
    rows = speed_table(args.robot, args.repeats, args.steps)
    print(f"robot {args.robot}, {args.repeats} repeats, median (min–max) env steps/s")
    print("| env | steps/s | range | ratio to bullet | |")
    print("|---|---|---|---|---|")
    for row in rows:
        print(
            f"| {row['name']} | {row['median']:.0f} | {row['min']:.0f}–{row['max']:.0f} | "
            f"{row['ratio']:.2f}× | {row['note']} |"
        )


if __name__ == "__main__":
    main()
