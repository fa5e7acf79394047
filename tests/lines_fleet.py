"""A fleet on parallel lines, as the tests write one: vehicles 1..n on level lines along x at 10 m depth, 20 m apart,
each starting 5 m behind its line's start, off it by `off` m; a chain graph 1 - 2 - ... - n; presets: a vehicle's
own preset (a mixed fleet)."""

from __future__ import annotations


def lines_fleet(
    name: str, fleet_preset: str, n: int = 3, off: float = 0.0, presets: dict[int, str] | None = None
) -> str:
    edges = [[i, i + 1] for i in range(1, n)]
    text = f'[scenario]\nname = "{name}"\nduration = 200.0\nstep = 0.1\n[vehicle]\npreset = "{fleet_preset}"\n'
    text += f"[graph]\nedges = {edges}\n"
    for i in range(1, n + 1):
        y = 20.0 * (i - 1)
        own = f'preset = "{presets[i]}"\n' if presets and i in presets else ""
        text += (
            f"[[vehicles]]\nid = {i}\nposition = [-5.0, {y + off}, -10.0]\n{own}"
            f'path = {{ type = "line", start = [0.0, {y}, -10.0], velocity = [1.0, 0.0, 0.0] }}\n'
        )
    return text
