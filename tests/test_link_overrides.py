"""A link's own settings in [[comms.links]] replace the fleet-wide ones when given, whatever their value: an explicit
loss of 0 is a loss of 0, not "not given". Only a key left out (None) falls back on [comms].

The scenario is configs/examples/per_link_comms.toml with a fleet-wide loss of 0.9 and the noisy pair made clean:

        1 ---- 2            1 <-> 2: loss = 0.0 (their own)
        |      |            every other link: the fleet's 0.9 (3 -> 4 its own bursts on top)
        4 ---- 3
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from comms.channel.channel import Channel, ChannelParams, LinkParams
from comms.channel.loss import Bernoulli, Composite, CompositeLink
from comms.records.records import Kinematics, LinkEvent, Transmission
from supervisor.config.fleet import channel_params
from supervisor.config.scenario import parse_scenario
from supervisor.config.scenario_schema import Scenario
from supervisor.config.stability import analyse, describe
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from tests.conftest import CONFIGS, shortened

EXAMPLE = CONFIGS / "examples" / "per_link_comms.toml"
PACKETS = 200


def clean_pair(fleet_loss: float = 0.9, duration: float = 60.0) -> Scenario:
    text = shortened(EXAMPLE.read_text(), duration).replace("loss = 0.3", "loss = 0.0")
    return parse_scenario(text, "links.toml", [f"comms.loss={fleet_loss}"])


def fates(channel: Channel, sender: int, receivers: dict[int, tuple[float, float, float]]) -> dict[int, Counter[str]]:
    """PACKETS transmissions of sender at the origin, a second apart: each receiver's events by kind."""
    still = np.zeros(3)
    where = {j: Kinematics(np.asarray(p, dtype=float), still) for j, p in receivers.items()}
    events: list[LinkEvent] = []
    for seq in range(1, PACKETS + 1):
        sent = Transmission(sender, seq, float(seq), 0.0, 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        events += channel.transmit(sent, 16, set(where), where)
    delivered, _ = channel.deliver(1e9)
    out: dict[int, Counter[str]] = {j: Counter(e.kind for e in events if e.receiver == j) for j in receivers}
    for r in delivered:
        out[r.receiver]["delivered"] += 1
    return out


def test_a_links_zero_loss_replaces_the_fleets_in_the_channel_the_scenario_describes():
    """The channel of the scenario (pure, no Zenoh): 1 -> 2 and 2 -> 1 lose nothing, 1 -> 4 loses the fleet's 90 %.
    The link's loss 0 built no loss model (None), and the channel took None for "not given": the fleet's."""
    params = channel_params(clean_pair())
    one = fates(Channel(params, seed=3), 1, {2: (20.0, 0.0, 0.0), 4: (0.0, 60.0, 0.0)})
    assert one[2] == Counter(sent=PACKETS, delivered=PACKETS)
    assert 0.8 * PACKETS < one[4]["dropped"] < PACKETS  # the fleet's 0.9 where the link has none of its own
    two = fates(Channel(params, seed=3), 2, {1: (20.0, 0.0, 0.0)})
    assert two[1] == Counter(sent=PACKETS, delivered=PACKETS)


@dataclass(frozen=True)
class NothingLost:
    """A loss model that is falsy (as one that counts its parts may be) and loses nothing: still the link's own."""

    draws: int = 0

    def link(self) -> CompositeLink:
        return CompositeLink(())

    def __bool__(self) -> bool:
        return False


def test_a_links_own_loss_model_replaces_the_fleets_whatever_its_truth_value():
    for own in (Composite(()), NothingLost()):
        params = ChannelParams(loss=Bernoulli(0.9), links={(1, 2): LinkParams(loss=own)})
        assert fates(Channel(params, seed=1), 1, {2: (20.0, 0.0, 0.0)})[2] == Counter(sent=PACKETS, delivered=PACKETS)
    unset = ChannelParams(loss=Bernoulli(0.9), links={(1, 2): LinkParams(extra_delay=1.0)})  # no loss: the fleet's
    assert fates(Channel(unset, seed=1), 1, {2: (20.0, 0.0, 0.0)})[2]["dropped"] > 0.8 * PACKETS


def test_a_run_delivers_every_packet_of_a_link_with_loss_zero_under_a_lossy_fleet():
    """The in-process run of the example (the channel is both engines'): 1 <-> 2 dropped ~5 % with the fleet's 0.05
    and nearly everything with its 0.9, though their own loss was 0."""
    sc = clean_pair(duration=30.0)
    result = run_inprocess(sc, "links.toml", "", None, 0, Progress(30.0, enabled=False), scene=False)
    assert result.link_stats is not None
    books = {(link["sender"], link["receiver"]): link for link in result.link_stats["links"]}
    for pair in ((1, 2), (2, 1)):
        assert books[pair]["sent"] >= 29 and books[pair]["dropped"].keys() <= {"end_of_run"}, books[pair]
    assert books[(4, 3)]["dropped"]["loss"] > 0.7 * books[(4, 3)]["sent"]


def test_cpf_stability_analyses_a_links_zero_loss_as_its_own():
    """It analysed the fleet's loss and said nothing of the links: `link.loss or link.burst` took 0.0 for none (it
    then said they were left out; now it analyses them, a loss of 0 as the link's own)."""
    paper = CONFIGS / "paper.toml"
    clean = "comms.links=[{sender=1,receiver=2,loss=0.0},{sender=2,receiver=1,loss=0.0}]"
    sc = parse_scenario(paper.read_text(), str(paper), ["comms.loss=0.05", clean])
    text = describe(analyse(sc, margins=False), sc)
    assert "loss 0.05 (links' own: 2->1 0, 1->2 0)" in text and "left out" not in text
