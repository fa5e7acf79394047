"""The stability analysis of a validated Scenario: its loop, period, delay and loss, and a paragraph for people.

What is read from the scenario: the graph, law (5)'s gains k, k2, the path-following gain k_zeta and the predictor;
the transmit period (every step if none; an event-triggered policy is analysed at its heartbeat, the longest silence
it allows, or else at every step, which is optimistic); TDMA: the frame (slot x vehicles, or the whole frames the
period needs) with each vehicle's slot start as its offset; the delay d = airtime (packet bits / bitrate, preamble
included) + time of flight over the mean initial distance of linked vehicles + half the jitter + the mean extra link
delay, rounded up to the sync step as arrivals are; loss: comms.loss combined with the burst model's long-run rate,
taken as independent (a bursty channel is worse than that), range-dependent loss and comms.loss_model (whose rate
only running it tells) left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from supervisor.config.links import (
    delay_of,
    link_loss_of,
    loss_of,
    needs_fitting,
    tdma_schedule,
    timing,
    transmit_period,
    unmodelled,
)
from supervisor.config.scenario_schema import Scenario
from supervisor.config.stability.margins import (
    MAX_LOSS_STATES,
    PERIOD_REACH,
    Setting,
    delay_reach,
    largest_delay,
    largest_loss,
    largest_period,
    rate,
)
from supervisor.config.stability.model import Loop
from supervisor.config.stability.monodromy import Layout
from supervisor.config.stability.offset import Offset, steady_offset
from supervisor.config.stability.schedule import fastest_gain


def loop_of(scenario: Scenario) -> Loop:
    """The scenario's coordination loop (vehicles as indices in the order they are listed)."""
    ids = scenario.vehicle_ids
    index = {vid: i for i, vid in enumerate(ids)}
    co = scenario.coordination
    edges = [(index[a], index[b]) for a, b in scenario.graph.edges]
    return Loop.of_edges(len(ids), edges, co.k, co.k2, scenario.path_following.k_zeta, co.predictor)


def setting_of(scenario: Scenario) -> Setting:
    """The loop as it runs: with the k law (5) runs with (coupling_gain)."""
    nominal = nominal_setting(scenario)
    return replace(nominal, loop=replace(nominal.loop, k=coupling_gain(scenario)))


def coupling_gain(scenario: Scenario) -> float:
    """The k law (5) runs with: the scenario's, or the one fitted to its links (stability.schedule)."""
    if not needs_fitting(scenario):
        return scenario.coordination.k
    return fastest_gain(nominal_setting(scenario, "fastest"))


def nominal_setting(scenario: Scenario, event: str = "heartbeat") -> Setting:
    """The loop with the scenario's own k (event: how an event-triggered policy is taken, _period). ValueError for a
    loop the analysis does not model (links.unmodelled: another law or a user's predictor)."""
    if (why := unmodelled(scenario)) is not None:
        raise ValueError(why)
    period, phases = timing(scenario, event)
    loop = _heard(scenario, loop_of(scenario))
    return Setting(loop, period, delay_of(scenario), phases, loss_of(scenario), own_losses(scenario, loop))


def _heard(scenario: Scenario, loop: Loop) -> Loop:
    """The loop without the links whose own loss is 1: nothing ever comes over them, and a neighbour never heard does
    not count in the law (vehicles.agent.neighbour_values), where the linear loop would hold its estimate for ever (a
    mode of eigenvalue 1: the verdict said 'neutral' of a fleet that converges, and k was fitted to noise, a new
    user). Every link dead: kept, the neutral loop it is."""
    dead = {n for n, p in own_losses(scenario, loop) if p >= 1.0}
    if not dead or len(dead) == len(loop.links):
        return loop
    return replace(loop, links=tuple(link for n, link in enumerate(loop.links) if n not in dead))


