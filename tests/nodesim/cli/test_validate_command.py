"""``nodesim validate``: exit status with and without ``--strict``, the kind of every row in the JSON, the kind
column and the per-kind summary of the table.  The check list is replaced by a small one (one failing row where
the test needs it), so these tests do not run the real checks (``nodesim validate`` takes minutes)."""

import json

import pytest

import nodesim.validation as validation
from nodesim.cli.main import main
from nodesim.validation import Check, within_abs, within_rel

PASSING = [
    within_rel("toy reproduction", "thesis toy table", 1.0, 1.0, 0.01),
    within_abs("toy read-back", "thesis toy table", 2.0, 2.0, 0.1, kind="self_consistency"),
    within_abs("toy assumption", "thesis toy figure", 3.0, 3.5, 1.0, "assumes a toy offset", kind="hypothesis"),
]
FAILING = within_rel("toy failing reproduction", "thesis toy table", 2.0, 1.0, 0.01, "off by a factor 2")


@pytest.fixture
def checks(monkeypatch):
    """Let the test choose what ``run_checks`` returns."""
    chosen: list[Check] = []
    monkeypatch.setattr(validation, "run_checks", lambda: list(chosen))
    return chosen


@pytest.mark.parametrize("extra", [[], ["--json"]])
def test_strict_exits_1_when_a_row_fails_and_plain_validate_exits_0(checks, capsys, extra):
    checks.extend([*PASSING, FAILING])
    assert main(["validate", *extra]) == 0
    assert main(["validate", "--strict", *extra]) == 1
    capsys.readouterr()


@pytest.mark.parametrize("extra", [[], ["--json"]])
def test_strict_exits_0_when_every_row_is_ok(checks, capsys, extra):
    checks.extend(PASSING)
    assert main(["validate", "--strict", *extra]) == 0
    capsys.readouterr()


def test_json_carries_the_kind_of_every_row(checks, capsys):
    checks.extend([*PASSING, FAILING])
    assert main(["validate", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["name"], r["kind"], r["ok"]) for r in rows] == [
        ("toy reproduction", "reproduction", True),
        ("toy read-back", "self_consistency", True),
        ("toy assumption", "hypothesis", True),
        ("toy failing reproduction", "reproduction", False),
    ]


def test_table_shows_the_kind_and_a_summary_per_kind(checks, capsys):
    checks.extend([*PASSING, FAILING])
    assert main(["validate"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:3] == ["ok", "kind", "name"]
    row = next(line for line in lines if "toy read-back" in line)
    assert row.split()[:2] == ["yes", "self_consistency"]
    assert "reproduction: 1 of 2 ok" in lines
    assert "self_consistency: 1 of 1 ok" in lines
    assert "hypothesis: 1 of 1 ok" in lines
    assert lines[-1] == "3 of 4 checks within tolerance"


def test_a_row_without_a_published_figure_prints_a_dash(checks, capsys):
    checks.append(Check("toy ordering of our own runs", "thesis toy set-up", 1.2, float("nan"), "ordering (ratio > 1)",
                        True, kind="self_consistency"))
    assert main(["validate"]) == 0
    row = next(line for line in capsys.readouterr().out.splitlines() if "toy ordering" in line)
    assert row.split()[8:10] == ["1.2", "-"]  # ok, kind, the name (six words), then ours and published
    assert main(["validate", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)[0]["published"] is None


def test_an_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="kind 'replication'"):
        within_rel("toy", "thesis", 1.0, 1.0, 0.1, kind="replication")


def test_a_distribution_row_prints_its_band_and_the_published_percentile(checks, capsys):
    from nodesim.validation import within_band

    checks.extend([within_band("toy published run", "thesis toy table", list(range(101)), 30.0), *PASSING])
    assert main(["validate"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "band 5-95%" in lines[0]
    assert "[5, 95] at 30%" in next(line for line in lines if "toy published run" in line)
    read_back = next(line for line in lines if "toy read-back" in line)
    assert read_back.split()[4:7] == ["2", "2", "-"]  # ours, published, no band
    assert main(["validate", "--json"]) == 0
    row = json.loads(capsys.readouterr().out)[0]
    assert (row["ours"], row["band_p5"], row["band_p95"], row["realizations"]) == (50.0, 5.0, 95.0, 101)
