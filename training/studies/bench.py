"""Throughput of the environments and of PPO training, measured side by side in one run.

Usage::

    python -m training.studies.bench [--quick] [--repeats K] [--out FILE.md|FILE.json] [--config YAML]

Rows (env-steps per second, the median of K repeats; the range is min–max):

* ``CCKAReach-v0`` through ``gymnasium.make`` (its default wrappers: PassiveEnvChecker,
  OrderEnforcing, TimeLimit), next to Gymnasium's ``Pendulum-v1`` made the same way;
* the batched env (``make_vec(..., vectorization_mode="vector_entry_point")``) and a
  ``SyncVectorEnv`` of single envs, at 64, 1 024 and 16 384 envs;
* ``BulletReach-v0`` through ``gymnasium.make`` ("unavailable: <reason>" if it cannot be built);
* PPO training steps/s on the default config (``configs/ppo_ccka_reach.yaml``: its PPO
  hyperparameters, envs and VecNormalize), with the config's ``DummyVecEnv`` of single envs and
  with ``BatchedVecEnv``, at equal steps.

Every loop is used as a training loop uses an env: random actions (a fixed pool), results kept
until the next step, single envs reset when their episode ends (resets are in the timing). The
machine is described in the output (CPU, cores, load average, versions); on a shared machine run
it more than once and compare medians.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path
from typing import Any

import gymnasium
import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401
from training.run.algorithms import ppo_kwargs, wrap_normalize
from training.run.argtypes import positive_int
from training.run.config import load_config
from training.run.envs import build_vec_env
from training.run.sb3_vec import BatchedVecEnv

__all__ = ["main", "run_benchmarks"]


def _default_config() -> Path:
    """configs/ppo_ccka_reach.yaml of the checkout, else the copy shipped in the wheel
    (``training.configs``): never relative to the working directory."""
    checkout = Path(__file__).resolve().parents[2] / "configs" / "ppo_ccka_reach.yaml"
    if checkout.is_file():
        return checkout
    return Path(__file__).resolve().parents[1] / "configs" / "ppo_ccka_reach.yaml"


DEFAULT_CONFIG = _default_config()
VECTOR_SIZES = (64, 1024, 16384)


# -- measurement ----------------------------------------------------------------------------------
def _rate(step: Callable[[], int], min_time: float, min_calls: int) -> float:
    """Steps per second of ``step`` (which returns how many env steps it made)."""
    start = time.perf_counter()
    steps = calls = 0
    while calls < min_calls or time.perf_counter() - start < min_time:
        steps += step()
        calls += 1
    return steps / (time.perf_counter() - start)


def _repeat(measure: Callable[[], float], repeats: int) -> dict[str, Any]:
    rates = [measure() for _ in range(repeats)]
    return {
        "median": statistics.median(rates),
        "min": min(rates),
        "max": max(rates),
        "repeats": repeats,
    }


def _single_env(env_id: str, min_time: float, repeats: int, **kwargs: Any) -> dict[str, Any]:

    env = gym.make(env_id, **kwargs)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(64)]
    state = {"k": 0, "out": None}

    def step() -> int:
        k = state["k"] = (state["k"] + 1) % 64
        out = state["out"] = env.step(actions[k])
        if out[2] or out[3]:
            env.reset()
        return 1

    for _ in range(200):  # warm-up (the passive checker's first-step checks, caches)
        step()
    result = _repeat(lambda: _rate(step, min_time, 10), repeats)
    env.close()
    return result


def _vector_env(
    mode: str, n: int, min_time: float, repeats: int, robot: str = "paper"
) -> dict[str, Any]:

    env = gym.make_vec("cdcr_gym/CCKAReach-v0", num_envs=n, vectorization_mode=mode, robot=robot)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(8)]
    state = {"k": 0, "out": None}

    def step() -> int:
        k = state["k"] = (state["k"] + 1) % 8
        state["out"] = env.step(actions[k])
        return n

    step()
    # at least 100 steps for the batched env, so that each repeat includes the autoresets of
    # every env (episodes are 100 steps, all in phase)
    calls = 100 if mode == "vector_entry_point" else 3
    result = _repeat(lambda: _rate(step, min_time, calls), repeats)
    env.close()
    return result


def _sb3_vec_env(kind: str, n: int, min_time: float, repeats: int) -> dict[str, Any]:
    """SB3 VecEnv steps/s: ``DummyVecEnv`` of single envs vs ``BatchedVecEnv``."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    if kind == "batched":
        venv = BatchedVecEnv(n, seed=0)
    else:
        venv = DummyVecEnv([lambda: gym.make("cdcr_gym/CCKAReach-v0")] * n)
        venv.seed(0)
    venv.reset()
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, (n, 3)).astype(np.float32) for _ in range(8)]
    state = {"k": 0, "out": None}

    def step() -> int:
        k = state["k"] = (state["k"] + 1) % 8
        state["out"] = venv.step(actions[k])
        return n

    result = _repeat(lambda: _rate(step, min_time, 100), repeats)
    venv.close()
    return result