def own_losses(scenario: Scenario, loop: Loop) -> tuple[tuple[int, float], ...]:
    """(link's index in loop.links, its long-run loss) of the links whose [[comms.links]] entry gives their own loss
    or burst (a loss of 0 too: links.link_loss_of, as the channel takes them)."""
    ids = scenario.vehicle_ids
    given = {(link.sender, link.receiver) for link in scenario.comms.links if (link.loss, link.burst) != (None, None)}
    return tuple(
        (n, link_loss_of(scenario, ids[s], ids[r])) for n, (r, s) in enumerate(loop.links) if (ids[s], ids[r]) in given
    )


@dataclass(frozen=True)
class Verdict:
    """The analysis of one scenario: its setting, decay rate (1/s) and margins (None: none found in reach)."""

    setting: Setting
    rate: float
    period: float | None
    delay: float | None
    loss: float | None
    offset: Offset | None = None  # the hold predictor's steady spread and the fleet's rate (stability.offset)

    @property
    def converges(self) -> bool:
        return self.rate > 0


def analyse(scenario: Scenario, margins: bool = True) -> Verdict:
    """The verdict on a scenario; margins=False: the rate alone (fast, for cpf validate)."""
    s = setting_of(scenario)
    offset = _orbit(s, scenario)
    if not margins:
        return Verdict(s, rate(s), None, None, None, offset)
    return Verdict(s, rate(s), largest_period(s), largest_delay(s), largest_loss(s), offset)


def _margin_text(name: str, value: float | None, unit: str, beyond: str) -> str:
    if value is not None and math.isnan(value):  # only the loss: its mean-square analysis squares the states
        return f"{name} not analysed (more than {MAX_LOSS_STATES} states for its mean-square analysis)"
    return f"{name} up to {value:.3g}{unit}" if value is not None else f"{name} {beyond}"


def _loss_margin(verdict: Verdict, scenario: Scenario) -> str:
    """The loss margin: comms.loss's (largest_loss), on the links that take it; none if every link has its own
    loss (a link with only its own burst takes comms.loss: held at the scenario's in the scan)."""
    s, ids = verdict.setting, scenario.vehicle_ids
    own = {(link.sender, link.receiver) for link in scenario.comms.links if link.loss is not None}
    if s.loop.links and all((ids[sender], ids[receiver]) in own for receiver, sender in s.loop.links):
        return "any comms.loss (every link has a loss of its own, which it keeps)"
    name = "an independent loss probability" + (" on the links without one of their own" if s.own_losses else "")
    return _margin_text(name, verdict.loss, "", "of any value below 1")


def describe(verdict: Verdict, scenario: Scenario) -> str:
    """One paragraph: the verdict, its rate, what was analysed (and what not), the margins."""
    s = verdict.setting
    how = f"with {_how(s, scenario)} (linearised sampled loop, perfect path following{_left_out(s, scenario)})"
    period = "a TDMA frame (a message a frame at most)" if scenario.comms.tdma else "a transmit period"
    if abs(verdict.rate) < NEUTRAL:  # every message lost, say: the rate's sign is the rounding's
        head = f"coordination is neutral: the error neither decays nor grows (rate within {NEUTRAL:g} 1/s of 0)"
        return f"{head}, {how}: no message keeps the fleet"
    if not verdict.converges:
        head = f"coordination DIVERGES: the error grows at {-verdict.rate:.3g} 1/s"
        return (
            f"{head}, {how}. It would converge with {_margin_text(period, verdict.period, ' s', 'of no length tried')}."
        )
    head = (
        f"coordination converges: the error decays at {verdict.rate:.3g} 1/s (time constant {1 / verdict.rate:.3g} s)"
    )
    margins = ", ".join((
        _margin_text(period, verdict.period, " s", f"of any length up to {max(PERIOD_REACH, s.period):g} s"),
        _margin_text("a delay", verdict.delay, " s", f"of any length up to {delay_reach(s):.3g} s"),
        _loss_margin(verdict, scenario),
    ))  # fmt: skip
    head += _offset_text(verdict.offset, s.lossy(), scenario)
    return f"{head}, {how}. With the other settings as they are, it converges with {margins}."


