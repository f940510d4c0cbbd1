"""Turn an RL Baselines3 Zoo run into a cdcr_gym run directory, so ``training.evaluate`` reads it.

The zoo (``python -m rl_zoo3.train ... -f LOGS``) saves ``LOGS/ppo/<env>_<k>/<env>.zip`` and
``<env>/vecnormalize.pkl``. This copies them to ``RUN/final_model/model.zip`` and
``RUN/final_model/vecnormalize.pkl`` and writes ``RUN/config.yaml`` from a cdcr_gym config (the
env, evaluation settings and seed the evaluation uses)::

    python -m training.run.from_zoo runs/zoo/ppo/cdcr_gym-CCKAReach-v0_1 runs/zoo_eval \\
        --config configs/ppo_ccka_reach.yaml
    python -m training.evaluate runs/zoo_eval --model final

Exit code 2 with a message naming the path when the zoo run is incomplete.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path


def convert(zoo_run: Path, run_dir: Path, config: Path) -> Path:
    """Copy the zoo model and its normalisation into ``run_dir``; returns the model directory.

    Raises:
        FileNotFoundError: naming the missing file.
        FileExistsError: if ``run_dir`` already holds a model.
    """
    zips = sorted(p for p in zoo_run.glob("*.zip") if not p.name.startswith("rl_model"))
    if not zips:
        raise FileNotFoundError(f"no saved zoo model (<env>.zip) in {str(zoo_run)!r}")
    model = zips[0]
    vecnormalize = zoo_run / model.stem / "vecnormalize.pkl"
    if not config.is_file():
        raise FileNotFoundError(f"config {str(config)!r} does not exist")
    model_dir = run_dir / "final_model"
    if (model_dir / "model.zip").exists():
        raise FileExistsError(f"{str(model_dir / 'model.zip')!r} exists; choose another run dir")
    model_dir.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(model, model_dir / "model.zip")
    if vecnormalize.is_file():
        shutil.copyfile(vecnormalize, model_dir / "vecnormalize.pkl")
    shutil.copyfile(config, run_dir / "config.yaml")
    (run_dir / "command.txt").write_text(
        f"converted from the rl_zoo3 run {zoo_run} (model {model.name}) with {config}\n",
        encoding="utf-8",
    )
    return model_dir


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="cdcr-gym from-zoo",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("zoo_run", type=Path, help="the zoo's run folder (LOGS/ppo/<env>_<k>)")
    parser.add_argument("run_dir", type=Path, help="the cdcr_gym run directory to write")
    parser.add_argument(
        "--config",
        type=Path,
        default=Path("configs/ppo_ccka_reach.yaml"),
        help="cdcr_gym config for the env and evaluation settings",
    )
    args = parser.parse_args(argv)
    try:
        model_dir = convert(args.zoo_run, args.run_dir, args.config)
    except (FileNotFoundError, FileExistsError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(
        f"wrote {model_dir}; evaluate with: python -m training.evaluate {args.run_dir} "
        f"--model final"
    )
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
