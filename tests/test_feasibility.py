"""What cannot deliver is said before a run (issue 30, item 1): `cpf validate` and `cpf run` refuse a channel on which
no packet can ever arrive and warn, with the reason and the fix, where links deliver nothing at the start, the period
is shorter than the airtime, receivers are out of the link budget's range or delays dwarf the period; the summary
names a link that delivered nothing."""

from __future__ import annotations

from typing import Any

import pytest

from supervisor.analysis.comms_summary import comms_summary, format_comms
from supervisor.cli import main
from supervisor.config.scenario import parse_scenario
from supervisor.config.scenario_checks import scenario_warnings
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS, shortened

PAPER = (CONFIGS / "paper.toml").read_text()
CIRCLES = (CONFIGS / "examples" / "circles.toml").read_text()
UNET_1S = ("comms.modem=unet_2400", "comms.transmit.period=1.0")


def errors_of(text: str, overrides: tuple[str, ...]) -> list[str]:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "s.toml", overrides)
    return info.value.errors


def warnings_of(text: str, overrides: tuple[str, ...]) -> list[str]:
    return scenario_warnings(parse_scenario(text, "s.toml", overrides))


@pytest.mark.parametrize(
    ("text", "overrides"),
    [
        (PAPER, UNET_1S),  # the paper's helices: 20-45 m apart, 0.03 s of flight against 0.22 s on air
        (CIRCLES, UNET_1S),  # concentric circles, another graph
        (CIRCLES, ("comms.modem=usmart_nanomodem", "comms.transmit.period=2.0")),  # another modem, period
        (PAPER, ("comms.modem=unet_800", "comms.transmit.period=0.5", "vehicles.1.preset=remus100")),  # mixed fleet
    ],
)
def test_synchronous_half_duplex_transmission_without_tdma_is_refused_with_its_fix(text, overrides):
    errors = errors_of(text, overrides)
    assert len(errors) == 1
    assert errors[0].startswith("s.toml: comms.transmit: every vehicle transmits at the same instants")
    assert "half_duplex" in errors[0] and "comms.tdma = { slot = " in errors[0] and 'policy = "event"' in errors[0]


def test_the_fix_it_names_is_valid_and_silent():
    slot = errors_of(PAPER, UNET_1S)[0].split("slot = ")[1].split(" ")[0]
    assert float(slot) >= 0.218  # the airtime of a 15-B packet in one 64-B frame at 2400 bit/s, and the flight
    assert warnings_of(PAPER, (*UNET_1S, f"comms.tdma.slot={slot}")) == []
    event = ("comms.modem=unet_2400", "comms.transmit.policy=event", "comms.transmit.heartbeat=5.0")
    assert warnings_of(PAPER, event) == []
    # the event policy in place of the periodic one: a period kept would do nothing, and is said
    assert warnings_of(PAPER, (*UNET_1S, *event[1:])) == [
        "comms.transmit.period: a key of the periodic policy, it has no effect under policy 'event', got 1.0"
    ]


def test_links_that_deliver_nothing_at_the_start_only_are_a_warning_naming_them():
    far = ("vehicles.0.position=[500.0, 0.0, 0.0]",)  # 1 is 0.33 s away: 2 and 3 hear it; its receptions collide
    [warning] = warnings_of(PAPER, (*UNET_1S, *far))
    assert "2 of 4 links deliver nothing: 2->1 (collision), 3->1 (collision)" in warning


def test_a_period_shorter_than_the_airtime_hears_nothing():
    # WHOI rate 0: a 32-B frame at 80 bit/s is 3.2 s on air: said once, not again as synchronous transmissions
    overrides = ("comms.modem=whoi_micromodem_rate0", "comms.transmit.period=1.0")
    [error] = errors_of(PAPER, overrides)
    assert error.startswith("s.toml: comms.transmit.period: a vehicle transmits every 1 s") and "3.2 s on air" in error
    assert "period of at least 6.4 s" in error
    quiet = ("comms.bitrate=80", "comms.packet_bytes=32", "comms.transmit.period=1.0")  # no duplex, no collisions
    assert any("no real modem sends faster" in w for w in warnings_of(PAPER, quiet))


