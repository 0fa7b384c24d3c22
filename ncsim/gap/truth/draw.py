"""Random truth parameters of the withheld-effect benchmarks (:mod:`ncsim.gap.truth.cases`,
:mod:`ncsim.gap.truth.independent`): one effect, each parameter drawn from its range."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def draw_value(rng: np.random.Generator, low, high, scale: str):
    """One value in [low, high]: ``"int"`` a whole number (both ends included), ``"log"``
    log-uniform, ``"lin"`` uniform."""
    if scale == "int":
        return int(rng.integers(int(low), int(high) + 1))
    if scale == "log":
        return float(np.exp(rng.uniform(math.log(low), math.log(high))))
    return float(rng.uniform(low, high))


@dataclass(frozen=True)
class EffectDraw:
    """How to draw one effect's truth: parameter name -> (low, high, scale) with scale
    ``"log"``, ``"lin"`` or ``"int"`` (:func:`draw_value`), and fixed extra values."""

    effect: str
    ranges: dict
    fixed: dict = field(default_factory=dict)

    def draw(self, rng: np.random.Generator) -> dict:
        """The parameters of one truth, drawn in the order of ``ranges``, with ``fixed``."""
        params = {name: draw_value(rng, *spec) for name, spec in self.ranges.items()}
        params.update(self.fixed)
        return params
