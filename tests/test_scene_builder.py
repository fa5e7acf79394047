"""The Foxglove scene builder as pure functions: attitude quaternions, path sampling, records in any order giving
the same messages, and a recorder that closes its log whatever the scene does."""

from __future__ import annotations

import json
import random
from collections.abc import Iterator

import numpy as np
import pytest
from mcap.reader import make_reader
from scipy.spatial.transform import Rotation

from supervisor.record import logfile
from supervisor.record.recorder import Recorder
from supervisor.record.scene.geometry import path_points, quaternions
from supervisor.record.scene.history import FleetHistory
from supervisor.record.scene.scene import FleetScene, SceneMessage
from tests.conftest import CONFIGS, shortened
from tests.procs import cpf
from vehicles.paths import Circle, Line


def same_attitude(q: np.ndarray, r: np.ndarray) -> None:
    """q is the unit quaternion of matrices r, with w >= 0 (q and -q are one attitude: scipy's canonical form)."""
    expected = Rotation.from_matrix(r).as_quat(canonical=True)
    np.testing.assert_allclose(q, expected, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    assert (q[:, 3] >= 0).all()


def test_quaternions_of_random_rotations_are_scipys():
    r = Rotation.random(2000, rng=np.random.default_rng(7)).as_matrix()
    same_attitude(quaternions(r), r)
    same_attitude(quaternions(r.reshape(-1, 9)), r)  # the log's row-major 9 numbers


@pytest.mark.parametrize("angle", [0.0, 1e-12, np.pi / 2, np.pi - 1e-9, np.pi])
@pytest.mark.parametrize("axis", [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, -1, 1)])
def test_quaternions_near_the_readings_that_divide_by_little(axis, angle):
    """A half turn about any axis leaves w ~ 0: the trace reading would divide by ~0; each pivot must be taken."""
    rotvec = np.array(axis, dtype=float) / np.linalg.norm(axis) * angle
    r = Rotation.from_rotvec(rotvec).as_matrix()[None]
    q = quaternions(r)
    back = Rotation.from_quat(q).as_matrix()
    np.testing.assert_allclose(back, r, atol=1e-12)
    assert abs(np.linalg.norm(q) - 1.0) < 1e-15


def test_a_matrix_slightly_off_so3_gives_its_nearest_attitude():
    r = Rotation.from_euler("xyz", [0.3, -1.2, 2.9]).as_matrix()
    noisy = r + 1e-7 * np.random.default_rng(1).standard_normal((3, 3))
    q = quaternions(noisy[None])
    assert abs(np.linalg.norm(q) - 1.0) < 1e-15
    np.testing.assert_allclose(Rotation.from_quat(q).as_matrix()[0], r, atol=1e-6)


