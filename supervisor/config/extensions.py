"""Extensions: coordination laws, neighbour predictors, transmission policies, the channel's loss models,
path-following controllers and vehicle models named in a scenario, found, checked and built the same way whether
they ship with cpf-cosim or with someone else's package.

A name in a scenario is either an entry point of the group (`cpf.coordination`, `cpf.predictors`,
`cpf.transmission`, `cpf.loss`, `cpf.controllers`, `cpf.vehicles`; cpf-cosim registers its built-ins there itself,
pyproject.toml) or an import path `package.module:Name`. The object it names is a class whose fields are its options
(a dataclass, or a pydantic model): its options table in the scenario is validated against those fields by pydantic,
so a bad option is the usual one-line error naming the file, the field and the value. An instance must have the
interface's methods (vehicles.coordination.CoordinationLaw, vehicles.estimates.Predictor,
vehicles.transmission.TransmissionPolicy, comms.channel.loss.LossModel, vehicles.path_following.PathFollowingController,
vehicles.vehicle_model.VehicleModel).

Each extension has an identity (its name, the object it resolves to, its distribution and version, and the SHA-256
of its module's source): the hello digest covers it, so a vehicle on another host running other code is refused,
and the log's meta records it. Someone else's extension runs inside a guard (vehicles.guard; comms.channel.guard for a
loss model) that turns an exception, a result of the wrong kind or an overrun of its time budget into one line naming
it.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib
import inspect
import types
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import metadata
from typing import TYPE_CHECKING, Any

from comms.channel.guard import GuardedLoss
from comms.channel.loss import LossModel
from vehicles.coordination import CoordinationLaw
from vehicles.estimates import Predictor
from vehicles.guard import Guarded
from vehicles.path_following import PathFollowingController
from vehicles.transmission import TransmissionPolicy
from vehicles.vehicle_model import VehicleModel

if TYPE_CHECKING:
    from pydantic import TypeAdapter

GROUPS: dict[str, tuple[str, type]] = {
    "law": ("cpf.coordination", CoordinationLaw),
    "predictor": ("cpf.predictors", Predictor),
    "transmission": ("cpf.transmission", TransmissionPolicy),
    "loss": ("cpf.loss", LossModel),
    "controller": ("cpf.controllers", PathFollowingController),
    "model": ("cpf.vehicles", VehicleModel),
}
OURS = "cpf-cosim"  # the distribution whose extensions are built-ins: they run without a guard


@dataclass(frozen=True, slots=True)
class Identity:
    """Which code an extension name resolved to."""

    kind: str  # law, predictor, transmission, loss
    name: str  # as the scenario gives it
    target: str  # module:qualname of the class
    distribution: str | None  # the installed distribution that provides it (None: not found)
    version: str | None
    source_sha256: str  # of the module's source file ("" if it has none)

    @property
    def builtin(self) -> bool:
        return self.distribution == OURS

    def describe(self) -> str:
        where = f"{self.distribution} {self.version}" if self.distribution else "no distribution"
        return f"{self.kind} {self.name} = {self.target} ({where}, source {self.source_sha256[:12]})"


def available(kind: str) -> dict[str, str]:
    """name -> module:attr of every installed entry point of the kind's group (built-ins included; a name that is
    a built-in's is the built-in's, whoever else declares it)."""
    group = GROUPS[kind][0]
    found: dict[str, list[metadata.EntryPoint]] = {}
    for entry in metadata.entry_points(group=group):
        found.setdefault(entry.name, []).append(entry)
    return {name: chosen.value if (chosen := _chosen(entries)) else _ambiguous(name, entries)
            for name, entries in found.items()}  # fmt: skip


def _chosen(entries: list[metadata.EntryPoint]) -> metadata.EntryPoint | None:
    """Of the entry points declaring one name: cpf-cosim's own if it is one of them, else the only one (None: two
    or more others)."""
    ours = [entry for entry in entries if _distribution(entry) == OURS]
    return ours[0] if ours else entries[0] if len(entries) == 1 else None


def _ambiguous(name: str, entries: list[metadata.EntryPoint]) -> str:
    by = ", ".join(sorted(f"{_distribution(entry)} ({entry.value})" for entry in entries))
    return f"{name!r} is declared by {by}: name the one you mean by package.module:Name"


def _entry(group: str, name: str) -> metadata.EntryPoint | None:
    """The entry point a name means: cpf-cosim's own if it declares the name (another distribution's of that name
    cannot replace a built-in: one declaring `corrected` silently ran every scenario with its law), else the one
    distribution's that declares it; ValueError if two others do."""
    found = [ep for ep in metadata.entry_points(group=group) if ep.name == name]
    if not found:
        return None
    chosen = _chosen(found)
    if chosen is None:
        raise ValueError(_ambiguous(name, found))
    return chosen


