"""Time-optimal path following by reachability analysis (TOPP-RA: Pham and Pham, IEEE T-RO
34(3), 2018), with null-space efforts.

On N + 1 grid points s_k = k ds the unknowns are x_k = s_dot^2 and, per segment, u_k = s_ddot
(x_{k+1} = x_k + 2 ds u_k). F functions, each affine in (a, b, alpha) at every point,

    lo_f <= F_k,f . (a, b, alpha, 1) <= hi_f,

hold at both ends of every segment with its acceleration (TOPP-RA's interpolation scheme:
point k with u_{k-1} and with u_k, each with its own alpha; the 'collocation' scheme holds
point k with u_k only, the last point with u_{N-1}).

1. Projection: alpha is eliminated point by point (Fourier-Motzkin for m = 1: every row with a
   positive alpha coefficient paired with every row with a negative one), vectorised over the
   points; what is left is a polygon of (a, b) per point.
2. Stages in the coordinates (c, x) = (x_{k+1}, x_k): stage k's polygon holds point k's rows
   (b = x) and point k + 1's (b = c), with 0 <= x <= X_k, 0 <= c <= X_{k+1}.
3. Four 2-D linear programs per stage (largest and smallest x and c), all stages at once:
   Seidel's incremental algorithm (rows in a fixed random order, the 1-D program on the line
   of a violated row), vectorised with numpy over the stages.
4. Backward: the controllable sets K_k = [lo_k, hi_k] = {x : some c in K_{k+1} with (c, x) in
   stage k}. In (c, x) the largest x of the polygon at a given c is concave in c, so the
   largest x over c in K_{k+1} is its value at the polygon's top vertex's c clipped into
   K_{k+1} (the smallest alike): the few lines of the polygon's upper chain (found for all
   stages at once) evaluated once per stage, no program.
5. Forward greedy pass from x_0: the largest c at x_k within stage k's rows and K_{k+1}.
6. alpha per point from the chosen (a, b) (the acceleration of the segment after the point):
   the largest smallest margin of the `margin` rows (the contact condition) inside the other
   rows, or, without margin rows, the given preferred alpha clipped into its interval (m = 1:
   closed form).

The convex program of :mod:`rrr4.optimal.time_law` holds each point with both its segments'
accelerations and one alpha; the durations agree to about 1e-5 and converge together at first
order in 1/N. The collocation scheme converges to the same law at first order too, but its
s_ddot jumps between neighbouring segments where the binding constraint changes.
"""

from __future__ import annotations

import numpy as np

__all__ = ["time_optimal_speeds", "recover_alpha", "point_rows", "project_out", "lp2", "prune", "X_CAP", "SCHEMES"]

# s_dot^2 [1/s^2] where nothing else bounds it: a speed cap the optimum must stay well below
X_CAP = 1e8
# which points hold each segment's acceleration: both its ends, or the point it starts at
SCHEMES = ("interpolation", "collocation")
TOL = 1e-9      # relative: a row's violation, a coefficient counted as zero
SEED = 44       # the one fixed order of Seidel's rows

# Layout: a set of rows over y (dimension d) at K points or stages is G (d, R, K), h (R, K):
# G[:, r, k] . y <= h[r, k]; every (R, K) slice contiguous, the reductions over the rows.


def point_rows(F, lo, hi, margin):
    """Rows over y = (a, b, alpha) of every point: F (K, nf, 3 + m) the functions'
    coefficients (a, b, alpha..., constant), lo, hi (nf,) their bounds (+-inf: none), margin
    (nf,) bool the functions whose margin :func:`recover_alpha` maximises. Returns G (2 + m,
    R, K), h (R, K), margin (R,)."""
    up, down = np.isfinite(hi), np.isfinite(lo)
    Ft = np.ascontiguousarray(F.transpose(2, 1, 0))          # (3 + m, nf, K)
    G = np.concatenate([Ft[:-1, up], -Ft[:-1, down]], axis=1)
    h = np.concatenate([hi[up, None] - Ft[-1, up], Ft[-1, down] - lo[down, None]], axis=0)
    return G, h, np.concatenate([margin[up], margin[down]])


def _normalised(G, h, ref):
    """Rows scaled to unit normal; rows whose normal is below TOL of `ref` (the size of the
    terms that made them) become the trivial 0 <= 1, or 0 <= -1 where their constant fails."""
    n = np.sqrt((G * G).sum(axis=0))
    zero = n <= TOL * np.maximum(ref, 1e-300)
    scale = np.where(zero, 0.0, 1.0 / np.where(zero, 1.0, n))
    h = np.where(zero, np.where(h >= -TOL * np.maximum(ref, 1.0), 1.0, -1.0), h * scale)
    return G * scale, h


