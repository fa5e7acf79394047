"""cpf schema, validate and presets, and --help showing defaults: the scenario format without reading the source."""

from __future__ import annotations

import argparse
import json

import pytest

from comms.channel.modem import PRESETS as MODEMS
from supervisor.cli import _parser, main
from supervisor.config.presets_table import top_speed
from supervisor.config.reference import json_schema, markdown
from supervisor.config.scenario import load_scenario
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS
from vehicles.params import PRESETS


def _cpf(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_schema_prints_the_json_schema_and_the_markdown_reference(capsys):
    code, out, _ = _cpf(capsys, "schema")
    assert code == 0 and json.loads(out) == json_schema()
    code, out, _ = _cpf(capsys, "schema", "--markdown")
    assert code == 0 and out == markdown()


def test_validate_a_good_scenario_says_what_would_run(capsys):
    code, out, err = _cpf(capsys, "validate", str(CONFIGS / "paper_acoustic.toml"))
    assert code == 0, err
    text = " ".join(out.split())  # one paragraph, wrapped
    assert text.startswith(f"{CONFIGS / 'paper_acoustic.toml'}: valid. paper_acoustic: 3 vehicles")
    for expected in (
        "400 s in 4000 steps of 0.1 s",
        "1 from (10, -15, -5) on a helix (radius 20, climb 0.05, period 400",
        "over the graph 1-2, 1-3",
        "whoi_micromodem_rate0 modem, 80 bit/s, 3.2 s on air per 15-B packet, half-duplex, collisions",
        "sound speed 1490 m/s",
        "event-triggered (threshold 0.02, at least 4 s apart, heartbeat 12 s), on TDMA slots of 4 s (frame 12 s)",
        "speed_cap on [150, 250) s: vehicle 1 (gamma_dot_max 0.5)",
    ):
        assert expected in text
    assert len(out.strip().split("\n\n")) == 1


def test_validate_names_an_extensions_policy_by_its_name_and_options(capsys):
    """A user's policy was described as 'event-triggered (threshold 0.05)', the built-in's defaults (a new user)."""
    policy = ["--set", "comms.transmit.policy=vehicles.transmission:PeriodicPolicy", "--set",
              "comms.transmit.options={period=2.0}"]  # fmt: skip
    code, out, err = _cpf(capsys, "validate", str(CONFIGS / "paper.toml"), *policy)
    text = " ".join(out.split())
    assert code == 0, err
    assert "Transmission: vehicles.transmission:PeriodicPolicy (period 2)." in text and "event" not in text, text


def test_validate_applies_set_and_fault(capsys):
    args = ["--set", "scenario.duration=100", "--fault", "kind=blackout,start=10,end=20"]
    code, out, err = _cpf(capsys, "validate", str(CONFIGS / "paper.toml"), *args)
    text = " ".join(out.split())
    assert code == 0, err
    assert "for 100 s in 1000 steps" in text and "blackout on [10, 20) s: every link" in text


def test_validate_gives_a_broker_kill_without_end_its_one_step(capsys):
    """The broker restarts a step after the kill: validate said '[10, end) s' (a new user)."""
    code, out, err = _cpf(capsys, "validate", str(CONFIGS / "paper.toml"), "--fault", "kind=broker_kill,start=10")
    assert code == 0, err
    assert "broker_kill on [10, 10.1) s: broker" in " ".join(out.split())


def test_validate_a_bad_scenario_gives_every_error_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    text = (CONFIGS / "paper.toml").read_text().replace("step = 0.1", "step = -0.1").replace("k1 = 0.5", "k1 = 0")
    bad.write_text(text)
    with pytest.raises(ScenarioError) as raised:
        load_scenario(bad)
    code, out, err = _cpf(capsys, "validate", str(bad))
    assert code == 2 and out == ""
    for line in str(raised.value).splitlines():  # one line today, one line per error once validation collects them
        assert line in err
    assert "scenario.step" in err and str(bad) in err


def test_validate_a_missing_file_is_exit_2(tmp_path, capsys):
    code, _, err = _cpf(capsys, "validate", str(tmp_path / "nope.toml"))
    assert code == 2 and "nope.toml" in err and "cannot read" in err


def test_presets_lists_every_vehicle_and_modem_preset_with_its_numbers(capsys):
    code, out, _ = _cpf(capsys, "presets")
    assert code == 0
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line and not line.startswith(" ")}
    for name, params in PRESETS.items():
        assert rows[name][1] == f"{params.weight / 9.81:.2f}"
        assert rows[name][-1] == f"{top_speed(params):.2f}"
    for name, modem in MODEMS.items():
        assert rows[name][1] == ("unlimited" if modem.bitrate is None else f"{modem.bitrate:g}")
        assert rows[name][-1] == f"{modem.airtime(15):.3g}"
    assert rows["whoi_micromodem_rate0"][1:5] == ["80", "0", "32", "32"]


