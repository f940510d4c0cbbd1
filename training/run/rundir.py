"""The run directory: its paths, its lock, the checkpoints' state files, and what a fresh start
clears."""

from __future__ import annotations

import hashlib
import os
import pickle
import re
import shutil
import socket
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from training.run.config import ConfigError

#: Files a training session writes into a run directory (removed when a run restarts afresh).
ARTEFACTS = (
    "tb",
    "progress.csv",
    "eval_log.csv",
    "checkpoints",
    "best_model",
    "final_model",
    "vecnormalize.pkl",
    "learning_curve.png",
    "demonstrations.json",
)
#: Off-policy checkpoints keep their (large) replay buffer for the newest this many.
KEEP_REPLAY_BUFFERS = 2


# -- the run directory --------------------------------------------------------------------------
class RunDir:
    """Paths inside a run directory."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    config = property(lambda self: self.root / "config.yaml")
    run_json = property(lambda self: self.root / "run.json")
    command = property(lambda self: self.root / "command.txt")
    tb = property(lambda self: self.root / "tb")
    progress = property(lambda self: self.root / "progress.csv")
    eval_log = property(lambda self: self.root / "eval_log.csv")
    checkpoints = property(lambda self: self.root / "checkpoints")
    best = property(lambda self: self.root / "best_model")
    final = property(lambda self: self.root / "final_model")
    vecnormalize = property(lambda self: self.root / "vecnormalize.pkl")
    learning_curve = property(lambda self: self.root / "learning_curve.png")

    def checkpoint_paths(self, steps: int) -> tuple[Path, Path]:
        return (
            self.checkpoints / f"model_{steps}_steps.zip",
            self.checkpoints / f"vecnormalize_{steps}_steps.pkl",
        )

    def replay_buffer_path(self, steps: int) -> Path:
        return self.checkpoints / f"replay_buffer_{steps}_steps.pkl"

    def state_path(self, steps: int) -> Path:
        return self.checkpoints / f"state_{steps}_steps.pkl"

    def checkpoint_steps(self) -> list[int]:
        """Step counts that have a checkpoint state file, newest first (not yet validated)."""
        steps = []
        for path in self.checkpoints.glob("state_*_steps.pkl"):
            m = re.fullmatch(r"state_(\d+)_steps\.pkl", path.name)
            if m:
                steps.append(int(m.group(1)))
        return sorted(steps, reverse=True)

    def latest_checkpoint(self) -> int | None:
        """Step count of the newest complete checkpoint (see :meth:`Checkpoint.read`), or None."""
        for steps in self.checkpoint_steps():
            try:
                Checkpoint.read(self, steps)
            except CheckpointError:
                continue
            return steps
        return None


class CheckpointError(Exception):
    """A checkpoint that is incomplete or corrupt (the message names the file)."""


def sha256_file(path: Path) -> str:

    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def atomic_write(path: Path, write: Callable[[Path], None]) -> None:
    """``write(tmp)`` then rename ``tmp`` to ``path``: a kill leaves the old file or none."""
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:  # a full disk, a kill: no half-written temporary left behind
        tmp.unlink(missing_ok=True)
        raise


class Checkpoint:
    """The state file of one checkpoint: what :func:`save_checkpoint` stored besides the model.

    Attributes:
        steps: environment steps at the checkpoint.
        data: ``files`` (name -> size, sha256), ``rng`` (python, numpy, torch, action space),
            ``envs`` (pickled training-env states, or None), ``vecnormalize_returns``,
            ``best_score``, ``wall_time_s``, ``last_eval_step``.
    """

    def __init__(self, steps: int, data: dict[str, Any]) -> None:
        self.steps = steps
        self.data = data

    @classmethod
    def read(cls, run: RunDir, steps: int) -> Checkpoint:
        """Load and validate checkpoint ``steps``: every file present with its recorded size and
        hash. Raises :class:`CheckpointError` naming the bad file."""
        path = run.state_path(steps)
        try:
            with open(path, "rb") as f:
                data = pickle.load(f)
            files = data["files"]
        except Exception as exc:  # noqa: BLE001 - truncated/foreign: many exception types
            raise CheckpointError(f"{path}: unreadable ({type(exc).__name__}: {exc})") from None
        for name, (size, digest) in files.items():
            file = run.checkpoints / name
            if not file.is_file():
                raise CheckpointError(f"{file}: missing")
            if file.stat().st_size != size or sha256_file(file) != digest:
                raise CheckpointError(f"{file}: truncated or modified (size/hash differ)")
        return cls(steps, data)


def clear_artefacts(run: RunDir) -> None:
    """Remove what a previous session wrote (a restart afresh of a run without a checkpoint)."""

    for name in ARTEFACTS:
        path = run.root / name
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()


def refuse_legacy(run: RunDir) -> None:
    """A run directory of the previous checkpoint format (``checkpoints/state.json``, no state
    files) is neither resumed nor restarted over: its checkpoints would be discarded."""
    if (run.checkpoints / "state.json").is_file() and not run.checkpoint_steps():
        raise ConfigError(
            f"--run-dir {str(run.root)!r} holds checkpoints of an older format (no "
            f"state_N_steps.pkl), which cannot be resumed exactly and would be discarded; "
            f"train into another --run-dir"
        )


#: The lock file of a run directory (holds the pid of the training that has, or last had, it).
LOCK_NAME = ".train.lock"


class RunDirBusy(ConfigError):
    """Another training holds the run directory's lock (the message names its pid)."""


