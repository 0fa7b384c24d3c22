"""840D modal groups, reset values and the interpreter's modal state.

The G functions ncsim knows, by group (a group may appear once per block):

========================  ==============================================  =====================
group                     codes                                           ncsim
========================  ==============================================  =====================
motion (1)                G0 G1 G2 G3, CIP CT (commands)                  simulated
dwell (2, non-modal)      G4                                              simulated
exact stop (11, block)    G9                                              simulated
plane (6)                 G17 G18 G19                                     simulated
frame suppression (9)     G53 G153 (and SUPA)                             simulated
settable frame (8)        G500 G54..G57 G505..G599                        simulated (offsets)
cp mode (10)              G60 G64 G641 G642 G643 G644 G645                simulated (plan.blend)
stop window (12)          G601 G602 G603                                  recorded per segment
units (13)                G70 G71 G700 G710                               simulated
distance (14)             G90 G91                                         simulated
feed type (15)            G94 G95 G97 G971; G93 G96 G961 G931 G942 ..    G94 G95 G97 G971, others error
pole (3, non-modal)       G110 G111 G112 (with AP= RP=)                   simulated
tool radius comp (7)      G40; G41 G42                                    G41/G42 warned
corner behaviour (18)     G450 G451                                       no effect without G41/G42
working area (3)          G25 G26                                         warned
diameter (29)             DIAMOF DIAMON DIAM90 DIAMCYCOF (commands)       simulated (nc.diameter)
========================  ==============================================  =====================

Other G functions that change the path (threads, tapping, polar coordinates, approach cycles)
are NcUnsupportedError at their word; unknown ones NcSemanticError. Commands are listed in
``COMMANDS_NOT_SIMULATED`` (accepted, warned) and ``UNSUPPORTED_MOTION`` (splines: an error).

Reset values are the 840D's as delivered (MD20150 $MC_GCODE_RESET_VALUES): G1, G17, G90,
G71, G94, G60, G601, BRISK, FFWOF, COMPOF, G500, G40; a machine builder may change them.
CTOL and OTOL are deleted at reset (no programmed tolerance: the machine data apply). The group-10
reset value (G60 or a continuous-path mode) comes from the machine file
(``[ncu] reset_path_mode``), as many machines are delivered in G64, and so does the group-30
one (``[ncu] reset_compressor``: a compressor on where the program selects none).

:class:`ModalState` is mutable on purpose: million-block programs cannot afford a new object
per block; the interpreter keeps one and advances it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ncsim.nc.frames import IDENTITY, Frame
from ncsim.path import BRISK, COMPCAD, COMPCURV, COMPOF, COMPON, COMPSURF, DRIVE, SOFT
from ncsim.units import MM_PER_INCH

CIP = 10   # motion codes beyond G0..G3
CT = 11
MOTION_NAMES = {0: "G0", 1: "G1", 2: "G2", 3: "G3", CIP: "CIP", CT: "CT"}

# G code -> (group, value)
G_CODES: dict[int, tuple[str, int]] = {
    0: ("motion", 0), 1: ("motion", 1), 2: ("motion", 2), 3: ("motion", 3),
    4: ("dwell", 4), 9: ("block_exact_stop", 9),
    17: ("plane", 17), 18: ("plane", 18), 19: ("plane", 19),
    40: ("radius_comp", 40), 41: ("radius_comp", 41), 42: ("radius_comp", 42),
    53: ("suppress", 53), 153: ("suppress", 153),
    500: ("settable", 500), 54: ("settable", 54), 55: ("settable", 55), 56: ("settable", 56),
    57: ("settable", 57),
    60: ("cp_mode", 60), 64: ("cp_mode", 64), 641: ("cp_mode", 641), 642: ("cp_mode", 642),
    643: ("cp_mode", 643), 644: ("cp_mode", 644), 645: ("cp_mode", 645),
    601: ("stop_window", 601), 602: ("stop_window", 602), 603: ("stop_window", 603),
    70: ("units", 70), 71: ("units", 71), 700: ("units", 700), 710: ("units", 710),
    90: ("distance", 90), 91: ("distance", 91),
    94: ("feed_type", 94), 95: ("feed_type", 95), 97: ("feed_type", 97),
    971: ("feed_type", 971),
    110: ("pole", 110), 111: ("pole", 111), 112: ("pole", 112),
    450: ("corner", 450), 451: ("corner", 451),
    25: ("limits", 25), 26: ("limits", 26),
}
G_CODES.update({code: ("settable", code) for code in range(505, 600)})

# Real 840D G functions that change what a path means and that ncsim does not simulate.
G_UNSUPPORTED: dict[int, str] = {
    93: "inverse-time feed G93", 96: "constant cutting rate G96 (turning)",
    961: "constant cutting rate G961 (turning)", 931: "travel-time feed G931", 942: "G942",
    952: "G952", 962: "constant cutting rate G962 (turning)",
    972: "G972", 973: "G973",
    5: "oblique plunge-cutting G5", 7: "G7", 33: "thread cutting G33", 34: "G34", 35: "G35",
    331: "rigid tapping G331", 332: "rigid tapping G332", 63: "tapping G63",
    74: "reference point approach G74", 75: "fixed point approach G75",
    147: "soft approach G147", 148: "soft retract G148", 247: "G247", 248: "G248",
    347: "G347", 348: "G348", 340: "G340", 341: "G341", 810: "G810", 811: "G811",
}

INCH_FEED = {700}
PER_REVOLUTION = (95, 97)    # feed types whose F is per spindle revolution (G97: as G95)
MM_PER_INCH_CODES = {70: MM_PER_INCH, 700: MM_PER_INCH, 71: 1.0, 710: 1.0}

ACCEL_COMMANDS = {"SOFT": SOFT, "BRISK": BRISK, "DRIVE": DRIVE}
#: group 30, the NC block compressor (simulated by ncsim.plan.compressor; COMPSURF as COMPCAD)
COMPRESSOR_CODES = {"COMPOF": COMPOF, "COMPON": COMPON, "COMPCURV": COMPCURV,
                    "COMPCAD": COMPCAD, "COMPSURF": COMPSURF}
COMPRESSOR_COMMANDS = tuple(COMPRESSOR_CODES)
#: G group 59, the technology groups of the dynamic response (their index is the Path's
#: ``dyn_group`` and the machine data's array index, machine.TECHNOLOGY_GROUPS)
DYNAMIC_COMMANDS = ("DYNNORM", "DYNPOS", "DYNROUGH", "DYNSEMIFIN", "DYNFINISH", "DYNPREC")

# CYCLE832 "High speed settings" (SINUMERIK NC programming manual 12/2019, "Programming cycles
# externally", CYCLE832(S_TOL, S_TOLM, S_OTOL)). The machining type is the units digit of
# S_TOLM; the tens digit 1 means S_OTOL is the orientation tolerance (the _ORI_ forms). The
# predefined names of the cycle package and their codes:
CYCLE832_CONSTANTS = {"_OFF": 0.0, "_FINISH": 1.0, "_SEMIFIN": 2.0, "_ROUGH": 3.0,
                      "_PRECISION": 4.0, "_ORI_FINISH": 11.0, "_ORI_SEMIFIN": 12.0,
                      "_ORI_ROUGH": 13.0}
#: the technology G group 59 each machining type selects (SINUMERIK Operate commissioning,
#: "High speed settings"): index into the dynamic-response machine data MD20600 etc.
CYCLE832_DYNAMICS = ("DYNNORM", "DYNFINISH", "DYNSEMIFIN", "DYNROUGH", "DYNPREC")
CYCLE832_TYPE_NAMES = ("deselection", "finishing", "rough-finishing", "roughing",
                       "smooth finishing")

# 840D commands that ncsim accepts without simulating them (each use is warned). The path they
# would change is kept as programmed: the warning says what is missing.
COMMANDS_NOT_SIMULATED = {
    "FLIN": "linear feed profile", "FCUB": "cubic feed profile",
    "CFTCP": "feed at the tool centre", "CFIN": "feed at the inner contour",
    "UPATH": "path parameter of the FGROUP axes", "SPATH": "path parameter of the FGROUP axes",
    "SOFTA": "axis-specific SOFT", "BRISKA": "axis-specific BRISK", "DRIVEA": "axis-specific DRIVE",
    "ORIWKS": "tool orientation (5-axis)", "ORIMKS": "tool orientation (5-axis)",
    "ORIAXES": "tool orientation (5-axis)", "ORIVECT": "tool orientation (5-axis)",
    "ORICONCW": "tool orientation (5-axis)", "ORICONCCW": "tool orientation (5-axis)",
    "TCOABS": "tool length from the orientation", "TCOFR": "tool length from the frame",
    "TOFRAME": "frame along the tool", "PAROT": "frame along the workpiece",
    "CUT2D": "2D cutter compensation", "CUT2DF": "2D cutter compensation",
    "CUT3DC": "3D cutter compensation", "CUT3DF": "3D cutter compensation",
    "WAITM": "channel synchronisation", "WAITE": "channel synchronisation",
    # Programming Manual Fundamentals, "Rapid traverse movement (G0, RTLION, RTLIOF)": each axis
    # at its own rapid traverse; the time is that of the interpolated straight line
    # (max |d_i| / v_i) but for the axes' separate ramps
    "RTLIOF": "G0 without linear interpolation: the axes' separate ramps",
}

# Motion commands whose path ncsim cannot build: an error, not a silently wrong path.
UNSUPPORTED_MOTION = {
    "ASPLINE": "Akima spline", "BSPLINE": "B spline", "CSPLINE": "cubic spline",
    "POLY": "polynomial interpolation", "INVCW": "involute", "INVCCW": "involute",
    "OEMIPO1": "OEM interpolation", "OEMIPO2": "OEM interpolation",
}

# M functions with a meaning beyond "auxiliary output"
M_STOP, M_OPTIONAL_STOP, M_END, M_END_RESET, M_RETURN = 0, 1, 2, 30, 17
M_SPINDLE_CW, M_SPINDLE_CCW, M_SPINDLE_STOP, M_TOOL_CHANGE = 3, 4, 5, 6


@dataclass(slots=True)
class ModalState:
    """Everything that persists from block to block (reset values of the 840D)."""

    motion: int = 1
    plane: int = 17
    incremental: bool = False
    units: int = 71
    feed_mm_s: float = math.nan          # NaN: no F programmed yet
    cp_mode: int = 60
    stop_window: int = 601
    adis_mm: float = 0.0
    adispos_mm: float = 0.0
    compressor: int = COMPOF             # group 30
    ctol_mm: float = math.nan            # CTOL= / CYCLE832 contour tolerance; NaN: machine data
    otol_deg: float = math.nan           # OTOL= orientation tolerance (recorded: no orientation)
    accel_mode: int = BRISK
    ffw: bool = False
    radius_comp: int = 40
    spindle_rpm: float | None = None
    spindle_on: bool = False
    d_number: int = 0
    settable_mm: tuple = (0.0, 0.0, 0.0)
    prog_frame: Frame = IDENTITY
    frame: Frame = IDENTITY              # settable offset + programmable frame
    pos_wcs: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    pos_mcs: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    last_rapid: bool | None = None       # rapid flag of the last segment
    last_segment: tuple | None = None    # (kind, start, end, center, normal, radius, sweep, helix)
    pending_stop: bool = False           # stop before the next segment
    pending_dwell_s: float = 0.0         # dwell before the next segment
    diameter: int = 0                    # group 29: DIAMOF DIAMON DIAM90 DIAMCYCOF (nc.diameter)
    dyn_group: int = 0                   # group 59: index of DYNAMIC_COMMANDS (DYNNORM ...)
    compress_break: bool = False         # an instruction since the last segment interrupts the
                                         # compressor (the next segment starts a new group)

    @property
    def length_scale(self) -> float:
        """mm per programmed length unit (25.4 under G70/G700)."""
        return MM_PER_INCH_CODES[self.units]

    @property
    def feed_scale(self) -> float:
        """mm per programmed feed length unit (25.4 under G700 only: G70 keeps metric feed)."""
        return MM_PER_INCH if self.units in INCH_FEED else 1.0

    def set_frames(self) -> None:
        """Recompute the combined frame and the WCS position (the machine does not move)."""
        self.frame = self.prog_frame.offset_by(self.settable_mm)
        self.pos_wcs = list(self.frame.inverse_apply(*self.pos_mcs))
