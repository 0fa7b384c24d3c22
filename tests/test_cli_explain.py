"""`ncsim machines` and `ncsim explain`: the MIKRON's derived limits against the paper.

Paper values (sec. 5.2.1, 5.2.4, Table 3): V_Jtcurv = 2.01 m/min at R 2.5 and 10.53 m/min at
R 30 (eq. 11 with J_tcurv = 10 x 0.6 = 6 m/s^3, eq. 10); min V_Jt = 1.9 m/min at R 2.5 and
9.9 m/min at R 30 (eq. 4 with min J_t = 5 m/s^3); V_t from 30 to 42.4 m/min (eq. 7);
V_tcy = 78.5 m/min for the R 2.5 circle (eq. 6, t_cy = 12 ms); J_t up to 7.07 m/s^3 (eq. 9).
"""
from __future__ import annotations

import json

import matplotlib.image as matplotlib_image
import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli


def invoke(*args):
    return CliRunner().invoke(cli, [*map(str, args)])


def test_machines_lists_the_bundled_mikron():
    r = invoke("machines")
    assert r.exit_code == 0
    assert any(line.split()[0] == "mikron" and "MIKRON UCP 710" in line for line in r.stdout.splitlines())


def _row(out: str, radius: str) -> list[str]:
    table = out.split("set pt")[1]
    return next(line.split() for line in table.splitlines() if line.split()[:1] == [radius])


def test_explain_table_shows_the_paper_values():
    r = invoke("explain", "--machine", "mikron", "--feed-unit", "m/min")   # the paper's unit
    assert r.exit_code == 0, r.output
    out = r.stdout
    assert "J_tcurv       6 m/s^3" in out and "(eq. 10: J_curv x r_jct)" in out
    assert "J_t (eq. 9)   5 .. 7.07 m/s^3" in out
    assert "V_t (eq. 7)   30.00 .. 42.43 m/min" in out
    r25 = _row(out, "2.5")
    # columns: R, V_Jtcurv, V_Jt min..max, V_An min..max, V_t min..max, V_tcy, V_fr, set point, binds
    assert r25[1] == "2.01" and r25[2].startswith("1.89..")     # paper 2.01, min V_Jt 1.9
    assert r25[5] == "78.5"                                      # paper V_tcy 78.5 m/min
    assert r25[7] == "2.01" and r25[8] == "ncu_path_jerk"        # paper: V_st = V_Jtcurv
    r30 = _row(out, "30")
    assert r30[1] == "10.53" and r30[2].startswith("9.91..")    # paper 10.53, min V_Jt 9.9
    assert r30[4] == "30.00..42.43"
    assert r30[7] == "10.53" and r30[8] == "ncu_path_jerk"
    radii = [line.split()[0] for line in out.split("set pt")[1].splitlines()[2:10]]
    assert radii == ["1", "2.5", "5", "10", "20", "30", "50", "100"]


def test_explain_feeds_are_in_mm_min_by_default_like_run():
    out = invoke("explain", "--machine", "mikron").stdout
    assert "V_t (eq. 7)   30000 .. 42426 mm/min" in out
    assert "steady feed (mm/min) each limit allows" in out and "m/min)" not in out.replace("mm/min", "")
    r25 = _row(out, "2.5")
    assert float(r25[1]) == pytest.approx(2010, abs=5) and float(r25[5]) == pytest.approx(78500, rel=1e-3)


def test_explain_json_and_chosen_radii():
    r = invoke("explain", "-m", "mikron", "--radius-mm", 30, "--radius-mm", 2.5, "--json")
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    rows = data["radii"]
    assert [row["radius_mm"] for row in rows] == [2.5, 30.0]
    assert data["units"] == "mm/min"
    assert rows[0]["v_jtcurv_mm_min"] == pytest.approx(2010, abs=5)
    assert rows[1]["v_jtcurv_mm_min"] == pytest.approx(10530, abs=5)
    assert rows[1]["v_jt_min_mm_min"] == pytest.approx(9900, abs=50)
    assert rows[0]["v_an_max_mm_min"] > rows[0]["v_an_min_mm_min"]


def test_explain_plot(tmp_path):
    out = tmp_path / "limits.png"
    r = invoke("explain", "-m", "mikron", "--plot", out)
    assert r.exit_code == 0, r.output
    assert r.stdout.rstrip().endswith(f"wrote {out}")
    img = matplotlib_image.imread(out)
    assert img.shape[:2] == (650, 1000)


@pytest.mark.parametrize("args, expected", [
    (["explain", "-m", "nosuch"], "no bundled machine named 'nosuch'"),
    (["explain", "-m", "mikron", "--radius-mm", "0"], "ncsim explain: error: Invalid value for '--radius-mm'"),
    (["explain", "-m", "mikron", "--plot", "x.jpeg"], "x.jpeg: cannot tell the figure format"),
])
def test_explain_bad_input_exits_2(args, expected):
    r = invoke(*args)
    assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1 and expected in r.stderr


def test_explain_machine_file_error_names_the_key(tmp_path):
    bad = tmp_path / "m.toml"
    bad.write_text('[machine]\nname = "m"\n[axes.X]\nmax_velocity_m_min = -1\n')
    r = invoke("explain", "-m", bad)
    assert r.exit_code == 2 and r.stderr.startswith(f"{bad}: ")
    assert len(r.stderr.splitlines()) == 1
