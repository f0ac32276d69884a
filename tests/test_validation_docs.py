"""scripts/validation_table.py writes the per-kind counts (README, docs/validation.md) and the table grouped by
kind (docs) from ``nodesim validate --json``; the committed docs agree with themselves (counts = table rows)."""

import importlib.util
import json
import re
from pathlib import Path

import pytest

from nodesim.validation import KINDS

REPO = Path(__file__).resolve().parents[1]
SPEC = importlib.util.spec_from_file_location("validation_table", REPO / "scripts" / "validation_table.py")
validation_table = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(validation_table)

ROWS = [
    {"name": "a |x|", "source": "thesis", "ours": 1.0, "published": 1.0, "tolerance": "rel 0.1", "ok": True,
     "note": "long note", "kind": "reproduction"},
    {"name": "b", "source": "thesis", "ours": 3.0, "published": 1.0, "tolerance": "rel 0.1", "ok": False, "note": "",
     "kind": "reproduction"},
    {"name": "c", "source": "thesis", "ours": 1.17, "published": None, "tolerance": "ordering", "ok": True,
     "note": "ours only", "kind": "self_consistency"},
]
BLOCKS = "x\n<!-- validation-counts:start -->\nold\n<!-- validation-counts:end -->\n"


def _section_counts(text: str) -> dict[str, tuple[int, int]]:
    """(ok, total) of every kind section of a generated table: its heading and its rows."""
    out = {}
    for kind in KINDS:
        m = re.search(rf"### {kind}: (\d+) of (\d+) ok\n\n\|.*\|\n\|[-|]+\|\n((?:\|.*\|\n?)*)", text)
        assert m, f"no section for {kind}"
        rows = [r for r in m.group(3).splitlines() if r]
        assert (int(m.group(1)), int(m.group(2))) == (sum(r.startswith("| yes |") for r in rows), len(rows)), kind
        out[kind] = (int(m.group(1)), int(m.group(2)))
    return out


def _counts_block(text: str) -> dict[str, tuple[int, int]]:
    block = text.split("<!-- validation-counts:start -->\n")[1].split("<!-- validation-counts:end -->")[0]
    return {m.group(1): (int(m.group(2)), int(m.group(3))) for m in re.finditer(r"^\| (\w+) \| (\d+) \| (\d+) \|", block, re.M)}


def test_script_writes_counts_and_the_table_grouped_by_kind(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "validation.md").write_text(BLOCKS + "y\n<!-- validation-table:start -->\n<!-- validation-table:end -->\nz\n")
    (tmp_path / "README.md").write_text(BLOCKS)
    (tmp_path / "checks.json").write_text(json.dumps(ROWS))
    assert validation_table.main([str(tmp_path / "checks.json"), "--repo", str(tmp_path)]) == 0
    docs, readme = (tmp_path / "docs" / "validation.md").read_text(), (tmp_path / "README.md").read_text()
    expected = {"reproduction": (1, 2), "self_consistency": (1, 1), "hypothesis": (0, 0), "all": (2, 3)}
    assert _counts_block(docs) == _counts_block(readme) == expected
    assert _section_counts(docs) == {k: expected[k] for k in KINDS}
    assert "| yes | a \\|x\\| | 1 | 1 | rel 0.1 | thesis |" in docs  # reproduction rows: no note column
    assert "| yes | c | 1.17 | - | ordering | thesis | ours only |" in docs
    assert docs.startswith("x\n") and docs.endswith("z\n") and "old" not in docs


def test_script_refuses_an_unknown_kind_and_a_missing_marker(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "validation.md").write_text("no markers\n")
    (tmp_path / "README.md").write_text(BLOCKS)
    (tmp_path / "bad.json").write_text(json.dumps([{**ROWS[0], "kind": "replication"}]))
    with pytest.raises(SystemExit, match="unknown kind"):
        validation_table.main([str(tmp_path / "bad.json"), "--repo", str(tmp_path)])
    (tmp_path / "good.json").write_text(json.dumps(ROWS))
    with pytest.raises(SystemExit, match="marker"):
        validation_table.main([str(tmp_path / "good.json"), "--repo", str(tmp_path)])


def test_committed_counts_match_the_committed_table():
    docs, readme = (REPO / "docs" / "validation.md").read_text(), (REPO / "README.md").read_text()
    counts = _counts_block(docs)
    assert counts == _counts_block(readme)
    assert {k: counts[k] for k in KINDS} == _section_counts(docs)
    assert counts["all"] == tuple(map(sum, zip(*(counts[k] for k in KINDS))))


BAND_ROW = {"name": "lab x: RMS azimuth error [deg]", "source": "thesis table 4.22", "ours": 0.46, "published": 0.25,
            "tolerance": "published inside our 5-95 % band (256 runs)", "ok": True, "note": "", "kind": "reproduction",
            "band_p5": 0.15, "band_p95": 1.19, "published_percentile": 27.0, "realizations": 256}


def test_distribution_rows_show_their_band_and_percentile(tmp_path):
    low = {**BAND_ROW, "name": "lab y", "published": 0.029, "published_percentile": 0.0, "ok": False}
    rows = [BAND_ROW, low, *ROWS]
    table = validation_table.table_block(rows)
    assert "| ok | check | ours | published | our 5-95 % | published at | tolerance | source |" in table
    assert "| yes | lab x: RMS azimuth error [deg] | 0.46 | 0.25 | [0.15, 1.19] | 27.0 % |" in table
    assert "| yes | a \\|x\\| | 1 | 1 | - | - | rel 0.1 | thesis |" in table  # a row without a band in that kind
    assert "| yes | c | 1.17 | - | ordering | thesis | ours only |" in table  # a kind without bands: no new columns
    bands = validation_table.bands_block(rows)
    assert "| lab x: RMS azimuth error [deg] | 0.25 | 0.46 | 0.15 | 1.19 | 27.0 % | yes |" in bands
    assert "| lab y | 0.029 | 0.46 | 0.15 | 1.19 | 0.0 % | no |" in bands
    assert bands.endswith("1 of 2 published values inside our 5-95 % band (50 %).") and "| b |" not in bands
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "validation.md").write_text(
        BLOCKS + "<!-- validation-table:start -->\n<!-- validation-table:end -->\n"
        "<!-- validation-bands:start -->\nold\n<!-- validation-bands:end -->\n")
    (tmp_path / "README.md").write_text(BLOCKS)
    (tmp_path / "checks.json").write_text(json.dumps(rows))
    assert validation_table.main([str(tmp_path / "checks.json"), "--repo", str(tmp_path)]) == 0
    docs = (tmp_path / "docs" / "validation.md").read_text()
    assert bands in docs and "old" not in docs
