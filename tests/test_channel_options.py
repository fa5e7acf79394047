"""The issue-16 channel keys of [comms]: each bad value a one-line error, both engines identical with every option on,
and `cpf per` drawing its figure.

The engines' run is paper_acoustic for 40 s with a weak source (85 dB) so that shadowing and Rayleigh fading lose
packets at the fleet's tens of metres, time-based bursts, and SINR capture without TDMA (so packets overlap):

        2 ---- 1 ---- 3
"""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

import pytest

from supervisor.config.scenario import parse_scenario
from supervisor.errors import ScenarioError
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, link_events, shortened
from tests.procs import cpf
from tests.run_digest import digest

SOURCE = "acoustic.toml"
ACOUSTIC = (CONFIGS / "paper_acoustic.toml").read_text()
RANGE = 'range = { type = "link_budget", source_level = 185.0 }'
BURST = "burst = { mean_loss = 0.05, mean_burst = 2.0 }"


def acoustic_with(old: str, new: str) -> str:
    assert old in ACOUSTIC, old
    return ACOUSTIC.replace(old, new, 1)


def with_range(extra: str) -> str:
    return acoustic_with(RANGE, RANGE.replace(" }", f", {extra} }}"))


def first_error(text: str) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, SOURCE)
    assert all("\n" not in line for line in info.value.errors)
    return info.value.errors[0]


BAD = {
    "negative shadowing": (with_range("shadowing = -1.0"), "comms.range.shadowing", "-1.0"),
    "shadowing not a number": (with_range('shadowing = "4 dB"'), "comms.range.shadowing", "'4 dB'"),
    "negative shadowing time": (with_range("shadowing_time = -5.0"), "comms.range.shadowing_time", "-5.0"),
    "negative K": (with_range("rician_k = -0.5"), "comms.range.rician_k", "-0.5"),
    "infinite K": (with_range("rician_k = inf"), "comms.range.rician_k", "inf"),
    "unknown bits": (with_range('bits = "payload"'), "comms.range.bits", "'payload'"),
    "unknown ebn0": (with_range('ebn0 = "magic"'), "comms.range.ebn0", "'magic'"),
    "unknown reception": (acoustic_with(RANGE, RANGE + '\nreception = "capture"'), "comms.reception", "'capture'"),
    "capture threshold too high": (
        acoustic_with(RANGE, RANGE + "\ncapture_threshold = 500.0"),
        "comms.capture_threshold",
        "500.0",
    ),
    "sinr without a link budget": (acoustic_with(RANGE, 'reception = "sinr"'), "comms.reception", "'sinr'"),
    "sinr without collisions": (
        acoustic_with(RANGE, RANGE + '\nreception = "sinr"\ncollisions = false'),
        "comms.reception",
        "'sinr'",
    ),
    "burst in packets and seconds": (
        acoustic_with(BURST, "burst = { mean_loss = 0.05, mean_burst = 2.0, mean_duration = 3.0 }"),
        "comms.burst",
        "both given",
    ),
    "burst of no length": (acoustic_with(BURST, "burst = { mean_loss = 0.05 }"), "comms.burst", "neither given"),
    "burst of zero seconds": (
        acoustic_with(BURST, "burst = { mean_loss = 0.05, mean_duration = 0.0 }"),
        "comms.burst.mean_duration",
        "0.0",
    ),
}


@pytest.mark.parametrize(("text", "field", "value"), list(BAD.values()), ids=list(BAD))
def test_a_bad_channel_key_is_one_line_naming_file_field_and_value(text: str, field: str, value: str) -> None:
    message = first_error(text)
    assert message.startswith(f"{SOURCE}: {field}: "), message
    assert f"got {value}" in message or value in message.partition(": ")[2], message


def test_every_new_key_is_valid_together() -> None:
    text = with_range('shadowing = 4.0, shadowing_time = 30.0, rician_k = 0.0, bits = "message", ebn0 = "snr"')
    text = acoustic_with(BURST, 'burst = { mean_loss = 0.05, mean_duration = 3.0 }\nreception = "sinr"').replace(
        RANGE,
        re.search(r"range = .*", text)[0],  # type: ignore[index]
    )
    sc = parse_scenario(text, SOURCE)
    assert sc.comms.reception == "sinr" and sc.comms.range is not None and sc.comms.burst is not None
    assert sc.comms.burst.mean_duration == 3.0


# Half-duplex off: vehicles 2 and 3 may answer 1 at once, their packets overlap at 1 and capture decides.
CHANNEL = """burst = { mean_loss = 0.1, mean_duration = 8.0 }
reception = "sinr"
capture_threshold = 1.0
half_duplex = false"""
FADING = shortened(
    re.sub(r"(?m)^\[comms\.tdma\]\n.*?\n\n", "", ACOUSTIC, flags=re.S)  # no TDMA: packets overlap, capture decides
    .replace(RANGE, 'range = { type = "link_budget", source_level = 85.0, shadowing = 6.0, rician_k = 0.0 }')
    .replace(BURST, CHANNEL),
    40.0,
)


@pytest.mark.e2e
def test_both_engines_record_the_same_run_with_fading_capture_and_time_bursts(tmp_path: Path) -> None:
    text = FADING
    assert "\nslot = " not in text and "[comms.transmit]" in text and "[[faults]]" in text
    scenario = tmp_path / "fading.toml"
    scenario.write_text(text)
    for engine in ("inprocess", "zenoh"):
        done = cpf("run", str(scenario), "--engine", engine, "--out", f"{engine}.mcap", "--quiet", cwd=tmp_path)
        assert done.returncode == 0, done.stderr
    assert digest(tmp_path / "inprocess.mcap") == digest(tmp_path / "zenoh.mcap")
    causes = _causes(tmp_path / "zenoh.mcap")
    assert min(causes[k] for k in ("range", "burst", "collision", "delivered")) > 0, causes  # the options acted
    # Capture acted: the same run where any overlap loses both delivers fewer packets.
    args = ("--engine", "inprocess", "--set", "comms.reception=overlap", "--out", "overlap.mcap", "--quiet")
    done = cpf("run", str(scenario), *args, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    overlap = _causes(tmp_path / "overlap.mcap")
    assert overlap["delivered"] < causes["delivered"], (overlap, causes)


def _causes(log: Path) -> Counter[str]:
    """What became of each packet of a log: its link events' reasons (or kinds)."""
    return Counter(m.get("reason") or m["kind"] for m in link_events(read_messages(log)))


@pytest.mark.e2e
def test_cpf_per_draws_a_figure_and_refuses_an_unknown_modem(tmp_path: Path) -> None:
    done = cpf("per", "--modem", "unet_800", "--draws", "200", "--out", "per.png", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "per.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = cpf("per", "--modem", "sirene", cwd=tmp_path)
    assert bad.returncode == 2 and bad.stderr.startswith("cpf: error: --modem: unknown modem 'sirene'"), bad.stderr
    assert len(bad.stderr.splitlines()) == 1
