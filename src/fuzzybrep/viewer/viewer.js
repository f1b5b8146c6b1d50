/* fuzzybrep viewer: a fuzzy B-rep map and its α-cuts on a canvas. No library, no network.
 *
 * α-cuts are read from the parametric lines in O(n) (thesis 4.1.2): the offset of vertex i at
 * inward distance d is X − T·d/SI, at outward distance d it is X + T·d/SI (t = 1 ∓ d/SI on the
 * line x = U + T·t). They are drawn as regions, not as offset rings: the inner α-cut is the crisp
 * free space minus the convex hulls of the free-side bands (crisp edge to α-cut edge), the outer
 * one the crisp free space plus the hulls of the other bands. That is the proper polygon of
 * docs/fuzzy.md, so self-intersecting offsets need no special case. Every hull is wound the same
 * way, so one nonzero fill paints their union.
 *
 * The safe sweep (the default, D.method "safe"; fuzzy/safe_sweep.py) is drawn the same way: the
 * inner α-cut is the crisp free space minus every free-side piece, the outer one plus every other
 * piece, where a piece is an edge's rectangle of height d(α), or the fan that circumscribes the
 * arc of radius d(α) at a corner's outer side (tangent segments of at most 60°), or, with several
 * or sided functions, every edge's circumscribed stadium. Each piece is a convex polygon whose
 * corners are crisp vertices moved d(α) along directions computed once from the vertices.
 *
 * μ under the cursor: the method's μ (largest α whose band hull or piece still holds the point,
 * with the side rules of FuzzyBRepMap.membership) and the exact μ (membership function of the
 * signed distance to the nearest crisp edge), both from a grid index of the edges. docs/viewer.md.
 */
