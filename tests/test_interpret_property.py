"""Property tests: random valid programs give the segments expected from their text; random
garbage gives an InterpretResult or one typed NcError, never another exception."""
from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings, strategies as st

from ncsim.errors import NcError
from ncsim.nc.interpret import InterpretResult, interpret_text
from ncsim.path import ARC, LINE

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _f(x: float) -> float:
    return float(f"{x:.6f}")


@st.composite
def valid_programs(draw):
    """(text, expected segments) for G17 G90 programs of lines, arcs and full circles."""
    lines = ["G17 G90 G71"]
    expected = []
    pos = (0.0, 0.0, 0.0)
    feed = None
    for _ in range(draw(st.integers(1, 30))):
        kind = draw(st.sampled_from(["G0", "G1", "G1", "G2", "G3", "full"]))
        words = []
        n_before = len(expected)
        if kind != "G0" and (feed is None or draw(st.integers(0, 4)) == 0):
            feed = draw(st.integers(10, 20000))
        if kind in ("G0", "G1"):
            end = tuple(_f(draw(st.floats(-100, 100))) if draw(st.booleans()) else p for p in pos)
            words = [kind] + [f"{a}{v:.6f}" for a, v in zip("XYZ", end)]
            if end != pos:
                expected.append(dict(kind=LINE, start=pos, end=end, rapid=kind == "G0",
                                     length=math.dist(pos, end)))
        else:
            i, j = _f(draw(st.floats(-30, 30))), _f(draw(st.floats(-30, 30)))
            r = math.hypot(i, j)
            if r < 0.5:
                continue
            centre = (pos[0] + i, pos[1] + j, pos[2])
            g = draw(st.sampled_from(["G2", "G3"])) if kind == "full" else kind
            sign = 1.0 if g == "G3" else -1.0
            if kind == "full":
                end, sweep = pos, 2 * math.pi
                words = [g, f"I{i:.6f}", f"J{j:.6f}"]
            else:
                sweep = draw(st.floats(0.05, 2 * math.pi - 0.05))
                start_angle = math.atan2(pos[1] - centre[1], pos[0] - centre[0])
                a = start_angle + sign * sweep
                end = (_f(centre[0] + r * math.cos(a)), _f(centre[1] + r * math.sin(a)), pos[2])
                words = [g, f"X{end[0]:.6f}", f"Y{end[1]:.6f}", f"I{i:.6f}", f"J{j:.6f}"]
            expected.append(dict(kind=ARC, start=pos, end=end, rapid=False, centre=centre, radius=r,
                                 sweep=sweep, normal=(0.0, 0.0, sign), length=r * sweep))
        if kind != "G0":
            words.append(f"F{feed}")
            if len(expected) > n_before:
                expected[-1]["feed"] = feed / 60.0
        lines.append(" ".join(words))
        pos = end
    return "\n".join(lines) + "\nM30\n", expected


@SETTINGS
@given(valid_programs())
def test_random_valid_programs_give_the_expected_segments(case):
    text, expected = case
    r = interpret_text(text, "v.mpf")
    assert len(r.path) == len(expected)
    for s, e in zip(r.path.segments(), expected):
        assert s.kind == e["kind"] and s.rapid == e["rapid"]
        assert np.allclose(s.start_mm, e["start"], atol=1e-9) and np.allclose(s.end_mm, e["end"], atol=1e-9)
        if e["rapid"]:
            assert s.feed_mm_s == math.inf
        else:
            assert s.feed_mm_s == e["feed"]
        if e["kind"] == ARC:
            assert np.allclose(s.center_mm, e["centre"], atol=1e-9)
            assert np.allclose(s.normal, e["normal"]) and abs(s.radius_mm - e["radius"]) < 1e-9
            assert abs(s.sweep_rad - e["sweep"]) < 1e-5
            assert abs(s.length_mm - e["length"]) < 1e-4
        else:
            assert abs(s.length_mm - e["length"]) < 1e-9


TOKENS = ["G0", "G1", "G2", "G3", "G4", "G17", "G18", "G91", "G90", "G64", "G9", "X1", "Y-2.5", "Z.5",
          "I1", "J-1", "K2", "F100", "F0", "S100", "M3", "M30", "M17", "CR=5", "AR=90", "TURN=1",
          "I1=2", "CIP", "CT", "R1=", "R1", "=", "(", ")", "+", "-", "*", "/", "IF", "ELSE", "ENDIF",
          "WHILE", "ENDWHILE", "GOTOB", "GOTOF", "LBL:", "LBL", "N10", "TRANS", "AROT", "SCALE",
          "MIRROR", "X0", "SUPA", "DEF", "REAL", "_V", "PROC", "RET", "SIN(", "AC(", ",", ";", "\"s\"",
          "$A", "[", "]", "<<", "==", "AND", "LOOP", "ENDLOOP", "FOR", "TO", "ENDFOR", "REPEAT",
          "UNTIL", "1", "0", "1e5", "\t", "é", "\x00", "CYCLE832(", "MSG(", "L5", "P2", "D1", "T=",
          "G700", "G70", "STOPRE", "SOFT", "ADIS=", "G641", "B5", "%"]


@st.composite
def garbage(draw):
    rows = []
    for _ in range(draw(st.integers(1, 12))):
        if draw(st.integers(0, 4)) == 0:
            rows.append(draw(st.text(max_size=20)))
        else:
            parts = draw(st.lists(st.sampled_from(TOKENS), max_size=8))
            rows.append(draw(st.sampled_from([" ", "", "  "])).join(parts))
    return draw(st.sampled_from(["\n", "\r\n"])).join(rows)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(garbage(), st.booleans())
def test_garbage_gives_a_result_or_one_typed_error(text, fast):
    try:
        result = interpret_text(text, "g.mpf", fast=fast, block_budget=300)
    except NcError as exc:
        rendered = exc.render()
        assert rendered.startswith("g.mpf:") and "\n" not in rendered
        assert exc.line >= 0 and exc.column >= 0
    else:
        assert isinstance(result, InterpretResult)
        assert np.all(np.isfinite(result.path.length_mm))