def _compact(mask):
    """(n, K) indices of each column's True entries first (n: the most over the columns),
    padded with False entries."""
    n = max(int(mask.sum(axis=0).max()), 1)
    return np.argsort(~mask, axis=0, kind="stable")[:n]


def _take(a, idx):
    """The rows idx (n, K) of every column of a (R, K) or of G (d, R, K)."""
    return np.take_along_axis(a, idx, axis=0) if a.ndim == 2 else np.take_along_axis(a, idx[None], axis=1)


def project_out(G, h):
    """(G2 (2, W, K), h2 (W, K)): the rows over (a, b) that some alpha meets with G y <= h
    (G (2 + m, R, K)); Fourier-Motzkin for m = 1 (every row that bounds alpha from above with
    every row that bounds it from below), compacted to the largest count W of non-trivial rows
    over the points."""
    m = G.shape[0] - 2
    size = np.sqrt((G * G).sum(axis=0))
    if m == 0:
        return _normalised(G, h, size)
    if m > 1:
        raise ValueError(f"alpha of dimension {m}: Fourier-Motzkin here projects one degree of redundancy")
    g = G[2]
    pos, neg = g > TOL * size, g < -TOL * size
    with np.errstate(divide="ignore", invalid="ignore"):
        Gs, hs = G[:2] / g, h / g       # pos rows: alpha <= hs - Gs y; neg rows: alpha >= hs - Gs y
    P, Q = _compact(pos), _compact(neg)                      # (nP, K), (nQ, K) row indices
    Gp, Gq, hp, hq = _take(Gs, P), _take(Gs, Q), _take(hs, P), _take(hs, Q)
    K = g.shape[1]
    pair = (_take(pos, P)[:, None] & _take(neg, Q)[None]).reshape(-1, K)
    Gpair = (Gp[:, :, None] - Gq[:, None]).reshape(2, -1, K)
    hpair = (hp[:, None] - hq[None]).reshape(-1, K)
    ref = (np.sqrt((Gp * Gp).sum(axis=0))[:, None] + np.sqrt((Gq * Gq).sum(axis=0))[None]).reshape(-1, K)
    Gpair, hpair, ref = np.where(pair, Gpair, 0.0), np.where(pair, hpair, 1.0), np.where(pair, ref, 1.0)
    flat = ~pos & ~neg
    G2, h2 = _normalised(np.concatenate([Gpair, G[:2]], axis=1), np.concatenate([hpair, h], axis=0),
                         np.concatenate([ref, size], axis=0))
    keep = np.concatenate([pair, flat], axis=0)
    keep &= (np.abs(G2).sum(axis=0) > 0) | (h2 < 0)
    order = _compact(keep)
    valid = _take(keep, order)
    return np.where(valid, _take(G2, order), 0.0), np.where(valid, _take(h2, order), 1.0)


def prune(G2, h2, X, ds):
    """The rows of every point's polygon of (a, b) that are its edges (the others are implied
    by them), compacted: two 2-D programs per point (its smallest and largest a, inside
    0 <= b <= X and |a| <= X_CAP / ds) and the walks along its upper and lower chains; every
    row that bounds a alone is kept, and every row of a point whose polygon is empty or
    degenerate (a single a)."""
    W, K = h2.shape
    A = np.full(K, X_CAP / ds)
    bG, bh = _box(-A, A, np.zeros(K), X)
    G, h = np.concatenate([bG, G2], axis=1), np.concatenate([bh, h2], axis=0)
    obj = np.repeat(np.array([[1.0, 0.0], [-1.0, 0.0]]).T, K, axis=1)
    lo, hi = np.tile(np.stack([-A, np.zeros(K)]), (1, 2)), np.tile(np.stack([A, X]), (1, 2))
    a_max, a_min = lp2(np.tile(G, (1, 1, 2)), np.tile(h, (1, 2)), obj, lo, hi)[0].reshape(2, K)
    keep = np.zeros((W + 4, K), bool)
    cols = np.arange(K)
    for lines in _bounds(G, h, 1):
        keep[_envelope(*lines, a_min, a_max)[2], cols] = True
    keep |= np.abs(G[1]) <= TOL
    whole = ~(a_max - a_min > TOL * (1.0 + np.abs(a_min) + np.abs(a_max)))   # NaN: empty
    keep[:, whole] = True
    keep = keep[4:]
    order = _compact(keep)
    valid = _take(keep, order)
    return np.where(valid, _take(G2, order), 0.0), np.where(valid, _take(h2, order), 1.0)