def _distribution(entry: metadata.EntryPoint) -> str | None:
    return entry.dist.name.replace("_", "-").lower() if entry.dist is not None else None


@functools.lru_cache(maxsize=256)
def resolve(kind: str, name: str) -> tuple[type, Identity]:
    """The class a name means and its identity; ValueError (a message for '<field>: ...') if there is none. Cached:
    a fleet of many vehicles looks each name up once."""
    group, _ = GROUPS[kind]
    if ":" in name:
        cls, distribution = _imported(name), _distribution_of(name.partition(":")[0])
    else:
        entry = _entry(group, name)
        if entry is None:
            known = ", ".join(sorted(available(kind))) or "none"
            raise ValueError(f"no {kind} {name!r} (installed: {known}; or give package.module:Name)")
        cls = _loaded(entry)
        distribution = (entry.dist.name, entry.dist.version) if entry.dist else None
    if not inspect.isclass(cls):
        raise ValueError(f"{name!r} is not a class (a {kind} is a class whose fields are its options)")
    dist, version = distribution if distribution else (None, None)
    return cls, Identity(kind, name, f"{cls.__module__}:{cls.__qualname__}", dist, version, _source_hash(cls))


def _imported(path: str) -> Any:
    module_name, _, attr = path.partition(":")
    try:
        module = importlib.import_module(module_name)
    except Exception as exc:  # anything an import of someone else's code raises: one line, not a traceback
        raise ValueError(f"cannot import {module_name!r} ({type(exc).__name__}: {exc})") from None
    try:
        obj = module
        for part in attr.split("."):
            obj = getattr(obj, part)
    except AttributeError:
        raise ValueError(f"module {module_name!r} has no {attr!r}") from None
    return obj


def _loaded(entry: metadata.EntryPoint) -> Any:
    try:
        return entry.load()
    except Exception as exc:  # a broken installed extension: one line naming it
        raise ValueError(
            f"entry point {entry.name} = {entry.value} does not load ({type(exc).__name__}: {exc})"
        ) from None


def _distribution_of(module: str) -> tuple[str, str] | None:
    top = module.partition(".")[0]
    names = metadata.packages_distributions().get(top, [])
    if not names:
        return None
    return names[0], metadata.version(names[0])


def _source_hash(cls: type) -> str:
    try:
        source = inspect.getsource(inspect.getmodule(cls))  # type: ignore[arg-type]
    except (OSError, TypeError):
        return ""
    return hashlib.sha256(source.encode()).hexdigest()


Problem = tuple[str | None, str]  # (the option it is about, None: the name itself; what is wrong)


def build(kind: str, name: str, options: dict[str, Any], context: dict[str, Any] | None = None) -> tuple[Any, Identity]:
    """An instance of the named extension with its options; ValueError with every problem ('; '-separated)."""
    instance, identity, problems = instantiate(kind, name, options, context)
    if problems or identity is None:
        raise ValueError("; ".join(f"{key}: {text}" if key else text for key, text in problems))
    return instance, identity


