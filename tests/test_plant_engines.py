"""Both engines give the same records with the ocean current (steady + tide + shear, known to the controllers) and a
+-20 % model mismatch on, across a vehicle's kill and restart (its plant is drawn again from (seed, vehicle id), the
current is a function of (t, p): nothing to hand over).

    vehicle 2 ---- vehicle 1 ---- vehicle 3        (paper graph, 20 s, vehicle 3 killed at 8 s, back at 10 s)
"""

from __future__ import annotations

import pytest

from tests.conftest import shortened
from tests.procs import cpf
from tests.test_cosim_e2e import states, write_scenario

pytestmark = pytest.mark.e2e

PLANT = """
[environment]
current = [0.08, -0.05, 0.0]
shear = [0.004, 0.002]
shear_origin = -2.0
current_known = {known}
tide = {{ amplitude = [0.03, 0.02, 0.005], period = 60.0, phase_rad = 0.4 }}

[[faults]]
kind = "vehicle_kill"
vehicle = 3
start = 8.0
end = 10.0
"""


@pytest.mark.parametrize(
    ("known", "controller", "hosts"), [("true", "auto", "1"), ("false", "auto", "1"), ("false", "line_of_sight", "3")]
)
def test_both_engines_agree_with_current_and_mismatch_on_across_a_restart(
    tmp_path, paper_text, known, controller, hosts
):
    """auto: the adaptive supervisor (the plant is uncertain), with the current observer where the current is not
    known; line_of_sight: vehicles.line_of_sight, its three vehicles served by one vehicle host (the kill an order to
    the host, the restart a process of its own). While it is down vehicle 3 coasts in the current (vehicles.coast),
    in both engines alike."""
    text = shortened(paper_text, 20.0).replace("[vehicle]\n", "[vehicle]\nuncertainty = 0.2\n", 1)
    text = text.replace("[path_following]\n", f'[path_following]\ncontroller = "{controller}"\n', 1)
    assert "uncertainty = 0.2" in text and controller in text
    scenario = write_scenario(tmp_path, text + PLANT.format(known=known))
    runs = {}
    for engine in ("zenoh", "inprocess"):
        hosting = ["--vehicles-per-process", hosts] if engine == "zenoh" else []
        done = cpf(
            "run", str(scenario), "--engine", engine, *hosting, "--out", f"{engine}.mcap", "--quiet", cwd=tmp_path
        )
        assert done.returncode == 0, done.stderr
        runs[engine] = states(tmp_path / f"{engine}.mcap")
    zen, inp = runs["zenoh"], runs["inprocess"]
    assert zen == inp
    assert len(zen) == 3 * 200 - 20  # vehicle 3 was down for 2 s of 0.1 s steps
    assert zen[(3, 100)]["position"] != zen[(3, 79)]["position"]  # it did not wait where it was for its restart
    nominal = write_scenario(tmp_path, shortened(paper_text, 20.0), "nominal.toml")
    done = cpf("run", str(nominal), "--engine", "inprocess", "--out", "nominal.mcap", "--quiet", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    still = states(tmp_path / "nominal.mcap")
    assert all(zen[key]["position"] != still[key]["position"] for key in zen if key[1] > 10)  # the plant acted
