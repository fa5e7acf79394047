"""Faults in words, for people: what `cpf validate` and `cpf info` print of a scenario's faults."""

from __future__ import annotations

from typing import Any

TARGET_FIELDS = ("vehicle", "sender", "receiver", "both", "edges")


def describe_fault(fault: dict[str, Any]) -> str:
    """'kind on [start, end) s: target (parameters)'."""
    end = fault.get("end")
    window = f"[{seconds(fault.get('start'))}, {'end' if end is None else seconds(end)}) s"
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