class RunLock:
    """An exclusive lock on a run directory for the duration of one training session.

    ``RUN/.train.lock`` is locked with ``fcntl.flock`` (the kernel releases it when its process
    ends, however it ends: a lock left by a killed training is stale and simply taken over) and
    holds the holder's pid, host and start time for the message of a second training, which
    raises :class:`RunDirBusy` before it has read, written or deleted anything. Without
    ``fcntl`` (Windows) the file is created with ``O_EXCL`` and a lock whose pid no longer runs
    on this host is stale and replaced."""

    def __init__(self, root: str | Path) -> None:
        self.path = Path(root) / LOCK_NAME
        self.fd: int | None = None

    def holder(self) -> str:
        try:
            return self.path.read_text().strip() or "pid unknown"
        except OSError:
            return "pid unknown"

    def busy(self) -> RunDirBusy:
        return RunDirBusy(
            f"--run-dir {str(self.path.parent)!r} is in use by another training "
            f"({self.holder()}); nothing was changed: wait for it to end, or train into "
            f"another --run-dir"
        )

    def acquire(self) -> RunLock:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows
            fd = self._acquire_exclusive()
        else:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                os.close(fd)
                raise self.busy() from None
        stamp = time.strftime("%Y-%m-%dT%H:%M:%S%z")
        os.ftruncate(fd, 0)
        os.write(fd, f"pid {os.getpid()} on {socket.gethostname()} since {stamp}\n".encode())
        self.fd = fd
        return self

    def _acquire_exclusive(self) -> int:  # pragma: no cover - Windows
        for _ in range(2):
            try:
                return os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                words = self.holder().split()
                pid = int(words[1]) if len(words) > 1 and words[1].isdigit() else None
                if pid is not None and _pid_alive(pid):
                    raise self.busy() from None
                self.path.unlink(missing_ok=True)  # stale: its training is gone
        raise self.busy()

    def release(self) -> None:
        if self.fd is None:
            return
        os.close(self.fd)  # releases the flock; the file stays (a later training reuses it)
        self.fd = None
        if os.name == "nt":  # pragma: no cover - the O_EXCL variant
            self.path.unlink(missing_ok=True)

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


def _pid_alive(pid: int) -> bool:  # pragma: no cover - Windows
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True
