"""Diameter programming of the transverse axis (turning).

840D semantics (Programming Manual Fundamentals, "Dimensions": "Dimensions for turning and
milling: DIAMON, DIAM90, DIAMOF, DIAMCYCOF" and "Non-modal axis-specific diameter/radius
programming: DAC, DIC, RAC, RIC"):

* the transverse axis is the geometry axis of machine data MD20100 ``$MC_DIAMETER_AX_DEF``
  (X on a lathe); its positions may be programmed as diameters, the control moving it by half
  the programmed value;
* G group 29 selects how: ``DIAMOF`` radius for G90 and G91; ``DIAMON`` diameter for G90 and
  G91 (an incremental X10 moves 5 mm); ``DIAM90`` diameter for G90, radius for G91 (and for
  ``AC()``/``IC()`` per value likewise); ``DIAMCYCOF`` radius while a cycle runs (the display
  keeps the last mode): for the path it is radius programming. Its reset value is machine data
  MD20150 ``$MC_GCODE_RESET_VALUES[28]``: DIAMOF as delivered, DIAMON on lathes
  (``machine.NcuSpec.reset_diameter_mode``); a program may switch it on any machine;
* ``X=DAC(d)`` is an absolute diameter, ``X=DIC(d)`` an incremental diameter, ``X=RAC(r)`` an
  absolute radius and ``X=RIC(r)`` an incremental radius, for that value only and whatever the
  mode (transverse axis only in ncsim);
* diameter values also apply to the intermediate point of CIP (I1= on the transverse axis) and to
  the centre when it is programmed absolutely (``I=AC(..)``); an incremental centre, the
  radius ``CR=`` and polar coordinates stay radius values (Fundamentals, "Axis-specific
  diameter programming": "interpolation parameters I, J, K for G2/G3 if programmed absolutely
  with AC"). Work offsets and frames (TRANS) are radius values in ncsim (their diameter
  setting, MD for work offsets in diameter, is not read).

The path, its length and its feed are those of the axis's real (radius) motion: the feed F
acts on the path the tool moves.
"""
from __future__ import annotations

DIAMOF, DIAMON, DIAM90, DIAMCYCOF = 0, 1, 2, 3
#: the G group 29 commands and their codes
DIAMETER_COMMANDS = {"DIAMOF": DIAMOF, "DIAMON": DIAMON, "DIAM90": DIAM90, "DIAMCYCOF": DIAMCYCOF}
#: non-modal value modes: name -> (incremental, diameter)
VALUE_MODES = {"DAC": (False, True), "DIC": (True, True), "RAC": (False, False),
               "RIC": (True, False)}


def diameter_applies(mode: int, incremental: bool) -> bool:
    """Whether a value of the transverse axis is a diameter under group-29 ``mode``."""
    return mode == DIAMON or (mode == DIAM90 and not incremental)


def transverse_value(word_mode, incremental_modal: bool, mode: int) -> tuple[bool, float]:
    """(incremental, factor to radius) of a transverse-axis value written with ``word_mode``
    (None, AC, IC, DAC, DIC, RAC, RIC) under G90/G91 (``incremental_modal``) and group 29."""
    if word_mode in VALUE_MODES:
        inc, diameter = VALUE_MODES[word_mode]
        return inc, 0.5 if diameter else 1.0
    inc = word_mode == "IC" or (word_mode is None and incremental_modal)
    return inc, 0.5 if diameter_applies(mode, inc) else 1.0