def _rollout_timer() -> Any:
    """An SB3 callback adding up the wall time spent collecting rollouts (envs + policy)."""
    from stable_baselines3.common.callbacks import BaseCallback

    class RolloutTimer(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.seconds = 0.0
            self._start = 0.0

        def _on_rollout_start(self) -> None:
            self._start = time.perf_counter()

        def _on_rollout_end(self) -> None:
            self.seconds += time.perf_counter() - self._start

        def _on_step(self) -> bool:
            return True

    return RolloutTimer()


def _env_timer(venv: Any) -> Any:
    """``venv`` wrapped so that the wall time spent inside it (reset, step_async, step_wait) adds
    up in ``.seconds``: the env's share of a PPO run, policy inference and VecNormalize excluded."""
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class EnvTimer(VecEnvWrapper):
        def __init__(self, inner: Any) -> None:
            super().__init__(inner)
            self.seconds = 0.0

        def reset(self) -> Any:
            start = time.perf_counter()
            out = self.venv.reset()
            self.seconds += time.perf_counter() - start
            return out

        def step_async(self, actions: Any) -> None:
            start = time.perf_counter()
            self.venv.step_async(actions)
            self.seconds += time.perf_counter() - start

        def step_wait(self) -> Any:
            start = time.perf_counter()
            out = self.venv.step_wait()
            self.seconds += time.perf_counter() - start
            return out

    return EnvTimer(venv)


def _ppo_runs(
    make_model: Callable[[], tuple[Any, Any]], steps: int, repeats: int
) -> dict[str, Any]:
    """``make_model()`` returns (PPO model, its env timer from :func:`_env_timer`)."""
    rates, shares, env_shares = [], [], []
    for _ in range(repeats):
        model, env_timer = make_model()
        timer = _rollout_timer()
        start = time.perf_counter()
        model.learn(total_timesteps=steps, callback=timer)
        elapsed = time.perf_counter() - start
        model.get_env().close()
        rates.append(model.num_timesteps / elapsed)
        shares.append(timer.seconds / elapsed)
        env_shares.append(env_timer.seconds / elapsed)
    return {
        "median": statistics.median(rates),
        "min": min(rates),
        "max": max(rates),
        "repeats": repeats,
        "rollout_share": statistics.median(shares),
        "env_share": statistics.median(env_shares),
        "steps": steps,
    }


def _ppo(config_path: Path, vec_env: str, steps: int, repeats: int) -> dict[str, Any]:
    """PPO ``learn`` wall time at ``steps`` env steps on the config's hyperparameters."""
    import torch
    from stable_baselines3 import PPO

    config = load_config(config_path)
    config = dataclasses.replace(config, env=dataclasses.replace(config.env, vec_env=vec_env))
    torch.set_num_threads(config.runtime.torch_threads)

    def make_model() -> tuple[Any, Any]:
        env_timer = _env_timer(build_vec_env(config, config.seed))
        venv = wrap_normalize(config, env_timer, None)
        model = PPO(
            "MlpPolicy",
            venv,
            seed=config.seed,
            device=config.runtime.device,
            verbose=0,
            **ppo_kwargs(config),
        )
        return model, env_timer

    result = _ppo_runs(make_model, steps, repeats)
    result.update(
        n_envs=config.env.n_envs,
        n_steps=config.ppo.n_steps,
        torch_threads=config.runtime.torch_threads,
    )
    return result


def _ppo_defaults(vec_env: str, steps: int, repeats: int) -> dict[str, Any]:
    """Fallback without the config: PPO's defaults on 8 envs."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    torch.set_num_threads(1)

    def make_model() -> tuple[Any, Any]:
        if vec_env == "batched":
            venv = VecMonitor(BatchedVecEnv(8, seed=0))
        else:
            venv = VecMonitor(DummyVecEnv([lambda: gym.make("cdcr_gym/CCKAReach-v0")] * 8))
        env_timer = _env_timer(venv)
        return PPO("MlpPolicy", env_timer, seed=0, device="cpu", verbose=0), env_timer

    result = _ppo_runs(make_model, steps, repeats)
    result.update(n_envs=8, torch_threads=1)
    return result


# -- the run --------------------------------------------------------------------------------------
def machine() -> dict[str, Any]:
    """CPU model, core count, load average and library versions."""

    model = platform.processor() or "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    info: dict[str, Any] = {
        "cpu": model,
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "gymnasium": gymnasium.__version__,
    }
    for name in ("torch", "stable_baselines3", "pybullet"):
        try:
            info[name] = version(name.replace("_", "-"))
        except Exception:  # noqa: BLE001 - informational
            info[name] = "not installed"
    return info


def _load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def run_benchmarks(
    quick: bool = False,
    repeats: int | None = None,
    config: Path = DEFAULT_CONFIG,
    log: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Run every benchmark; returns ``{"machine", "rows", "checks", ...}``."""

    repeats = repeats or (3 if quick else 5)
    min_time = 0.3 if quick else 1.0
    ppo_steps = 8192 if quick else 20480
    ppo_repeats = 1 if quick else 3
    rows: list[dict[str, Any]] = []
    result: dict[str, Any] = {
        "machine": machine(),
        "load_before": _load(),
        "quick": quick,
        "repeats": repeats,
    }

    def add(
        name: str, envs: int | None, measured: dict[str, Any] | None, note: str = "", key: str = ""
    ) -> None:
        row = {"key": key or name, "name": name, "envs": envs, "note": note}
        if measured is not None:
            row.update(measured)
        rows.append(row)
        log(_format_row(row))

    log(_HEADER)
    add(
        "CCKAReach-v0 (gym.make)",
        1,
        _single_env("cdcr_gym/CCKAReach-v0", min_time, repeats),
        "single env, default wrappers",
        key="ccka_single",
    )
    add(
        "Pendulum-v1 (gym.make)",
        1,
        _single_env("Pendulum-v1", min_time, repeats),
        "Gymnasium reference",
        key="pendulum",
    )
    add(
        "CCKAReach-v0 tdcr2 (gym.make)",
        1,
        _single_env("cdcr_gym/CCKAReach-v0", min_time, repeats, robot="tdcr2"),
        "single env, two-section robot (6 cables)",
        key="ccka_single_tdcr2",
    )
    for n in VECTOR_SIZES:
        add(
            "CCKAReach-v0 batched",
            n,
            _vector_env("vector_entry_point", n, min_time, repeats),
            "make_vec vector_entry_point",
            key=f"batched_{n}",
        )
        add(
            "CCKAReach-v0 SyncVectorEnv",
            n,
            _vector_env("sync", n, min_time, 1 if n > 1024 else repeats),
            "make_vec sync" + (" (1 repeat)" if n > 1024 else ""),
            key=f"sync_{n}",
        )
    add(
        "CCKAReach-v0 tdcr2 batched",
        16384,
        _vector_env("vector_entry_point", 16384, min_time, repeats, robot="tdcr2"),
        "make_vec vector_entry_point, two-section robot",
        key="batched_16384_tdcr2",
    )
    for kind, label in (("dummy", "SB3 DummyVecEnv"), ("batched", "SB3 BatchedVecEnv")):
        add(
            label,
            8,
            _sb3_vec_env(kind, 8, min_time, repeats),
            "the VecEnv PPO steps (SB3 API: per-env info dicts)",
            key=f"sb3_{kind}",
        )
    try:
        bullet = _single_env("cdcr_gym/BulletReach-v0", min_time, repeats)
        add("BulletReach-v0 (gym.make)", 1, bullet, "single env, pybullet", key="bullet")
    except Exception as exc:  # noqa: BLE001 - the row reports why
        add(
            "BulletReach-v0 (gym.make)",
            1,
            None,
            f"unavailable: {type(exc).__name__}: {exc}"[:160],
            key="bullet",
        )
    if config.exists():
        default_vec_env = load_config(config).env.vec_env
        result["ppo_default_vec_env"] = default_vec_env
        for vec_env in ("dummy", "batched"):
            measured = _ppo(config, vec_env, ppo_steps, ppo_repeats)
            add(
                f"PPO training ({vec_env})",
                measured["n_envs"],
                measured,
                f"{config.name}{' (its vec_env)' if vec_env == default_vec_env else ''}, "
                f"{ppo_steps} steps, torch threads {measured['torch_threads']}; rollouts "
                f"{measured['rollout_share']:.0%} of the time, in the env "
                f"{measured['env_share']:.1%}",
                key=f"ppo_{vec_env}",
            )
    else:
        for vec_env in ("dummy", "batched"):
            measured = _ppo_defaults(vec_env, ppo_steps, ppo_repeats)
            add(
                f"PPO training ({vec_env})",
                8,
                measured,
                f"{config} missing: PPO defaults, 8 envs, {ppo_steps} steps; rollouts "
                f"{measured['rollout_share']:.0%} of the time, in the env "
                f"{measured['env_share']:.1%}",
                key=f"ppo_{vec_env}",
            )

    result["rows"] = rows
    result["load_after"] = _load()
    result["checks"] = _checks({r["key"]: r for r in rows}, result.get("ppo_default_vec_env"))
    return result


def _checks(
    by_key: dict[str, dict[str, Any]], ppo_vec_env: str | None = None
) -> list[dict[str, Any]]:
    """The targets: (name, value, target, ok) rows; ``ok`` is value >= target, or value <=
    target for the rows marked "at most"."""

    def ratio(a: str, b: str) -> float | None:
        if "median" in by_key.get(a, {}) and "median" in by_key.get(b, {}):
            return by_key[a]["median"] / by_key[b]["median"]
        return None

    checks = [
        ("CCKAReach-v0 / Pendulum-v1 (gym.make)", ratio("ccka_single", "pendulum"), 0.5),
        (
            "batched at 16 384 envs, M env-steps/s",
            by_key["batched_16384"]["median"] / 1e6 if "batched_16384" in by_key else None,
            20.0,
        ),
        (
            "tdcr2 batched at 16 384 envs, M env-steps/s",
            by_key["batched_16384_tdcr2"]["median"] / 1e6
            if "median" in by_key.get("batched_16384_tdcr2", {})
            else None,
            5.0,
        ),
        ("batched / SyncVectorEnv at 1 024 envs", ratio("batched_1024", "sync_1024"), 50.0),
        ("batched / SyncVectorEnv at 64 envs", ratio("batched_64", "sync_64"), None),
        ("batched / SyncVectorEnv at 16 384 envs", ratio("batched_16384", "sync_16384"), None),
        (
            "SB3 VecEnv, BatchedVecEnv / DummyVecEnv (8 envs)",
            ratio("sb3_batched", "sb3_dummy"),
            None,
        ),
        ("PPO wall-time speed-up, batched / dummy", ratio("ppo_batched", "ppo_dummy"), None),
    ]
    at_most = set()
    if ppo_vec_env is not None and "env_share" in by_key.get(f"ppo_{ppo_vec_env}", {}):
        name = f"default PPO run ({ppo_vec_env}): env share of wall time, at most"
        checks.append((name, by_key[f"ppo_{ppo_vec_env}"]["env_share"], 0.10))
        at_most.add(name)
    return [
        {
            "name": name,
            "value": value,
            "target": target,
            "ok": None
            if value is None or target is None
            else (value <= target if name in at_most else value >= target),
        }
        for name, value, target in checks
    ]


# -- formatting -----------------------------------------------------------------------------------
_HEADER = (
    "| benchmark | envs | env-steps/s (median) | range (min–max) | notes |\n"
    "|---|---:|---:|---:|---|"
)


def _si(x: float) -> str:
    for scale, suffix in ((1e6, " M"), (1e3, " k")):
        if x >= scale:
            return f"{x / scale:.3g}{suffix}"
    return f"{x:.3g}"


def _format_row(row: dict[str, Any]) -> str:
    envs = "" if row["envs"] is None else f"{row['envs']:,}".replace(",", " ")
    if "median" not in row:
        return f"| {row['name']} | {envs} | – | – | {row['note']} |"
    return (
        f"| {row['name']} | {envs} | {_si(row['median'])} | "
        f"{_si(row['min'])}–{_si(row['max'])} | {row['note']} |"
    )


def to_markdown(result: dict[str, Any]) -> str:
    m = result["machine"]
    lines = [
        f"Machine: {m['cpu']}, {m['cores']} cores ({m['platform']}); Python {m['python']}, "
        f"numpy {m['numpy']}, gymnasium {m['gymnasium']}, torch {m['torch']}, "
        f"stable-baselines3 {m['stable_baselines3']}, pybullet {m['pybullet']}.",
        f"Load average (1/5/15 min) before: {result['load_before']}, after: "
        f"{result['load_after']}. Median of {result['repeats']} repeats"
        + (" (--quick)." if result["quick"] else "."),
        "",
        _HEADER,
        *(_format_row(r) for r in result["rows"]),
        "",
        "| check | value | target | met |",
        "|---|---:|---:|:---:|",
    ]
    for c in result["checks"]:
        value = "–" if c["value"] is None else f"{c['value']:.3g}"
        sign = "≤" if c["name"].endswith("at most") else "≥"
        target = "" if c["target"] is None else f"{sign} {c['target']:g}"
        ok = {True: "yes", False: "NO", None: ""}[c["ok"]]
        lines.append(f"| {c['name']} | {value} | {target} | {ok} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="cdcr-gym bench",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="shorter timings (0.3 s per repeat, 3 repeats, PPO 8 192 steps)",
    )
    parser.add_argument(
        "--repeats",
        type=positive_int,
        default=None,
        help="repeats per row (default 5; 3 with --quick)",
    )
    parser.add_argument(
        "--config",
        type=Path,
        default=DEFAULT_CONFIG,
        help=f"training config for the PPO rows (default {DEFAULT_CONFIG})",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        help="also write the results: .json (all numbers) or .md (the tables)",
    )
    args = parser.parse_args(argv)
    if args.repeats is not None and args.repeats < 1:
        parser.error("--repeats must be >= 1")
    if args.out is not None and args.out.suffix not in (".json", ".md"):
        parser.error("--out must end in .json or .md")
    if not args.config.is_file():
        parser.error(f"--config {str(args.config)!r} does not exist")
    if args.out is not None:  # fail now, not after minutes of benchmarking
        try:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            with open(args.out, "a", encoding="utf-8"):
                pass
        except OSError as exc:
            parser.error(f"--out {str(args.out)!r} is not writable: {exc.strerror}")

    result = run_benchmarks(quick=args.quick, repeats=args.repeats, config=args.config)
    text = to_markdown(result)
    print()
    print(text)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        if args.out.suffix == ".json":
            args.out.write_text(json.dumps(result, indent=2) + "\n")
        else:
            args.out.write_text(text + "\n")
        print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