def _stage(G2, h2, ds, at_end=False):
    """Point rows over (a, b) as stage rows over (c, x): a = (c - x) / (2 ds), b = x (the
    point the stage starts at) or b = c (the last point, at_end)."""
    ga, gb = G2[0] / (2 * ds), G2[1]
    Gs = np.stack([ga + gb, -ga]) if at_end else np.stack([ga, gb - ga])
    return _normalised(Gs, h2, np.abs(ga) + np.abs(gb))


def _box(lo0, hi0, lo1, hi1):
    """The rows lo0 <= y0 <= hi0, lo1 <= y1 <= hi1 (K,) of each of K sets: (2, 4, K), (4, K)."""
    G = np.zeros((2, 4, len(lo0)))
    G[0, 0], G[0, 1], G[1, 2], G[1, 3] = 1.0, -1.0, 1.0, -1.0
    return G, np.stack([hi0, -lo0, hi1, -lo1])


def lp2(G, h, obj, lo, hi):
    """Maximise obj . y over y in R^2 subject to G y <= h, for K programs at once (Seidel's
    incremental algorithm, vectorised over the programs). G (2, R, K) with unit rows (or zero
    rows), h (R, K), obj (2, K), the box lo <= y <= hi (2, K) finite, whose rows must lead G.
    Returns y (2, K) (NaN where infeasible)."""
    y0, y1 = np.where(obj > 0, hi, lo)
    o0, o1 = obj
    G0, G1 = G
    for r in range(h.shape[0]):
        a0, a1, hr = G0[r], G1[r], h[r]
        viol = a0 * y0 + a1 * y1 > hr + TOL * (1.0 + np.abs(hr) + np.maximum(np.abs(y0), np.abs(y1)))
        V = np.flatnonzero(viol)
        if not V.size:
            continue
        a0, a1, hr = a0[V], a1[V], hr[V]
        p0, p1 = a0 * hr, a1 * hr              # the point of the line nearest the origin
        d0, d1 = -a1, a0                       # the line's direction
        g0, g1, hj = G0[:r, V], G1[:r, V], h[:r, V]
        den = g0 * d0 + g1 * d1
        num = hj - g0 * p0 - g1 * p1
        with np.errstate(divide="ignore", invalid="ignore"):
            q = num / den
        thi = np.where(den > TOL, q, np.inf).min(axis=0)
        tlo = np.where(den < -TOL, q, -np.inf).max(axis=0)
        parallel_out = ((np.abs(den) <= TOL) & (num < -TOL * (1.0 + np.abs(hj)))).any(axis=0)
        ok = (tlo <= thi + TOL * (1.0 + np.abs(thi))) & ~parallel_out & (np.abs(a0) + np.abs(a1) > 0)
        t = np.where(o0[V] * d0 + o1[V] * d1 > 0, thi, tlo)
        y0[V] = np.where(ok, p0 + t * d0, np.nan)
        y1[V] = np.where(ok, p1 + t * d1, np.nan)
    return np.stack([y0, y1])


def _bounds(G, h, axis):
    """The rows' bounds on coordinate `axis` of y as lines in the other one, w, each as slopes
    and intercepts (P, Q) (R, K) whose minimum is the bound: the upper bounds y_axis <= P w + Q
    (rows with a positive coefficient of y_axis) and the negated lower bounds -y_axis <= P w + Q
    (negative coefficient); Q = inf for the other rows."""
    g, o = G[axis], G[1 - axis]
    up, down = g > TOL, g < -TOL
    with np.errstate(divide="ignore", invalid="ignore"):
        P, Q = -o / g, h / g
    return (np.where(up, P, 0.0), np.where(up, Q, np.inf)), (np.where(down, -P, 0.0), np.where(down, -Q, np.inf))


