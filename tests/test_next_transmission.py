"""The earliest next transmission a vehicle reports (vehicles.transmission.earliest_transmission), against the
policies' own due() and the MAC's may_transmit(): the supervisor lets the fleet run without the bus until then, so a
bound one step too late would lose a transmission. With a gamma that always leaves the prediction (the earliest an
event can trigger), the first step at which a vehicle transmits is exactly the bound: never earlier (it would break
results), and not later either (windows as long as they can be)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from vehicles.estimates import NeighbourEstimate
from vehicles.transmission import EventTriggeredPolicy, PeriodicPolicy, Policy, Tdma, earliest_transmission

STEPS = [0.05, 0.1, 0.2, 0.25, 1.0 / 3.0, 0.5, 1.0]


def first_transmission(policy: Policy, tdma: Tdma | None, vid: int, k: int, dt: float, last: float | None,
                       pending: bool) -> int:  # fmt: skip
    """The first step after k at which a vehicle transmits, run step by step as vehicles.runtime.node_step decides
    (wants: a waiting wish or the policy due; may: its slot), with a gamma far off any prediction."""
    sent = None if last is None else NeighbourEstimate(0.0, 0.0, last)
    for j in range(k + 1, k + 100_000):
        t = j * dt
        wants = pending or policy.due(t, dt, NeighbourEstimate(1e12, 0.0, t), sent)
        may = tdma is None or tdma.may_transmit(vid, t, dt)
        if wants and may:
            return j
        pending = wants
    raise AssertionError("never transmits")


periodic = st.builds(PeriodicPolicy, st.one_of(st.none(), st.floats(0.01, 30.0)))
event = st.builds(
    EventTriggeredPolicy,
    threshold=st.floats(0.0, 1.0),
    min_interval=st.floats(0.0, 30.0),
    heartbeat=st.one_of(st.none(), st.floats(0.01, 60.0)),
)


@st.composite
def tdma_of(draw: st.DrawFn, dt: float) -> tuple[Tdma, int]:
    n = draw(st.integers(1, 8))
    order = tuple(draw(st.permutations(range(1, n + 1))))
    slot = round(dt * draw(st.integers(1, 40)), 9)  # a whole number of steps (validated), as a user writes it
    return Tdma(slot, order), draw(st.sampled_from(order))


@st.composite
def cases(draw: st.DrawFn) -> tuple[Policy, Tdma | None, int, int, float, float | None, bool]:
    dt = draw(st.sampled_from(STEPS))
    policy = draw(st.one_of(periodic, event))
    tdma, vid = draw(st.one_of(st.none().map(lambda _: (None, 1)), tdma_of(dt)))
    k = draw(st.integers(0, 50_000))
    last = draw(st.one_of(st.none(), st.integers(0, k).map(lambda m: m * dt)))  # stamps are step times
    return policy, tdma, vid, k, dt, last, draw(st.booleans()) and tdma is not None


@settings(max_examples=1000, deadline=None)
@given(cases())
def test_no_step_before_the_bound_transmits_and_the_bound_does(case):
    policy, tdma, vid, k, dt, last, pending = case
    assert earliest_transmission(policy, tdma, vid, k, dt, last, pending) == first_transmission(*case)


def test_the_bound_of_the_common_policies():
    every_second = PeriodicPolicy(1.0)
    assert earliest_transmission(PeriodicPolicy(None), None, 1, 7, 0.1, 0.7, False) == 8
    assert earliest_transmission(every_second, None, 1, 7, 0.1, 0.7, False) == 17
    assert earliest_transmission(every_second, None, 1, 7, 0.1, None, False) == 8  # nothing sent yet
    assert earliest_transmission(EventTriggeredPolicy(0.1, min_interval=2.0), None, 1, 30, 0.1, 2.9, False) == 49
    frame = Tdma(0.5, (1, 2, 3))  # vehicle 2's slots start at 0.5 + 1.5 n s
    assert earliest_transmission(every_second, frame, 2, 7, 0.1, 0.7, False) == 20
    assert earliest_transmission(every_second, frame, 2, 7, 0.1, 0.7, True) == 20  # a waiting wish: its slot
    assert earliest_transmission(PeriodicPolicy(None), frame, 2, 5, 0.1, 0.5, False) == 20
