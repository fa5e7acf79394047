"""The scenario's extensions, checked before anything runs: each name resolves (an installed entry point or an
importable package.module:Name), its options validate against its own fields, and the object has the interface.
Each problem is the usual '<field>: <problem>, got <value>' line (supervisor.config.scenario_checks' rules)."""

from __future__ import annotations

from collections.abc import Generator, Iterator
from typing import Any

from comms.channel.guard import GuardedLoss
from supervisor.config.controller_choice import AUTO, controller_names, controller_options
from supervisor.config.extensions import Identity, instantiate, resolve
from supervisor.config.parameter_ranges import out_of_range
from supervisor.config.scenario_schema import Scenario
from vehicles.estimates import FirstOrder
from vehicles.params import VehicleParams


def extension_errors(sc: Scenario) -> Iterator[str]:
    co, tx = sc.coordination, sc.comms.transmit
    predictor = yield from _checked("predictor", "coordination", co.predictor, co.predictor_options)
    yield from _checked("law", "coordination", co.law, co.law_options)
    if tx.policy not in ("periodic", "event"):  # the built-ins' keys are [comms.transmit]'s own, checked by pydantic
        context = {"predictor": predictor or FirstOrder(), "v_r": co.v_r}
        yield from _checked("transmission", "comms.transmit", tx.policy, tx.options, context)
    elif tx.options:
        yield f"comms.transmit.options: the {tx.policy} policy takes its keys from [comms.transmit], got {tx.options}"
    c = sc.comms
    if c.loss_model is not None:
        model = yield from _checked("loss", "comms", c.loss_model, c.loss_model_options)
        if model is not None:
            yield from _draws_errors(model, c.loss_model)
    elif c.loss_model_options:
        yield f"comms.loss_model_options: options for no loss model (comms.loss_model), got {c.loss_model_options}"


def _draws_errors(model: Any, name: str) -> Iterator[str]:
    """Whether the loss model says how many numbers it draws a decision (a count): asked once here, behind the
    guard, so that it fails before the run (the channel is built from it at the start: a traceback there)."""
    try:
        _ = GuardedLoss(model, f"loss {name}").draws
    except FloatingPointError as exc:  # the guard's one line: raised, overran its budget, not a count
        yield f"comms.loss_model: {exc}, got {name!r}"


def controller_errors(sc: Scenario) -> Iterator[str]:
    """The controller's options, of each controller the fleet steers with (auto's choice reads [vehicle] and
    [[vehicles]]: each vehicle's actuators)."""
    pf = sc.path_following
    if pf.controller == AUTO and pf.controller_options:
        yield (
            "path_following.controller_options: auto chooses the controller and its options; name the controller "
            f"(backstepping, supervisory, ...) to give it options, got {pf.controller_options}"
        )
        return
    for name in controller_names(sc):  # auto's choice may differ between the vehicles of a mixed fleet
        if name != "backstepping":  # the built-in's gains are [path_following]'s own keys, checked by pydantic
            yield from _checked("controller", "path_following", name, controller_options(sc, name))
        elif pf.controller_options:
            keys = "delta, k1, k2, k_zeta, damping"
            yield (
                f"path_following.controller_options: backstepping takes its gains from [path_following] ({keys}), "
                f"got {pf.controller_options}"
            )


def vehicle_model_errors(sc: Scenario) -> Iterator[str]:
    """[vehicle] model with its model_options (the whole fleet's: no preset or overrides besides), or the presets,
    which take their changes from overrides (checked by scenario_checks against the preset's parameters)."""
    v, context = sc.vehicle, {"dimension": sc.scenario.dimension}
    if v.model is None:
        if v.model_options:
            yield f"vehicle.model_options: a preset takes its changes from [vehicle] overrides, got {v.model_options}"
        return
    instance = yield from _checked("model", "vehicle", v.model, v.model_options, context)
    if v.overrides:
        yield f"vehicle.overrides: a vehicle.model takes its options from vehicle.model_options, got {v.overrides}"
    for index, entry in enumerate(sc.vehicles):
        if entry.preset is not None or entry.overrides:
            given = "preset" if entry.preset is not None else "overrides"
            own = "no preset or overrides of its own"
            yield f"vehicles[{index}].{given}: the fleet runs vehicle.model {v.model}: {own}"
    if instance is not None:
        yield from _parameters_errors(instance, v.model)


