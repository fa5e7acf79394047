"""The channel's loss model as an extension (issue 22): a model named by `comms.loss_model` (entry point of cpf.loss or
package.module:Name) runs on every directed link after the scenario's own range, loss and burst models, the same on
both engines; a bad name or option is one line and exit 2 before the run; a model that raises, returns anything but
None or a reason, or overruns its CPU budget stops the run with one line naming it (exit 1); its identity reaches the
hello digest, the log's meta and `cpf info`; the built-ins are built through the same registry.

The paper scenario's graph, every directed link running the named model:

    2 <--> 1 <--> 3
"""

from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from comms.channel.guard import GuardedLink, GuardedLoss
from comms.channel.loss import Bernoulli, Composite, GilbertElliott, LossModel, RangeTable
from supervisor.config import extensions
from supervisor.config.extensions import build, plugins_text, resolve
from supervisor.config.fleet import channel_params
from supervisor.config.scenario import load_scenario
from supervisor.config.scenario_digest import section_digests
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, link_events, shortened
from tests.procs import cpf
from tests.run_digest import digest
from tests.samples.loss import Cutoff, Raises, ReturnsNumber, Slow

ROOT = Path(__file__).resolve().parent.parent
ENV = {"PYTHONPATH": str(ROOT)}  # tests.samples importable in every process of the run
SAMPLES = "tests.samples.loss"
CUTOFF = (f"comms.loss_model={SAMPLES}:Cutoff", "comms.loss_model_options.p=0.2")


def run(tmp_path: Path, *options: str, engine: str = "inprocess", seconds: float = 20.0, env: dict | None = None):
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), seconds))
    args = ["run", str(scenario), "--engine", engine, "--quiet", "--out", "run.mcap"]
    return cpf(*args, *(x for o in options for x in ("--set", o)), cwd=tmp_path, env=env or ENV)


def one_line(text: str) -> str:
    lines = [line for line in text.splitlines() if line.startswith("cpf: error")]
    assert len(lines) == 1, text
    return lines[0]


def test_a_user_loss_model_runs_the_paper_scenario_on_both_engines_with_the_same_records(tmp_path):
    digests = {}
    for engine in ("inprocess", "zenoh"):
        (tmp_path / engine).mkdir()
        done = run(tmp_path / engine, *CUTOFF, engine=engine)
        assert done.returncode == 0, done.stderr
        digests[engine] = digest(tmp_path / engine / "run.mcap")
    assert digests["inprocess"] == digests["zenoh"]
    log = tmp_path / "zenoh" / "run.mcap"
    reasons = [m.get("reason") for m in link_events(read_messages(log))]
    assert 0.1 < reasons.count("noise") / reasons.count(None) < 0.3  # its decisions, under its own reason (p = 0.2)
    meta = next(m for topic, _, m in read_messages(log) if topic == "cpf/run/meta")
    assert any(e.startswith(f"loss {SAMPLES}:Cutoff = {SAMPLES}:Cutoff (") for e in meta["extensions"])
    info = cpf("info", "run.mcap", cwd=tmp_path / "zenoh", env=ENV)
    assert f"loss {SAMPLES}:Cutoff = {SAMPLES}:Cutoff" in info.stdout


