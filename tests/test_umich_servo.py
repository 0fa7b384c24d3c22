"""The servo part (commanded against actual) on real data: two University of Michigan SMART
mill runs (``shared/data/real/umich-smart-cnc-mill-tool-wear``, CC0, 10 Hz). The expectations
are physical: the recovered lag is a few milliseconds and the same in both runs, and it agrees
with the independent ramp-delay estimate of ncsim.gap.lag.estimate_lag (a different method on
the same data)."""
from __future__ import annotations

import pytest

from ncsim.gap.measured import load_umich_csv
from ncsim.gap.servo_part import diagnose_servo


@pytest.fixture(scope="module")
def runs(shared):
    umich = shared / "data" / "real" / "umich-smart-cnc-mill-tool-wear"
    return {name: diagnose_servo(load_umich_csv(umich / f"{name}.csv"))
            for name in ("experiment_08", "experiment_09")}


def test_lag_is_consistent_across_runs(runs):
    lags = {}
    for name, d in runs.items():
        assert d.signal == "velocity"            # positions have 1 mm resolution above 100 mm
        for effect in ("servo_delay", "servo_lag"):
            f = d.fit(effect)
            assert 0.005 <= f.lag_s <= 0.010, (name, effect, f.lag_s)
            assert f.shrink_percent > 20.0       # the lag explains a real part of the gap
        lags[name] = d.fit("servo_delay").lag_s
        ramp = d.lag_estimate.pooled_ramp_delay_s
        assert abs(lags[name] - ramp) < 0.002, (name, lags[name], ramp)
    assert abs(lags["experiment_08"] - lags["experiment_09"]) < 0.002


def test_a_pure_delay_explains_the_runs_better_than_a_position_loop(runs):
    for d in runs.values():
        assert d.best.effect == "servo_delay"
        assert d.distinguishable
        lag = d.fit("servo_lag")
        assert lag.gap_after.gap > d.best.gap_after.gap
        dd = d.as_dict()
        assert dd["best"] == "servo_delay" and dd["lag_estimate"]["ramp_samples"] > 10
