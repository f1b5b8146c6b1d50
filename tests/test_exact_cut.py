"""The exact α-cut (Extension principle) against its plain definition on random maps with many holes.

``alpha_cut(α, "exact")`` buffers each principal polygon and hole alone and assembles the free
space from them; here the result is compared with GEOS buffering the whole crisp map (one
distance), or with the crisp map minus and plus the band of whole-multilinestring edge buffers
(several distances, asymmetric functions). The maps are made to catch a wrong decomposition:
holes closer than 2·TME (their grown offsets overlap), holes touching each other and the principal
polygon's wall at a point, pieces of explored space inside holes (with holes of their own, and a
piece inside one of those) near enough for their grown offsets to overlap the outer region's.
"""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzybrep.brep import BRepMap, Ring
from fuzzybrep.fuzzy.exact import EXACT_QUAD_SEGS
from fuzzybrep.fuzzy.map import fuzzify
from fuzzybrep.fuzzy.membership import Triangular

#: area of the symmetric difference allowed, relative to the crisp map's area (rounding only)
SYMDIFF_TOL = 1e-9


def star(rng, cx: float, cy: float, rmin: float, rmax: float, nmax: int = 9) -> shapely.Polygon:
    n = int(rng.integers(3, nmax + 1))
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = rng.uniform(rmin, rmax, n)
    return shapely.Polygon(np.column_stack((cx + r * np.cos(ang), cy + r * np.sin(ang))))


def diamond(x: float, y: float, rx: float, ry: float) -> shapely.Polygon:
    """A diamond whose bottom vertex is exactly (x, y): another one can stand on its top vertex."""
    return shapely.Polygon([(x, y), (x + rx, y + ry), (x, y + 2 * ry), (x - rx, y + ry)])


def floor(seed: int, n_holes: int, touching: bool, nested: bool) -> BRepMap:
    """A 12 × 8 floor: jagged walls but for a straight stretch of the bottom wall (y = 0, 3 ≤ x ≤ 9),
    recesses, ``n_holes`` star obstacles packed close; with ``touching`` diamonds meeting each
    other at a vertex and the bottom wall at a point; with ``nested`` a 3 × 3 hole holding a piece
    of explored space with holes, one of which holds a piece in turn."""
    rng = np.random.default_rng(seed)
    walls = [np.array([(0.0, 0.0), (3.0, 0.0), (9.0, 0.0)])]
    for p, q in [((12.0, 0.0), (12.0, 8.0)), ((12.0, 8.0), (0.0, 8.0)), ((0.0, 8.0), (0.0, 0.0))]:
        p, q = np.array(p), np.array(q)
        t = np.sort(rng.uniform(0.02, 0.98, int(rng.integers(3, 30))))
        normal = np.array([-(q - p)[1], (q - p)[0]]) / np.hypot(*(q - p))
        walls.append(np.vstack((p, p + t[:, None] * (q - p) + rng.uniform(-0.05, 0.05, (len(t), 1)) * normal)))
    shell = shapely.Polygon(np.vstack(walls))
    recesses = [shapely.box(x, 7.8, x + rng.uniform(0.1, 0.8), 8 + rng.uniform(0.2, 1.5))
                for x in rng.uniform(0.5, 11, int(rng.integers(0, 5)))]
    shell = shapely.union_all([shell, *recesses])
    if shell.geom_type != "Polygon":
        shell = max(shapely.get_parts(shell), key=lambda g: g.area)
    holes: list[shapely.Polygon] = []
    pieces: list[shapely.Polygon] = []

    def fits(h, within, gap: float = 0.0) -> bool:
        if not h.is_valid or not h.within(within):
            return False
        tree = shapely.STRtree(holes) if holes else None
        return tree is None or not tree.query(h, predicate="dwithin", distance=gap).size

    if nested:  # a big hole with a piece inside: a piece that has holes, one holding a piece
        gap = float(rng.uniform(0.02, 0.4))
        big = shapely.box(7.5, 3.5, 10.5, 6.5)
        inner = shapely.box(7.5 + gap, 3.5 + gap, 10.5 - gap, 6.5 - gap)
        h1 = shapely.box(8.0, 4.0, 9.0, 6.0)
        h2 = star(rng, 9.7, 5.0, 0.1, 0.3 - gap / 2)
        while not h2.is_valid:  # angles apart by more than π can make it cross itself
            h2 = star(rng, 9.7, 5.0, 0.1, 0.3 - gap / 2)
        island = shapely.box(8.0 + gap, 4.0 + gap, 9.0 - gap, 6.0 - gap)
        holes.append(big)
        pieces += [shapely.Polygon(inner.exterior, [h1.exterior, h2.exterior]), island]
    if touching:  # a chain of diamonds meeting at vertices, the first on the straight wall
        chain = [diamond(float(rng.uniform(4, 6)), 0.0, *rng.uniform((0.1, 0.1), (0.4, 0.5)))]
        for _ in range(int(rng.integers(1, 4))):
            x, y = chain[-1].exterior.coords[2]
            chain.append(diamond(x, y, *rng.uniform((0.1, 0.1), (0.4, 0.4))))
        x, y = chain[0].exterior.coords[1]  # and one lying to the right of the first
        rx, ry = rng.uniform(0.1, 0.3, 2)
        chain.append(shapely.Polygon([(x, y), (x + rx, y - ry), (x + 2 * rx, y), (x + rx, y + ry)]))
        holes += [h for h in chain if h.within(shell)]
    for _ in range(4 * n_holes):
        if len(holes) >= n_holes:
            break
        h = star(rng, *rng.uniform((0.5, 0.5), (11.5, 7.5)), 0.05, float(rng.uniform(0.1, 0.7)))
        if fits(h, shell, float(rng.uniform(0.005, 0.1))):
            holes.append(h)
    free = shapely.Polygon(shell.exterior, [h.exterior for h in holes])
    assert free.is_valid, shapely.is_valid_reason(free)
    return BRepMap.from_shapely(shapely.MultiPolygon([free, *pieces]) if pieces else free)


