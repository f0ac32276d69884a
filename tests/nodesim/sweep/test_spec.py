"""Sweep files: axes (lists, ranges, log ranges), zip/cross, seeds, metrics, and clear user errors."""

import math

import pytest

from nodesim.errors import NodesimError
from nodesim.sweep.spec import load_sweep, select_metrics


def test_cross_product_of_range_and_logrange_with_seeds(make_sweep):
    spec = load_sweep(make_sweep("""
seeds = 3
[[axis]]
key = "chain.nodes"
range = [1, 4, 4]
[[axis]]
key = "chain.link_loss_probability"
logrange = [0.001, 0.1, 3]
"""))
    assert spec.axes[0].values == (1, 2, 3, 4) and all(type(v) is int for v in spec.axes[0].values)
    assert spec.axes[1].values == pytest.approx((0.001, 0.01, 0.1))
    tasks = spec.plan()
    assert len(tasks) == 4 * 3 * 3
    assert len({t.run_id for t in tasks}) == len(tasks)
    # common random numbers: seeds are base seed + 0..N-1 at every point
    assert {t.seed for t in tasks} == {7, 8, 9}
    # the scenario each run gets carries its point's values and its seed
    t = tasks[-1]
    assert t.scenario["chain"]["nodes"] == 4 and math.isclose(t.scenario["chain"]["link_loss_probability"], 0.1)
    assert t.scenario["seed"] == 9


def test_zip_advances_axes_together_and_float_range_stays_float(make_sweep):
    spec = load_sweep(make_sweep("""
combine = "zip"
seeds = [11, 5]
[[axis]]
key = "schedule.timeout_s"
range = [10.0, 30.0, 3]
[[axis]]
key = "schedule.update_s"
values = [5.0, 6.0, 7.0]
"""))
    assert spec.points() == [
        (("schedule.timeout_s", 10.0), ("schedule.update_s", 5.0)),
        (("schedule.timeout_s", 20.0), ("schedule.update_s", 6.0)),
        (("schedule.timeout_s", 30.0), ("schedule.update_s", 7.0)),
    ]
    assert [t.seed for t in spec.plan()[:2]] == [11, 5]


def test_value_rejected_by_the_schema_is_planned_as_a_failed_point(make_sweep):
    spec = load_sweep(make_sweep("""
[[axis]]
key = "simulation.realizations"
values = [1, 0, 2]
"""))
    tasks = spec.plan()
    assert [t.invalid is None for t in tasks] == [True, False, True]
    assert "simulation.realizations" in tasks[1].invalid and "greater than or equal to 1" in tasks[1].invalid


@pytest.mark.parametrize(
    "body, words",
    [
        ('bogus = 1\n', ["unknown key", "bogus"]),
        ('[[axis]]\nkey = "chain.nodez"\nvalues = [1]\n', ["axis[0].key", "chain.nodez", "not a scenario key"]),
        ('[[axis]]\nkey = "chain.nodes"\nvalues = [1]\nrange = [1, 2, 2]\n', ["axis[0]", "exactly one"]),
        ('[[axis]]\nkey = "chain.nodes"\nvalues = []\n', ["axis[0]", "non-empty"]),
        ('[[axis]]\nkey = "chain.nodes"\nrange = [1, 2]\n', ["axis[0]", "[start, stop, num]"]),
        ('[[axis]]\nkey = "chain.firmware_rate_hz"\nlogrange = [0.0, 2.0, 3]\n', ["logrange", "> 0"]),
        ('combine = "zip"\n[[axis]]\nkey = "chain.nodes"\nvalues = [1, 2]\n[[axis]]\nkey = "seed"\nvalues = [1]\n', ["seed"]),
        ('combine = "zip"\n[[axis]]\nkey = "chain.nodes"\nvalues = [1, 2]\n[[axis]]\nkey = "chain.firmware_rate_hz"\nvalues = [1.0]\n', ["zip", "equal length"]),
        ('combine = "diagonal"\n', ["combine", "cross"]),
        ('seeds = 0\n', ["seeds", "[1, 1000000]"]),
        ('seeds = [1, 1]\n', ["seeds", "duplicated"]),
        ('retries = 11\n', ["retries", "[0, 10]"]),
        ('[overrides]\n"chain.speed" = 1\n', ["overrides", "chain.speed"]),
    ],
)
def test_bad_sweep_files_name_the_key(make_sweep, body, words):
    path = make_sweep(body)
    with pytest.raises(NodesimError) as err:
        load_sweep(path)
    msg = str(err.value)
    assert str(path) in msg
    for w in words:
        assert w in msg


def test_missing_base_and_unreadable_file(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('name = "x"\n')
    with pytest.raises(NodesimError, match="base: required"):
        load_sweep(p)
    with pytest.raises(NodesimError, match="cannot read sweep file"):
        load_sweep(tmp_path / "missing.toml")


def test_select_metrics_flattens_drops_timing_and_reserved_names():
    summary = {"a_deg": 1.5, "b": None, "flag": True, "name": "x", "seed": 3, "node": {"1": {"err_deg": 2.0}},
               "timing": {"wall_s": 9.0}}
    got = select_metrics(summary, ())
    assert set(got) == {"a_deg", "b", "node.1.err_deg"}
    assert math.isnan(got["b"])
    assert select_metrics(summary, ("node.*",)) == {"node.1.err_deg": 2.0}
    with pytest.raises(NodesimError, match="matches no numeric summary key"):
        select_metrics(summary, ("missing_metric",))


def test_every_bundled_example_sweep_loads_and_plans():
    from pathlib import Path

    folder = Path(__file__).resolve().parents[3] / "scenarios" / "sweeps"
    files = sorted(folder.glob("*.toml"))
    assert len(files) >= 3
    for f in files:
        spec = load_sweep(f)
        tasks = spec.plan()
        assert tasks and all(t.invalid is None for t in tasks), f
