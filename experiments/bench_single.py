"""The single env's speed as a ratio to ``Pendulum-v1``, both through ``gymnasium.make``, measured
in one process by alternating the two envs for several rounds (the median ratio is robust to a
shared, loaded machine where absolute rates are not). Optionally the batched env too.

Usage::

    python -m experiments.bench_single [--rounds 9] [--steps 4000] [--output speed.json]
    python -m experiments.bench_single --against /tmp/base --rounds 5 [--batched 64 16384]
        [--batched-repeats 3]

``--against CHECKOUT`` alternates this checkout and another one (imported from its directory)
in subprocesses, round by round, and prints the medians of both and of their per-round ratios:
the single-env/Pendulum ratio of each checkout, and with ``--batched`` the batched env's
env-steps/s at the given sizes (this/baseline per round).

``--output FILE`` writes the result (and the command that produced it) as JSON: the source of
the speed table of ``docs/results.md`` (``docs/figures/benchmark/speed.json``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401 - registers the ids
from training.run.argtypes import positive_int

__all__ = ["single_ratio", "batched_rates"]

SINGLE_ID = "cdcr_gym/CCKAReach-v0"


def _stepper(env_id: str) -> Any:
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(64)]

    def run(steps: int) -> float:
        out = None
        start = time.perf_counter()
        for i in range(steps):
            out = env.step(actions[i & 63])
            if out[2] or out[3]:
                env.reset()
        elapsed = time.perf_counter() - start
        del out
        return steps / elapsed

    run(300)  # warm-up: the passive checker's first-step checks, caches
    return run


def single_ratio(rounds: int = 9, steps: int = 4000) -> dict[str, float]:
    """Median env-steps/s of the single env and of Pendulum-v1, alternated ``rounds`` times,
    and the median of the per-round ratios."""
    ccka, pend = _stepper(SINGLE_ID), _stepper("Pendulum-v1")
    rates: dict[str, list[float]] = {"single": [], "pendulum": []}
    ratios = []
    for k in range(rounds):
        # alternate which goes first, so that a load change does not favour one of them
        if k % 2:
            p, c = pend(steps), ccka(steps)
        else:
            c, p = ccka(steps), pend(steps)
        rates["single"].append(c)
        rates["pendulum"].append(p)
        ratios.append(c / p)
    return {
        "single": statistics.median(rates["single"]),
        "pendulum": statistics.median(rates["pendulum"]),
        "ratio": statistics.median(ratios),
    }


def batched_rates(sizes: list[int], repeats: int = 3) -> dict[str, float]:
    """Median env-steps/s of the batched reach env at each size (results kept until the next
    step, as a training loop keeps them; max(100, 131 072 / size) steps per repeat: every env's
    autoreset, and at least ~0.1 s at small sizes), and
    the median of its ratio to Pendulum-v1's env-steps/s timed right after each repeat
    (``batched_N_per_pendulum``: comparable across runs on a machine whose load changes)."""
    out: dict[str, float] = {}
    pend = _stepper("Pendulum-v1")
    for n in sizes:
        env = gym.make_vec(SINGLE_ID, num_envs=n, vectorization_mode="vector_entry_point")
        env.reset(seed=0)
        rng = np.random.default_rng(0)
        actions = [rng.uniform(-1, 1, env.action_space.shape).astype(np.float32) for _ in range(8)]
        res = None
        for i in range(10):
            res = env.step(actions[i % 8])
        rates, ratios = [], []
        steps = max(100, 131072 // n)
        for _ in range(repeats):
            start = time.perf_counter()
            for i in range(steps):
                res = env.step(actions[i % 8])
            rates.append(n * steps / (time.perf_counter() - start))
            ratios.append(rates[-1] / pend(2000))
        del res
        env.close()
        out[f"batched_{n}"] = statistics.median(rates)
        out[f"batched_{n}_per_pendulum"] = statistics.median(ratios)
    return out


def _alternate(baseline: str, rounds: int, sizes: list[int], steps: int, repeats: int) -> None:
    here = str(Path(__file__).resolve().parents[1])
    runs: dict[str, list[dict[str, float]]] = {"baseline": [], "this": []}
    args = ["--json", "--rounds", "3", "--steps", str(steps)]
    if sizes:
        args += ["--batched", *map(str, sizes), "--batched-repeats", str(repeats)]
    for k in range(rounds):
        order = (("baseline", baseline), ("this", here))
        for label, root in order if k % 2 == 0 else order[::-1]:
            env = dict(os.environ, PYTHONPATH=root)
            proc = subprocess.run(
                # run as a script (sys.path[0] is its folder): cdcr_gym comes from PYTHONPATH
                [sys.executable, __file__, *args],
                env=env,
                capture_output=True,
                text=True,
                check=True,
                cwd=root,
            )
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            runs[label].append(r)
            print(f"round {k + 1} {label:8s}: {_line(r)}", flush=True)
    for label, rs in runs.items():
        med = {key: statistics.median(r[key] for r in rs) for key in rs[0]}
        print(f"median   {label:8s}: {_line(med)}")
    for key in runs["this"][0]:
        if key.startswith("batched_"):
            per = [t[key] / b[key] for t, b in zip(runs["this"], runs["baseline"])]
            print(
                f"{key} this/baseline per round: {', '.join(f'{x:.2f}' for x in per)}; "
                f"median {statistics.median(per):.2f}"
            )


def _line(r: dict[str, float]) -> str:
    parts = [
        f"single {r['single'] / 1e3:.1f} k/s, Pendulum-v1 {r['pendulum'] / 1e3:.1f} k/s, "
        f"ratio {r['ratio']:.3f}"
    ]
    parts += [
        f"{k} {v / 1e6:.3f} M/s" if k[-1].isdigit() else f"{k} {v:.1f}"
        for k, v in r.items()
        if k.startswith("batched_")
    ]
    return "; ".join(parts)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.bench_single", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--rounds", type=positive_int, default=9, help="alternation rounds")
    parser.add_argument("--steps", type=positive_int, default=4000, help="steps per env per round")
    parser.add_argument("--batched", type=positive_int, nargs="*", default=[], help="batched sizes")
    parser.add_argument(
        "--batched-repeats", type=positive_int, default=3, help="repeats per batched size"
    )
    parser.add_argument("--against", metavar="CHECKOUT", help="alternate with this checkout")
    parser.add_argument("--json", action="store_true", help="print one JSON line")
    parser.add_argument("--output", metavar="FILE", help="also write the result as JSON here")
    args = parser.parse_args(argv)
    if args.output and args.against:
        parser.error("--output writes this checkout's result: not with --against")
    if args.against:
        _alternate(args.against, args.rounds, args.batched, args.steps, args.batched_repeats)
        return 0
    result = single_ratio(args.rounds, args.steps)
    result.update(batched_rates(args.batched, repeats=args.batched_repeats))
    print(json.dumps(result) if args.json else _line(result), flush=True)
    if args.output:
        command = "python -m experiments.bench_single " + " ".join(
            sys.argv[1:] if argv is None else argv
        )
        record = {
            "command": command,
            "cpu_count": os.cpu_count(),
            "rounds": args.rounds,
            "steps": args.steps,
            "result": result,
        }
        Path(args.output).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