def test_a_period_left_unset_is_shown_as_every_step_not_none():
    """The period unset means every step: "got None" read oddly (a new user); a heartbeat is named as such."""
    [error] = errors_of(PAPER, ("comms.modem=whoi_micromodem_rate0",))
    assert error.endswith("give a period of at least 6.4 s, got every step (0.1 s)")
    quiet = ("comms.bitrate=80", "comms.packet_bytes=32")
    [warning] = [w for w in warnings_of(PAPER, quiet) if "no real modem" in w]
    assert warning.endswith("give a period of at least 3.2 s, got every step (0.1 s)")
    event = ("comms.transmit.policy=event", "comms.transmit.heartbeat=1.0")
    [warning] = [w for w in warnings_of(PAPER, (*quiet, *event)) if "no real modem" in w]
    assert warning.endswith("got heartbeat 1.0")


def test_receivers_out_of_range_at_the_start_are_named_with_their_odds():
    budget = ("comms.modem=whoi_micromodem_rate0", "comms.tdma.slot=4.0", "comms.transmit.period=12.0",
              "comms.range.type=link_budget", "comms.range.source_level=100.0",
              "vehicles.1.position=[1000.0, 0.0, 0.0]")  # fmt: skip
    [warning] = [w for w in warnings_of(PAPER, budget) if w.startswith("comms.range")]
    assert "1->2 (990 m, " in warning and "2->1 (990 m, " in warning and "source_level" in warning
    assert "1->3" not in warning


def test_jitter_that_dwarfs_the_period_is_a_warning_in_seconds():
    given = ("comms.transmit.period=1.0", "coordination.schedule=none")  # k as given: no fit to a 25 s delay
    jitter = [w for w in warnings_of(PAPER, ("comms.jitter=50", *given)) if "jitter" in w]
    assert jitter == [
        "comms.jitter: 50 s is 50 transmit intervals (1 s; a packet is 0 s on air): neighbours' estimates are that "
        "old when they arrive; is it in seconds? got 50.0"
    ]
    assert warnings_of(PAPER, ("comms.jitter=2", *given)) == []
    # a user's trigger: how long it stays silent is its own (one sending every 4 s was warned of in 0.1 s steps)
    mine = ("comms.transmit.policy=tests.samples.laws:Every", "comms.jitter=2", "coordination.schedule=none")
    assert [w for w in warnings_of(PAPER, mine) if "jitter" in w] == []


def test_cpf_run_refuses_what_validate_refuses_and_names_the_fix(tmp_path, capsys):
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened(PAPER, 5.0))
    sets = [item for key in UNET_1S for item in ("--set", key)]
    out = tmp_path / "run.mcap"
    assert main(["run", str(scenario), "--engine", "inprocess", *sets, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no packet can arrive" in err and not out.exists()
    assert main(["validate", str(scenario), *sets]) == 2


def test_the_summary_names_the_links_that_delivered_nothing():
    final: dict[str, Any] = {"t": 30.0, "window": 10.0, "lambda2": 0.0, "links": [
        {"sender": 1, "receiver": 2, "sent": 300, "delivered": 0, "dropped": {"half_duplex": 290, "collision": 10}},
        {"sender": 2, "receiver": 1, "sent": 300, "delivered": 12, "dropped": {"half_duplex": 288}},
    ]}  # fmt: skip
    text = format_comms(comms_summary(final, [], {}))
    assert "NOTHING DELIVERED on 1 of 2 links (1->2), mostly lost to half_duplex" in text
    final["links"][0]["delivered"] = 1
    assert "NOTHING" not in format_comms(comms_summary(final, [], {}))