def _envelope(P, Q, lo, hi):
    """The lines of min_r (P_r w + Q_r) on [lo, hi] (K programs, P, Q (R, K), Q = inf for no
    line): walking from lo to the right, at each vertex the line of least slope among those
    through it, all programs at once. Returns their slopes and intercepts as K lists each
    (repeats possible), whose minimum equals the envelope on [lo, hi]."""
    R, K = P.shape
    cols = np.arange(K)
    w = lo.copy()
    val = P * w + Q
    low = val.min(axis=0)
    through = val <= low + TOL * (1.0 + np.abs(low))
    cur = np.argmin(np.where(through, P, np.inf), axis=0)
    chosen, done = [cur], np.zeros(K, bool)
    finite = np.isfinite(Q)
    for _ in range(R):
        Pc, Qc = P[cur, cols], Q[cur, cols]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            wx = (Q - Qc) / (Pc - P)
        wx = np.where((P < Pc - TOL * np.abs(Pc)) & (wx > w) & finite, wx, np.inf)
        w_next = wx.min(axis=0)
        done |= w_next >= hi
        if done.all():
            break
        at = wx <= w_next + TOL * (1.0 + np.abs(w_next))
        cur = np.where(done, cur, np.argmin(np.where(at, P, np.inf), axis=0))
        w = np.where(done, w, w_next)
        chosen.append(cur)
    idx = np.stack(chosen)
    return P[idx, cols].T.tolist(), Q[idx, cols].T.tolist(), idx


def _stages(G2, h2, ds, X, scheme):
    """The stages' rows over (c, x), box first and the rest in Seidel's random order, in groups
    of equal row counts, with their upper bounds X0 of x and X1 of c. 'interpolation': stage
    k holds the rows of points k (b = x) and k + 1 (b = c), one group; 'collocation': the rows
    of point k, the last stage those of the last point too (two groups)."""
    N = len(X) - 1
    Gs, hs = _stage(G2[:, :, :N], h2[:, :N], ds)
    if scheme == "interpolation":
        Ge, he = _stage(G2[:, :, 1:], h2[:, 1:], ds, at_end=True)
        parts = [(np.concatenate([Gs, Ge], axis=1), np.concatenate([hs, he], axis=0), X[:N], X[1:])]
    else:
        Ge, he = _stage(G2[:, :, N:], h2[:, N:], ds, at_end=True)
        parts = [(Gs[:, :, :-1], hs[:, :-1], X[:N - 1], X[1:N]),
                 (np.concatenate([Gs[:, :, -1:], Ge], axis=1), np.concatenate([hs[:, -1:], he], axis=0),
                  X[N - 1:N], X[N:])]
    rng = np.random.default_rng(SEED)
    out = []
    for G, h, X0, X1 in parts:
        bG, bh = _box(np.zeros(len(X0)), X1, np.zeros(len(X0)), X0)   # 0 <= c <= X1, 0 <= x <= X0
        perm = rng.permutation(h.shape[0])
        out.append((np.concatenate([bG, G[:, perm]], axis=1), np.concatenate([bh, h[perm]], axis=0), X0, X1))
    return out


def _extremes(G, h, X0, X1):
    """(4, 2, K): the vertices (c, x) of largest x, smallest x, largest c and smallest c of
    every stage's polygon (NaN where it is empty): one vectorised Seidel for all four."""
    K = len(X0)
    obj = np.repeat(np.array([[0.0, 1.0], [0.0, -1.0], [1.0, 0.0], [-1.0, 0.0]]).T, K, axis=1)
    hi = np.tile(np.stack([X1, X0]), (1, 4))
    y = lp2(np.tile(G, (1, 1, 4)), np.tile(h, (1, 4)), obj, np.zeros((2, 4 * K)), hi)
    return y.reshape(2, 4, K).transpose(1, 0, 2)


