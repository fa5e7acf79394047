"""Every process proves it runs the supervisor's scenario: a digest of the validated scenario, whole and per
section (the broker's covers the run's seed), answered on its hello key and checked by the supervisor."""

from __future__ import annotations

import pytest
import zenoh

from comms.bus.bus import free_port, open_session, serve
from comms.records.messages import (
    COMMS_ALIVE,
    STOP_KEY,
    SUPERVISOR_ALIVE,
    Hello,
    decode,
    encode,
    hello_key,
    vehicle_alive_key,
)
from supervisor.config.scenario import parse_scenario
from supervisor.config.scenario_digest import difference, hello, section_digests
from supervisor.engine.startup import ask_hello, check_hello, missing_names
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS
from tests.test_messages import assert_valid

PAPER = (CONFIGS / "paper.toml").read_text()


def test_the_digest_is_of_the_validated_scenario_not_of_its_text() -> None:
    same = PAPER.replace("k = 0.2 ", "k = 0.20").replace("# K = diag(k)", "# another comment")
    assert same != PAPER
    assert section_digests(parse_scenario(same)) == section_digests(parse_scenario(PAPER))
    set_again = parse_scenario(PAPER, overrides=("coordination.k=0.2", "scenario.seed=0"))
    assert section_digests(set_again) == section_digests(parse_scenario(PAPER))


def test_a_different_setting_is_named_by_its_section() -> None:
    ours = section_digests(parse_scenario(PAPER))
    theirs = Hello.from_message(hello("vehicle 2", parse_scenario(PAPER, overrides=("coordination.k=0.5",))))
    message = difference("vehicle 2", ours, theirs)
    assert message is not None
    assert message.startswith("vehicle 2 runs another scenario than the supervisor (differs in coordination): ")
    assert theirs.digest[:12] in message and "\n" not in message
    assert difference("vehicle 2", ours, Hello.from_message(hello("vehicle 2", parse_scenario(PAPER)))) is None


def test_the_brokers_digest_covers_the_seed() -> None:
    scenario = parse_scenario(PAPER)
    message = difference("comms broker", section_digests(scenario, 0), Hello.from_message(hello("comms", scenario, 7)))
    assert message is not None and "(differs in seed)" in message
    several = Hello.from_message(hello("comms", parse_scenario(PAPER, overrides=("comms.loss=0.1", "faults=[]")), 0))
    assert "(differs in comms, faults)" in str(difference("comms broker", section_digests(scenario, 0), several))


def test_the_hello_message_has_its_schema_and_survives_the_wire() -> None:
    message = hello("vehicle 3", parse_scenario(PAPER))
    assert_valid(message, hello_key(vehicle_alive_key(3)))
    assert Hello.from_message(decode(encode(message))) == Hello.from_message(message)
    assert hello_key(COMMS_ALIVE) == "cpf/hello/comms"
    for bad in ({"process": "x", "digest": "y"}, {"process": "x", "digest": "y", "sections": {"a": 1}}):
        with pytest.raises(ValueError):
            Hello.from_message(bad)


def test_no_answer_is_refused_too() -> None:
    with pytest.raises(ScenarioError, match="vehicle 4 did not say which scenario it runs"):
        check_hello("vehicle 4", {}, None)


def test_missing_processes_are_named() -> None:
    names = ["vehicle 3", "vehicle 2", "comms broker", "vehicle 5"]
    assert missing_names(names, (2, 3)) == "vehicles 2, 3 (started by hand), vehicle 5 and the comms broker"
    assert missing_names(["vehicle 2"], (2,)) == "vehicle 2 (started by hand)"


@pytest.mark.integration
def test_a_served_process_answers_its_hello_before_its_token_appears() -> None:
    """serve declares the hello queryable first: whoever sees the token can ask at once."""
    import threading

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    greeting = hello("vehicle 2", parse_scenario(PAPER))
    with open_session("router", listen=[endpoint]) as session:
        token = session.liveliness().declare_token(SUPERVISOR_ALIVE)
        appeared = threading.Event()
        answers: list[int] = []

        def on_token(sample: zenoh.Sample) -> None:
            if sample.kind == zenoh.SampleKind.PUT:
                appeared.set()

        watcher = session.liveliness().declare_subscriber(vehicle_alive_key(2), on_token)
        handler = lambda publishers: lambda key, payload: None  # noqa: E731 - nothing to step here
        child = threading.Thread(
            target=lambda: answers.append(serve("vehicle 2", [endpoint], (), vehicle_alive_key(2), handler, greeting))
        )
        child.start()
        try:
            assert appeared.wait(timeout=30)
            assert ask_hello(session, vehicle_alive_key(2), timeout=5.0) == Hello.from_message(greeting)
        finally:
            session.put(STOP_KEY, encode({"t": 0.0, "reason": "end of run"}))
            child.join(10)
            watcher.undeclare()
            token.undeclare()
        assert answers == [0]