(function () {
  "use strict";

  const D = JSON.parse(document.getElementById("fuzzybrep-data").textContent);
  const css = getComputedStyle(document.documentElement);
  const colour = (name) => css.getPropertyValue("--" + name).trim();
  const C = {
    free: colour("free"), support: colour("support"), band: colour("band"), outside: colour("outside"),
    obstacle: colour("obstacle"), frontier: colour("frontier"), pose: colour("pose"), path: colour("path"),
  };

  // ------------------------------------------------------------------------- the payload
  const q = D.q, qt = D.q / 10, unit = D.unit;
  const sizes = D.rings.size, nRings = sizes.length;
  const N = D.x.length;
  const X = new Float64Array(N), Y = new Float64Array(N), T = new Float64Array(N), V = new Float64Array(N);
  const ringStart = new Int32Array(nRings), ringOf = new Int32Array(N), next = new Int32Array(N);
  const shellRing = Uint8Array.from(D.rings.shell), regionOfRing = Int32Array.from(D.rings.region);
  const nRegions = regionOfRing.length ? regionOfRing[nRings - 1] + 1 : 0;
  {
    let k = 0;
    for (let r = 0; r < nRings; r++) {
      ringStart[r] = k;
      let ax = 0, ay = 0;
      for (let i = 0; i < sizes[r]; i++, k++) {
        ax += D.x[k]; ay += D.y[k];
        X[k] = ax * q; Y[k] = ay * q;
        T[k] = D.t[k] * qt; V[k] = D.v[k] * qt;
        ringOf[k] = r;
        next[k] = i + 1 < sizes[r] ? k + 1 : ringStart[r];
      }
    }
  }
  const frontierEdge = new Uint8Array(N);
  for (let i = 0; i < N; i++) frontierEdge[i] = D.kind.charCodeAt(i) === 49 ? 1 : 0; // "1"

  // membership functions (Table 4.2): d_in(α), d_out(α) sampled at α = k/K
  const K = D.levels;
  const fns = D.functions;
  const slotOf = new Map(fns.map((f, s) => [f.index, s]));
  const slot = new Int32Array(N);
  for (let i = 0; i < N; i++) slot[i] = slotOf.get(typeof D.fm === "number" ? D.fm : D.fm[i]);
  const SI = new Float64Array(N), reachV = new Float64Array(N);
  for (let i = 0; i < N; i++) {
    const f = fns[slot[i]];
    SI[i] = f.support_in;
    reachV[i] = Math.max(f.support_in, f.support_out);
  }

  // ------------------------------------------------------------------------- the safe sweep's pieces
  const METHOD = D.method || "thesis"; // pages written before the safe sweep drew the thesis's
  const SAFE = METHOD === "safe";
  const uniform = !!(D.safe && D.safe.uniform);
  const prev = new Int32Array(N);
  for (let i = 0; i < N; i++) prev[next[i]] = i;
  const orient = new Float64Array(nRings); // +1: the ring runs counter-clockwise
  for (let r = 0; r < nRings; r++) {
    let a2 = 0;
    for (let i = ringStart[r]; i < ringStart[r] + sizes[r]; i++) a2 += X[i] * Y[next[i]] - X[next[i]] * Y[i];
    orient[r] = a2 >= 0 ? 1 : -1;
  }
  /* Piece k: corners pBase[c] + d·(pUx[c], pUy[c]) for c in [pStart[k], pStart[k + 1]), counter-
     clockwise; pSide +1 on the IN side of its edge's ring, −1 OUT, 0 both (stadiums and spike
     discs); pEdge: the edge (or, for a fan, the edge its corner starts) the index finds it by. */
  const pBase = [], pUx = [], pUy = [], pStart = [0], pSide = [], pEdge = [], pFree = [], pObst = [];
  function addPiece(corners, side, edge, free, obst) {
    // a corner it cannot compute (NaN) would end the path's text at "NaN", and the browser drops
    // the rest of the path without a word: such a piece is left out
    if (!corners.every(([, ux, uy]) => Number.isFinite(ux) && Number.isFinite(uy))) return;
    let a2 = 0;
    for (let c = 0; c < corners.length; c++) {
      const [b, ux, uy] = corners[c], [b2, vx, vy] = corners[(c + 1) % corners.length];
      a2 += (X[b] + ux) * (Y[b2] + vy) - (X[b2] + vx) * (Y[b] + uy);
    }
    if (a2 < 0) corners.reverse();
    for (const [b, ux, uy] of corners) { pBase.push(b); pUx.push(ux); pUy.push(uy); }
    pStart.push(pBase.length); pSide.push(side); pEdge.push(edge); pFree.push(free); pObst.push(obst);
  }
  const rot = (ux, uy, a, k) => [k * (Math.cos(a) * ux - Math.sin(a) * uy), k * (Math.sin(a) * ux + Math.cos(a) * uy)];
  if (SAFE) {
    const capK = 1 / Math.cos(Math.PI / 8);
    for (let i = 0; i < N; i++) {
      const j = next[i], r = ringOf[i], o = orient[r], shell = shellRing[r] === 1;
      let tx = X[j] - X[i], ty = Y[j] - Y[i];
      const len = Math.hypot(tx, ty);
      // an edge the millimetre rounding made a point (maps keep edges of 1 mm and more, which a
      // diagonal can still round away) has no direction: it is skipped, and the corner after it
      // turns from the edge before it
      if (!(len > 0)) continue;
      tx /= len; ty /= len;
      let p = prev[i];
      while (p !== i && X[p] === X[i] && Y[p] === Y[i]) p = prev[p];
      if (!uniform) { // the edge's stadium: caps of 4 tangent segments at b and at a
        const corners = [];
        for (let q = 0; q < 4; q++) {
          const ang = (q + 0.5) * Math.PI / 4, c = Math.cos(ang) * capK, sn = Math.sin(ang) * capK;
          corners.push([j, ty * c + tx * sn, -tx * c + ty * sn]);
        }
        for (let q = 0; q < 4; q++) {
          const ang = (q + 0.5) * Math.PI / 4, c = Math.cos(ang) * capK, sn = Math.sin(ang) * capK;
          corners.push([i, -ty * c - tx * sn, tx * c - ty * sn]);
        }
        addPiece(corners, 0, i, true, true);
        continue;
      }
      for (const side of [1, -1]) { // the edge's rectangle on each side
        const mx = -side * o * ty, my = side * o * tx;
        addPiece([[i, 0, 0], [j, 0, 0], [j, mx, my], [i, mx, my]], side, i, (side > 0) === shell, (side > 0) !== shell);
      }
      let ex = X[i] - X[p], ey = Y[i] - Y[p];
      const le = Math.hypot(ex, ey); ex /= le; ey /= le;
      const cr = ex * ty - ey * tx, dt = ex * tx + ey * ty, psi = Math.atan2(cr, dt);
      if (Math.abs(cr) <= 1e-12 && dt < 0) { // a spike: a disc round it, on both sides
        const corners = [];
        for (let q = 0; q < 8; q++) {
          const ang = (q + 0.5) * Math.PI / 4;
          corners.push([i, Math.cos(ang) * capK, Math.sin(ang) * capK]);
        }
        addPiece(corners, 0, i, true, true);
        continue;
      }
      for (const side of [1, -1]) { // the fan on the outer side of the turn
        if (!(side * o * psi < 0)) continue;
        const mex = -side * o * ey, mey = side * o * ex;
        // as safe_sweep.fan_pieces: 1 up to 60°, then an even number of at most 60° each
        const a = Math.abs(psi), P = Math.PI / 3;
        const k = a <= P * (1 + 1e-9) ? 1 : 2 * Math.ceil(a / (2 * P) - 1e-9), half = psi / (2 * k);
        const corners = [[i, 0, 0], [i, mex, mey]];
        for (let q = 0; q < k; q++) corners.push([i, ...rot(mex, mey, (2 * q + 1) * half, 1 / Math.cos(half))]);
        corners.push([i, ...rot(mex, mey, psi, 1)]);
        addPiece(corners, side, i, (side > 0) === shell, (side > 0) !== shell);
      }
    }
  }
  const nPieces = pSide.length;
  const piecesOfEdge = Array.from({ length: N }, () => []);
  for (let k = 0; k < nPieces; k++) piecesOfEdge[pEdge[k]].push(k);

  function sample(tab, a) {
    const p = a * K;
    let k = Math.floor(p + 1e-9);
    if (k >= K) return tab[K];
    if (k < 0) return tab[0];
    const f = Math.max(0, p - k);
    return f < 1e-9 ? tab[k] : tab[k] + (tab[k + 1] - tab[k]) * f;
  }

  /* μ of a function at distance |x| on one side: the largest α with d(α) ≥ |x| (d does not grow
     with α), interpolated between samples. */
  function muOf(tab, ax) {
    if (!(ax <= tab[0])) return 0;
    let lo = 0, hi = K; // tab[lo] ≥ ax; find the last such k
    if (tab[K] >= ax) return 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (tab[mid] >= ax) lo = mid; else hi = mid;
    }
    const span = tab[lo] - tab[hi];
    return (lo + (span > 0 ? (tab[lo] - ax) / span : 0)) / K;
  }

  /* The distance piece k's corners move at α: its side's d(α) of its function (one for the whole
     map), or for a stadium the largest d_in(α), d_out(α) of its edge's two vertices. */
  function pieceDistance(k, a) {
    const i = pEdge[k];
    if (!uniform) {
      const fi = fns[slot[i]], fj = fns[slot[next[i]]];
      return Math.max(sample(fi.d_in, a), sample(fi.d_out, a), sample(fj.d_in, a), sample(fj.d_out, a));
    }
    const f = fns[slot[i]];
    return pSide[k] > 0 ? sample(f.d_in, a) : sample(f.d_out, a);
  }

  function pieceCorners(k, d) {
    const out = [];
    for (let c = pStart[k]; c < pStart[k + 1]; c++) out.push(X[pBase[c]] + d * pUx[c], Y[pBase[c]] + d * pUy[c]);
    return out;
  }

  /* Pieces at α, as Path2D (free side, obstacle side) and, when asked, as coordinate lists. */
  function safeHulls(a, lists) {
    const free = [], obst = [];
    const out = lists ? { free: [], obstacle: [] } : null;
    for (let k = 0; k < nPieces; k++) {
      const d = pieceDistance(k, a);
      if (!(d > 0)) continue;
      const c = pieceCorners(k, d);
      let txt = "M";
      for (let m = 0; m < c.length; m += 2) txt += (m ? "L" : "") + text(c[m], c[m + 1]);
      txt += "Z";
      if (pFree[k]) { free.push(txt); if (out) out.free.push(c); }
      if (pObst[k]) { obst.push(txt); if (out) out.obstacle.push(c); }
    }
    return { free: new Path2D(free.join("")), obst: new Path2D(obst.join("")), lists: out };
  }

  /* Whether (x, y) lies in the convex counter-clockwise polygon c (x0, y0, x1, y1, …). */
  function inConvex(c, x, y) {
    let size = 0;
    for (let m = 2; m < c.length; m += 2) size = Math.max(size, Math.abs(c[m] - c[0]), Math.abs(c[m + 1] - c[1]));
    const tol = 1e-12 * size * size;
    for (let m = 0; m < c.length; m += 2) {
      const n = (m + 2) % c.length;
      if (cross(c[m], c[m + 1], c[n], c[n + 1], x, y) < -tol) return false;
    }
    return true;
  }

  /* Largest α at which piece k still holds (x, y) (NaN if not even at α = 0): pieces shrink as
     α grows, so bisection finds it. */
  function pieceLevel(k, x, y) {
    if (!(pieceDistance(k, 0) > 0) || !inConvex(pieceCorners(k, pieceDistance(k, 0)), x, y)) return NaN;
    let lo = 0, hi = 1;
    for (let it = 0; it < 40; it++) {
      const mid = 0.5 * (lo + hi), d = pieceDistance(k, mid);
      if (d > 0 && inConvex(pieceCorners(k, d), x, y)) lo = mid; else hi = mid;
    }
    return lo;
  }

  // ------------------------------------------------------------------------- α-cuts
  /* The corners of edge i's band on one side at α: crisp ends c0, c1 and offsets p1, p0.
     side +1: IN of the edge's own ring, −1: OUT. */
  function bandCorners(i, side, a, out) {
    const j = next[i];
    const fi = fns[slot[i]], fj = fns[slot[j]];
    const si = side > 0 ? -sample(fi.d_in, a) / SI[i] : sample(fi.d_out, a) / SI[i];
    const sj = side > 0 ? -sample(fj.d_in, a) / SI[j] : sample(fj.d_out, a) / SI[j];
    out[0] = X[i]; out[1] = Y[i];
    out[2] = X[j]; out[3] = Y[j];
    out[4] = X[j] + T[j] * sj; out[5] = Y[j] + V[j] * sj;
    out[6] = X[i] + T[i] * si; out[7] = Y[i] + V[i] * si;
    return si !== 0 || sj !== 0;
  }

  const cross = (ax, ay, bx, by, cx, cy) => (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);

  /* The convex hull of four points (x0,y0,…,x3,y3) as corner indices, counter-clockwise. A band
     that does not fold is its own convex quadrilateral: most take one of the first two branches. */
  const CCW = [0, 1, 2, 3], CW = [3, 2, 1, 0];
  function hull4(c) {
    const t0 = cross(c[0], c[1], c[2], c[3], c[4], c[5]), t1 = cross(c[2], c[3], c[4], c[5], c[6], c[7]);
    const t2 = cross(c[4], c[5], c[6], c[7], c[0], c[1]), t3 = cross(c[6], c[7], c[0], c[1], c[2], c[3]);
    if (t0 >= 0 && t1 >= 0 && t2 >= 0 && t3 >= 0) return CCW;
    if (t0 <= 0 && t1 <= 0 && t2 <= 0 && t3 <= 0) return CW;
    const idx = [0, 1, 2, 3].sort((a, b) => c[2 * a] - c[2 * b] || c[2 * a + 1] - c[2 * b + 1]);
    const chain = (order) => {
      const h = [];
      for (const k of order) {
        while (h.length >= 2 && cross(c[2 * h[h.length - 2]], c[2 * h[h.length - 2] + 1], c[2 * h[h.length - 1]],
          c[2 * h[h.length - 1] + 1], c[2 * k], c[2 * k + 1]) <= 0) h.pop();
        h.push(k);
      }
      return h;
    };
    const lower = chain(idx), upper = chain(idx.slice().reverse());
    return lower.slice(0, -1).concat(upper.slice(0, -1));
  }

  /* Band hulls at α, as Path2D (free side, obstacle side) and, when asked, as coordinate lists.
     The paths are built from SVG path text in integer units of q/10 (PU per map unit): Chromium
     builds a Path2D of n subpaths op by op in O(n²), from text in O(n). Every vertex's two offset
     points are read from its line once; each band then joins four ready-made coordinate texts. */
  const PU = 1 / qt;
  const text = (x, y) => Math.round(x * PU) + " " + Math.round(y * PU);
  const crispText = Array.from({ length: N }, (_, i) => text(X[i], Y[i]));
  function bandHulls(a, lists) {
    const dIn = fns.map((f) => sample(f.d_in, a)), dOut = fns.map((f) => sample(f.d_out, a));
    // side +1: IN of the vertex's own ring, X − T·d_in/SI; side −1: OUT, X + T·d_out/SI
    const off = [null, null];
    for (const side of [1, -1]) {
      const ox = new Float64Array(N), oy = new Float64Array(N), txt = new Array(N), moved = new Uint8Array(N);
      for (let i = 0; i < N; i++) {
        const s = side > 0 ? -dIn[slot[i]] / SI[i] : dOut[slot[i]] / SI[i];
        ox[i] = X[i] + T[i] * s; oy[i] = Y[i] + V[i] * s;
        if (!Number.isFinite(ox[i]) || !Number.isFinite(oy[i])) { ox[i] = X[i]; oy[i] = Y[i]; } // never "NaN" in a path
        txt[i] = text(ox[i], oy[i]);
        moved[i] = s !== 0;
      }
      off[(1 - side) / 2] = { ox, oy, txt, moved };
    }
    const free = [], obst = [];
    const out = lists ? { free: [], obstacle: [] } : null;
    const c = new Float64Array(8);
    for (let i = 0; i < N; i++) {
      const j = next[i], shell = shellRing[ringOf[i]] === 1;
      for (let side = 1; side >= -1; side -= 2) {
        const o = off[(1 - side) / 2];
        if (!o.moved[i] && !o.moved[j]) continue;
        c[0] = X[i]; c[1] = Y[i]; c[2] = X[j]; c[3] = Y[j];
        c[4] = o.ox[j]; c[5] = o.oy[j]; c[6] = o.ox[i]; c[7] = o.oy[i];
        const h = hull4(c);
        if (h.length < 3) continue;
        let d;
        if (h === CCW) d = "M" + crispText[i] + "L" + crispText[j] + "L" + o.txt[j] + "L" + o.txt[i] + "Z";
        else if (h === CW) d = "M" + o.txt[i] + "L" + o.txt[j] + "L" + crispText[j] + "L" + crispText[i] + "Z";
        else d = "M" + h.map((k) => text(c[2 * k], c[2 * k + 1])).join("L") + "Z";
        const freeSide = (side > 0) === shell;
        (freeSide ? free : obst).push(d);
        if (out) (freeSide ? out.free : out.obstacle).push(h.flatMap((k) => [c[2 * k], c[2 * k + 1]]));
      }
    }
    return { free: new Path2D(free.join("")), obst: new Path2D(obst.join("")), lists: out };
  }

  /* Hulls per α, most recently used last; the support (α = 0) is drawn under every α-cut and is
     kept apart. A Path2D of a 20k-vertex map holds a few MB, hence the small cache. */
  const cutHulls = (a, lists) => (SAFE ? safeHulls(a, lists) : bandHulls(a, lists));
  const support = cutHulls(0, false);
  const cache = new Map();
  function hullsAt(a) {
    if (a === 0) return support;
    const key = a.toFixed(6);
    let h = cache.get(key);
    if (h) { cache.delete(key); cache.set(key, h); return h; }
    h = cutHulls(a, false);
    cache.set(key, h);
    if (cache.size > 12) cache.delete(cache.keys().next().value);
    return h;
  }

  // crisp map: free space (even-odd over all rings), edges by kind
  const pt = (i) => crispText[i];
  const crispPath = (function () {
    const d = [];
    for (let r = 0; r < nRings; r++) {
      const s = ringStart[r];
      let ring = "M" + pt(s);
      for (let i = s + 1; i < s + sizes[r]; i++) ring += "L" + pt(i);
      d.push(ring + "Z");
    }
    return new Path2D(d.join(""));
  })();
  const frontierPath = (function () {
    const d = [];
    for (let i = 0; i < N; i++) if (frontierEdge[i]) d.push("M" + pt(i) + "L" + pt(next[i]));
    return new Path2D(d.join(""));
  })();

  // poses and path
  const poses = [];
  if (D.poses) {
    let ax = 0, ay = 0;
    for (let k = 0; k < D.poses.x.length; k++) {
      ax += D.poses.x[k]; ay += D.poses.y[k];
      poses.push([ax * q, ay * q, D.poses.heading[k] / 1000]);
    }
  }
  const path = D.path ? D.path.x.map((x, k) => [x * q, D.path.y[k] * q]) : [];
  if (!poses.length) document.getElementById("legend-poses").hidden = true;
  if (!path.length) document.getElementById("legend-path").hidden = true;

  // ------------------------------------------------------------------------- grid index
  /* Every edge goes into the cells its box, grown by its reach (largest support of its two
     vertices), overlaps: a point's cell lists every edge whose bands or support can hold it. */
  let bx0 = Infinity, by0 = Infinity, bx1 = -Infinity, by1 = -Infinity, maxReach = 0;
  for (let i = 0; i < N; i++) {
    bx0 = Math.min(bx0, X[i]); bx1 = Math.max(bx1, X[i]);
    by0 = Math.min(by0, Y[i]); by1 = Math.max(by1, Y[i]);
    // the safe sweep's fans and stadium caps reach up to 1/cos(30°) of the support
    if (SAFE) reachV[i] /= Math.cos(Math.PI / 6);
    maxReach = Math.max(maxReach, reachV[i]);
  }
  const index = (function () {
    const gx0 = bx0 - maxReach, gy0 = by0 - maxReach;
    const w = bx1 - bx0 + 2 * maxReach, h = by1 - by0 + 2 * maxReach;
    const cell = Math.max(maxReach, 2 * Math.sqrt((w * h) / Math.max(N, 1)), 1e-12);
    const cols = Math.max(1, Math.ceil(w / cell)), rows = Math.max(1, Math.ceil(h / cell));
    const range = (i) => {
      const j = next[i], r = Math.max(reachV[i], reachV[j]);
      const cx = (v) => Math.min(cols - 1, Math.max(0, Math.floor((v - gx0) / cell)));
      const cy = (v) => Math.min(rows - 1, Math.max(0, Math.floor((v - gy0) / cell)));
      return [cx(Math.min(X[i], X[j]) - r), cx(Math.max(X[i], X[j]) + r), cy(Math.min(Y[i], Y[j]) - r),
        cy(Math.max(Y[i], Y[j]) + r)];
    };
    const start = new Int32Array(cols * rows + 1);
    for (let i = 0; i < N; i++) {
      const [c0, c1, r0, r1] = range(i);
      for (let r = r0; r <= r1; r++) for (let c = c0; c <= c1; c++) start[r * cols + c + 1]++;
    }
    for (let k = 0; k < cols * rows; k++) start[k + 1] += start[k];
    const fill = start.slice(0, cols * rows), items = new Int32Array(start[cols * rows]);
    for (let i = 0; i < N; i++) {
      const [c0, c1, r0, r1] = range(i);
      for (let r = r0; r <= r1; r++) for (let c = c0; c <= c1; c++) items[fill[r * cols + c]++] = i;
    }
    return {
      near(x, y) {
        const c = Math.floor((x - gx0) / cell), r = Math.floor((y - gy0) / cell);
        if (c < 0 || r < 0 || c >= cols || r >= rows) return items.subarray(0, 0);
        return items.subarray(start[r * cols + c], start[r * cols + c + 1]);
      },
    };
  })();

  // ------------------------------------------------------------------------- membership
  function inRing(r, x, y) {
    let inside = false;
    const s = ringStart[r], e = s + sizes[r];
    for (let i = s, j = e - 1; i < e; j = i++) {
      if ((Y[i] > y) !== (Y[j] > y) && x < X[j] + ((X[i] - X[j]) * (y - Y[j])) / (Y[i] - Y[j])) inside = !inside;
    }
    return inside;
  }

  /* The region whose free space holds the point, or −1. */
  function locate(x, y, ringInside) {
    for (let g = 0, r = 0; g < nRegions; g++) {
      const first = r;
      while (r < nRings && regionOfRing[r] === g) r++;
      if (!inside(first)) continue;
      let hole = false;
      for (let h = first + 1; h < r && !hole; h++) hole = inside(h);
      if (!hole) return g;
    }
    return -1;
    function inside(r) {
      if (!ringInside.has(r)) ringInside.set(r, inRing(r, x, y));
      return ringInside.get(r);
    }
  }

  /* Whether (x, y) lies in the convex hull of the four corners (as sweep.in_hull: four triangles). */
  function inHull(c, x, y) {
    let lx = Infinity, ly = Infinity, hx = -Infinity, hy = -Infinity;
    for (let k = 0; k < 4; k++) {
      lx = Math.min(lx, c[2 * k]); hx = Math.max(hx, c[2 * k]);
      ly = Math.min(ly, c[2 * k + 1]); hy = Math.max(hy, c[2 * k + 1]);
    }
    const size = Math.max(hx - lx, hy - ly), m = 1e-9 * size, tol = 1e-12 * size * size;
    if (x < lx - m || x > hx + m || y < ly - m || y > hy + m) return false;
    const tri = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
    for (const [i, j, k] of tri) {
      const d1 = cross(c[2 * i], c[2 * i + 1], c[2 * j], c[2 * j + 1], x, y);
      const d2 = cross(c[2 * j], c[2 * j + 1], c[2 * k], c[2 * k + 1], x, y);
      const d3 = cross(c[2 * k], c[2 * k + 1], c[2 * i], c[2 * i + 1], x, y);
      if ((d1 >= -tol && d2 >= -tol && d3 >= -tol) || (d1 <= tol && d2 <= tol && d3 <= tol)) return true;
    }
    return false;
  }

  /* Largest α at which the hull of edge i's band on one side still holds (x, y): the hull shrinks
     as α grows, so bisection finds it (NaN if not even the support's hull holds it). */
  function hullLevel(i, side, x, y, c) {
    bandCorners(i, side, 0, c);
    if (!inHull(c, x, y)) return NaN;
    let lo = 0, hi = 1;
    for (let it = 0; it < 40; it++) {
      const mid = 0.5 * (lo + hi);
      bandCorners(i, side, mid, c);
      if (inHull(c, x, y)) lo = mid; else hi = mid;
    }
    return lo;
  }

  function segmentDistance(x, y, ax, ay, bx, by) {
    const ex = bx - ax, ey = by - ay, den = ex * ex + ey * ey;
    const t = den > 0 ? Math.min(1, Math.max(0, ((x - ax) * ex + (y - ay) * ey) / den)) : 0;
    return Math.hypot(x - ax - t * ex, y - ay - t * ey);
  }

  /* μ at (x, y): {sweep, exact, inCrisp}. */
  function muAt(x, y) {
    const ringInside = new Map();
    const region = locate(x, y, ringInside);
    const inCrisp = region >= 0;
    const ownInside = (r) => {
      if (!ringInside.has(r)) ringInside.set(r, inRing(r, x, y));
      return ringInside.get(r);
    };
    let sweep = 0, exact = 0, safe = 0;
    const c = new Float64Array(8);
    for (const i of index.near(x, y)) {
      const r = ringOf[i], shell = shellRing[r] === 1;
      // the safe sweep: inside the crisp map its free-side pieces, outside the others
      for (const k of piecesOfEdge[i]) {
        if (!(inCrisp ? pFree[k] : pObst[k])) continue;
        const level = pieceLevel(k, x, y);
        if (level > safe) safe = level;
      }
      // the sweep: which bands may hold the point (FuzzyBRepMap._membership_sweep)
      for (let side = 1; side >= -1; side -= 2) {
        const freeSide = (side > 0) === shell;
        if (inCrisp && freeSide) {
          if (regionOfRing[r] !== region) continue;
        } else if (!inCrisp && !freeSide) {
          if (shell ? ownInside(r) : !ownInside(r)) continue;
        } else continue;
        const level = hullLevel(i, side, x, y, c);
        if (level > sweep) sweep = level;
      }
      // exact: the function of the signed distance (negative on the IN side of the edge's ring);
      // an edge whose ends carry different functions is split at its middle
      const j = next[i];
      const inSide = inCrisp === shell;
      const halves = slot[i] === slot[j]
        ? [[X[i], Y[i], X[j], Y[j], slot[i]]]
        : [[X[i], Y[i], 0.5 * (X[i] + X[j]), 0.5 * (Y[i] + Y[j]), slot[i]],
          [0.5 * (X[i] + X[j]), 0.5 * (Y[i] + Y[j]), X[j], Y[j], slot[j]]];
      for (const [ax, ay, bx, by, s] of halves) {
        const d = segmentDistance(x, y, ax, ay, bx, by);
        const m = muOf(inSide ? fns[s].d_in : fns[s].d_out, d);
        if (m > exact) exact = m;
      }
    }
    const clip = (v) => Math.min(1, Math.max(0, v));
    // mu: the page's own method's μ (what it draws); sweep: the thesis's, safe: the safe sweep's
    return { mu: clip(SAFE ? safe : sweep), sweep: clip(sweep), safe: clip(safe), exact: clip(exact), inCrisp };
  }

  // ------------------------------------------------------------------------- view
  const canvas = document.getElementById("map");
  const ctx = canvas.getContext("2d");
  const slider = document.getElementById("alpha");
  const alphaOut = document.getElementById("alpha-value");
  const status = document.getElementById("status");
  const info = document.getElementById("info");
  slider.step = String(1 / (D.slider - 1));
  const view = { s: 1, ox: 0, oy: 0 }; // screen = (ox + s·x, oy − s·y), CSS pixels
  let dpr = 1, alpha = 0.5, frame = 0, redraws = 0, lastDrawMs = 0, cursor = null;

  function fit() {
    let x0 = bx0, y0 = by0, x1 = bx1, y1 = by1;
    for (const p of poses.concat(path)) {
      x0 = Math.min(x0, p[0]); x1 = Math.max(x1, p[0]); y0 = Math.min(y0, p[1]); y1 = Math.max(y1, p[1]);
    }
    x0 -= maxReach; y0 -= maxReach; x1 += maxReach; y1 += maxReach;
    const w = canvas.clientWidth, h = canvas.clientHeight, m = 12;
    view.s = Math.min((w - 2 * m) / Math.max(x1 - x0, 1e-9), (h - 2 * m) / Math.max(y1 - y0, 1e-9));
    view.ox = w / 2 - view.s * (x0 + x1) / 2;
    view.oy = h / 2 + view.s * (y0 + y1) / 2;
  }

  function resize() {
    dpr = window.devicePixelRatio || 1;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    canvas.width = Math.max(1, Math.round(w * dpr));
    canvas.height = Math.max(1, Math.round(h * dpr));
  }

  const toScreen = (x, y) => [view.ox + view.s * x, view.oy - view.s * y];
  const toMap = (sx, sy) => [(sx - view.ox) / view.s, (view.oy - sy) / view.s];

  /* Two pictures that depend on the view only, redrawn when it pans, zooms or resizes: the base
     (outside grey, the support band pale, the free space white) and the mask of the crisp free
     space. A new α then costs two fills: the α-band's free-side hulls kept inside the mask, its
     obstacle-side hulls kept outside (compositing instead of a clip, which is slow on long paths). */
  const base = { key: "", picture: document.createElement("canvas"), mask: document.createElement("canvas") };
  const layer = document.createElement("canvas");

  function toMapUnits(c) {
    const k = dpr * view.s / PU; // map → device pixels, paths being in units of q/10
    c.setTransform(k, 0, 0, -k, dpr * view.ox, dpr * view.oy);
  }

  function refreshBase() {
    const key = [canvas.width, canvas.height, view.s, view.ox, view.oy].join();
    if (base.key === key) return;
    base.key = key;
    for (const c of [base.picture, base.mask, layer]) { c.width = canvas.width; c.height = canvas.height; }
    const b = base.picture.getContext("2d");
    b.fillStyle = C.outside;
    b.fillRect(0, 0, canvas.width, canvas.height);
    toMapUnits(b);
    b.fillStyle = C.support; b.fill(support.obst);
    b.fillStyle = C.free; b.fill(crispPath, "evenodd");
    b.save();
    b.clip(crispPath, "evenodd");
    b.fillStyle = C.support; b.fill(support.free);
    b.restore();
    const m = base.mask.getContext("2d");
    toMapUnits(m);
    m.fillStyle = "#000"; m.fill(crispPath, "evenodd");
  }

  function paintBand(hulls, keep) {
    const l = layer.getContext("2d");
    l.setTransform(1, 0, 0, 1, 0, 0);
    l.globalCompositeOperation = "source-over";
    l.clearRect(0, 0, layer.width, layer.height);
    toMapUnits(l);
    l.fillStyle = C.band; l.fill(hulls);
    l.setTransform(1, 0, 0, 1, 0, 0);
    l.globalCompositeOperation = keep;
    l.drawImage(base.mask, 0, 0);
    ctx.drawImage(layer, 0, 0);
  }

  function draw() {
    frame = 0;
    const t0 = performance.now();
    refreshBase();
    const cut = hullsAt(alpha);
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(base.picture, 0, 0);
    // inner α-cut: the crisp free space minus the free-side band hulls;
    // outer α-cut: the crisp free space plus the obstacle-side band hulls
    paintBand(cut.free, "destination-in");
    paintBand(cut.obst, "destination-out");
    toMapUnits(ctx);
    ctx.lineJoin = "round";
    const px = PU / view.s; // one CSS pixel in path units
    ctx.lineWidth = px;
    ctx.strokeStyle = C.obstacle; ctx.stroke(crispPath);
    ctx.lineWidth = 2.2 * px;
    ctx.setLineDash([5 * px, 3 * px]);
    ctx.strokeStyle = C.frontier; ctx.stroke(frontierPath);
    ctx.setLineDash([]);
    // poses and path at a constant size on screen
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    if (poses.length) {
      const r = 6, d = [];
      for (const [x, y, h] of poses) {
        // tip along the heading (y down on screen), base corners either side behind the pose
        const [sx, sy] = toScreen(x, y), ux = r * Math.cos(h), uy = -r * Math.sin(h);
        const p = (a, b) => (sx + a * ux - b * uy).toFixed(1) + " " + (sy + a * uy + b * ux).toFixed(1);
        d.push("M" + p(1, 0) + "L" + p(-0.6, 0.45) + "L" + p(-0.6, -0.45) + "Z");
      }
      ctx.globalAlpha = 0.75; ctx.fillStyle = C.pose; ctx.fill(new Path2D(d.join(""))); ctx.globalAlpha = 1;
    }
    if (path.length) {
      ctx.beginPath();
      path.forEach(([x, y], k) => { const [sx, sy] = toScreen(x, y); k ? ctx.lineTo(sx, sy) : ctx.moveTo(sx, sy); });
      ctx.lineWidth = 3; ctx.lineCap = "round"; ctx.lineJoin = "round"; ctx.strokeStyle = C.path; ctx.stroke();
      for (const [p, fillc] of [[path[0], "#2b8a3e"], [path[path.length - 1], C.path]]) {
        const [sx, sy] = toScreen(p[0], p[1]);
        ctx.beginPath(); ctx.arc(sx, sy, 5, 0, 2 * Math.PI);
        ctx.fillStyle = fillc; ctx.fill(); ctx.lineWidth = 1.5; ctx.strokeStyle = "#fff"; ctx.stroke();
      }
    }
    drawScaleBar();
    const snap = snapshot.canvas;
    if (snap.width !== canvas.width || snap.height !== canvas.height) {
      snap.width = canvas.width; snap.height = canvas.height;
    }
    snap.getContext("2d").drawImage(canvas, 0, 0);
    Object.assign(snapshot, { s: view.s, ox: view.ox, oy: view.oy });
    lastDrawMs = performance.now() - t0;
    redraws++;
    info.textContent = `${D.stats.vertices} vertices, ${D.stats.holes} holes · drawn in ${lastDrawMs.toFixed(0)} ms`;
    prefetch();
  }

  /* A round length (1, 2 or 5 × 10^k map units) near a fifth of the canvas width, as the SVG's. */
  function scaleBarLength(extent) {
    const target = Math.max(extent, 1e-300) / 5;
    const k = Math.floor(Math.log10(target));
    for (const m of [5, 2, 1]) if (m * 10 ** k <= target) return m * 10 ** k;
    return 10 ** k;
  }

  /* The scale bar, bottom left, in CSS pixels: a length of the map at the current zoom. */
  const scaleBar = { length: 0, pixels: 0 };
  function drawScaleBar() {
    const w = canvas.clientWidth, h = canvas.clientHeight;
    const length = scaleBarLength(w / view.s), px = length * view.s;
    const label = `${+length.toPrecision(6)} ${unit}`;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.font = "12px system-ui, sans-serif";
    const x0 = 14, y0 = h - 14, boxW = Math.max(px, ctx.measureText(label).width) + 16;
    ctx.fillStyle = "rgba(255, 255, 255, 0.85)";
    ctx.fillRect(x0 - 8, y0 - 26, boxW, 32);
    ctx.strokeStyle = "#222"; ctx.lineWidth = 1.5; ctx.lineCap = "butt";
    ctx.beginPath();
    ctx.moveTo(x0, y0 - 6); ctx.lineTo(x0, y0); ctx.lineTo(x0 + px, y0); ctx.lineTo(x0 + px, y0 - 6);
    ctx.stroke();
    ctx.fillStyle = "#222"; ctx.textAlign = "center"; ctx.textBaseline = "alphabetic";
    ctx.fillText(label, x0 + px / 2, y0 - 9);
    ctx.textAlign = "start";
    Object.assign(scaleBar, { length, pixels: px, x: x0, y: y0 });
  }

  const schedule = () => { if (!frame) frame = requestAnimationFrame(draw); };

  /* Panning and zooming show the last picture moved and scaled at once, and draw afresh when the
     view has rested for a moment: a full drawing of a large map takes longer than a mouse move. */
  const snapshot = { canvas: document.createElement("canvas"), s: 1, ox: 0, oy: 0 };
  let settle = 0;
  function viewChanged() {
    const f = view.s / snapshot.s;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = C.outside;
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    ctx.setTransform(f, 0, 0, f, dpr * (view.ox - f * snapshot.ox), dpr * (view.oy - f * snapshot.oy));
    ctx.drawImage(snapshot.canvas, 0, 0);
    clearTimeout(settle);
    settle = setTimeout(schedule, 120);
  }

  /* While nothing else happens, read the α-cuts one slider step either side, so that stepping
     with the keys or a slow drag finds them ready. */
  let prefetchTimer = 0;
  function prefetch() {
    clearTimeout(prefetchTimer);
    const step = 1 / (D.slider - 1);
    const todo = [alpha + step, alpha - step].filter((a) => a > 0 && a < 1 && !cache.has(a.toFixed(6)));
    prefetchTimer = setTimeout(function next() {
      if (frame || !todo.length) return;
      const a = todo.shift();
      const key = a.toFixed(6);
      if (!cache.has(key)) hullsAt(a);
      // keep the one on screen the most recent
      hullsAt(alpha);
      prefetchTimer = setTimeout(next, 30);
    }, 120);
  }

  function fmt(v) { return v.toFixed(3); }

  function showStatus() {
    if (!cursor) return;
    const [x, y] = toMap(cursor[0], cursor[1]);
    const m = muAt(x, y);
    const where = m.mu >= alpha && m.mu > 0 ? "in the α-band (μ ≥ α)"
      : m.inCrisp ? "inside the inner α-cut (free at confidence α)" : "outside the outer α-cut";
    status.textContent =
      `x ${fmt(x)}, y ${fmt(y)} ${unit} · μ = ${fmt(m.mu)} (${METHOD}) · exact μ = ${fmt(m.exact)} · ${where}`;
    status.dataset.mu = String(m.mu);
    status.dataset.muExact = String(m.exact);
  }

  function setAlpha(a) {
    // the slider snaps to its steps: α is what it shows
    slider.value = String(Math.min(1, Math.max(0, Number(a) || 0)));
    alpha = Number(slider.value);
    alphaOut.textContent = alpha.toFixed(2);
    schedule();
    showStatus();
  }

  slider.addEventListener("input", () => setAlpha(slider.value));
  canvas.addEventListener("mousemove", (e) => {
    const rect = canvas.getBoundingClientRect();
    cursor = [e.clientX - rect.left, e.clientY - rect.top];
    if (drag) {
      view.ox += cursor[0] - drag[0]; view.oy += cursor[1] - drag[1];
      drag = cursor; viewChanged();
    }
    showStatus();
  });
  let drag = null;
  canvas.addEventListener("mousedown", (e) => {
    const rect = canvas.getBoundingClientRect();
    drag = [e.clientX - rect.left, e.clientY - rect.top];
    canvas.classList.add("dragging");
  });
  window.addEventListener("mouseup", () => { drag = null; canvas.classList.remove("dragging"); });
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    const rect = canvas.getBoundingClientRect();
    const sx = e.clientX - rect.left, sy = e.clientY - rect.top;
    const [x, y] = toMap(sx, sy);
    view.s *= Math.exp(-e.deltaY * 0.0015);
    view.ox = sx - view.s * x; view.oy = sy + view.s * y;
    viewChanged();
  }, { passive: false });
  canvas.addEventListener("dblclick", () => { fit(); schedule(); });
  window.addEventListener("resize", () => { resize(); fit(); schedule(); });

  // α from the address (#alpha=0.3), so a view can be linked
  const fromHash = /alpha=([0-9.]+)/.exec(location.hash);
  resize();
  fit();
  setAlpha(fromHash ? fromHash[1] : slider.value);
  draw();

  // for tests and the console
  window.fuzzybrepViewer = {
    get alpha() { return alpha; },
    setAlpha, muAt, toScreen, toMap, draw,
    /* zoom by a factor about the canvas centre, as the wheel does about the cursor */
    zoom(f) {
      const sx = canvas.clientWidth / 2, sy = canvas.clientHeight / 2, [x, y] = toMap(sx, sy);
      view.s *= f; view.ox = sx - view.s * x; view.oy = sy + view.s * y;
    },
    method: METHOD,
    hulls: (a) => cutHulls(a, true).lists,
    get redraws() { return redraws; },
    get scaleBar() { return Object.assign({}, scaleBar, { scale: view.s }); },
    get lastDrawMs() { return lastDrawMs; },
  };
})();