def _offset_text(offset: Offset | None, lossy: bool, scenario: Scenario) -> str:
    """The hold predictor's steady orbit, in words: a converging verdict said nothing of a fleet that kept 8 units
    of gamma apart at 0.87 v_r (a new user's study)."""
    if offset is None:
        return ""
    v_r, losses = scenario.coordination.v_r, " (without its losses: they make messages older and widen it)"
    return (f", to a steady spread max|gi-gj| of {offset.spread:.3g}{losses if lossy else ''} with the fleet at "
            f"{offset.rate / v_r:.2f} v_r (the hold predictor keeps each neighbour where it was heard, v_r times its "
            "age behind)")  # fmt: skip


def _how(s: Setting, scenario: Scenario) -> str:
    co = scenario.coordination
    gain = f"k {s.loop.k:.3g}" + (f" (fitted to the links; {co.k:g} given)" if s.loop.k != co.k else "")
    return (f"law {co.law!r} with {gain}, predictor {co.predictor!r}, a message every {s.period:g} s"
            f"{_every(s, scenario)}, {s.delay:g} s of delay, loss {s.loss:g}{_own_text(s, scenario)}")  # fmt: skip


def _own_text(s: Setting, scenario: Scenario) -> str:
    """The links' own losses, as the verdict takes them: ' (links' own: 1->2 0.5, ...)'."""
    ids, links = scenario.vehicle_ids, s.loop.links
    own = [f"{ids[links[n][1]]}->{ids[links[n][0]]} {p:g}" for n, p in s.own_losses]
    return f" (links' own: {', '.join(own)})" if own else ""


def _every(s: Setting, scenario: Scenario) -> str:
    """What the period analysed is, unless plainly the transmit period or the TDMA frame: the event policy's
    heartbeat (every step without one), held to whole TDMA frames. It said "every 48 s (TDMA frame)" of a 48 s
    heartbeat on 24 s frames (a new user)."""
    tx, tdma = scenario.comms.transmit, tdma_schedule(scenario)
    frames = round(s.period / tdma.frame) if tdma else 0
    held = "a TDMA frame" if frames == 1 else f"{frames} TDMA frames of {s.period / max(frames, 1):g} s"
    if tx.policy == "event" and tx.heartbeat is None:
        return f" (the event policy has no heartbeat: {held if tdma else 'every step'}, optimistic)"
    if tx.policy != "event" and frames <= 1:
        return " (TDMA frame)" if tdma else ""
    own = "the event policy's heartbeat" if tx.policy == "event" else "the period"
    asked = transmit_period(scenario)
    if not tdma:
        return f" ({own})"
    if math.isclose(asked, s.period):
        return f" ({own}: {held})"
    return f" ({own}, {asked:g} s, rounded up to {held})"


def _left_out(s: Setting, scenario: Scenario) -> str:
    """What the scenario has that this verdict leaves out (a new user's study found each, unsaid): a loss in a loop
    too large for its mean-square analysis, and coordination.max_age shorter than a message's wait."""
    out = []
    if s.lossy() and s.states() > MAX_LOSS_STATES:
        out.append(f"its loss left out: more than {MAX_LOSS_STATES} states for the mean-square analysis, so this "
                   "rate is the lossless loop's, faster than the loop's")  # fmt: skip
    c = scenario.comms
    if c.transmit.policy not in ("periodic", "event"):
        out.append(f"comms.transmit.policy {c.transmit.policy} left out: analysed as a message every step")
    if c.loss_model is not None or c.range is not None:
        out.append("the loss model and range loss left out: only comms.loss, [comms.burst] and the links' own are "
                   "analysed")  # fmt: skip
    if (horizon := short_horizon(s, scenario)) is not None:
        out.append(f"coordination.predictor_options.horizon {horizon:g} s left out: shorter than a message is held "
                   f"({s.period + s.delay:.3g} s), after it the prediction stops; this is first_order's verdict "
                   "without it, which errs towards divergence")  # fmt: skip
    max_age = scenario.coordination.max_age
    if max_age is not None and max_age < s.period + s.delay:
        out.append(f"coordination.max_age {max_age:g} s left out: the law drops a neighbour older than that between "
                   "messages, which slows the loop")  # fmt: skip
    return "".join(f"; {text}" for text in out)