def time_optimal_speeds(G2, h2, ds, X, x_start, x_end, scheme="interpolation", prune_rows=True):
    """x (N+1,) = s_dot^2 of the time-optimal law (TOPP-RA) on N + 1 points of spacing ds:
    G2, h2 the projected rows of every point over (a, b) (:func:`project_out`), X (N+1,) the
    upper bounds of x (speed bounds, at most X_CAP), x_start, x_end the end values, scheme
    (SCHEMES) which points' rows hold each segment's acceleration (:func:`_stages`),
    prune_rows: each point's rows pruned to its polygon's edges first (:func:`prune`). Returns
    (x, where): x None and where the stage at which no law exists ('stage k', or 'start' where
    no law reaches the end from x_start)."""
    N = len(X) - 1
    if prune_rows:
        G2, h2 = prune(G2, h2, X, ds)
    groups = _stages(G2, h2, ds, X, scheme)
    ext = np.concatenate([_extremes(*g) for g in groups], axis=2)   # top, bottom, right, left
    feasible = ~np.isnan(ext).any(axis=(0, 1))
    if not feasible.all():
        return None, f"stage {int(np.flatnonzero(~feasible)[0])}"
    (top_c, top_x), (bottom_c, bottom_x), (right_c, _), (left_c, _) = (v.tolist() for v in ext)
    # per stage the lines whose minimum bounds x from above and from below (in c, on the
    # polygon's c range), and c from above (in x, on its x range)
    env = [[], [], [], [], [], []]
    start = 0
    for G, h, X0, _ in groups:
        sl = slice(start, start + len(X0))
        start += len(X0)
        (xu, xl), (cu, _) = _bounds(G, h, 1), _bounds(G, h, 0)
        for i, (lines, lo, hi) in enumerate(((xu, ext[3, 0, sl], ext[2, 0, sl]), (xl, ext[3, 0, sl], ext[2, 0, sl]),
                                             (cu, ext[1, 1, sl], ext[0, 1, sl]))):
            P, Q, _ = _envelope(*lines, lo, hi)
            env[2 * i] += P
            env[2 * i + 1] += Q
    PH, QH, PL, QL, PC, QC = env
    lo, hi = [0.0] * (N + 1), [0.0] * (N + 1)
    lo[N] = hi[N] = x_end
    for k in range(N - 1, -1, -1):     # backward: the controllable sets
        a, b = max(lo[k + 1], left_c[k]), min(hi[k + 1], right_c[k])
        if a > b + TOL * (1.0 + abs(b)):
            return None, f"stage {k}"
        a = min(a, b)
        c = top_c[k]            # the top vertex within reach: the top itself, no chain to evaluate
        hi[k] = top_x[k] if a <= c <= b else \
            min(min([p * min(max(c, a), b) + q for p, q in zip(PH[k], QH[k], strict=True)]), top_x[k])
        c = bottom_c[k]
        lo[k] = bottom_x[k] if a <= c <= b else \
            max(-min([p * min(max(c, a), b) + q for p, q in zip(PL[k], QL[k], strict=True)]), bottom_x[k])
        lo[k] = min(lo[k], hi[k])
    if not lo[0] - TOL * (1.0 + lo[0]) <= x_start <= hi[0] + TOL * (1.0 + hi[0]):
        return None, "start"
    x = [x_start] * (N + 1)
    for k in range(N):                 # forward: the greedy pass
        xk = x[k]
        x[k + 1] = max(min(min([p * xk + q for p, q in zip(PC[k], QC[k], strict=True)]), hi[k + 1]), lo[k + 1])
    return np.array(x), ""


def recover_alpha(G, h, margin, preferred):
    """alpha (K, m) per point at the chosen (a, b): G (m, R, K), h (R, K) the rows over alpha
    with (a, b) substituted, margin (R,) bool: the rows whose smallest slack is maximised
    within the others, or, with no margin rows, `preferred` (K, m) clipped into the
    interval the rows leave (m = 1)."""
    m, R, K = G.shape
    if m == 0:
        return np.zeros((K, 0))
    g = G[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = h / g
    hard = ~margin[:, None]
    a_hi = np.where(hard & (g > TOL), q, np.inf).min(axis=0)
    a_lo = np.minimum(np.where(hard & (g < -TOL), q, -np.inf).max(axis=0), a_hi)
    if not margin.any():
        return np.clip(preferred[:, 0], a_lo, a_hi)[:, None]
    # slack of margin row j: s_j(alpha) = h_j - g_j alpha; the largest min_j s_j over [a_lo, a_hi]
    # lies at the end its slopes point to where they agree in sign (the contact rows of one
    # null-space direction do), else at an end or where two slacks of opposite slopes cross
    gm, hm = g[margin], h[margin]
    alpha = np.where((gm >= 0).all(axis=0), a_lo, a_hi)
    mixed = np.flatnonzero((gm > TOL).any(axis=0) & (gm < -TOL).any(axis=0))
    if mixed.size:
        gx, hx, lo, hi = gm[:, mixed], hm[:, mixed], a_lo[mixed], a_hi[mixed]
        with np.errstate(divide="ignore", invalid="ignore"):
            cross = ((hx[:, None] - hx[None]) / (gx[:, None] - gx[None])).reshape(-1, mixed.size)
        cand = np.concatenate([lo[None], hi[None], cross], axis=0)
        cand = np.clip(np.where(np.isfinite(cand), cand, lo), lo, hi)
        slack = (hx[None] - gx[None] * cand[:, None]).min(axis=1)
        alpha[mixed] = cand[np.argmax(slack, axis=0), np.arange(mixed.size)]
    return alpha[:, None]
