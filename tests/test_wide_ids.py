"""Fleets with vehicle ids above 255 (issue 26's 1000 AUVs): the coordination message then carries its sender in two
bytes (comms.records.wire: 16 B instead of 15), every vehicle of that fleet alike, and the channel charges airtime
for 16; a fleet whose ids fit in a byte keeps its 15 bytes and so every record it had (tests/test_bit_identical.py).

The paper scenario with AUV 3 renamed 300, on a bare modem (no framing, 80 bit/s, no preamble, full duplex; a
message every 2 s): a message's airtime is 8 x bytes / 80 s, 1.6 s for 16 B against 1.5 s for 15, and the AUVs are
< 60 m apart (< 0.04 s of flight).
"""

from __future__ import annotations

import struct

import pytest

from comms.records.records import Transmission
from comms.records.wire import SIZE, decode_coordination, encode_coordination, message_size, wide_for
from supervisor.config.fleet import broker_core
from supervisor.config.medium import message_bytes, modem_params
from supervisor.config.scenario import parse_scenario
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, link_events, shortened
from tests.procs import cpf
from tests.run_digest import digest

BARE_MODEM = """
[comms]
modem = "unet_800"
bitrate = 80.0
preamble = 0.0
frame_bytes = 1
half_duplex = false
collisions = false
[comms.transmit]
policy = "periodic"
period = 2.0
"""


def renamed(duration: float) -> str:
    """The paper scenario, AUV 3 called 300, on the bare modem."""
    text = shortened((CONFIGS / "paper.toml").read_text(), duration)
    text = text.replace("edges = [[1, 2], [1, 3]]", "edges = [[1, 2], [1, 300]]").replace("id = 3\n", "id = 300\n")
    return text + BARE_MODEM


def tx(sender: int) -> Transmission:
    return Transmission(sender, 70000, 12.3, 401.123456789, 0.987654321, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))


def test_a_fleet_whose_ids_fit_in_a_byte_keeps_its_fifteen_bytes():
    assert not wide_for([1, 2, 255]) and message_size() == SIZE == 15
    assert encode_coordination(tx(255)) == struct.pack("<BHIff", 255, 70000 % 65536, 12300, 401.123456789, 0.987654321)
    with pytest.raises(struct.error):
        encode_coordination(tx(256))  # a narrow message cannot carry it: the fleet's layout must be wide


def test_a_fleet_with_a_larger_id_sends_sixteen_bytes_that_carry_the_same_values():
    assert wide_for([1, 2, 256]) and message_size(wide=True) == 16
    wide = decode_coordination(encode_coordination(tx(65535), wide=True), wide=True)
    narrow = decode_coordination(encode_coordination(tx(7)))
    assert wide.sender == 65535 and (wide.seq, wide.t, wide.gamma, wide.gamma_dot) == (
        narrow.seq, narrow.t, narrow.gamma, narrow.gamma_dot,
    )  # fmt: skip


def test_the_channel_and_the_checks_charge_the_fleets_message_size():
    sc = parse_scenario(renamed(5.0), "s.toml")
    paper = parse_scenario((CONFIGS / "paper.toml").read_text() + BARE_MODEM, "p.toml")
    assert message_bytes(sc) == 16 and message_bytes(paper) == 15
    airtime = modem_params(sc).airtime(16)
    assert airtime == pytest.approx(1.6, rel=1e-12)
    assert airtime <= broker_core(sc, 0).least_delay() < airtime + 0.04
    assert broker_core(paper, 0).least_delay() < 1.55


def test_a_fleet_with_an_id_of_300_runs_on_both_engines_alike_with_sixteen_byte_airtimes(tmp_path):
    (tmp_path / "s.toml").write_text(renamed(20.0))
    digests = {}
    for engine in ("inprocess", "zenoh"):
        done = cpf("run", "s.toml", "--engine", engine, "--quiet", "--out", f"{engine}.mcap", cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        digests[engine] = digest(tmp_path / f"{engine}.mcap")
    assert digests["inprocess"] == digests["zenoh"]
    events = link_events(read_messages(tmp_path / "zenoh.mcap"))
    delays = [e["delay"] for e in events if e["kind"] == "delivered"]
    assert {e["sender"] for e in events} == {1, 2, 300} and len(delays) > 10
    assert min(delays) >= 1.6 - 1e-9 and max(delays) < 1.6 + 0.04  # 16 B at 80 bit/s, plus the flight


def test_a_fleet_past_the_logs_channels_is_refused_in_one_line_counting_it():
    """MCAP numbers channels in 16 bits and each vehicle has ~5: at most MAX_FLEET vehicles (ids go to 65535)."""
    from supervisor.config.schema_base import MAX_FLEET
    from supervisor.errors import ScenarioError

    vehicles = "".join(
        f'\n[[vehicles]]\nid = {i}\nposition = [0.0, {i}.0, 0.0]\npath = {{ type = "line", start = [0.0, {i}.0, 0.0], '
        "velocity = [1.0, 0.0, 0.0] }\n"
        for i in range(1, MAX_FLEET + 2)
    )
    text = '[scenario]\nname = "big"\nduration = 1.0\nstep = 0.1\n[graph]\nedges = [[1, 2]]\n' + vehicles
    with pytest.raises(ScenarioError) as refused:
        parse_scenario(text, "big.toml")
    assert str(refused.value) == f"big.toml: vehicles: must have at most {MAX_FLEET} items, got {MAX_FLEET + 1}"
