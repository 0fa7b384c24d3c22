"""PathBuilder and Path basics."""
from __future__ import annotations

import numpy as np
import pytest

from ncsim.path import ARC, LINE, PathBuilder


def test_builder_mixes_rows_and_chunks_of_lines_and_arcs():
    b = PathBuilder()
    b.add_line([0, 0, 0], [10, 0, 0], line=1, feed_mm_s=100.0)
    b.add_arc([10, 0, 0], [10, 10, 0], [10, 5, 0], [0, 0, 1], 5.0, np.pi, line=2, feed_mm_s=50.0)
    b.add_line([10, 10, 0], [0, 10, 0], line=3, feed_mm_s=100.0, exact_stop=True)
    b.extend(kind=np.array([LINE, LINE], np.int8), start_mm=[[0, 10, 0], [0, 20, 0]],
             end_mm=[[0, 20, 0], [5, 20, 0]], length_mm=[10.0, 5.0], line=[4, 5], feed_mm_s=20.0)
    b.add_line([5, 20, 0], [5, 20, 3], line=6, feed_mm_s=np.inf, rapid=True)
    b.set_last(stop_before=True)
    p = b.build()
    assert p.n == 6
    assert list(p.kind) == [LINE, ARC, LINE, LINE, LINE, LINE]
    assert np.isnan(p.center_mm[0]).all() and np.all(p.normal[0] == 0)
    assert p.length_mm[1] == pytest.approx(5 * np.pi)
    assert p.total_length_mm == pytest.approx(10 + 5 * np.pi + 10 + 10 + 5 + 3)
    assert list(p.exact_stop) == [False, False, True, False, False, False]
    assert p.stop_before[5] and p.rapid[5]
    assert list(p.line) == [1, 2, 3, 4, 5, 6]
    np.testing.assert_allclose(p.s_start_mm[:3], [0, 10, 10 + 5 * np.pi])
    seg = p.segment(1)
    assert seg.is_arc and seg.radius_mm == 5.0 and not seg.clockwise_in_plane


def test_path_columns_are_read_only():
    b = PathBuilder()
    b.add_line([0, 0, 0], [1, 0, 0], line=1, feed_mm_s=1.0)
    p = b.build()
    with pytest.raises(ValueError):
        p.length_mm[0] = 2.0