@pytest.mark.parametrize(
    ("setting", "expected"),
    [
        ("comms.loss_model=no_such_module:Loss", "comms.loss_model: cannot import 'no_such_module'"),
        ("comms.loss_model=bogus", "comms.loss_model: no loss 'bogus' (installed: "),
        (f"comms.loss_model={SAMPLES}:NoLink", "comms.loss_model: tests.samples.loss:NoLink lacks the loss interface"),
        (f"comms.loss_model={SAMPLES}:Cutoff\0comms.loss_model_options.p=2",
         "comms.loss_model_options.p: Input should be less than or equal to 1, got 2"),
        (f"comms.loss_model={SAMPLES}:Cutoff\0comms.loss_model_options.range=1",
         "comms.loss_model_options.range: tests.samples.loss:Cutoff has no such option (its options: max_range, p)"),
        ("comms.loss_model=comms.channel.loss:Bernoulli\0comms.loss_model_options.p=1.5",
         "comms.loss_model: comms.channel.loss:Bernoulli refuses its options (p must be in [0, 1], got 1.5)"),
        ("comms.loss_model_options.p=0.2", "comms.loss_model_options: options for no loss model"),
        # a new user's: each ended in a traceback when the channel was built from it
        (f"comms.loss_model={SAMPLES}:NegativeDraws",
         f"comms.loss_model: loss {SAMPLES}:NegativeDraws has draws = -1, not a count of random numbers"),
        (f"comms.loss_model={SAMPLES}:DrawsRaises",
         f"comms.loss_model: {SAMPLES}:DrawsRaises raised RuntimeError when asked for its interface: draws boom"),
    ],
)  # fmt: skip
def test_a_bad_loss_model_or_option_is_one_line_and_exit_2_before_the_run(tmp_path, setting, expected):
    done = run(tmp_path, *setting.split("\0"))
    assert done.returncode == 2 and expected in one_line(done.stderr), done.stderr
    assert not (tmp_path / "run.mcap").exists()


@pytest.mark.parametrize(
    ("engine", "model", "expected"),
    [
        ("inprocess", "Raises", "loss tests.samples.loss:Raises raised ZeroDivisionError: division by zero"),
        ("zenoh", "Raises", "loss tests.samples.loss:Raises raised ZeroDivisionError: division by zero"),
        ("inprocess", "ReturnsNumber", "loss tests.samples.loss:ReturnsNumber returned 1, not None or a reason"),
        ("zenoh", "ReturnsNumber", "loss tests.samples.loss:ReturnsNumber returned 1, not None or a reason"),
        ("inprocess", "Slow", "loss tests.samples.loss:Slow took 0.3"),
    ],
)
def test_a_loss_model_that_breaks_stops_the_run_with_one_line_naming_it(tmp_path, engine, model, expected):
    done = run(tmp_path, f"comms.loss_model={SAMPLES}:{model}", engine=engine, seconds=5.0)
    line = one_line(done.stderr)
    assert done.returncode == 1 and expected in line, done.stderr
    sent = re.search(r"a packet sent at t = (\d+\.\d) s", line)  # the first one after the model's 2 s
    stopped = re.search(r"comms broker stopped at t = (\d+\.\d) s", line)  # the supervisor's clock then
    assert sent and sent[1] == "2.1" and stopped, done.stderr
    # A packet sent at a step goes in the water at the next (0.1 s on): in process the clock stops there. Over Zenoh
    # the supervisor's clock is the step whose records it is taking in, and the broker may run a window or a span
    # ahead of it (comms.broker.windows): the clock is then behind, never ahead.
    lag = float(sent[1]) + 0.1 - float(stopped[1])
    assert abs(lag) < 1e-9 if engine == "inprocess" else lag > -1e-9, done.stderr
    assert "Traceback" not in done.stderr
    assert cpf("info", "run.mcap", cwd=tmp_path, env=ENV).returncode == 0  # the log was closed


@pytest.mark.parametrize(
    ("model", "expected"),
    [
        (Raises(after=0.0), "loss x raised ZeroDivisionError: division by zero"),
        (ReturnsNumber(after=0.0), "loss x returned 1, not None or a reason string"),
        (Slow(after=0.0), "loss x took 0.3"),
    ],
)
def test_the_guard_turns_a_bad_decision_into_one_line(model, expected):
    link = GuardedLoss(model, "loss x").link()
    with pytest.raises(FloatingPointError, match=expected):
        link.decide(np.random.default_rng(0), 10.0, 32, 1.0)


@pytest.mark.parametrize("reason", ["", b"loss", 0.5, ("loss",)])
def test_only_none_or_a_word_is_a_decision(reason):
    class Says(Cutoff):
        def decide(self, rng, distance_m, size_bytes, t=0.0):
            return reason

    with pytest.raises(FloatingPointError, match="not None or a reason string"):
        GuardedLink(Says(), "loss x", 0.1).decide(np.random.default_rng(0), 10.0, 32, 1.0)


