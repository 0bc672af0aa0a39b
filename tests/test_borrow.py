"""The frame pass's arguments held in one structref and borrowed inside a kernel (``runtime/_borrow_kernel.py``)."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from numba import njit

from adverbs._scratch_kernel import carve, keep
from adverbs.runtime._borrow_kernel import Held, borrowed_box, hold


@njit
def _write_through(held, value):
    rows, (column, k) = borrowed_box(held)
    for c in range(rows.shape[0]):
        rows[c, :] = value + c  # a view of a borrowed array, written in place
    column[k] = value
    return rows[1:, 0].sum() + k


def test_a_held_box_is_the_same_arrays_and_a_kernel_writes_into_them():
    rows, column = np.zeros((4, 3)), np.zeros(5)
    held = hold((rows, (column, 2)))
    assert isinstance(held, Held)
    back_rows, (back_column, k) = held.box
    assert k == 2 and np.shares_memory(back_rows, rows) and np.shares_memory(back_column, column)
    assert _write_through(held, 10.0) == 11.0 + 12.0 + 13.0 + 2
    np.testing.assert_array_equal(rows, np.array([[10.0] * 3, [11.0] * 3, [12.0] * 3, [13.0] * 3]))
    assert column[2] == 10.0 and column.sum() == 10.0


def test_borrowing_leaves_the_arrays_counts_as_they_were():
    rows, column = np.zeros((4, 3)), np.zeros(5)
    held = hold((rows, (column, 0)))
    before = sys.getrefcount(rows), sys.getrefcount(column)
    for _ in range(100):
        _write_through(held, 1.0)
    assert (sys.getrefcount(rows), sys.getrefcount(column)) == before
    del held  # the Held let go: the arrays are the caller's alone again
    assert sys.getrefcount(rows) == before[0] - 1 and sys.getrefcount(column) == before[1] - 1


# ----- the kernels' working arrays: carved from one buffer, borrowed (``_scratch_kernel``) ----------------------


@njit
def _carved(n):
    buf = np.full(3 + 4 * n * 2 + 5, -1.0)
    a, at = carve(buf, 0, (3,))
    b, at = carve(buf, at, (4, n, 2))
    c, end = carve(buf, at, (5,))
    a[:] = 1.0
    for i in range(4):
        for j in range(n):
            b[i, j, 0], b[i, j, 1] = 10.0 * i + j, -(10.0 * i + j)
    c[:] = 3.0
    laid = buf.copy()
    keep(buf)
    return laid, end, b.strides, b.flags.c_contiguous


@njit
def _too_far():
    buf = np.empty(4)
    view, _ = carve(buf, 1, (2, 2))
    keep(buf)
    return view.sum()


def test_carved_arrays_are_c_ordered_views_laid_end_to_end_in_their_buffer():
    n = 3
    laid, end, strides, contiguous = _carved(n)
    assert end == laid.size == 3 + 8 * n + 5 and contiguous and strides == (8 * 2 * n, 8 * 2, 8)
    middle = np.array([[[10.0 * i + j, -(10.0 * i + j)] for j in range(n)] for i in range(4)])
    expect = np.concatenate([np.ones(3), middle.ravel(), np.full(5, 3.0)])
    np.testing.assert_array_equal(laid, expect)


def test_carving_past_the_buffer_is_refused():
    with pytest.raises(IndexError, match="too small"):
        _too_far()
