"""The interface between the reach task and a robot model (a *backend*).

A backend owns the robot's physical state and nothing else: it knows no goals, rewards or
Gymnasium spaces. The env (``cdcr_gym.envs.reach.ReachEnv``) turns actions into cable
commands, hands them to the backend, and reads the robot back through this interface.

Conventions: SI units (m, N, rad, s); base frame R0 at the base disk centre with the backbone
along +Z0 and cable 1 at +X0; cable i sits at angle β_i = 0°, 120°, 240° about +Z0
(``cdcr_gym.params.CABLE_ANGLES``). Tensions are the three cable tensions in N, ordered
(cable 1, cable 2, cable 3), each in [0, params.max_tension]. Cable lengths are the lengths of the
three cables between the base disk and the tip disk (m), ordered the same way.
"""

from __future__ import annotations

import abc

import numpy as np

from cdcr_gym.params import RobotParams

__all__ = ["Backend"]


class Backend(abc.ABC):
    """A robot model the reach task can drive.

    Subclasses set :attr:`params`, :attr:`control_timestep` and
    :attr:`supports_length_control`, and implement the abstract methods. Every method takes and
    returns float64 numpy arrays in SI units.
    """

    #: The robot's parameters.
    params: RobotParams
    #: Simulated time (s) that one :meth:`apply_tensions` / :meth:`apply_cable_lengths` call
    #: advances; 0.0 for a quasi-static model that jumps to equilibrium.
    control_timestep: float = 0.0
    #: Whether :meth:`apply_cable_lengths` is available (cable-displacement actions).
    supports_length_control: bool = False

    @abc.abstractmethod
    def reset(self, tensions: np.ndarray) -> None:
        """Put the robot at rest in its static equilibrium under ``tensions`` (3,) N.

        ``np.zeros(3)`` gives the straight robot (with gravity, where the backend has it, the
        equilibrium under its own weight). Must be deterministic: the same call gives exactly the
        same state, whatever happened before.
        """

    @abc.abstractmethod
    def apply_tensions(self, tensions: np.ndarray) -> None:
        """Hold the cable tensions ``tensions`` (3,) N for one control step.

        The caller guarantees finite values in [0, params.max_tension].
        """

    def apply_cable_lengths(self, lengths: np.ndarray) -> None:
        """Set the three cable lengths ``lengths`` (3,) m (cable-displacement control).

        The caller guarantees lengths of a reachable shape (sum = 3ℓ, inside the workspace).
        Only backends with ``supports_length_control`` implement it.
        """
        raise NotImplementedError(f"{type(self).__name__} does not support cable-length control")

    @property
    @abc.abstractmethod
    def tip(self) -> np.ndarray:
        """Tip (tip-disk centre) position in R0, shape (3,), m."""

    @property
    @abc.abstractmethod
    def cable_lengths(self) -> np.ndarray:
        """Sensed cable lengths from base disk to tip disk, shape (3,), m."""

    @property
    @abc.abstractmethod
    def tensions(self) -> np.ndarray:
        """Cable tensions currently acting, shape (3,), N."""

    @abc.abstractmethod
    def backbone_points(self) -> np.ndarray:
        """Points along the backbone from base to tip, shape (n, 3), m, in R0.

        The first point is the base (0, 0, 0); the last is :attr:`tip`. Include at least every
        disk station.
        """

    def render_rgb(self, goal: np.ndarray | None, width: int, height: int) -> np.ndarray:
        """An RGB image (height, width, 3) uint8 of the robot and the ``goal`` (3,) m.

        The default draws :meth:`backbone_points` with matplotlib (see
        ``cdcr_gym.rendering``); a simulator backend may use its own renderer.
        """
        from cdcr_gym.rendering import draw_robot

        return draw_robot(self.backbone_points(), self.params, goal, width=width, height=height)

    def render_human(self, goal: np.ndarray | None) -> None:
        """Show the robot in a window (``render_mode="human"``). Default: a matplotlib window."""
        from cdcr_gym.rendering import show_robot

        show_robot(self.backbone_points(), self.params, goal)

    def close(self) -> None:
        """Release any resource (simulator client, window). Safe to call more than once."""
