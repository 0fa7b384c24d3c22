"""The withheld-effect benchmark's bookkeeping (the full run is benchmarks/bench_gap.py): case
drawing, parameter errors and the summary tables on hand-made rows."""
from __future__ import annotations

import argparse
import importlib.util
import math
import sys

import numpy as np
import pytest

from ncsim.gap.effects import EFFECTS
from ncsim.gap.truth.cases import CASE_KINDS, draw_case, truth_model
from ncsim.machine import load_machine


@pytest.fixture(scope="module")
def bench(repo_root):
    spec = importlib.util.spec_from_file_location("bench_gap", repo_root / "benchmarks" / "bench_gap.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["bench_gap"] = mod
    spec.loader.exec_module(mod)
    return mod


def test_cases_are_deterministic_balanced_and_in_range(bench):
    a = bench.draw_cases(16, 7)
    b = bench.draw_cases(16, 7)
    assert [c.as_dict() for c in a] == [c.as_dict() for c in b]
    assert sorted(c.effect for c in a) == sorted(list(CASE_KINDS) * 2)
    assert len(CASE_KINDS) >= 5
    for c in a:
        k = CASE_KINDS[c.effect]
        for name, (lo, hi, _) in k.ranges.items():
            assert lo <= c.params[name] <= hi
        assert 1e-3 <= c.scope.period_s <= 12e-3 and 0.3 <= c.scope.noise_um <= 2.0
        assert EFFECTS[c.effect].kind in ("planner", "trace")
        assert c.base in ("full", f"full-minus-{c.effect}")


def test_truth_servo_parameters():
    m = load_machine("mikron")
    rng = np.random.default_rng(0)
    comp = draw_case(rng, 0, "compliance")
    _, servo = truth_model(m, comp)
    c_s2 = comp.params["compliance_um_per_m_s2"] * 1e-6
    assert np.allclose(servo.compliance_mm_per_mm_s2, c_s2)          # 1 / w_s^2
    lag = draw_case(rng, 1, "servo_lag")
    model, servo = truth_model(m, lag)
    assert np.allclose(servo.kv_1_s, lag.params["kv_1_s"]) and np.allclose(servo.ffw_weight, 0.0)
    assert model.post == ()                                           # the truth's loop is RK4
    plan_case = draw_case(rng, 2, "transition")
    model, servo = truth_model(m, plan_case)
    assert math.isclose(model.machine.ncu.transition_time_s * 1000,
                        plan_case.params["transition_time_ms"])
    assert np.allclose(servo.ffw_weight, 1.0)                         # mild baseline loop


def test_summary_tables(bench):
    cases = bench.draw_cases(8, 2)
    rows = []
    for c in cases:
        right = c.effect != "lookahead"
        rows.append({**c.as_dict(), "top1": c.effect if right else "cycle_time", "right": right,
                     "ranking": [[c.effect, 95.0]], "max_param_error": 0.01 if right else 0.5,
                     "shrink_percent": 95.0 if right else 40.0})
    args = argparse.Namespace(seed=2, program="p.mpf", machine="m", workers=1)
    summary, text = bench.summarise(rows, 12.0, args)
    assert math.isclose(summary["top1_rate"], 7 / 8)
    assert summary["confusion"]["lookahead"] == {"cycle_time": 1}
    assert summary["per_effect"]["lookahead"]["top1"] == 0.0
    assert not summary["targets_met"]                    # fewer than 50 cases
    assert "| lookahead |" in text and "Misidentified" in text
    errs = bench.param_errors(cases[0], {**cases[0].params,
                                         **{k: v * 1.05 for k, v in cases[0].params.items()
                                            if not isinstance(v, str)}})
    assert all(math.isclose(e, 0.05, rel_tol=1e-9) or e == 0.0 for e in errs.values())


def test_independent_cases_cover_every_effect_and_condition(bench):
    from ncsim.gap.truth.independent import CONDITIONS, INDEPENDENT_KINDS
    n = len(INDEPENDENT_KINDS) * len(CONDITIONS)
    cases = bench.draw_independent_cases(n, 3)
    assert {(c.effect, c.condition) for c in cases} == {(k, c) for k in INDEPENDENT_KINDS
                                                        for c in CONDITIONS}
    assert [c.as_dict() for c in cases] == [c.as_dict() for c in bench.draw_independent_cases(n, 3)]
    for c in cases:
        for name, (lo, hi, _) in INDEPENDENT_KINDS[c.effect].ranges.items():
            assert lo <= c.params[name] <= hi
        assert c.known_recorder_ms == (20.0 if c.condition in ("50hz", "kit")
                                       and c.effect != "recorder" else None)


def test_one_independent_case_end_to_end(bench, repo_root):
    """A rapid override planted in the plain planner's truth, recorded like KIT's trace (one
    pass of three, machine coordinates, 50 Hz after a 20 ms mean): named, and its value found."""
    from ncsim.gap.truth.independent import draw_independent_case
    case = draw_independent_case(np.random.default_rng(11), 0, "rapid_override", "kit")
    bench._init(str(repo_root / "programs" / "diagnosis_mix.mpf"), "mikron")
    row = bench.run_case(case)
    assert row["suite"] == "independent" and row["right"], row["ranking"][:3]
    assert row["max_param_error"] < 0.02 and row["shrink_percent"] > 80.0
    assert row["offset_error_um"] < 5.0