def _parameters_errors(instance: Any, name: str) -> Iterator[str]:
    """Whether the model gives its parameters (a VehicleParams): asked once here, so that it fails before the run."""
    try:
        params = instance.parameters()
    except Exception as exc:  # someone else's code: one line naming it, not a traceback
        yield f"vehicle.model: parameters() raised {type(exc).__name__}: {exc}, got {name!r}"
        return
    if not isinstance(params, VehicleParams):
        yield f"vehicle.model: parameters() returned {type(params).__name__}, not a VehicleParams, got {name!r}"
        return
    for problem in out_of_range(params):  # the ranges [vehicle] overrides are held to (a force below zero ran)
        yield f"vehicle.model: parameters() gives {problem}, got {name!r}"


# Where each kind's name and options are in a scenario, below its section.
FIELDS = {"law": ("law", "law_options"), "predictor": ("predictor", "predictor_options"),
          "transmission": ("policy", "options"), "loss": ("loss_model", "loss_model_options"),
          "controller": ("controller", "controller_options"), "model": ("model", "model_options")}  # fmt: skip


def _checked(
    kind: str, section: str, name: str, options: dict[str, Any], context: dict[str, Any] | None = None
) -> Generator[str, None, Any]:
    """Yields the errors of one extension; returns its instance (None if it failed)."""
    instance, _, problems = instantiate(kind, name, dict(options), context)
    name_field, options_field = FIELDS[kind]
    for key, text in problems:
        if key is None:
            yield f"{section}.{name_field}: {text}, got {name!r}"
        else:
            yield f"{section}.{options_field}.{key}: {text}"
    return instance


def extension_identities(sc: Scenario) -> list[Identity]:
    """The identity of each extension the scenario names (law, predictor, transmission policy, controller, vehicle
    models: the fleet's presets, or its model; the loss model if it names one): what the hello digest covers and the
    log's meta records. Call on a checked scenario: every name resolves."""
    return [resolve(kind, name)[1] for kind, _, name in _named(sc)]


SECTIONS = {"law": "coordination", "predictor": "coordination", "transmission": "comms.transmit",
            "loss": "comms", "controller": "path_following", "model": "vehicle"}  # fmt: skip


def _named(sc: Scenario) -> list[tuple[str, str, str]]:
    """(kind, the scenario field naming it, name) of each extension the scenario names, in extension_identities'
    order."""
    co = sc.coordination
    named = [("law", co.law), ("predictor", co.predictor), ("transmission", sc.comms.transmit.policy)]
    named += [("controller", name) for name in controller_names(sc)]  # a mixed fleet's auto may choose several
    if sc.comms.loss_model is not None:  # none named: the digest stays what it was for scenarios without one
        named.append(("loss", sc.comms.loss_model))
    models = [sc.vehicle.model] if sc.vehicle.model else sorted({v.preset or sc.vehicle.preset for v in sc.vehicles})
    named += [("model", model) for model in models]
    return [(kind, f"{SECTIONS[kind]}.{FIELDS[kind][0]}", name) for kind, name in named]


def unloadable_errors(sc: Scenario) -> Iterator[str]:
    """The extensions the Zenoh engine's processes cannot load: they are handed their extensions pickled, and import
    each class by its module and name, so one defined inside a function or in the script being run (__main__) runs in
    process only (it ended in a pickling traceback, or a vehicle refusing its start file). Call on a checked
    scenario."""
    for kind, field, name in _named(sc):
        cls, _ = resolve(kind, name)
        where = "inside a function" if "<locals>" in cls.__qualname__ else None
        where = "in the script being run (__main__)" if cls.__module__ == "__main__" else where
        if where is not None:
            yield (
                f"{field}: {name} is defined {where}; the zenoh engine's processes import an extension by its module: "
                f"put it at the top of a module on their PYTHONPATH, or run --engine inprocess, got {name!r}"
            )
