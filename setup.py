"""Package layout that pyproject.toml cannot express: the top-level ``configs/`` directory (the
source of the experiment YAMLs, kept where the README's commands expect it) ships inside the wheel
as ``training/configs/``, so ``cdcr-gym train ppo_ccka_reach`` works from a wheel install.

Everything else (metadata, dependencies, extras, scripts, tools) is in pyproject.toml.
"""

from setuptools import find_namespace_packages, setup

setup(
    packages=[
        # namespace-aware: a sub-package without __init__.py still ships
        *find_namespace_packages(
            include=["cdcr_gym", "cdcr_gym.*", "training", "training.*"],
            exclude=["*.__pycache__", "*.__pycache__.*"],
        ),
        "training.configs",
    ],
    package_dir={"training.configs": "configs"},
    package_data={
        "cdcr_gym": ["py.typed"],
        "training.configs": ["*.yaml", "**/*.yaml", "**/*.yml"],
    },
)