def short_horizon(s: Setting, scenario: Scenario) -> float | None:
    """first_order's horizon (predictor_options) if a message is held longer than it (the period and the delay),
    else None. Past it the prediction stops advancing (vehicles.estimates.FirstOrder): the analysis does not model
    that switch, and first_order's loop without it can diverge where the fleet does not (a new user's study:
    'DIVERGES at 0.0203 1/s' of a run that held at 1.44 with a 1 s horizon every 12 s)."""
    co = scenario.coordination
    horizon = co.predictor_options.get("horizon") if co.predictor == "first_order" else None
    if not isinstance(horizon, int | float) or horizon >= s.period + s.delay:
        return None
    return float(horizon)


def predicted_growth(scenario: Scenario) -> float | None:
    """The growth rate (1/s) of the coordination error if the stability analysis predicts divergence, else None
    (also when the loop is too large to analyse quickly, or not modelled)."""
    return _diverging(predicted_change(scenario))


def predictions(scenario: Scenario) -> tuple[float | None, Offset | None]:
    """predicted_growth and predicted_offset, the loop set up once (setting_of: k fitted to the links, maybe)."""
    if unmodelled(scenario) is not None:
        return None, None
    setting = setting_of(scenario)
    return _diverging(_change(setting, scenario)), _orbit(setting, scenario)


def _diverging(change: float | None) -> float | None:
    """A predicted change that is growth, else None."""
    return change if change is not None and change > 0 else None


# 1/s: a growth rate this small is the arithmetic's, not the loop's: every packet lost leaves the loop neutral (the
# monodromy's eigenvalue 1 within rounding), and it was warned of as 'predicted to diverge, growing at 8.88e-15 1/s'
# (up to 3.6e-9 seen, its sign varying from process to process). An e-folding time of 11.6 days: no run lasts that.
NEUTRAL = 1e-6


def predicted_change(scenario: Scenario) -> float | None:
    """The coordination error's predicted growth rate (1/s; negative: it decays), None when the loop is too large
    to analyse quickly, is not one the analysis models (links.unmodelled), has a first_order horizon it leaves out
    (short_horizon) or is neutral (within NEUTRAL of 0: no prediction either way)."""
    return None if unmodelled(scenario) is not None else _change(setting_of(scenario), scenario)


def _change(setting: Setting, scenario: Scenario) -> float | None:
    """predicted_change of a modelled loop, set up."""
    from supervisor.config.stability.margins import MAX_STATES

    if setting.states() > MAX_STATES or short_horizon(setting, scenario) is not None:
        return None  # too large to analyse quickly; or a horizon it leaves out, with which it errs
    growth = -rate(setting)
    return growth if abs(growth) >= NEUTRAL else None


def predicted_offset(scenario: Scenario) -> Offset | None:
    """The hold predictor's steady orbit (stability.offset), None for another predictor, a loop not modelled or too
    large, or one that does not converge."""
    if unmodelled(scenario) is not None or scenario.coordination.predictor != "hold":
        return None
    return _orbit(setting_of(scenario), scenario)


def _orbit(s: Setting, scenario: Scenario) -> Offset | None:
    """steady_offset of the setting, for law (5) corrected only (its docstring says why)."""
    if scenario.coordination.law != "corrected" or scenario.coordination.predictor != "hold":
        return None  # (steady_offset says the same of another predictor, after a Layout built for nothing)
    return steady_offset(Layout(s.loop, s.sampling()), scenario.coordination.v_r)
