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


def test_extend_copies_and_a_built_path_never_changes():
    start = np.zeros((2, 3))
    end = np.array([[1.0, 0, 0], [2.0, 0, 0]])
    cols = dict(kind=np.zeros(2, np.int8), start_mm=start, end_mm=end,
                length_mm=np.array([1.0, 2.0]), line=np.array([1, 2], np.int32), feed_mm_s=10.0)
    b = PathBuilder(capacity=100)
    b.extend(**cols)
    end[0, 0] = 9.0                       # the builder copied: the path keeps 1.0
    p = b.build()
    assert p.end_mm[0, 0] == 1.0 and p.n == 2 and p.end_mm.shape == (2, 3)
    assert end.flags.writeable            # the caller's arrays stay the caller's
    b.set_last(exact_stop=True)           # after build: changes a copy, not the built path
    assert not p.exact_stop[-1] and b.build().exact_stop[-1]
    b.extend(**cols)                      # so does building on
    q = b.build()
    assert p.n == 2 and q.n == 4 and q.end_mm[3, 0] == 2.0 and q.exact_stop[1]


def test_columns_grow_past_the_capacity_and_keep_the_rows():
    b = PathBuilder(capacity=3)
    for i in range(2000):
        b.add_line([i, 0, 0], [i + 1, 0, 0], line=i + 1, feed_mm_s=1.0)
        if i % 500 == 0:
            b.extend(kind=np.zeros(700, np.int8), start_mm=np.zeros((700, 3)),
                     end_mm=np.ones((700, 3)), length_mm=np.full(700, 1.5), line=-1)
    p = b.build()
    assert p.n == 2000 + 4 * 700
    assert list(p.line[p.line > 0]) == list(range(1, 2001))
    assert (p.length_mm[p.line < 0] == 1.5).all() and (p.length_mm[p.line > 0] == 1.0).all()


def test_rows_and_chunks_keep_their_order_across_row_chunks(monkeypatch):
    monkeypatch.setattr(PathBuilder, "ROW_CHUNK", 3)
    b = PathBuilder()
    for i in range(8):
        b.add_line([i, 0, 0], [i + 1, 0, 0], line=i + 1, feed_mm_s=1.0)
        if i == 4:
            b.extend(kind=np.zeros(1, np.int8), start_mm=[[5, 0, 0]], end_mm=[[5, 1, 0]],
                     length_mm=[1.0], line=[100])
    b.set_last(exact_stop=True)
    p = b.build()
    assert list(p.line) == [1, 2, 3, 4, 5, 100, 6, 7, 8]
    assert list(p.exact_stop) == [False] * 8 + [True]
