"""The cdcr-gym console script: a thin front over the python -m training.<module> mains."""

from __future__ import annotations

import subprocess
import sys
import types
from pathlib import Path

import pytest

from training import cli

REPO = Path(__file__).resolve().parents[2]


def _fake(monkeypatch, module_name):
    calls = []
    fake = types.SimpleNamespace(main=lambda argv: calls.append(list(argv)) or 0)
    monkeypatch.setitem(sys.modules, module_name, fake)
    return calls


def test_help_lists_every_subcommand(capsys):
    assert cli.main(["--help"]) == 0
    out = capsys.readouterr().out
    for command in [*cli.COMMANDS, "configs"]:
        assert f"  {command} " in out
    assert cli.main([]) == 2  # no command: usage, usage error


@pytest.mark.parametrize("command", sorted(cli.COMMANDS))
def test_each_subcommand_has_help_that_names_it(command, capsys):
    """One command: every subcommand's usage line reads ``cdcr-gym SUBCOMMAND``."""
    with pytest.raises(SystemExit) as exc:
        cli.main([command, "--help"])
    assert exc.value.code == 0
    assert f"usage: cdcr-gym {command} " in capsys.readouterr().out


@pytest.mark.parametrize(
    "name", ["ppo_ccka_reach", "ppo_ccka_reach.yaml", "configs/ppo_ccka_reach.yaml"]
)
def test_train_resolves_packaged_config_names(monkeypatch, tmp_path, name):
    monkeypatch.chdir(tmp_path)  # outside the checkout: the name is not a path here
    calls = _fake(monkeypatch, "training.run.train")
    assert cli.main(["train", name, "--seed", "3", "--run-dir", "runs/x"]) == 0
    (argv,) = calls
    assert Path(argv[0]) == REPO / "configs" / "ppo_ccka_reach.yaml"
    assert argv[1:] == ["--seed", "3", "--run-dir", "runs/x"]


def test_an_existing_config_path_is_kept_and_options_before_it_are_skipped(monkeypatch, tmp_path):
    own = tmp_path / "ppo_ccka_reach.yaml"
    own.write_text("name: mine\n")
    monkeypatch.chdir(tmp_path)
    calls = _fake(monkeypatch, "training.run.train")
    cli.main(["train", "--seed", "1", "ppo_ccka_reach.yaml"])
    assert calls == [["--seed", "1", "ppo_ccka_reach.yaml"]]


def test_every_packaged_config_is_listed(capsys):
    assert cli.main(["configs"]) == 0
    listed = capsys.readouterr().out.split()
    for path in (REPO / "configs").rglob("*.yaml"):
        assert str(path.relative_to(REPO / "configs").with_suffix("")) in listed


def test_demo_and_evaluate_forward_their_arguments(monkeypatch):
    calls = _fake(monkeypatch, "training.evaluate.ik_demo")
    cli.main(["demo", "--episodes", "2"])
    assert calls == [["--episodes", "2"]]
    calls = _fake(monkeypatch, "training.evaluate.agent")
    cli.main(["evaluate", "runs/a", "--video"])
    assert calls == [["runs/a", "--video"]]


def test_sweep_without_training_sweep_exits_2_with_a_clear_message(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "training.sweep.tune", None)  # import fails as if absent
    assert cli.main(["sweep", "--help"]) == 2
    assert "training.sweep.tune is not part of this installation" in capsys.readouterr().err


def test_sweep_forwards_when_present(monkeypatch):
    calls = _fake(monkeypatch, "training.sweep.tune")
    assert cli.main(["sweep", "--config", "ppo_ccka_reach"]) == 0
    assert calls[0][0] == "--config" and Path(calls[0][1]).name == "ppo_ccka_reach.yaml"


def test_a_missing_dependency_names_the_extra(monkeypatch, capsys):
    def missing(name):
        raise ModuleNotFoundError("No module named 'torch'", name="torch")

    monkeypatch.setattr(cli.importlib, "import_module", missing)
    assert cli.main(["train", "ppo_ccka_reach"]) == 2
    err = capsys.readouterr().err
    assert "'torch'" in err and "cdcr-gym[train]" in err


def test_unknown_command_is_a_usage_error(capsys):
    assert cli.main(["trian"]) == 2
    assert "unknown command 'trian'" in capsys.readouterr().err


def test_python_m_training_cli_runs():
    out = subprocess.run(
        [sys.executable, "-m", "training.cli", "demo", "--episodes", "1"],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    assert "analytic-IK controller, 1 episodes" in out.stdout


def test_an_optional_dependency_missing_at_run_time_names_its_extra(monkeypatch, capsys):
    def main(argv):
        raise ModuleNotFoundError("No module named 'stable_baselines3'", name="stable_baselines3")

    monkeypatch.setitem(sys.modules, "training.studies.bench", types.SimpleNamespace(main=main))
    assert cli.main(["bench", "--quick"]) == 2
    assert "cdcr-gym[train]" in capsys.readouterr().err

    def broken(argv):
        raise ModuleNotFoundError("No module named 'cdcr_gym.nothing'", name="cdcr_gym.nothing")

    monkeypatch.setitem(sys.modules, "training.studies.bench", types.SimpleNamespace(main=broken))
    with pytest.raises(ModuleNotFoundError):  # a real bug is not disguised as a missing extra
        cli.main(["bench"])


def test_configs_listing_into_a_closed_pipe_is_not_an_error() -> None:
    """`cdcr-gym configs | head -1` (or `| grep -q`): the reader closes the pipe early; the
    listing ends quietly with status 0 instead of a BrokenPipeError traceback."""
    import subprocess
    import sys

    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from training.cli import main; sys.exit(main(['configs']))",
        ],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None
    proc.stdout.close()  # the reader is gone before anything is written
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err.decode()
    assert b"BrokenPipeError" not in err and b"Traceback" not in err
