"""Survey input: bad input is a clear error naming the row and the allowed range."""

import numpy as np
import pytest

from nodesim.errors import NodesimError
from nodesim.ground.survey import make_survey, read_survey_csv


@pytest.mark.parametrize(
    "md, inc, azi, pattern",
    [
        ([0, 10, 5], [0, 1, 2], [0, 0, 0], r"station 3: md_m 5 is decreasing"),
        ([0, 10, 10], [0, 1, 2], [0, 0, 0], r"station 3: md_m 10 is duplicate"),
        ([0, 10, 20], [0, 181, 2], [0, 0, 0], r"station 2: inc_deg 181 is outside \[0, 180\]"),
        ([0, 10, 20], [0, -1, 2], [0, 0, 0], r"station 2: inc_deg -1 is outside"),
        ([0, np.nan, 20], [0, 1, 2], [0, 0, 0], r"station 2: md_m is not a finite number"),
        ([0, 10, 20], [0, 1, 2], [0, np.inf, 0], r"station 2: azi_deg is not a finite number"),
        ([0], [0], [0], r"at least 2 stations"),
    ],
)
def test_bad_surveys_name_the_row(md, inc, azi, pattern):
    with pytest.raises(NodesimError, match=pattern):
        make_survey(md, inc, azi)


def test_default_time_is_seconds_per_station_and_azimuth_wraps():
    s = make_survey([0, 2, 4], [0, 1, 2], [0, 370, -10], seconds_per_station=60)
    np.testing.assert_allclose(s.time_s, [0, 60, 120])
    np.testing.assert_allclose(np.degrees(s.azi_rad), [0, 10, 350])


def test_csv_reader(tmp_path):
    p = tmp_path / "s.csv"
    p.write_text("# comment\nmd_m,inc_deg,azi_deg,time_s\n0,0,0,0\n2,1,90,30\n")
    s = read_survey_csv(p)
    np.testing.assert_allclose(s.time_s, [0, 30])


@pytest.mark.parametrize(
    "text, pattern",
    [
        ("md,inc_deg,azi_deg\n0,0,0\n", r"missing column\(s\) \['md_m'\]"),
        ("md_m,inc_deg,azi_deg\n0,0,0\n2,x,0\n", r"line 3: column inc_deg: 'x' is not a number"),
        ("md_m,inc_deg,azi_deg\n0,0,0\n2,1\n", r"line 3: 2 fields"),
        ("md_m,inc_deg,azi_deg\n0,0,0\n2,1,0\n1,1,0\n", r"line 4: md_m 1 is decreasing"),
        ("", r"empty survey file"),
    ],
)
def test_bad_csv_is_a_clear_error(tmp_path, text, pattern):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(NodesimError, match=pattern):
        read_survey_csv(p)