def extension(kind: str, name: str, options: Mapping[str, Any], context: dict[str, Any] | None = None) -> Any:
    """The named extension built with its options; someone else's behind the guard (vehicles.guard; comms.channel.guard
    for a loss model, which the broker runs). The scenario's checks have built it once already: here it cannot fail."""
    instance, identity = build(kind, name, dict(options), context)
    if identity.builtin:
        return instance
    label = f"{kind} {name}"
    return GuardedLoss(instance, label) if kind == "loss" else Guarded(instance, label)


def instantiate(
    kind: str, name: str, options: dict[str, Any], context: dict[str, Any] | None = None
) -> tuple[Any, Identity | None, list[Problem]]:
    """(instance, identity, problems) of the named extension built with its options (validated by its own fields)
    and, for fields it has of those names, the context the fleet gives it (a transmission policy's `predictor` and
    `v_r`). Problems: the name that does not resolve, options it does not have or refuses, a missing interface."""
    try:
        cls, identity = resolve(kind, name)
    except ValueError as exc:
        return None, None, [(None, str(exc))]
    fields = _field_names(cls)
    unknown = sorted(set(options) - fields)
    if unknown:
        known = ", ".join(sorted(fields)) or "none"
        return None, identity, [(key, f"{name} has no such option (its options: {known})") for key in unknown]
    given = {key: value for key, value in (context or {}).items() if key in fields and key not in options}
    from pydantic import ValidationError  # here: a vehicle or broker process started from a plan never gets here

    if not dataclasses.is_dataclass(cls) and not hasattr(cls, "model_fields"):  # pydantic's advice would follow
        return None, identity, [(None, f"{identity.target} is not a dataclass or a pydantic model (its fields are its "
                                       "options): decorate it with @dataclass(frozen=True)")]  # fmt: skip
    try:
        instance = _adapter(cls).validate_python({**options, **given})
    except ValidationError as exc:
        return None, identity, [_option_problem(name, e) for e in exc.errors()]
    except Exception as exc:  # its own checks (__post_init__) or a class pydantic cannot build
        return None, identity, [(None, f"{name} refuses its options ({type(exc).__name__}: {exc})")]
    problem = _interface_problem(instance, identity.target, kind)
    if problem is not None:
        return None, identity, [(None, problem)]
    return instance, identity, []


def _interface_problem(instance: Any, target: str, kind: str) -> str | None:
    """Why instance does not have the kind's interface (None: it has): a member it lacks (named), a member whose
    reading raises, a method its interface's arguments cannot call."""
    _, protocol = GROUPS[kind]
    try:
        has = isinstance(instance, protocol)  # reads each member: a property of its own code may raise
    except Exception as exc:
        return f"{target} raised {type(exc).__name__} when asked for its interface: {exc}"
    if not has:
        lacks = ", ".join(name for name in _members(protocol) if not hasattr(instance, name))
        return f"{target} lacks the {kind} interface ({protocol.__qualname__})" + (f": no {lacks}" if lacks else "")
    mismatch = _signature_problem(instance, protocol)
    return None if mismatch is None else f"{target}.{mismatch}"


# What _signature_problem found for instances of a class, per interface and the class's methods of it as they are (a
# method replaced on the class is checked again): every vehicle of a fleet builds the same dozen extensions (0.14 ms
# each to inspect; 1.5 s for a fleet of 1000).
_CHECKED: dict[tuple[object, ...], str | None] = {}


def _signature_problem(instance: Any, protocol: type) -> str | None:
    """Why a method of the interface cannot be called on instance with the interface's arguments (None: it can):
    a wrong signature is found before the run, not at its first call. Once per class, unless an instance holds a
    method of its own (in its __dict__)."""
    cls, names = type(instance), _methods(protocol)
    if not _plain(cls, instance, names):
        return _problem_of(instance, protocol)
    key = (cls, protocol, *(inspect.getattr_static(cls, name, None) for name in names))
    if key not in _CHECKED:
        _CHECKED[key] = _problem_of(instance, protocol)
    return _CHECKED[key]


