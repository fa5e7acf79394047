"""Vehicle models for tests/test_vehicle_model_extension.py: one that works, and one of each way a model can break."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from vehicles.dynamics import Accelerations
from vehicles.params import VehicleParams
from vehicles.vehicle_model import Auv, Positive


@dataclass(frozen=True)
class Heavy(Auv):
    """A REMUS 100 carrying a 12 kg payload in a fairing: more mass and inertia, more drag (the remus100 preset's
    dynamics, other numbers)."""

    mass: tuple[Positive, Positive, Positive] = (43.9, 72.5, 72.5)
    inertia: tuple[Positive, Positive, Positive] = (0.2, 10.0, 10.0)
    linear_damping: tuple[float, float, float] = (2.5, 4.0, 4.0)
    quadratic_damping: tuple[float, float, float] = (2.4, 160.0, 160.0)
    weight: float = 42.0 * 9.81
    buoyancy: float = 42.0 * 9.81 + 3.3


@dataclass(frozen=True)
class NoDrift:
    """Has parameters but no dynamics: not a vehicle model."""

    dimension: int = 3

    def parameters(self) -> VehicleParams:
        return Auv().parameters()


@dataclass(frozen=True)
class WrongSignature(Auv):
    """Its drift takes the state alone."""

    def drift(self, s: Sequence[float]) -> Accelerations:  # type: ignore[override]
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class NoParameters(Auv):
    """Gives its parameters as a dict."""

    def parameters(self) -> VehicleParams:
        return {"mass": 1.0}  # type: ignore[return-value]


@dataclass(frozen=True)
class Raises(Auv):
    """Fails once the vehicle is under way (surge speed past 0.3 m/s)."""

    def drift(self, s: Sequence[float], params: VehicleParams) -> Accelerations:
        if s[12] > 0.3:
            raise ZeroDivisionError("no water")
        return super().drift(s, params)


@dataclass(frozen=True)
class NotFinite(Auv):
    """A heave acceleration of nan once the surge speed passes 0.3 m/s."""

    def drift(self, s: Sequence[float], params: VehicleParams) -> Accelerations:
        (du, dv, dw), angular = super().drift(s, params)
        return (du, dv, float("nan") if s[12] > 0.3 else dw), angular
