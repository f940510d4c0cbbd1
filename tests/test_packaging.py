"""What `pip install cdcr-gym` promises: the envs with numpy, gymnasium, pybullet, mujoco and scipy only; the
configs inside the wheel; extras for the rest. (.ci/run also installs the built wheel into a
fresh virtual environment without torch and makes every id there.)"""

from __future__ import annotations

import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

tomllib = pytest.importorskip("tomllib", reason="Python >= 3.11")

REPO = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())


def _names(requirements):
    return {re.split(r"[<>=!~\[; ]", r, maxsplit=1)[0].lower() for r in requirements}


def test_core_dependencies_are_the_env_stack_only():
    assert _names(PYPROJECT["project"]["dependencies"]) == {
        "numpy",
        "gymnasium",
        "pybullet",
        "mujoco",
        "scipy",
    }


def test_extras():
    extras = {k: _names(v) for k, v in PYPROJECT["project"]["optional-dependencies"].items()}
    assert {
        "torch",
        "stable-baselines3",
        "sb3-contrib",
        "tensorboard",
        "rich",
        "tqdm",
        "pyyaml",
        "matplotlib",
    } <= extras["train"]
    assert "ray" in extras["sweep"]
    assert {"imageio", "imageio-ffmpeg"} <= extras["video"]
    assert {"mkdocs-material", "mkdocstrings-python"} <= extras["docs"]
    assert "pytest" in extras["test"]
    test_extra = " ".join(PYPROJECT["project"]["optional-dependencies"]["test"])
    for needed in ("train", "video", "sweep"):
        assert needed in test_extra
    assert {"ruff", "mypy"} <= extras["dev"]
    assert PYPROJECT["project"]["scripts"]["cdcr-gym"] == "training.cli:main"


def test_importing_and_making_every_id_loads_neither_torch_nor_matplotlib():
    code = (
        "import sys, gymnasium as gym, cdcr_gym\n"
        "ids = [i for i in gym.registry if i.startswith('cdcr_gym/')]\n"
        "assert ids, 'no ids registered'\n"
        "for i in ids:\n"
        "    env = gym.make(i); env.reset(seed=0); env.step(env.action_space.sample()); env.close()\n"
        "heavy = sorted(m for m in ('torch', 'matplotlib', 'stable_baselines3', 'yaml', 'imageio')"
        " if m in sys.modules)\n"
        "assert not heavy, heavy\n"
        "print(len(ids))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=REPO
    )
    assert out.returncode == 0, out.stderr[-2000:]


@pytest.mark.slow
def test_the_wheel_ships_the_configs_and_the_package_data(tmp_path):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "-q",
            "-w",
            str(tmp_path),
            str(REPO),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    (wheel,) = tmp_path.glob("cdcr_gym-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for config in (REPO / "configs").rglob("*.yaml"):
        assert f"training/configs/{config.relative_to(REPO / 'configs').as_posix()}" in names
    for module in [*(REPO / "cdcr_gym").rglob("*.py"), *(REPO / "training").rglob("*.py")]:
        assert module.relative_to(REPO).as_posix() in names, "every module ships (namespace too)"
    assert "cdcr_gym/py.typed" in names
    assert "training/cli.py" in names and "cdcr_gym/rendering.py" in names
    assert not any(n.startswith(("tests/", "configs/", "experiments/")) for n in names)
    entry_points = next(n for n in names if n.endswith("entry_points.txt"))
    assert "cdcr-gym = training.cli:main" in zipfile.ZipFile(wheel).read(entry_points).decode()


def test_the_experiments_stay_out_of_the_wheel_and_in_the_sdist():
    setup = (REPO / "setup.py").read_text()
    assert '"experiments"' not in setup and "experiments." not in setup
    assert "recursive-include experiments *.py" in (REPO / "MANIFEST.in").read_text()
    assert (REPO / "experiments" / "__init__.py").is_file()
