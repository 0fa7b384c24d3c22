"""The column path: a run of plain blocks (:mod:`ncsim.nc.fastparse`) interpreted as whole columns.

What the block path does one block at a time is done here with numpy over the run: modal G and
F are forward-filled, G91 positions are cumulative sums, the run's one frame (it cannot change
inside a run of plain blocks) is applied to all end points at once, the transverse axis's
diameter programming (it cannot change inside a run either) is a factor on its column, and arcs
go through the same :func:`~ncsim.nc.moves.arc_columns` kernel and the same circle end-point
check (MD21000/MD21010) as in the block path. No object is made per block.

:meth:`ColumnPath.run` takes a run only when it cannot raise or warn: a value out of range, a
feed that is not positive, a move without feed, I J K on a line, a circle without centre or with
a centre off the plane, an ellipse, a bad circle end point, CIP/CT modal, the block budget, an
active modal call (MCALL) or a feed per revolution all send the whole run back to the block
path, having changed nothing. So both paths give the same
Path, warnings and errors (``tests/test_fastpath.py`` compares them).
"""
from __future__ import annotations

import numpy as np

from ncsim.geometry import PLANE_AXES
from ncsim.nc import program as P
from ncsim.nc.context import MIN_PROGRAMMED_F, WORD_VALUE_LIMIT
from ncsim.nc.diameter import diameter_applies
from ncsim.nc.frames import arc_normal
from ncsim.nc.moves import (MIN_LINE_MM, MIN_RADIUS_MM, arc_columns, circle_error_mm,
                             circle_tolerance_mm)
from ncsim.path import ARC
from ncsim.units import mm_min_to_mm_s


def _ffill(values: np.ndarray, present: np.ndarray, init):
    """``values`` with absent entries replaced by the last present one (``init`` before any)."""
    idx = np.where(present, np.arange(len(values)), -1)
    np.maximum.accumulate(idx, out=idx)
    return np.where(idx >= 0, values[np.maximum(idx, 0)], init)


