"""Faults in words, for people: what `cpf validate` and `cpf info` print of a scenario's faults."""

from __future__ import annotations

from typing import Any

TARGET_FIELDS = ("vehicle", "sender", "receiver", "both", "edges")


def describe_fault(fault: dict[str, Any], step: float) -> str:
    """'kind on [start, end) s: target (parameters)'. A broker_kill without an end lasts one step (the broker
    restarts then: derived.end_of), so its window says so: it was '[10, end) s' for a kill of one 0.1 s step."""
    end, start = fault.get("end"), fault.get("start")
    if end is None and fault.get("kind") == "broker_kill" and isinstance(start, int | float):
        end = start + step
    window = f"[{seconds(start)}, {'end' if end is None else seconds(end)}) s"
    return f"{fault.get('kind', '?')} on {window}: {_target(fault)}{_parameters(fault)}"


def _target(fault: dict[str, Any]) -> str:
    if fault.get("vehicle") is not None:
        return f"vehicle {fault['vehicle']}"
    if fault.get("sender") is not None:
        arrow = "<->" if fault.get("both") else "->"
        return f"link {fault['sender']}{arrow}{fault.get('receiver')}"
    if fault.get("edges") is not None:
        return "graph " + (", ".join(f"{i}-{j}" for i, j in fault["edges"]) or "without edges")
    return "broker" if fault.get("kind") == "broker_kill" else "every link"


def _parameters(fault: dict[str, Any]) -> str:
    rest = {k: v for k, v in fault.items() if k not in ("kind", "start", "end", *TARGET_FIELDS)}
    return f" ({', '.join(f'{k} {v}' for k, v in rest.items())})" if rest else ""


def seconds(value: Any) -> str:
    return "?" if value is None else f"{float(value):g}"
