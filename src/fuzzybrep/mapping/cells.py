"""Where the evidence grid keeps its cells: tile by tile, only where rays pass.

The evidence grid's frame must hold every return, and returns reach 80 m where rays are trusted
to 8 m: on freiburg-campus the frame is 37.5 M cells of 5 cm, most of which no ray ever crosses.
Stored whole, the grid took memory (and its counts time) for that bounding box; stored as tiles
of TILE × TILE cells where rays pass, it takes them for the area the scans saw.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

#: cells a side of a tile of the evidence grid, which is stored tile by tile where rays pass
TILE = 64
_SHIFT = 6  # TILE == 1 << _SHIFT
#: frames of at most this many cells keep a table of every cell's stored index (4 bytes a cell)
LUT_LIMIT = 1 << 22


@dataclass(frozen=True)
class Cells:
    """Where each cell of the evidence grid's frame (``shape``: ny × nx cells) is stored.

    ``tiles`` None: every cell, row by row. Otherwise the frame is cut into TILE × TILE tiles and
    only the tiles some ray passes through, and their neighbours, are stored (``tiles``: each
    tile's slot, 0 for a tile not stored: slot 0 is scratch, never hit and never occupied). The
    frame must hold every return, and returns reach 80 m (37.5 M cells on freiburg-campus) where
    rays are trusted to 8 m: stored whole, the grid took memory for the bounding box, not for the
    area the scans saw. A return beyond every stored tile lies more than a tile (3.2 m) from
    every ray: it could stop none, is inside no free space and beside no map edge."""

    shape: tuple[int, int]
    tiles: np.ndarray | None = None

    @property
    def size(self) -> int:
        """Cells stored (scratch tile included)."""
        ny, nx = self.shape
        return ny * nx if self.tiles is None else (int(self.tiles.max(initial=0)) + 1) * TILE * TILE

    def index(self, cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
        """Where the cells (cx, cy) of the frame are stored (integers of cx's type, or int64)."""
        cx, cy = np.asarray(cx), np.asarray(cy)
        if self.tiles is None:
            return cy.astype(np.int64) * self.shape[1] + cx
        lut = self._lut
        if lut is not None:
            return lut[cy * self.shape[1] + cx]
        return self._tiled_index(cx, cy)

    def _tiled_index(self, cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
        # TILE is a power of two: shifts and masks, and one look-up in the small tile table,
        # cost about as much as the sample's own arithmetic
        slot = self._flat[(cy >> _SHIFT) * self.tiles.shape[1] + (cx >> _SHIFT)]
        return (slot << (2 * _SHIFT)) | ((cy & (TILE - 1)) << _SHIFT) | (cx & (TILE - 1))

    @functools.cached_property
    def _lut(self) -> np.ndarray | None:
        """Every cell of the frame's stored index, row by row (int32), where the frame is not much
        larger than what is stored: indoors, where rays pass nearly everywhere in the frame
        (Intel: 564 k cells of frame, 516 k stored), one look-up instead of eleven operations per
        sample. None where the frame is far larger (freiburg-campus: returns out to 80 m)."""
        ny, nx = self.shape
        if ny * nx > min(LUT_LIMIT, 2 * self.size):
            return None
        cy, cx = np.divmod(np.arange(ny * nx, dtype=np.int32), np.int32(nx))
        return self._tiled_index(cx, cy).astype(np.int32)

    @property
    def _flat(self) -> np.ndarray:
        return self.tiles.reshape(-1)

    def xy(self, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(cx, cy) in the frame of the stored cells k (the scratch tile's are meaningless)."""
        k = np.asarray(k, np.int64)
        if self.tiles is None:
            cy, cx = np.divmod(k, self.shape[1])
            return cx, cy
        slot, local = np.divmod(k, TILE * TILE)
        ty, tx = np.divmod(self._tile_of_slot[slot], self.tiles.shape[1])
        return tx * TILE + local % TILE, ty * TILE + local // TILE

    @property
    def _tile_of_slot(self) -> np.ndarray:
        t = np.zeros(int(self.tiles.max(initial=0)) + 1, np.int64)
        t[self.tiles.ravel()] = np.arange(self.tiles.size)
        t[0] = 0
        return t

    def around(self, k: np.ndarray, offsets):
        """For each offset (dx, dy), in turn: (neighbour, source) for the stored cells k whose
        neighbour at that offset lies inside the frame: the stored index of the neighbour, and
        the position in k it is a neighbour of. One offset at a time, so that spreading over a
        5 x 5 neighbourhood holds one offset's arrays, not 25."""
        ny, nx = self.shape
        cx, cy = self.xy(k)
        for dx, dy in offsets:
            jx, jy = cx + dx, cy + dy
            inside = np.flatnonzero((jx >= 0) & (jx < nx) & (jy >= 0) & (jy < ny))
            yield self.index(jx[inside], jy[inside]), inside

    @classmethod
    def where_rays_pass(cls, shape, rays, origin: np.ndarray, cell: float) -> "Cells":
        """The tiles the rays (``evidence.Rays``, batch by batch) pass through, and their
        neighbours: every ray looked at once a
        tile's side along it (two such points lie in neighbouring tiles, so with the neighbours
        kept every cell along it is stored), and at its end."""
        ny, nx = shape
        seen = np.zeros((-(-ny // TILE), -(-nx // TILE)), bool)
        side = TILE * cell
        for b in rays:
            n = np.floor(np.maximum(b.length, 0) / side).astype(np.int64) + 2
            ray = np.repeat(np.arange(len(n)), n)
            k = np.arange(len(ray)) - np.repeat(np.cumsum(n) - n, n)
            t = np.minimum(k * side, b.length[ray].clip(0))
            x = b.ox[ray] + t * b.cos[ray]
            y = b.oy[ray] + t * b.sin[ray]
            tx = np.clip(((x - origin[0]) / cell).astype(np.int64) // TILE, 0, seen.shape[1] - 1)
            ty = np.clip(((y - origin[1]) / cell).astype(np.int64) // TILE, 0, seen.shape[0] - 1)
            seen[ty, tx] = True
        # and their neighbours (a 3 x 3 dilation, by hand: scipy.ndimage alone took longer to
        # import than small logs take to build)
        pad = np.pad(seen, 1)
        seen = np.zeros_like(seen)
        for dy in range(3):
            for dx in range(3):
                seen |= pad[dy : dy + seen.shape[0], dx : dx + seen.shape[1]]
        tiles = np.zeros(seen.shape, np.int32)
        # slots numbered as int32 (a cell's index is slot · TILE² + its place in the tile)
        if (int(seen.sum()) + 1) * TILE * TILE >= 2**31:
            raise ValueError(f"an evidence grid of {int(seen.sum())} tiles of {TILE} × {TILE} cells is too large to hold")
        tiles[seen] = np.arange(1, int(seen.sum()) + 1)
        return cls(shape, tiles)