class ColumnPath:
    """Interprets runs of plain blocks as columns, or declines (the block path then runs them)."""

    def __init__(self, state) -> None:
        self.state = state
        self.st = state.st

    def run(self, fr, run: P.PlainRun) -> bool:
        """Interpret a run of plain blocks as columns. Returns False, having changed nothing,
        when the run needs the block-by-block path (errors, warnings, budget, CIP/CT)."""
        state = self.state
        st = self.st
        n = len(run)
        if state.blocks + n > state.budget or state.modal_call is not None or \
                state.feed_type not in (94, 971):
            return False
        vals = run.values
        present = ~np.isnan(vals)
        if not (np.abs(vals[present]) < WORD_VALUE_LIMIT).all():
            return False
        has_g = run.g >= 0
        has_xyz = present[:, 0:3].any(axis=1)
        has_ijk = present[:, 3:6].any(axis=1)
        if st.motion not in (0, 1, 2, 3):
            first_g = int(np.argmax(has_g)) if has_g.any() else n
            if (has_xyz[:first_g] | has_ijk[:first_g]).any():
                return False
        motion = _ffill(run.g.astype(np.int16), has_g, st.motion)
        linear = motion <= 1
        arc = (motion == 2) | (motion == 3)
        perp = PLANE_AXES[st.plane][2]
        if (linear & has_ijk).any() or (arc & has_xyz & ~has_ijk).any() or (arc & present[:, 3 + perp]).any():
            return False
        f_present = present[:, 6]
        if not (vals[f_present, 6] >= MIN_PROGRAMMED_F).all():   # else the located error
            return False
        feed = _ffill(mm_min_to_mm_s(vals[:, 6] * st.feed_scale), f_present, st.feed_mm_s)
        moving = (linear & has_xyz) | (arc & (has_xyz | has_ijk))
        if (moving & (motion >= 1) & np.isnan(feed)).any():
            return False
        rows = np.flatnonzero(moving)
        if len(rows):
            built = self._segments(run, rows, motion, arc, feed, present)
            if built is None:
                return False
            self._commit(fr, *built)
        state.blocks += n
        st.motion = int(motion[-1])
        st.feed_mm_s = float(feed[-1])
        return True

    def _segments(self, run, rows, motion, arc, feed, present):
        st = self.st
        vals = run.values
        scale = st.length_scale
        m = len(rows)
        wcs_end = np.empty((m, 3))
        for a in range(3):
            v = vals[rows, a] * (scale * self._diameter_factor(a))
            p = present[rows, a]
            if st.incremental:
                d = np.where(p, v, 0.0)
                wcs_end[:, a] = np.cumsum(np.concatenate(([st.pos_wcs[a]], d)))[1:]
            else:
                wcs_end[:, a] = _ffill(v, p, st.pos_wcs[a])
        wcs_start = np.vstack([np.array([st.pos_wcs]), wcs_end[:-1]])
        mcs_end = st.frame.apply_rows(wcs_end)
        mcs_start = np.vstack([np.array([st.pos_mcs]), mcs_end[:-1]])
        d = mcs_end - mcs_start
        cols = {"kind": np.zeros(m, dtype=np.int8), "start_mm": mcs_start, "end_mm": mcs_end,
                "center_mm": np.full((m, 3), np.nan), "normal": np.zeros((m, 3)),
                "radius_mm": np.full(m, np.nan), "sweep_rad": np.zeros(m), "helix_mm": np.zeros(m),
                "length_mm": np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])}
        is_arc = arc[rows]
        if is_arc.any():
            if not self._arcs(run, rows, motion, is_arc, present, wcs_start, mcs_start, mcs_end, cols):
                return None
        keep = is_arc | (cols["length_mm"] > MIN_LINE_MM)
        rapid = motion[rows] == 0
        return run.first_line + rows, keep, cols, rapid, feed[rows], wcs_end, mcs_end

    def _diameter_factor(self, axis: int) -> float:
        """0.5 on the transverse axis under diameter programming (a plain run's X has no
        AC/IC, so G90/G91 decides: :func:`ncsim.nc.diameter.diameter_applies`), else 1. Plain
        centres (I J K without AC) stay radius values."""
        st = self.st
        if axis == self.state.diameter_axis and diameter_applies(st.diameter, st.incremental):
            return 0.5
        return 1.0

    def _arcs(self, run, rows, motion, is_arc, present, wcs_start, mcs_start, mcs_end, cols) -> bool:
        st = self.st
        n_ccw = arc_normal(st.frame, st.plane)
        if n_ccw is None:
            return False
        if is_arc.all():           # a run of arcs (CAM arc fitting): views, not gathers
            ai = slice(None)
            center_wcs = wcs_start.copy()
        else:
            ai = np.flatnonzero(is_arc)
            center_wcs = wcs_start[ai]
        arc_rows = rows[ai]
        scale = st.length_scale
        e1, e2, _ = PLANE_AXES[st.plane]
        for axis in (e1, e2):
            v = run.values[arc_rows, 3 + axis] * scale
            center_wcs[:, axis] = wcs_start[ai, axis] + np.where(present[arc_rows, 3 + axis], v, 0.0)
        sign = np.where(motion[arc_rows] == 3, 1.0, -1.0)
        normals = sign[:, None] * n_ccw[None, :]
        geo = arc_columns(mcs_start[ai], mcs_end[ai], st.frame.apply_rows(center_wcs), normals, 0.0)
        r_start = geo["radius_mm"]
        if not (r_start > MIN_RADIUS_MM).all():
            return False
        state = self.state
        if (circle_error_mm(r_start, geo["radius_end_mm"])
                > circle_tolerance_mm(r_start, state.circle_const_mm, state.circle_factor)).any():
            return False
        cols["kind"][ai] = ARC
        cols["normal"][ai] = normals
        for name in ("center_mm", "radius_mm", "sweep_rad", "helix_mm", "length_mm"):
            cols[name][ai] = geo[name]
        return True

    def _commit(self, fr, lines, keep, cols, rapid, feed, wcs_end, mcs_end) -> None:
        st = self.st
        st.pos_wcs = wcs_end[-1].tolist()
        st.pos_mcs = mcs_end[-1].tolist()
        idx = np.flatnonzero(keep)
        k = len(idx)
        if k == 0:
            return
        if k < len(keep):  # zero-length lines make no segment
            for name in cols:      # one column at a time: the full-size one is freed as it goes
                cols[name] = cols[name][idx]
            lines, rapid, feed = lines[idx], rapid[idx], feed[idx]
        stop = np.zeros(k, dtype=bool)
        stop[1:] = rapid[1:] != rapid[:-1]
        stop[0] = st.pending_stop or (st.last_rapid is not None and st.last_rapid != bool(rapid[0]))
        dwell = np.zeros(k)
        dwell[0] = st.pending_dwell_s
        compressor = np.where(cols["kind"] == ARC, 0, st.compressor).astype(np.int8)
        if st.compress_break:      # an instruction before the run interrupted the compressor
            compressor[0] = -compressor[0]
        self.state.out.extend(
            k, **cols, line=lines,
            file_index=fr.file_index, feed_mm_s=np.where(rapid, np.inf, feed), rapid=rapid,
            exact_stop=st.cp_mode == 60, stop_window=st.stop_window, cp_mode=st.cp_mode,
            adis_mm=np.where(rapid, st.adispos_mm, st.adis_mm), accel_mode=st.accel_mode,
            ffw=st.ffw, stop_before=stop, dwell_before_s=dwell,
            compressor=compressor, ctol_mm=st.ctol_mm, dyn_group=st.dyn_group)
        last = k - 1
        st.pending_stop = False
        st.pending_dwell_s = 0.0
        st.compress_break = False
        st.last_rapid = bool(rapid[-1])
        st.last_segment = (int(cols["kind"][last]), tuple(cols["start_mm"][last].tolist()),
                           tuple(cols["end_mm"][last].tolist()), tuple(cols["center_mm"][last].tolist()),
                           tuple(cols["normal"][last].tolist()), float(cols["radius_mm"][last]),
                           float(cols["sweep_rad"][last]), float(cols["helix_mm"][last]))
