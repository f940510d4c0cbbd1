"""The experiment configs that ship with the package, found by name.

A wheel has them in ``training/configs/``; a checkout (editable install) in ``configs/`` beside
``training/``. ``cdcr-gym train ppo_ccka_reach`` and a sweep file's ``configs:`` entries use
:func:`resolve_config`.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["configs_dir", "available_configs", "resolve_config"]


def configs_dir() -> Path | None:
    """The directory of the packaged experiment configs, or None if there is none.

    A wheel install has them in ``training/configs/``; a checkout (editable install) has them in
    ``configs/`` beside ``training/``.
    """
    here = Path(__file__).resolve().parent.parent  # training/
    packaged = here / "configs"
    if packaged.is_dir():
        return packaged
    checkout = here.parent / "configs"
    if checkout.is_dir() and (here.parent / "pyproject.toml").is_file():
        return checkout
    return None


def available_configs() -> list[str]:
    """Names (relative paths without ``.yaml``) of the packaged configs."""
    root = configs_dir()
    if root is None:
        return []
    return sorted(str(p.relative_to(root).with_suffix("")) for p in root.rglob("*.yaml"))


def resolve_config(name: str) -> str:
    """``name`` itself if it is an existing file, else the packaged config of that name.

    ``ppo_ccka_reach``, ``ppo_ccka_reach.yaml`` and ``configs/ppo_ccka_reach.yaml`` all find
    ``configs/ppo_ccka_reach.yaml``. An unknown name is returned unchanged (the trainer then
    reports the missing file).
    """
    if Path(name).is_file():
        return name
    root = configs_dir()
    if root is None:
        return name
    stem = Path(name)
    if stem.parts and stem.parts[0] == "configs":
        stem = Path(*stem.parts[1:])
    for candidate in (root / stem, root / stem.with_suffix(".yaml")):
        if candidate.is_file():
            return str(candidate)
    return name
