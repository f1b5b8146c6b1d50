"""A 2-D pose graph solved by sparse Gauss-Newton: the loop closure of ``registration.align_scans``.

Nodes are poses x_k = (x, y, θ); an edge (i, j, z, Ω) says that pose j seen from pose i is z
(3,), with information Ω (3, 3, in i's frame). The solution minimises Σ ρ(eᵀ Ω e) over the
edges, e = (R_iᵀ (t_j − t_i) − z_xy, wrap(θ_j − θ_i − z_θ)), with the first pose held where it is
(the map's frame). ρ is the identity on ordinary edges and Cauchy's kernel on ``robust`` ones (a
loop closure that matched the wrong corridor is outvoted rather than obeyed), by iteratively
reweighted least squares. Each Gauss-Newton step is one sparse solve (SciPy's SuperLU) of the
normal equations, whose matrix is block tri-diagonal plus the loop blocks: a few milliseconds for
thousands of poses.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..scans.scan import wrap

#: Cauchy kernel scale on robust edges, in units of the whitened error (χ with 3 dof)
ROBUST_SCALE = 3.0


def residuals(poses: np.ndarray, i: np.ndarray, j: np.ndarray, z: np.ndarray) -> np.ndarray:
    """(E, 3) errors e of the edges at ``poses`` (module docstring)."""
    pi, pj = poses[i], poses[j]
    c, s = np.cos(pi[:, 2]), np.sin(pi[:, 2])
    d = pj[:, :2] - pi[:, :2]
    return np.column_stack((c * d[:, 0] + s * d[:, 1] - z[:, 0], -s * d[:, 0] + c * d[:, 1] - z[:, 1],
                            wrap(pj[:, 2] - pi[:, 2] - z[:, 2])))


def cost(poses: np.ndarray, i, j, z, info, robust=None) -> float:
    """Σ ρ(eᵀ Ω e): what ``solve`` minimises."""
    e = residuals(np.asarray(poses, np.float64), np.asarray(i), np.asarray(j), np.asarray(z, np.float64))
    s2 = np.einsum("ea,eab,eb->e", e, info, e)
    if robust is not None and np.any(robust):
        r = np.asarray(robust, bool)
        s2 = np.where(r, ROBUST_SCALE ** 2 * np.log1p(s2 / ROBUST_SCALE ** 2), s2)
    return float(s2.sum())


def solve(poses: np.ndarray, i: np.ndarray, j: np.ndarray, z: np.ndarray, info: np.ndarray,
          robust: np.ndarray | None = None, iterations: int = 10, tolerance: float = 1e-4, plain: int = 3) -> np.ndarray:
    """The poses (N, 3) that best agree with the edges, from ``poses`` (N, 3) as the start; pose 0
    fixed. i, j (E,) node indices; z (E, 3); info (E, 3, 3); robust (E,) bool or None.

    The first ``plain`` iterations weigh every edge fully: from a start whose drift a loop closure
    has not corrected yet, the true loop edge is many standard deviations off, and a robust kernel
    from the start would discard it as an outlier. Once the loops have pulled the trajectory
    together, an edge that still disagrees is one (module docstring)."""
    x = np.array(poses, np.float64).reshape(-1, 3)
    i, j = np.asarray(i, np.int64).reshape(-1), np.asarray(j, np.int64).reshape(-1)
    z = np.asarray(z, np.float64).reshape(-1, 3)
    info = np.asarray(info, np.float64).reshape(-1, 3, 3)
    n, m = len(x), len(i)
    if m == 0 or n < 2:
        return x
    if i.min() < 0 or j.min() < 0 or max(i.max(), j.max()) >= n:
        raise ValueError(f"an edge names a pose outside 0..{n - 1}")
    robust = np.zeros(m, bool) if robust is None else np.asarray(robust, bool).reshape(-1)
    # every edge's four 3 × 3 blocks of the normal equations (i i, i j, j i, j j) and their places,
    # pose 0 held (its rows and columns dropped, the others shifted by one pose)
    bi = np.broadcast_to((3 * (i - 1))[:, None, None] + np.arange(3)[:, None], (m, 3, 3))
    bj = np.broadcast_to((3 * (j - 1))[:, None, None] + np.arange(3)[:, None], (m, 3, 3))
    rows = np.concatenate([r.ravel() for r in (bi, bi, bj, bj)])
    cols = np.concatenate([np.swapaxes(c, 1, 2).ravel() for c in (bi, bj, bi, bj)])
    keep = (rows >= 0) & (cols >= 0)
    # and the tiny damping on the diagonal: a pose no edge reaches has an empty block
    size = 3 * (n - 1)
    rows, cols = np.concatenate((rows[keep], np.arange(size))), np.concatenate((cols[keep], np.arange(size)))
    # the matrix's pattern is the same at every iteration: each entry's place in the CSC arrays
    # (sorted by column, then row) is worked out once, and each iteration's values are summed
    # into place by one bincount instead of a sparse matrix made and summed from triplets
    order = np.lexsort((rows, cols))
    rc = cols[order] * size + rows[order]
    first = np.r_[True, rc[1:] != rc[:-1]]
    slot = np.empty(len(rows), np.int64)
    slot[order] = np.cumsum(first) - 1
    indices = rows[order][first].astype(np.int32)
    indptr = np.searchsorted(cols[order][first], np.arange(size + 1)).astype(np.int32)
    nnz = len(indices)
    damping = np.full(size, 1e-9)
    for it in range(iterations):
        e = residuals(x, i, j, z)
        pi, pj = x[i], x[j]
        c, s = np.cos(pi[:, 2]), np.sin(pi[:, 2])
        d = pj[:, :2] - pi[:, :2]
        # Jacobians (E, 3, 3) of e with respect to pose i and pose j
        Ji = np.zeros((m, 3, 3))
        Ji[:, 0, 0], Ji[:, 0, 1] = -c, -s
        Ji[:, 1, 0], Ji[:, 1, 1] = s, -c
        Ji[:, 0, 2] = -s * d[:, 0] + c * d[:, 1]
        Ji[:, 1, 2] = -c * d[:, 0] - s * d[:, 1]
        Ji[:, 2, 2] = -1.0
        Jj = np.zeros((m, 3, 3))
        Jj[:, 0, 0], Jj[:, 0, 1] = c, s
        Jj[:, 1, 0], Jj[:, 1, 1] = -s, c
        Jj[:, 2, 2] = 1.0
        W = info
        if robust.any() and it >= plain:
            s2 = np.einsum("ea,eab,eb->e", e, info, e)
            W = info * np.where(robust, 1.0 / (1.0 + s2 / ROBUST_SCALE ** 2), 1.0)[:, None, None]
        # JᵀWJ and JᵀWe edge by edge, summed into their places
        WJi, WJj = W @ Ji, W @ Jj
        Jit, Jjt = np.swapaxes(Ji, 1, 2), np.swapaxes(Jj, 1, 2)
        blocks = np.concatenate([(Jit @ WJi).ravel(), (Jit @ WJj).ravel(), (Jjt @ WJi).ravel(), (Jjt @ WJj).ravel()])
        H = sp.csc_matrix((np.bincount(slot, np.concatenate((blocks[keep], damping)), minlength=nnz), indices, indptr),
                          shape=(size, size))
        We = np.einsum("eab,eb->ea", W, e)
        gi, gj = np.einsum("eba,eb->ea", Ji, We), np.einsum("eba,eb->ea", Jj, We)
        g = np.bincount(np.concatenate((bi[:, :, 0].ravel(), bj[:, :, 0].ravel())) + 3,
                        np.concatenate((gi.ravel(), gj.ravel())), minlength=3 * n)[3:]
        # symmetric positive definite: the fill-reducing order for AᵀA + A, the diagonal as pivots
        dx = -splu(H, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}).solve(g)
        if not np.isfinite(dx).all():
            break
        x[1:] += dx.reshape(-1, 3)
        x[:, 2] = wrap(x[:, 2])
        if np.abs(dx).max() < tolerance and (it >= plain or not robust.any()):
            break
    return x
