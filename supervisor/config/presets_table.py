"""`cpf presets`: the vehicle and modem presets a scenario can name, with their key numbers.

Everything is read from the presets themselves (vehicles/params.py, comms/channel/modem.py) or derived from them with
the model's own equations (top speed: full thrust against the surge damping; airtime of one cpf message), so a new
preset shows up here without a change.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import fields

from comms.channel.modem import PRESETS as MODEMS
from comms.channel.modem import ModemParams
from comms.records.wire import SIZE
from vehicles.actuators import remus100
from vehicles.params import GRAVITY, PRESETS, VehicleParams

__all__ = ["preset_text", "presets_text", "top_speed"]
_FINS = remus100(PRESETS["remus100"].max_surge_force)

VEHICLE_HEAD = (
    "vehicle", "mass [kg]", "M11/M22 [kg]", "W - B [N]", "max thrust [N]", "max torque [N m]", "top speed [m/s]",
)  # fmt: skip
MODEM_HEAD = (
    "modem", "bit/s", "preamble [s]", "frame [B]", "max [B]", "duplex", "collisions", "carrier [kHz]",
    "band [Hz]", "modulation", f"airtime {SIZE} B [s]",
)  # fmt: skip


def top_speed(params: VehicleParams) -> float:
    """Steady surge speed at full thrust, m/s: max_surge_force = X_u u + X_|u|u u^2 (surge damping of the model)."""
    lin, quad, force = params.linear_damping[0], params.quadratic_damping[0], params.max_surge_force
    if quad == 0:
        return force / lin if lin > 0 else math.inf
    return (-lin + math.sqrt(lin * lin + 4.0 * quad * force)) / (2.0 * quad)


def _vehicle_row(name: str, p: VehicleParams) -> tuple[str, ...]:
    return (
        name, f"{p.weight / GRAVITY:.2f}", f"{p.mass[0]:.2f} / {p.mass[1]:.2f}", f"{p.weight - p.buoyancy:+.1f}",
        f"{p.max_surge_force:g}", f"{p.max_torque:g}", f"{top_speed(p):.2f}",
    )  # fmt: skip


def _modem_row(name: str, m: ModemParams) -> tuple[str, ...]:
    def opt(value: float | None) -> str:
        return "-" if value is None else f"{value:g}"

    return (
        name, "unlimited" if m.bitrate is None else f"{m.bitrate:g}", f"{m.preamble:g}", opt(m.frame_bytes),
        opt(m.max_bytes), "half" if m.half_duplex else "full", "yes" if m.collisions else "no",
        f"{m.frequency_khz:g}", f"{m.bandwidth_hz:g}", m.modulation, f"{m.airtime(SIZE):.3g}",
    )  # fmt: skip


def _table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    widths = [max(len(row[i]) for row in [head, *rows]) for i in range(len(head))]

    def line(cells: Sequence[str]) -> str:
        first = f"{cells[0]:<{widths[0]}}"
        return "  ".join([first, *(f"{c:>{w}}" for c, w in zip(cells[1:], widths[1:], strict=True))]).rstrip()

    return [line(head), *(line(row) for row in rows)]


def presets_text() -> str:
    """Both tables, with what their columns mean."""
    vehicles = _table(VEHICLE_HEAD, [_vehicle_row(n, p) for n, p in sorted(PRESETS.items())])
    modems = _table(MODEM_HEAD, [_modem_row(n, m) for n, m in sorted(MODEMS.items())])
    return "\n".join(
        [
            "Vehicle presets ([vehicle] preset = NAME; any parameter can be changed in [vehicle] overrides):",
            *vehicles,
            "  mass: rigid body (W / g); M11/M22: surge / sway with added mass; W - B < 0: buoyant;",
            "  top speed: steady surge at full thrust against the model's surge damping.",
            "  remus100 is a REMUS 100 as at sea: Prestero's hull and fin lift, and its fins and propeller",
            f"  (vehicles/actuators.py): fin moment {_FINS.fin_lift:g} u^2 d, |d| <= "
            f"{math.degrees(_FINS.max_deflection):g} deg ({_FINS.torque_limit(1.0):.2f} N m at 1 m/s), lags of "
            f"{_FINS.fin_time_constant:g} s (fins)",
            f"  and {_FINS.thruster_time_constant:g} s (propeller); its default controller is line_of_sight. "
            "remus100_neutral and remus100_legacy",
            "  are the paper's model (eqs. (1)-(2): no lift) with ideal actuators, the force and torques as asked",
            "  within these limits; the paper's example keeps them. [vehicle] actuators sets either.",
            "",
            "Modem presets ([comms] modem = NAME; bitrate, preamble, frame_bytes, half_duplex, collisions can be",
            "changed in [comms]; the source level is the link budget's:",
            '[comms] range = { type = "link_budget", source_level = ... }):',
            *modems,
            f"  airtime: preamble + bits / bitrate of one cpf message ({SIZE} B, padded to whole frames).",
        ]
    )


VEHICLE_UNITS = {
    "mass": "kg, M's diagonal: rigid body + added mass", "inertia": "kg m^2, J's diagonal with added inertia",
    "linear_damping": "N s/m", "quadratic_damping": "N s^2/m^2", "angular_linear_damping": "N m s",
    "angular_quadratic_damping": "N m s^2", "weight": "N", "buoyancy": "N", "center_of_buoyancy": "m, body axes",
    "max_surge_force": "N", "max_torque": "N m", "lift_uv": "kg/m, Y_uv = Z_uw", "lift_ur": "kg/rad, Y_ur = -Z_uq",
    "lift_moment_uv": "kg, N_uv = -M_uw", "lift_moment_ur": "kg m/rad, N_ur = M_uq",
}  # fmt: skip
MODEM_UNITS = {
    "bitrate": "bit/s", "preamble": "s", "frame_bytes": "B", "max_bytes": "B", "frequency_khz": "kHz",
    "bandwidth_hz": "Hz",
}  # fmt: skip


def preset_text(name: str) -> str:
    """Every parameter of one vehicle or modem preset, with its unit (KeyError: no preset of that name)."""
    if name in PRESETS:
        params: VehicleParams | ModemParams = PRESETS[name]
        units, kind = VEHICLE_UNITS, "vehicle preset ([vehicle] preset; any of these in [vehicle] overrides)"
        extra = [f"  rigid-body mass {PRESETS[name].weight / GRAVITY:g} kg (overrides: mass = one number sets it)",
                 f"  top speed {top_speed(PRESETS[name]):.3g} m/s"]  # fmt: skip
    else:
        params, units, kind = MODEMS[name], MODEM_UNITS, "modem preset ([comms] modem)"
        extra = [f"  airtime of one cpf message ({SIZE} B) {MODEMS[name].airtime(SIZE):.4g} s"]
    lines = [f"{name}: {kind}"]
    for field in fields(params):
        value = getattr(params, field.name)
        shown = ", ".join(f"{v:g}" for v in value) if isinstance(value, tuple) else _shown(value)
        unit = f" [{units[field.name]}]" if field.name in units else ""
        lines.append(f"  {field.name} = {shown}{unit}")
    return "\n".join([*lines, *extra])


def _shown(value: object) -> str:
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return {True: "true", False: "false", None: "none (unlimited)"}.get(value, str(value))  # type: ignore[arg-type]
    return f"{value:g}"
