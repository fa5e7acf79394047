"""The Zenoh configuration every process of a run opens its session with (comms.bus.bus.config)."""

from __future__ import annotations

import json
from pathlib import Path

from comms.bus.bus import Extras, config


def shared_memory(conf: object) -> bool:
    return bool(json.loads(conf.get_json("transport/shared_memory/enabled")))  # type: ignore[attr-defined]


def test_sessions_map_no_shared_memory_pool() -> None:
    """With it on, every session sending a message over 3 KiB (a time window's report) mapped a 16 MiB pool: a
    host of 25 vehicles peaked at 488 MB resident instead of 73 MB (ring of 50 at 1 Hz)."""
    for mode in ("router", "client"):
        assert not shared_memory(config(mode))


def test_a_site_config_keeps_its_own_shared_memory_setting(tmp_path: Path) -> None:
    site = tmp_path / "zenoh.json5"
    site.write_text("{ transport: { shared_memory: { enabled: true } } }")
    assert shared_memory(config("client", extras=Extras(site=site)))
