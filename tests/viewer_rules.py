"""The JSON Schema subset the viewers read: a channel whose schema breaks a rule is refused whole (an alert, and every
plot of it empty). Written after Lichtblick's parser (packages/mcap-support/src/parseJsonSchema.ts, the open-source
Foxglove Studio's, which Foxglove shares): the root an object; each field of one type among boolean, string, number,
integer, object (with properties, recursively) and array; an array's items of one type among boolean, string,
number, integer and object (no arrays of arrays); no type lists, no null, no untyped enum, no references."""

from __future__ import annotations

from typing import Any

SCALARS = ("boolean", "string", "number", "integer")


def viewer_problems(schema: dict[str, Any], where: str = "$") -> list[str]:
    """What a viewer would refuse in a message schema (empty: it reads it)."""
    if schema.get("type") != "object" or not isinstance(schema.get("properties"), dict):
        return [f"{where}: not an object with properties ({schema.get('type')!r})"]
    problems = []
    for name, field in schema["properties"].items():
        problems += _field(field, f"{where}.{name}")
    return problems


def _field(field: dict[str, Any], where: str) -> list[str]:
    if "$ref" in field or "anyOf" in field or "oneOf" in field:
        return [f"{where}: a reference or union"]
    kind = field.get("type")
    if kind in SCALARS:
        return []
    if kind == "object":
        return viewer_problems(field, where)
    if kind == "array":
        items = field.get("items")
        if not isinstance(items, dict) or items.get("type") not in (*SCALARS, "object"):
            return [f"{where}: array items of type {None if not isinstance(items, dict) else items.get('type')!r}"]
        return viewer_problems(items, f"{where}[]") if items["type"] == "object" else []
    return [f"{where}: type {kind!r}"]