def test_path_points_are_about_the_spacing_apart_and_bounded():
    circle = Circle(10.0, 2 * np.pi, 0.0, (0.0, 0.0, -5.0))
    points = path_points(circle, 0.0, 2 * np.pi, 0.5, 4000)  # 62.8 m of path
    gaps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    assert 120 <= len(points) <= 130 and gaps.max() <= 0.5 + 1e-9
    np.testing.assert_allclose(np.linalg.norm(points[:, :2], axis=1), 10.0)
    assert len(path_points(circle, 0.0, 1e6, 0.5, 4000)) == 4000
    assert len(path_points(Line((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), 3.0, 3.0, 0.5, 4000)) == 2


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> list[tuple[str, float, dict]]:
    """(topic, t, message) of a 6 s in-process paper run with a lossy channel and a link fault, in log order."""
    where = tmp_path_factory.mktemp("scene")
    (where / "s.toml").write_text(shortened((CONFIGS / "paper.toml").read_text(), 6.0))
    args = ["--set", "comms.loss=0.3", "--fault", "kind=link_down,sender=1,receiver=3,start=2,end=4"]
    done = cpf("run", "s.toml", "--engine", "inprocess", "--quiet", "--out", "r.mcap", *args, cwd=where)
    assert done.returncode == 0, done.stderr
    return [(m.topic, m.log_time / 1e9, m.message) for m in logfile.messages(where / "r.mcap")]


def scene_of(records: list[tuple[str, float, dict]]) -> list[tuple[str, float, str]]:
    scene = FleetScene()
    for topic, _, message in records:
        scene.take(topic, message)
    return [(topic, t, json.dumps(message)) for topic, t, message in scene.messages()]


def test_the_scene_does_not_depend_on_the_order_records_come_in(records):
    """The Zenoh supervisor records the processes' messages as the bus brings them: any order after the meta."""
    cpf_records = [r for r in records if not r[0].startswith("foxglove/")]
    expected = scene_of(cpf_records)
    assert len(expected) > 50
    shuffled = cpf_records[1:]
    random.Random(3).shuffle(shuffled)
    assert scene_of([cpf_records[0], *shuffled]) == expected


def test_the_recorded_scene_is_the_scene_of_the_recorded_records(records):
    recorded = [(topic, t, json.dumps(m)) for topic, t, m in records if topic.startswith("foxglove/")]
    assert scene_of([r for r in records if not r[0].startswith("foxglove/")]) == recorded


def test_a_link_shows_the_fate_of_its_last_packet_before_each_instant(records):
    """On a lossy channel the links' colours change with their packets: some instants show loss, some delivery;
    the cut link 1->3 shows link_down while cut."""
    fates: dict[str, set[str]] = {}
    for topic, t, message in records:
        if topic == "foxglove/scene":
            links = next(e for e in message["entities"] if e["id"] == "links")
            for pair in links["metadata"]:
                fates.setdefault(pair["key"], set()).add(pair["value"])
                if pair["key"] == "1->3" and 2.5 <= t < 4.0:
                    assert pair["value"] == "link_down"
    assert all({"delivered", "loss"} <= seen for seen in fates.values()), fates


def test_nothing_is_kept_before_the_meta_nor_of_records_that_do_not_read(records):
    history = FleetHistory()
    history.take("cpf/vehicle/1/state", {"k": 0, "vehicle": 1})
    assert history.meta is None and history.states == {}
    assert list(FleetScene(history).messages()) == []
    history.take("cpf/run/meta", {"not": "a meta"})
    assert history.meta is None
    topic, _, meta = records[0]
    history.take(topic, meta)
    assert history.meta is not None and history.every == 5  # 0.5 s of 0.1 s steps
    good = {"t": 0.3, "sender": 1, "receiver": 2, "seq": 3, "kind": "dropped", "delay": None, "reason": "loss"}
    for bad in ({"t": "soon"}, {"t": float("nan")}, {"sender": 1.0}, {"seq": None}, {"reason": 4}, {"kind": "lost"}):
        history.take("cpf/comms/event", good | bad)
    history.take("cpf/vehicle/1/state", {"k": 0, "vehicle": 1, "position": "here"})
    assert history.outcomes == {} and history.states == {}
    history.take("cpf/comms/event", good)
    assert history.outcomes == {((1, 2), 5): (0.3, 3, "dropped", "loss")}  # shown at the next instant, 0.5 s


def test_a_state_record_is_kept_as_its_message_would_be(records):
    """The in-process engine feeds the scene its state records (Recorder.write_state), the Zenoh supervisor those it
    read: the same as the records' messages, a NaN in a diagnostic left out by both."""
    from msgspec.structs import replace

    from comms.records.state import StateReport

    topic, _, meta = records[0]
    states = [(t, m) for t, _, m in records if t.endswith("/state") and m["k"] % 5 == 0][:6]
    by_message, by_record = FleetHistory(), FleetHistory()
    for history in (by_message, by_record):
        history.take(topic, meta)
    for n, (key, message) in enumerate(states):
        report = StateReport.from_message(message, message["vehicle"])
        if n % 2:
            report = replace(report, gamma=float("nan"))
        by_message.take(key, report.to_message())
        by_record.take_state(report)
    assert by_record.states == by_message.states
    assert sum(len(kept) for kept in by_record.states.values()) == 3


class _Broken(FleetScene):
    def messages(self) -> Iterator[SceneMessage]:
        raise RuntimeError("a bug in the scene")


def test_the_log_is_closed_with_its_index_even_if_the_scene_fails(tmp_path):
    path = tmp_path / "r.mcap"
    with pytest.raises(RuntimeError, match="a bug in the scene"), Recorder(path) as rec:
        rec.scene = _Broken()
        rec.write("cpf/run/graph", 0.0, {"t": 0.0, "edges": [[1, 2]]})
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics is not None and summary.statistics.message_count == 1