def test_a_guarded_model_decides_as_the_model_itself():
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    plain, guarded = Cutoff(p=0.3).link(), GuardedLoss(Cutoff(p=0.3), "loss x").link()
    distances = np.linspace(0.0, 80.0, 400)
    assert [plain.decide(rng_a, d, 32) for d in distances] == [guarded.decide(rng_b, d, 32) for d in distances]
    assert guarded.draws == 1


@pytest.mark.parametrize("draws", [-1, 1.5, True, "1"])
def test_a_model_whose_draws_is_not_a_count_is_named(draws):
    class Odd(Cutoff):
        @property
        def draws(self):
            return draws

    with pytest.raises(FloatingPointError, match=r"loss x has draws = .*, not a count"):
        _ = GuardedLoss(Odd(), "loss x").draws


def test_the_scenario_keys_build_their_models_through_the_registry(monkeypatch):
    named: list[str] = []

    def recording(kind, name, options, context=None):
        named.append(name)
        return build(kind, name, options, context)

    sets = ["comms.loss=0.2", "comms.burst.mean_loss=0.1", "comms.burst.mean_burst=3",
            "comms.range.type=table", "comms.range.ranges=[0, 100]", "comms.range.success=[1, 0.5]"]  # fmt: skip
    scenario = load_scenario(CONFIGS / "paper.toml", sets)
    monkeypatch.setattr(extensions, "build", recording)
    params = channel_params(scenario)
    assert named == [
        "comms.channel.loss:RangeTable",
        "comms.channel.loss:Bernoulli",
        "comms.channel.loss:GilbertElliott",
        "comms.channel.loss:Composite",
    ]
    # The very models the keys always made, so their runs are unchanged (tests/test_bit_identical.py: every bit).
    assert params.loss == Composite((RangeTable((0.0, 100.0), (1.0, 0.5)), Bernoulli(0.2), GilbertElliott(0.1, 3.0)))


def test_a_named_model_composes_after_the_scenario_keys_on_every_link():
    sets = ["comms.loss=0.2", f"comms.loss_model={SAMPLES}:Cutoff", "comms.loss_model_options.max_range=30",
            "comms.links=[{sender = 1, receiver = 2, loss = 0.5}]"]  # fmt: skip
    params = channel_params(load_scenario(CONFIGS / "paper.toml", sets))
    guarded = GuardedLoss(Cutoff(max_range=30.0), f"loss {SAMPLES}:Cutoff")
    assert params.loss == Composite((Bernoulli(0.2), guarded))
    assert params.links[(1, 2)].loss == Composite((Bernoulli(0.5), guarded))  # a link's own loss keeps the model


def test_a_builtin_named_by_import_path_runs_unguarded():
    sets = ["comms.loss_model=comms.channel.loss:GilbertElliott", "comms.loss_model_options.mean_loss=0.2",
            "comms.loss_model_options.mean_burst=4"]  # fmt: skip
    params = channel_params(load_scenario(CONFIGS / "paper.toml", sets))
    assert params.loss == Composite((GilbertElliott(0.2, 4.0),))


def test_the_hello_digest_covers_the_loss_model_only_when_one_is_named():
    plain = section_digests(load_scenario(CONFIGS / "paper.toml", []))
    named = section_digests(load_scenario(CONFIGS / "paper.toml", list(CUTOFF)))
    assert {k for k in plain if plain[k] != named[k]} == {"comms", "extensions"}
    other = section_digests(load_scenario(CONFIGS / "paper.toml", [f"comms.loss_model={SAMPLES}:Slow"]))
    assert other["extensions"] != named["extensions"]


# --- the cpf.loss entry points, as pyproject.toml declares them ----------------------------------------------------


