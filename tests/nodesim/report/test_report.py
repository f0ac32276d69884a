"""Reports: parse the HTML, check every image is an embedded, non-empty, decodable PNG, and the content is right."""

import base64
import json
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nodesim.cli.main import main
from nodesim.errors import NodesimError
from nodesim.report import write_report
from nodesim.report.campaign_report import best_points
from nodesim.io.rundir import write_csv

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


class _Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.images, self.headings, self.notes, self.tables, self._in = [], [], [], 0, None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a)
        if tag == "table":
            self.tables += 1
        if tag == "h2" or (tag == "p" and a.get("class") == "note"):
            self._in = tag

    def handle_data(self, data):
        if self._in == "h2":
            self.headings.append(data)
        elif self._in == "p":
            self.notes.append(data)

    def handle_endtag(self, tag):
        if tag == self._in:
            self._in = None


def parse_report(path: Path) -> _Collect:
    c = _Collect()
    c.feed(path.read_text(encoding="utf-8"))
    assert c.images, "report without images"
    for img in c.images:
        src = img["src"]
        assert src.startswith("data:image/png;base64,"), "image not embedded"
        png = base64.b64decode(src.split(",", 1)[1], validate=True)
        assert png.startswith(PNG_MAGIC) and len(png) > 1000, img.get("alt")
        assert img.get("alt")
    return c


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "r"
    lab = Path(__file__).resolve().parents[3] / "scenarios" / "lab" / "continuous.toml"
    assert main(["run", str(lab), "--out", str(out), "--json"]) == 0
    return out


def test_run_report_embeds_every_plot_and_says_what_is_missing(run_dir):
    info = write_report(run_dir)
    c = parse_report(Path(info["report"]))
    assert info["kind"] == "run" and info["images"] == len(c.images)
    assert "Yaw error and bias estimate per node" in c.headings
    assert "Survey stations and uncertainty ellipses" in c.headings and "Link margins along the chain" in c.headings
    # the run's own PNGs are embedded too
    assert len(c.images) == 1 + len(list(run_dir.glob("*.png")))
    if not (run_dir / "ground_survey.csv").exists():
        assert any("no survey stations" in n for n in c.notes)
    assert any("no link data in this run" in n for n in c.notes)


def test_run_report_draws_survey_ellipses_and_link_margins_when_the_run_has_them(run_dir, tmp_path):
    d = tmp_path / "rich"
    d.mkdir()
    for f in ("summary.json", "manifest.json", "timeseries.parquet"):
        (d / f).write_bytes((run_dir / f).read_bytes())
    md = np.arange(0.0, 22.0, 2.0)
    write_csv(d / "ground_survey.csv", {"md_m": md, "inc_deg": np.full(md.size, 2.0), "azi_deg": np.full(md.size, 45.0),
                                         "time_s": 60.0 * np.arange(md.size)})
    write_csv(d / "links.csv", {"hop": np.arange(1, 6), "margin_db": np.array([20.0, 15.0, 9.0, 3.0, -2.0])})
    info = write_report(d, tmp_path / "rich.html", tool="vn100t")
    c = parse_report(tmp_path / "rich.html")
    assert info["images"] == 3  # yaw/bias, survey ellipses, link margins (no PNG files in this directory)
    assert not any("no survey stations" in n or "no link data" in n for n in c.notes)
    alts = " ".join(i["alt"] for i in c.images)
    assert "ellipses" in alts and "links.csv" in alts


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory):
    from nodesim.sweep.campaign import run_campaign
    from nodesim.sweep.executors import LocalExecutor
    from nodesim.sweep.spec import load_sweep

    d = tmp_path_factory.mktemp("camp")
    (d / "base.toml").write_text(
        'name = "short"\nseed = 7\n[simulation]\nduration_s = 120.0\n[motion]\nfast_turns = 2.0\n'
        "[metrics]\nwindow_start_s = 80.0\nwindow_end_s = 120.0\n"
    )
    (d / "sweep.toml").write_text(
        'base = "base.toml"\nseeds = 3\nmetrics = ["rms_azimuth_error_deg", "update_fraction"]\n'
        '[overrides]\n"schedule.mode" = "windowed"\n'
        '[[axis]]\nkey = "schedule.timeout_s"\nvalues = [5.0, 20.0, 40.0]\n'
        '[[axis]]\nkey = "filter.implementation"\nvalues = ["float", "fixed"]\n'
    )
    with LocalExecutor(workers=2) as ex:
        run_campaign(load_sweep(d / "sweep.toml"), d / "c", ex, quiet=True)
    return d / "c"


def test_campaign_report_plots_each_metric_against_each_axis(campaign_dir, tmp_path):
    out = tmp_path / "campaign.html"
    assert main(["report", str(campaign_dir), "--out", str(out), "--where", "update_fraction < 0.9",
                 "--minimize", "rms_azimuth_error_deg", "--json"]) == 0
    c = parse_report(out)
    assert len(c.images) == 2 * 2  # 2 metrics x 2 axes
    assert "Best points" in c.headings and "Failed runs" in c.headings


def test_best_points_are_the_constrained_minimum_of_per_point_means(campaign_dir):
    table = pd.read_parquet(campaign_dir / "results.parquet")
    axes = ["schedule.timeout_s", "filter.implementation"]
    metrics = ["rms_azimuth_error_deg", "update_fraction"]
    best = best_points(table, axes, metrics, "schedule.timeout_s >= 20 and update_fraction < 0.9",
                       "rms_azimuth_error_deg", None, 3)
    # independent computation with plain pandas
    means = table.groupby("point")[metrics + ["schedule.timeout_s"]].mean()
    means = means[(means["schedule.timeout_s"] >= 20) & (means["update_fraction"] < 0.9)]
    expected = means.sort_values("rms_azimuth_error_deg").head(3)
    assert list(best["point"]) == list(expected.index)
    assert np.allclose(best["rms_azimuth_error_deg"], expected["rms_azimuth_error_deg"])
    assert (best["seeds_ok"] == 3).all()


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"where": "no_such_metric < 1"}, ["--where", "no_such_metric"]),
        ({"where": "rms_azimuth_error_deg <"}, ["--where"]),
        ({"minimize": "energy_j"}, ["--minimize", "energy_j", "not a metric"]),
        ({"minimize": "update_fraction", "maximize": "update_fraction"}, ["not both"]),
    ],
)
def test_bad_report_options_are_clear_errors(campaign_dir, tmp_path, kwargs, words):
    with pytest.raises(NodesimError) as err:
        write_report(campaign_dir, tmp_path / "x.html", **kwargs)
    for w in words:
        assert w in str(err.value)
    assert not (tmp_path / "x.html").exists()


def test_report_of_a_directory_that_is_neither_exits_2(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    assert "neither a run directory" in capsys.readouterr().err
    assert main(["report", str(tmp_path / "missing")]) == 2


def test_run_report_of_a_two_node_chain_plots_per_node_metrics(tmp_path):
    lab = Path(__file__).resolve().parents[3] / "scenarios" / "lab" / "two_nodes_0p8hz.toml"
    out = tmp_path / "two"
    assert main(["run", str(lab), "--out", str(out), "--json"]) == 0
    info = write_report(out)
    c = parse_report(Path(info["report"]))
    assert "Metrics along the chain" in c.headings
    assert any("2 of 2 node(s)" in i["alt"] for i in c.images)