def test_top_speed_is_where_full_thrust_meets_the_surge_damping():
    params = PRESETS["remus100"]
    u = top_speed(params)
    drag = params.linear_damping[0] * u + params.quadratic_damping[0] * u * u
    assert drag == pytest.approx(params.max_surge_force, rel=1e-12)
    assert 2.0 < u < 4.0  # REMUS 100: about 2.5 m/s documented; the model's damping gives 3.0


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_help_shows_every_default_worth_showing():
    missing = []
    for name, command in _subparsers(_parser()).items():
        formatter = command._get_formatter()
        for action in command._actions:
            trivial = action.default in (None, False, [], (), argparse.SUPPRESS)
            flag = isinstance(action, argparse._StoreTrueAction | argparse._StoreFalseAction)  # on or off: no default
            if not action.option_strings or trivial or flag:
                continue
            shown = formatter._expand_help(action) if action.help else ""
            if "default" not in shown or "%(" in shown:
                missing.append(f"cpf {name} {action.option_strings[0]}")
    assert not missing, f"--help does not show the default of {missing}"


def test_help_of_run_shows_the_speed_default(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "simulated s per wall s (default: 1)" in out  # realtime only: None means "not given" (lockstep refuses it)


def test_help_does_not_read_a_flags_own_default_as_the_feature_being_off(capsys):
    """--no-foxglove's store_false default is True: "(default: True)" after "leave the Foxglove channels out of the
    log" read as if the scene were left out by default (issue 28)."""
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "out of the log: ~10-15 % of an in-process run --listen" in out


def test_validate_says_what_cpf_run_would_warn_about(capsys, caplog):
    """A fault that starts after the run ends never acts: cpf run warns, and so does cpf validate (it said nothing)."""
    code, _, err = _cpf(capsys, "validate", str(CONFIGS / "paper.toml"), "--set", "scenario.duration=100")
    assert code == 0, err
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any("faults[0].start: at or after the end of the run (100 s)" in line for line in warned), warned


def test_validate_names_a_mixed_fleets_presets_and_what_the_plant_adds():
    """Issue 28: a fleet of two presets read "4 vehicles (remus100, ...)", and the current, the model mismatch,
    the navigation and the saturation were left out."""
    from supervisor.config.explain import what_would_run
    from supervisor.config.scenario import parse_scenario

    text = (CONFIGS / "inline5.toml").read_text()
    mixed = ['vehicles.1.preset="remus100_legacy"', 'vehicles.2.preset="remus100_legacy"']
    said = what_would_run(parse_scenario(text, "inline5.toml", mixed))
    assert "5 vehicles (3 remus100, 2 remus100_legacy, the 6-DOF model)" in said
    assert "Plant: the nominal model in still water, exact navigation, coordination correction bounded" in said
    study = (CONFIGS / "studies" / "robustness.toml").read_text()
    said = " ".join(what_would_run(parse_scenario(study, "robustness.toml", [])).split())
    assert "current (0.2, 0, 0) m/s, not known to the controllers" in said
    assert "model mismatch (+-20 % in every group)" in said and "dead reckoning (DVL noise" in said