def _plain(cls: type, instance: Any, names: list[str]) -> bool:
    """Whether every instance of cls calls the same methods of these names: each a function, static or class
    method of the class (not a property, slot, partialmethod or an instance's own), and no __getattr__ of its own
    deciding otherwise (what _signature_problem may keep per class)."""
    if hasattr(cls, "__getattr__") or cls.__getattribute__ is not object.__getattribute__:
        return False
    own = getattr(instance, "__dict__", None) or {}
    kinds = (types.FunctionType, staticmethod, classmethod)
    return not any(name in own for name in names) and all(
        isinstance(inspect.getattr_static(cls, name, None), kinds) for name in names
    )


def _methods(protocol: type) -> list[str]:
    """The interface's methods (its public callables)."""
    return [name for name, method in vars(protocol).items() if not name.startswith("_") and callable(method)]


def _members(protocol: type) -> list[str]:
    """The interface's public methods and attributes (a vehicle model's dimension)."""
    annotated = getattr(protocol, "__annotations__", {})
    return [*_methods(protocol), *(name for name in annotated if not name.startswith("_"))] + [
        name for name, value in vars(protocol).items() if isinstance(value, property) and not name.startswith("_")
    ]


def _problem_of(instance: Any, protocol: type) -> str | None:
    for name in _methods(protocol):
        wanted = inspect.signature(getattr(protocol, name))
        try:
            inspect.signature(getattr(instance, name)).bind(*range(len(wanted.parameters) - 1))  # not self
        except TypeError:
            return f"{name} cannot be called with the interface's arguments ({', '.join(list(wanted.parameters)[1:])})"
        except ValueError:  # no signature to read (a builtin): its calls will tell
            continue
    return None


@functools.lru_cache(maxsize=256)
def _adapter(cls: type) -> TypeAdapter[Any]:
    from pydantic import TypeAdapter

    return TypeAdapter(cls)


def _field_names(cls: type) -> set[str]:
    """A dataclass's fields (not its ClassVars) or a pydantic model's: the options it takes."""
    if dataclasses.is_dataclass(cls):
        return {f.name for f in dataclasses.fields(cls)}
    return set(getattr(cls, "model_fields", None) or {})


def _option_problem(name: str, error: Any) -> Problem:
    where = ".".join(str(part) for part in error["loc"]) or None
    if where is None and "error" in error.get("ctx", {}):  # its own check of the whole (__post_init__): its words
        return None, f"{name} refuses its options ({error['ctx']['error']})"
    return where, f"{error['msg']}, got {error.get('input')!r}"


# Where a kind's name and options go in a scenario (for cpf plugins' table).
KEYS = {"law": "coordination.law", "predictor": "coordination.predictor", "transmission": "comms.transmit.policy",
        "loss": "comms.loss_model", "controller": "path_following.controller", "model": "vehicle.model"}  # fmt: skip


def plugins_text() -> str:
    """What `cpf plugins` prints: per kind, each installed name, what it resolves to and its options; a name that
    does not load says why, on its line."""
    lines: list[str] = []
    for kind, (group, _) in GROUPS.items():
        lines.append(f"{KEYS[kind]} (entry points {group}):")
        names = sorted(available(kind))
        width = max([12, *map(len, names)]) + 2  # a column per group: a long name does not shift the others
        for name in names:
            try:
                cls, identity = resolve(kind, name)
            except ValueError as exc:
                lines.append(f"  {name:<{width}}does not load: {exc}")
                continue
            where = f"{identity.distribution} {identity.version}" if identity.distribution else "-"
            options = ", ".join(sorted(_field_names(cls) - {"predictor", "v_r", "dimension"})) or "-"
            lines.append(f"  {name:<{width}}{identity.target:<44}{where:<22}options: {options}")
    lines.append("or any package.module:Name in the scenario (docs/extending.md)")
    return "\n".join(lines)
