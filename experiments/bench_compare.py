"""Side-by-side timing of two checkouts of cdcr_gym (e.g. before/after a refactor), run as a script.

    git worktree add /tmp/pre d9c52c3
    PYTHONPATH=/tmp/pre python experiments/bench_compare.py pre-refactor
    PYTHONPATH=.        python experiments/bench_compare.py now

``cdcr_gym`` is imported from ``PYTHONPATH`` (so the same loop times any checkout, including ones
older than ``training.studies.bench``). Prints the batched CCKA reach env at 16 384 envs (M env-steps/s,
median of 5 × 60 steps, each step's result kept until the next as in ``training.studies.bench``) and the
single env through ``gym.make`` beside ``Pendulum-v1`` (env-steps/s, median of 5 × 20 000 steps,
resets included). Alternate the checkouts a few times: the machine is
shared, so only numbers taken close together compare. ``--against CHECKOUT`` does the
alternating itself and prints the medians and the per-round ratios:

    python experiments/bench_compare.py --against /tmp/pre --rounds 5
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401 - registers the ids
from training.run.argtypes import positive_int


def batched_rate(num_envs: int = 16384, steps: int = 60, repeats: int = 5) -> float:
    """Median env-steps/s of the batched reach env (vector_entry_point) with random actions."""
    env = gym.make_vec(
        "cdcr_gym/CCKAReach-v0", num_envs=num_envs, vectorization_mode="vector_entry_point"
    )
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, env.action_space.shape).astype(np.float32) for _ in range(8)]
    out = None
    for i in range(10):  # warm-up
        out = env.step(actions[i % 8])
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for i in range(steps):
            # Each result is kept until the next step, as a training loop (and training.studies.bench)
            # keeps it: results dropped at once are freed and the next step's ~3 MB of outputs
            # are page-faulted in again (docs/experiments/throughput.md, "Notes").
            out = env.step(actions[i % 8])
        rates.append(num_envs * steps / (time.perf_counter() - start))
    del out
    env.close()
    return float(np.median(rates))


def single_rate(env_id: str, steps: int = 20000, repeats: int = 5) -> float:
    """Median env-steps/s of one env made by ``gym.make`` (default wrappers), resets included."""
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(64)]
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for i in range(steps):
            out = env.step(actions[i & 63])
            if out[2] or out[3]:
                env.reset()
        rates.append(steps / (time.perf_counter() - start))
    env.close()
    return float(np.median(rates))


def measure() -> dict[str, float]:
    """One round on the checkout imported: batched M env-steps/s, single env and Pendulum-v1
    env-steps/s and their ratio."""
    ccka = single_rate("cdcr_gym/CCKAReach-v0")
    pendulum = single_rate("Pendulum-v1")
    return {
        "batched_M": batched_rate() / 1e6,
        "single": ccka,
        "pendulum": pendulum,
        "ratio": ccka / pendulum,
    }


def alternate(baseline: str, rounds: int) -> None:
    """Time this checkout and ``baseline`` (a checkout's directory) in alternating subprocesses,
    ``rounds`` rounds each, and print every round and the medians (ratios measured in one run)."""
    here = str(Path(__file__).resolve().parents[1])
    runs: dict[str, list[dict[str, float]]] = {"baseline": [], "this": []}
    for k in range(rounds):
        for label, root in (("baseline", baseline), ("this", here)):
            env = dict(os.environ, PYTHONPATH=root)
            out = subprocess.run(
                [sys.executable, __file__, "--json"],
                env=env,
                capture_output=True,
                text=True,
                check=True,
                cwd=root,
            )
            r = json.loads(out.stdout.strip().splitlines()[-1])
            runs[label].append(r)
            print(f"round {k + 1} {label:8s}: {_line(r)}", flush=True)
    med = {
        label: {key: float(np.median([r[key] for r in rs])) for key in rs[0]}
        for label, rs in runs.items()
    }
    for label in runs:
        print(f"median   {label:8s}: {_line(med[label])}")
    ratios = [t["batched_M"] / b["batched_M"] for t, b in zip(runs["this"], runs["baseline"])]
    print(
        f"batched this/baseline per round: {', '.join(f'{x:.2f}' for x in ratios)}; "
        f"median {np.median(ratios):.2f}"
    )


def _line(r: dict[str, float]) -> str:
    return (
        f"batched 16384 envs {r['batched_M']:.2f} M env-steps/s; single env {r['single'] / 1e3:.1f} k, "
        f"Pendulum-v1 {r['pendulum'] / 1e3:.1f} k, ratio {r['ratio']:.3f}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.bench_compare", description=__doc__.split("\n")[0]
    )
    parser.add_argument("label", nargs="?", default="this checkout", help="name printed")
    parser.add_argument("--json", action="store_true", help="print one JSON line")
    parser.add_argument(
        "--against", metavar="CHECKOUT", help="alternate with this checkout's directory"
    )
    parser.add_argument("--rounds", type=positive_int, default=5, help="rounds with --against")
    args = parser.parse_args(argv)
    if args.against:
        alternate(args.against, args.rounds)
    else:
        result = measure()
        print(json.dumps(result) if args.json else f"{args.label}: {_line(result)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
