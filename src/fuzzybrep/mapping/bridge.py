"""The cells between two occupied cells of the evidence grid at most a span apart
(``evidence.bridged``: a glass pane's sparse returns joined back into the pane).

A segment's cells are the rounded points at every half cell along its longer axis, from the cell
first in row order to the other. The pairs are taken one displacement (dx, dy) at a time, over a
dense bitmap of the cells' box, block by block where the box is large: a site's occupied cells
lie kilometres apart, and one bitmap over their box grew with the site's bounding box, not with
what was seen (two copies of Intel 1 km apart: 3 bitmaps of 55 MB; 2 km: of 218 MB).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

#: occupied cells from which the displacements are split between two threads
THREADS_FROM = 32_000
#: a box of more cells than this is bridged in blocks of BLOCK × BLOCK cells (and their margins)
BOX_CELLS = 1 << 24
BLOCK = 2048


def segment_cells(ix: np.ndarray, iy: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """(kx, ky): every cell, not itself one of the cells (ix, iy), on the segment between two of
    them at most ``r`` cells apart (may lie left of 0 or past the cells' box by up to ``r``)."""
    ix, iy = np.asarray(ix, np.int64), np.asarray(iy, np.int64)
    m = int(np.floor(r))
    if not len(ix) or (int(np.ptp(ix)) + 2 * m + 1) * (int(np.ptp(iy)) + 2 * m + 1) <= BOX_CELLS or m >= BLOCK:
        return _segment_cells(ix, iy, r)
    # every pair lies within m cells of its first cell's block: each block with the cells within
    # m of it (a cell near a block's border goes to the neighbours too). A segment's cells lie in
    # its ends' box, where the block has every occupied cell, so its marks are the whole box's
    bx, by = ix // BLOCK, iy // BLOCK
    owner, cell = [], []
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            near = np.ones(len(ix), bool)
            if dx:
                near &= (ix + dx * m) // BLOCK == bx + dx
            if dy:
                near &= (iy + dy * m) // BLOCK == by + dy
            k = np.flatnonzero(near)
            owner.append((by[k] + dy) * (1 << 31) + bx[k] + dx)
            cell.append(k)
    owner, cell = np.concatenate(owner), np.concatenate(cell)
    order = np.argsort(owner, kind="stable")
    owner, cell = owner[order], cell[order]
    cuts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1], True])
    out = [_segment_cells(ix[cell[a:b]], iy[cell[a:b]], r) for a, b in zip(cuts[:-1], cuts[1:])]
    # a cell two blocks both mark once: keyed with an offset (a mark lies at most m left of 0)
    key = np.unique(np.concatenate([(ky + m + 1) * (1 << 32) + kx + m + 1 for kx, ky in out]))
    ky, kx = np.divmod(key, np.int64(1 << 32))
    return kx - m - 1, ky - m - 1


def _segment_cells(ix: np.ndarray, iy: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    m = int(np.floor(r))
    # a dense bitmap over the occupied cells' box, padded by the span: its look-ups and marks are
    # one add each, where the tiled store's index is eight operations. Shifted by even amounts:
    # np.rint rounds a half to even, so an odd shift moved segments' cells
    sx = m + (m - int(ix.min())) % 2 - int(ix.min())
    sy = -(int(iy.min()) - int(iy.min()) % 2)
    lx, ly = ix + sx, iy + sy
    w, h = int(lx.max()) + 1 + m, int(ly.max()) + 1 + m
    itype = np.int32 if h * w < 2**31 else np.int64
    # the cells by the parity of (lx, ly): a segment's cells, rint(l + t·d), lie at offsets from
    # its first cell that depend on l only through its parity (a half rounds to even), so each
    # displacement's offsets are worked out once per parity and added to the cells' positions:
    # the marks (some twenty per pair, 1.7 M pairs on Intel) were nine tenths of the time
    parity = (lx & 1) | ((ly & 1) << 1)
    order = np.argsort(parity, kind="stable")
    lx, ly, parity = lx[order], ly[order], parity[order]
    groups = np.searchsorted(parity, np.arange(5))
    at = (ly * w + lx).astype(itype)
    occupied = np.zeros(h * w, bool)
    occupied[at] = True
    # the pad (m cells left, right and above; dy >= 0) keeps every look-up inside the bitmap;
    # each pair once (dy > 0, or dy = 0 and dx > 0); neighbouring cells leave nothing between
    shifts = [(dx, dy) for dy in range(0, m + 1) for dx in range(-m, m + 1)
              if max(abs(dx), dy) > 1 and not (dy == 0 and dx < 0) and dx * dx + dy * dy <= r * r]

    def mark(part):
        marks = np.zeros(h * w, bool)
        for dx, dy in part:
            a = np.flatnonzero(occupied[at + itype(dy * w + dx)])
            if not len(a):
                continue
            n = 2 * max(abs(dx), dy)  # half-cell steps
            t = np.arange(1, n) / n
            fx, fy = t * dx, t * dy
            # a step whose t·d is a half only to within rounding (t = 15/22 · 11 is 7.4999...):
            # l + t·d then rounds by l's size, not its parity, so those steps are rounded per cell
            ragged = np.zeros(n - 1, bool)
            for f in (fx, fy):
                frac = f - np.floor(f)
                ragged |= (np.abs(frac - 0.5) < 1e-6) & (frac != 0.5)
            cut = np.searchsorted(a, groups)
            for p in range(4):
                first = a[cut[p] : cut[p + 1]]
                if len(first):
                    px, py = p & 1, p >> 1
                    off = (np.rint(py + fy[~ragged]) - py) * w + (np.rint(px + fx[~ragged]) - px)
                    marks[(at[first, None] + off.astype(itype)).ravel()] = True
            if ragged.any():
                px = np.rint(lx[a, None] + fx[ragged]).astype(np.int64)
                py = np.rint(ly[a, None] + fy[ragged]).astype(np.int64)
                marks[(py * w + px).ravel()] = True
        return marks

    # the displacements in two halves on the machine's cores (NumPy lets go of the GIL while it
    # adds and marks), each half into a bitmap of its own: the marks are the same in any order.
    # Only for many occupied cells: Freiburg 079's 40 k went from 0.41 to 0.26 s, where Intel's
    # 22 k took longer (0.15 -> 0.17 s: a displacement's few pairs hold the GIL between calls)
    parts = [shifts[j::2] for j in range(2)] if (os.cpu_count() or 1) > 1 and len(ix) >= THREADS_FROM else [shifts]
    if len(parts) == 1:
        marks = mark(shifts)
    else:
        with ThreadPoolExecutor(len(parts)) as ex:
            marks, other = ex.map(mark, parts)
        marks |= other
    marks &= ~occupied
    k = np.flatnonzero(marks)
    return k % w - sx, k // w - sy
