"""What can go wrong when simulating: bad input, and a simulation that blows up."""

from __future__ import annotations

from app.core.errors import StudioError


class SimulationError(StudioError):
    """A simulation that cannot be run or did not finish; the studio keeps its last results."""


class SimulationInputError(SimulationError):
    """A robot, trajectory, command or servo that cannot be simulated as given."""


class SimulationDiverged(SimulationError):
    """The physics blew up (NaN or runaway state): the time step is too long for the servos."""