def declared() -> dict[str, str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return dict(project["entry-points"]["cpf.loss"])


def test_every_declared_builtin_has_the_interface_and_is_cpf_cosims_own():
    assert sorted(declared()) == ["bernoulli", "gilbert_elliott", "gilbert_elliott_time", "link_budget", "range_table"]
    for target in declared().values():
        cls, identity = resolve("loss", target)
        assert identity.builtin and identity.target == target
        assert {"draws", "link"} <= set(dir(cls))


@pytest.fixture
def entry_points(tmp_path, monkeypatch):
    """cpf-cosim's metadata with this checkout's entry points (pyproject.toml) ahead of the installed one: what
    `pip install -e .` would give, without reinstalling the shared environment. On sys.path for this process and on
    PYTHONPATH for the ones it starts."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    info = tmp_path / "meta" / f"cpf_cosim-{project['version']}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: cpf-cosim\nVersion: {project['version']}\n")
    groups = {**project["entry-points"], "console_scripts": project["scripts"]}
    text = "".join(f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in eps.items()) for group, eps in groups.items())
    (info / "entry_points.txt").write_text(text)
    monkeypatch.syspath_prepend(str(info.parent))
    resolve.cache_clear()
    yield {"PYTHONPATH": f"{info.parent}:{ROOT}"}
    resolve.cache_clear()


def test_a_builtin_is_found_by_its_entry_point_name(entry_points):
    model, identity = build("loss", "gilbert_elliott_time", {"mean_loss": 0.2, "mean_duration": 5.0})
    assert identity.builtin and identity.target == "comms.channel.loss:GilbertElliottTime"
    assert isinstance(model, LossModel) and model.link().draws == 2


def test_cpf_plugins_lists_the_loss_models(entry_points, tmp_path):
    assert "comms.loss_model (entry points cpf.loss):" in plugins_text()
    done = cpf("plugins", cwd=tmp_path, env=entry_points)
    assert done.returncode == 0, done.stderr
    listed = done.stdout.split("comms.loss_model (entry points cpf.loss):")[1]
    for name, target in declared().items():
        assert f"  {name} " in listed and f" {target} " in listed
    assert "options: p\n" in listed and "options: bad_loss, good_loss, mean_duration, mean_loss\n" in listed


def test_a_scenario_names_a_builtin_loss_model_by_entry_point(entry_points, tmp_path):
    done = run(tmp_path, "comms.loss_model=bernoulli", "comms.loss_model_options.p=0.3", env=entry_points)
    assert done.returncode == 0, done.stderr
    events = link_events(read_messages(tmp_path / "run.mcap"))
    assert 0.2 < sum(m.get("reason") == "loss" for m in events) / sum(m["kind"] == "sent" for m in events) < 0.4
    assert sys.modules["comms.channel.loss"].Bernoulli is Bernoulli  # the entry point's class is this checkout's


def test_the_example_in_docs_extending_is_a_loss_model_that_decides_as_the_sample():
    doc = (ROOT / "docs" / "extending.md").read_text(encoding="utf-8")
    section = doc.split("## Loss models", 1)[1].split("\n## ", 1)[0]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    namespace: dict = {}
    exec(compile(code, "docs/extending.md", "exec"), namespace)
    example = namespace["Cutoff"](max_range=30.0, p=0.3)
    assert isinstance(example, LossModel)
    rng_a, rng_b = np.random.default_rng(1), np.random.default_rng(1)
    distances = np.linspace(0.0, 60.0, 300)
    link, sample = example.link(), Cutoff(max_range=30.0, p=0.3)
    assert [link.decide(rng_a, d, 32) for d in distances] == [sample.decide(rng_b, d, 32) for d in distances]


def test_cpf_validate_says_which_loss_model_and_options_would_run(tmp_path):
    scenario = CONFIGS / "paper.toml"
    done = cpf("validate", str(scenario), *(x for o in CUTOFF for x in ("--set", o)), cwd=tmp_path, env=ENV)
    assert done.returncode == 0, done.stderr
    assert f"loss model {SAMPLES}:Cutoff (p 0.2)" in " ".join(done.stdout.split())
