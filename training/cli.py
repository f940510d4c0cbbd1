"""``cdcr-gym``: the one command of the RL pipeline; each subcommand is a module's ``main``.

::

    cdcr-gym train ppo_ccka_reach [--run-dir DIR] ...   # training.run.train
    cdcr-gym evaluate RUN_DIR [--video] ...             # training.evaluate.agent
    cdcr-gym sweep sweeps/benchmark ...                 # training.sweep.tune (Ray Tune)
    cdcr-gym aggregate SWEEP_OUT [--doc PAGE]           # training.sweep.aggregate
    cdcr-gym reproduce [--out DIR] ...                  # training.studies.reproduce
    cdcr-gym bench [--quick] ...                        # training.studies.bench
    cdcr-gym demo [--env-id ID] ...                     # training.evaluate.ik_demo
    cdcr-gym configs                                    # the packaged experiment configs

and ``from-zoo``, ``oracles``, ``results``, ``bench-physics``, ``calibrate``
(``cdcr-gym --help``). One-off studies and benchmarks are not commands: they live in the
checkout's ``experiments/`` package (``python -m experiments.<name>``), outside the wheel.
Each subcommand's module also runs as ``python -m <module>`` (``python -m training.run.train``).

Everything after the subcommand goes to that module's ``main`` unchanged (``cdcr-gym train
--help`` prints the trainer's own help, whose usage line reads ``cdcr-gym train``). A config
argument that is not an existing file is looked up among the packaged configs by name, with or
without ``.yaml``: the checkout's ``configs/`` directory, which a wheel ships as
``training/configs/``.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from cdcr_gym import __version__
from training.run.packaged import available_configs, configs_dir, resolve_config

__all__ = ["main", "COMMANDS"]

#: subcommand -> (module, one-line description, the extra it needs)
COMMANDS: dict[str, tuple[str, str, str]] = {
    "train": (
        "training.run.train",
        "train an agent (PPO, SAC, TD3, TQC) from a YAML config",
        "train",
    ),
    "evaluate": (
        "training.evaluate.agent",
        "evaluate a run beside its task's oracle and baselines",
        "train",
    ),
    "sweep": ("training.sweep.tune", "hyperparameter sweep (Ray Tune)", "sweep"),
    "aggregate": ("training.sweep.aggregate", "a sweep's IQMs, CIs and benchmark page", "train"),
    "reproduce": (
        "training.studies.reproduce",
        "the paper's CCKA-vs-physics study (figures, report)",
        "train",
    ),
    "bench": ("training.studies.bench", "throughput of the envs and of PPO training", "train"),
    "demo": (
        "training.evaluate.ik_demo",
        "the analytic-IK controller on a few goals (no training)",
        "",
    ),
    "from-zoo": ("training.run.from_zoo", "an RL Baselines3 Zoo run as a run directory", "train"),
    "oracles": (
        "training.evaluate.oracles",
        "the task oracles' numbers on fixed-seed episodes",
        "train",
    ),
    "results": (
        "training.evaluate.results",
        "markdown tables of evaluated runs (any task); --out collects them into a JSON",
        "train",
    ),
    "bench-physics": (
        "training.studies.bench_physics",
        "MuJoCo vs bullet: env steps/s ratios and accuracy vs the Cosserat reference",
        "",
    ),
    "calibrate": (
        "training.studies.calibrate",
        "fit robot parameters to measured tip positions (CSV)",
        "",
    ),
}


#: importable name of an optional dependency -> the extra that installs it
OPTIONAL_MODULES: dict[str, str] = {
    **dict.fromkeys(
        (
            "torch",
            "stable_baselines3",
            "sb3_contrib",
            "tensorboard",
            "rich",
            "tqdm",
            "yaml",
            "matplotlib",
        ),
        "train",
    ),
    **dict.fromkeys(("imageio", "imageio_ffmpeg"), "video"),
    "ray": "sweep",
}


def _first_positional(argv: list[str], options_with_value: set[str]) -> int | None:
    skip = False
    for i, arg in enumerate(argv):
        if skip:
            skip = False
            continue
        if arg == "--":
            return i + 1 if i + 1 < len(argv) else None
        if arg.startswith("-"):
            skip = arg in options_with_value
            continue
        return i
    return None


def _rewrite(command: str, argv: list[str]) -> list[str]:
    """Resolve config names in ``argv`` for the subcommands that take a config."""
    argv = list(argv)
    if command == "train":
        i = _first_positional(argv, {"--run-dir", "--total-timesteps", "--seed"})
        if i is not None:
            argv[i] = resolve_config(argv[i])
    elif command in ("bench", "sweep"):
        if command == "sweep":  # the sweep file: a path or a packaged name (sweeps/benchmark)
            i = _first_positional(argv, {"--address", "--executor", "--out-dir"})
            if i is not None:
                argv[i] = resolve_config(argv[i])
        for i, arg in enumerate(argv):
            if arg == "--config" and i + 1 < len(argv):
                argv[i + 1] = resolve_config(argv[i + 1])
            elif arg.startswith("--config="):
                argv[i] = "--config=" + resolve_config(arg.split("=", 1)[1])
        if command == "bench" and not any(
            a == "--config" or a.startswith("--config=") for a in argv
        ):
            default = resolve_config("ppo_ccka_reach")
            if not Path("configs/ppo_ccka_reach.yaml").is_file() and Path(default).is_file():
                argv += ["--config", default]  # outside a checkout: the packaged default
    return argv


def _load_main(command: str) -> Callable[[list[str]], int | None]:
    module_name, _, extra = COMMANDS[command]
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name == module_name:
            raise SystemExit(
                f"cdcr-gym {command}: {module_name} is not part of this installation "
                f"(it has not been written yet, or this is an older cdcr-gym)"
            ) from None
        top = (exc.name or "").partition(".")[0]
        extra = OPTIONAL_MODULES.get(top, extra)
        hint = f"pip install 'cdcr-gym[{extra}]'" if extra else "reinstall cdcr-gym"
        raise SystemExit(
            f"cdcr-gym {command} needs the Python package {exc.name!r}, which is not installed: "
            f"{hint}"
        ) from None
    entry = getattr(module, "main", None)
    if not callable(entry):
        raise SystemExit(f"cdcr-gym {command}: {module_name} has no main()")
    return entry


def _usage() -> str:
    width = max(len(c) for c in COMMANDS) + 2
    lines = [
        "usage: cdcr-gym COMMAND [ARGS...]",
        "",
        "Cable-driven continuum robot gym: training, evaluation, the paper's study.",
        "",
        "commands:",
    ]
    for name, (_, text, _) in COMMANDS.items():
        lines.append(f"  {name:<{width}}{text}")
    lines.append(f"  {'configs':<{width}}list the packaged experiment configs")
    lines += [
        "",
        "`cdcr-gym COMMAND --help` shows that command's options.",
        "Config names are looked up among the packaged configs: `cdcr-gym train ppo_ccka_reach`.",
    ]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``cdcr-gym COMMAND ARGS``; returns the exit status (2 for usage errors)."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help", "help"):
        print(_usage())
        return 0 if args else 2
    if args[0] in ("-V", "--version"):
        print(f"cdcr-gym {__version__}")
        return 0
    command, rest = args[0], args[1:]
    if command == "configs":
        if rest and rest[0] in ("-h", "--help"):
            print("usage: cdcr-gym configs\n\nList the packaged experiment configs.")
            return 0
        if rest:
            print(
                f"usage: cdcr-gym configs\ncdcr-gym configs: error: unrecognized arguments: "
                f"{' '.join(rest)}",
                file=sys.stderr,
            )
            return 2
        root = configs_dir()
        if root is None:
            print("no packaged configs found", file=sys.stderr)
            return 2
        try:
            print(f"# {root}")
            for name in available_configs():
                print(name)
            sys.stdout.flush()
        except BrokenPipeError:  # the reader stopped early (`cdcr-gym configs | head -1`)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no error at exit
        return 0
    if command not in COMMANDS:
        print(f"cdcr-gym: unknown command {command!r}\n\n{_usage()}", file=sys.stderr)
        return 2
    try:
        entry = _load_main(command)
    except SystemExit as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        status = entry(_rewrite(command, rest))
    except ModuleNotFoundError as exc:  # a lazily imported optional dependency
        top = (exc.name or "").partition(".")[0]
        if top not in OPTIONAL_MODULES:
            raise
        print(
            f"error: cdcr-gym {command} needs {top!r}, which is not installed: "
            f"pip install 'cdcr-gym[{OPTIONAL_MODULES[top]}]'",
            file=sys.stderr,
        )
        return 2
    return int(status or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