def with_fm(m: BRepMap, rng, k: int) -> BRepMap:
    """Random FM indices 1..k, per vertex."""
    return m.with_rings([Ring(r.vertices, r.kinds, rng.integers(1, k + 1, len(r))) for r in m.rings])


def plain_cut(fz, alpha: float) -> tuple:
    """The exact cut by its definition, without the ring-by-ring decomposition: the crisp map
    buffered whole by ∓d (one symmetric distance), else minus and plus the band of every edge
    (split at its middle where its ends differ), d_in into its own ring and d_out out of it."""
    crisp = fz.crisp_geometry
    d = {k: (float(fz.table[k].d_in(alpha)), float(fz.table[k].d_out(alpha))) for k in fz.table.indices}
    d = {k: tuple(0.0 if x <= fz.rounding else x for x in v) for k, v in d.items()}
    segs, fms, rings = [], [], []
    for i, ring in enumerate(fz.crisp.rings):
        v, fm = ring.vertices, ring.fm
        w, fw = np.roll(v, -1, axis=0), np.roll(fm, -1)
        mid = (v + w) / 2
        same = fm == fw
        segs += [np.stack((v, w), 1)[same], np.stack((v, mid), 1)[~same], np.stack((mid, w), 1)[~same]]
        fms += [fm[same], fm[~same], fw[~same]]
        rings += [np.full(len(v) + (~same).sum(), i)]
    segs, fms, rings = np.concatenate(segs), np.concatenate(fms), np.concatenate(rings)
    used = {int(k) for k in np.unique(fms)}
    dist = {d[k] for k in used if d[k][0] == d[k][1]}
    if all(d[k][0] == d[k][1] for k in used) and len(dist) == 1:
        r = dist.pop()[0]
        if r == 0:
            return crisp, crisp
        return (shapely.buffer(crisp, -r, quad_segs=EXACT_QUAD_SEGS),
                shapely.buffer(crisp, r, quad_segs=EXACT_QUAD_SEGS))
    band = []
    for k in used:
        sel = fms == k
        d_in, d_out = d[k]
        lo, hi = min(d_in, d_out), max(d_in, d_out)
        if lo > 0:
            band.append(shapely.buffer(shapely.multilinestrings(shapely.linestrings(segs[sel])), lo,
                                       quad_segs=EXACT_QUAD_SEGS))
        if hi > lo:
            for i in np.unique(rings[sel]):
                own = shapely.Polygon(fz.crisp.rings[i].vertices)
                wide = shapely.buffer(shapely.multilinestrings(shapely.linestrings(segs[sel & (rings == i)])), hi,
                                      quad_segs=EXACT_QUAD_SEGS)
                band.append(shapely.intersection(wide, own) if d_in > d_out else shapely.difference(wide, own))
    if not band:
        return crisp, crisp
    band = shapely.union_all(band)
    return shapely.difference(crisp, band), shapely.union(crisp, band)


def symdiff_area(a, b) -> float:
    return float(shapely.area(shapely.symmetric_difference(a, b)))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_holes=st.integers(0, 40), touching=st.booleans(), nested=st.booleans(),
       tables=st.sampled_from(["one", "one, three FM indices", "two TMEs", "asymmetric", "asymmetric and two TMEs"]),
       tme=st.floats(0.02, 0.6), alpha=st.one_of(st.just(0.0), st.floats(0.0, 0.95)))
def test_exact_cut_is_the_plain_buffer(seed, n_holes, touching, nested, tables, tme, alpha):
    rng = np.random.default_rng(seed)
    m = floor(seed, n_holes, touching, nested)
    other = float(rng.uniform(0.02, 0.6))
    table = {"one": {1: Triangular(tme)},
             "one, three FM indices": {1: Triangular(tme), 2: Triangular(tme), 3: Triangular(tme)},
             "two TMEs": {1: Triangular(tme), 2: Triangular(other)},
             "asymmetric": {1: Triangular(tme_in=tme, tme_out=other)},
             "asymmetric and two TMEs": {1: Triangular(tme_in=tme, tme_out=other), 2: Triangular(2 * other)}}[tables]
    fz = fuzzify(with_fm(m, rng, len(table)), table)
    cut = fz.alpha_cut(alpha, "exact")
    inner, outer = plain_cut(fz, alpha)
    tol = SYMDIFF_TOL * fz.crisp_geometry.area
    for new, old in ((cut.inner, inner), (cut.outer, outer)):
        assert new.geom_type in ("Polygon", "MultiPolygon") and new.is_valid, shapely.is_valid_reason(new)
        assert symdiff_area(new, old) <= tol, (symdiff_area(new, old), tol)


def test_the_test_maps_have_what_they_are_made_for():
    """Touching holes, pieces in holes, holes closer than twice the TME: else the test above
    would not exercise the decomposition."""
    m = floor(3, 40, touching=True, nested=True)
    g = m.to_shapely()
    assert g.is_valid and len(m.regions) == 3 and len(m.regions[0].holes) >= 30
    holes = np.array([shapely.Polygon(h.vertices) for h in m.regions[0].holes])
    tree = shapely.STRtree(holes)
    a, b = tree.query(holes, predicate="touches")
    assert (a != b).any()  # holes meeting at a point
    assert shapely.touches(shapely.Polygon(m.principal.vertices).exterior, holes).any()  # a hole on the wall
    a, b = tree.query(holes, predicate="dwithin", distance=0.2)
    assert (a != b).sum() > 10  # grown by 0.1 they overlap
