"""Defuzzifying a Mamdani :class:`~controllers.fuzzy.fis.matlab.Fis` output: exactly, or
sampled as the Toolbox does (docs/fuzzy.md, "Any MATLAB FIS", says what "exactly" means).

The aggregated output mu(y) = AGG_r IMP(w_r, F_r(y)) (F_r the rule's consequent, 1 - it
for NOT) is smooth between its kinks: the membership functions' own breakpoints (fixed
for the file) and, per input, the points where a clipped consequent meets its clip level
(F_r = w_r, min implication) and where the largest rule changes (max aggregation).

*Exact* mode places a mesh on the output range: the range split in 16, every breakpoint,
and around each curved function's centre points spaced by its own scale (sigma, 1/a,
...) out to 40 scales; then, per input, finds every kink by a sign change between 4
sub-samples of a mesh cell (the clip level against the consequent, the largest rule
against the next) and bisects it to the last bit; where a third rule is on top at a change
so found, the stretch is split there and solved again. On each piece between kinks mu is a
polynomial (trimf, trapmf, smf, zmf, pimf under min / prod, max / sum, and probor of up
to 31 rules) or smooth, and 16-point Gauss-Legendre integrates it: exactly (to rounding)
for the polynomials, and to about 1e-13 for the curved functions on pieces no wider than
their scale (tests: against adaptive quadrature, scipy's ``quad`` at 1e-13). The centroid
is the ratio of the two integrals; the bisector the leftmost y where the integral from the
range's start reaches half the area (bisected to the last bit); mom / som / lom read the
set where mu is largest: whole pieces on which mu equals its maximum at every node (a
plateau: a clip level or a flat top, equal bit for bit) or the mesh points and kinks that
reach it; a maximum inside a smooth piece (e.g. a sum of two Gaussians) is found by golden
section, to about 1e-8 of the piece (the limit of any search on a flat maximum in
floating point). mom is the mean of the set by length (of its points where it has no
length), som / lom its element nearest to / farthest from 0 (the Toolbox's "smallest /
largest (absolute) value of maximum"; a tie goes to the smaller y, as the Toolbox keeps
the first).

*Sampled* mode is the Toolbox's ``fis.c``: mu on ``points`` evenly spaced values of the
range, the centroid sum(y mu) / sum(mu), the bisector the first point where the running
sum reaches half, mom the mean of the points at the maximum, som / lom as above on them.
"""

from __future__ import annotations

import numpy as np

_Q = 16
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(_Q)
_SCALES = np.array(
    [0.0, 0.25, 0.5, 0.75, 1, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10, 13, 16, 20, 25, 30, 40]
)
_SUB = 4  # sub-samples per mesh cell for finding kinks
_CHUNK = 32  # inputs per vectorised block
# the exact mode's working memory per rule and input, measured with tracemalloc (255 MiB
# for 800 rules x 32 inputs of Gaussian consequents: 10 KiB); a block holds fewer inputs
# where the rules are many, so that it stays under EXACT_BLOCK_BYTES
RULE_INPUT_BYTES = 10 << 10
EXACT_BLOCK_BYTES = 128 << 20


def block_inputs(rules: int) -> int:
    """Inputs per vectorised block for ``rules`` rules: 32, fewer where 32 would need
    more than EXACT_BLOCK_BYTES (at least 1)."""
    return max(1, min(_CHUNK, EXACT_BLOCK_BYTES // (RULE_INPUT_BYTES * max(rules, 1))))


_BISECT = 64
_ROUNDS = 8  # splits of a sub-sample cell where the largest rule changes more than once
_GOLDEN = 100


def _imp(method: str, w: np.ndarray, f: np.ndarray) -> np.ndarray:
    return np.minimum(w, f) if method == "min" else w * f


def _agg(method: str, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    if method == "max":
        return np.maximum(a, b)
    if method == "sum":
        return a + b
    return a + b - a * b


def _consequents(var, y: np.ndarray, cons: np.ndarray) -> list[np.ndarray | None]:
    """F_r(y) for every rule (None for a don't-care consequent)."""
    used = {abs(int(k)) for k in cons if k}
    table = {k: var.mfs[k - 1](y) for k in used}
    return [None if k == 0 else (table[k] if k > 0 else 1.0 - table[-k]) for k in cons]


def aggregate(fis, m: int, y: np.ndarray, w: np.ndarray, cons: np.ndarray) -> np.ndarray:
    """mu(y) for inputs' firing strengths ``w`` (n, R); ``y`` (n or 1, ...)."""
    var = fis.outputs[m]
    shape = np.broadcast_shapes(y.shape, (w.shape[0],) + (1,) * max(y.ndim - 1, 0))
    out = None
    for r, f in enumerate(_consequents(var, y, cons)):
        if f is None:
            continue
        wr = w[:, r].reshape((-1,) + (1,) * max(y.ndim - 1, 0))
        g = _imp(fis.imp_method, wr, f)
        out = g if out is None else _agg(fis.agg_method, out, g)  # the Toolbox's order
    return np.zeros(shape) if out is None else np.broadcast_to(out, shape)


# ----------------------------------------------------------------------------- sampled


def sampled_defuzz(fis, m: int, w: np.ndarray, cons: np.ndarray, points: int) -> np.ndarray:
    """The Toolbox's defuzzification on ``points`` samples (``fis.c``), per input."""
    var = fis.outputs[m]
    lo, hi = var.range
    step = (hi - lo) / (points - 1)
    y = lo + step * np.arange(points)
    mu = aggregate(fis, m, y[None, :], w, cons)
    total = mu.sum(axis=1)
    safe = np.where(total > 0, total, 1.0)
    method = fis.defuzz_method
    if method == "centroid":
        out = (mu * y).sum(axis=1) / safe
    elif method == "bisector":
        out = lo + step * np.argmax(np.cumsum(mu, axis=1) >= total[:, None] / 2, axis=1)
    else:
        at = mu == mu.max(axis=1, keepdims=True)
        if method == "mom":
            out = lo + step * (at * np.arange(points)).sum(axis=1) / at.sum(axis=1)
        else:
            out = _nearest(np.broadcast_to(y, mu.shape), at, method == "lom")
    return np.where(total > 0, out, var.mid)


def _nearest(y: np.ndarray, at: np.ndarray, largest: bool, tie: float = 0.0) -> np.ndarray:
    """Per row, the y (where ``at``) of least (largest: most) |y|, ties (within ``tie``)
    to the smaller y."""
    mag = np.abs(y)
    key = np.where(at, -mag if largest else mag, np.inf)
    best = key.min(axis=1, keepdims=True)
    return np.where(at & (key <= best + tie), y, np.inf).min(axis=1)


# ----------------------------------------------------------------------------- exact


def _mesh(fis, m: int) -> np.ndarray:
    """The fixed mesh of output ``m`` (see the module's docstring), cached on the Fis."""
    key = ("mesh", m)
    if key not in fis._cache:
        var = fis.outputs[m]
        lo, hi = var.range
        pts = [np.linspace(lo, hi, 17)]
        for mf in var.mfs:
            for c, width in mf.features():
                pts.append(np.array([c]) if width == 0 else c + width * np.r_[-_SCALES, _SCALES])
        mesh = np.unique(np.clip(np.concatenate(pts), lo, hi))
        fis._cache[key] = mesh
    return fis._cache[key]


def _kinks(fis, m, sub: np.ndarray, w: np.ndarray, cons: np.ndarray) -> list[np.ndarray]:
    """Per input row, the kinks of mu between the sub-samples ``sub``: where a clipped
    consequent meets its clip level (min implication) and where the largest rule changes
    (max aggregation), all bisected together (each output function evaluated once per
    step for every problem)."""
    var = fis.outputs[m]
    n = w.shape[0]
    live = [r for r, k in enumerate(cons) if k]
    if not live:
        return [np.empty(0) for _ in range(n)]
    used = sorted({abs(int(cons[r])) for r in live})
    column = {k: j for j, k in enumerate(used)}
    rule_mf = np.array([column.get(abs(int(k)), 0) for k in cons])
    rule_not = np.asarray(cons) < 0

    def table(y: np.ndarray) -> np.ndarray:  # every used consequent at y: (U, N)
        return np.stack([var.mfs[k - 1](y) for k in used])

    def pick(t: np.ndarray, r: np.ndarray) -> np.ndarray:
        f = t[rule_mf[r], np.arange(r.size)]
        return np.where(rule_not[r], 1.0 - f, f)

    T = table(sub)  # (U, S)
    rule_f = np.array(live)
    F = np.where(rule_not[rule_f, None], 1.0 - T[rule_mf[rule_f]], T[rule_mf[rule_f]])  # (R', S)
    W = w[:, live]  # (n, R')
    brackets = []
    if fis.imp_method == "min":  # a consequent meets its clip level
        brackets.append(_clip_brackets(W, F, sub, rule_f))
    if fis.agg_method == "max" and len(live) > 1:  # the largest rule changes
        brackets.append(_top_brackets(fis.imp_method, W, F, sub, rule_f))
    if not brackets:  # prod implication, sum or probor aggregation: no kinks of their own
        return [np.empty(0) for _ in range(n)]
    i, a, b, ra, rb, clip = (np.concatenate(parts) for parts in zip(*brackets, strict=True))
    pos = np.full(len(cons), -1)
    pos[rule_f] = np.arange(rule_f.size)
    roots = []
    for _ in range(_ROUNDS):
        if not i.size:
            break
        root = _solve(fis, table, pick, w, i, a, b, ra, rb, clip)
        roots.append((i, root))
        # a third rule on top at a change found between two sub-samples: the largest
        # rule changed more than once there; split at the root and solve both sides
        sw = ~clip
        t = table(root[sw])
        iw = i[sw]
        fl = np.where(rule_not[rule_f, None], 1.0 - t[rule_mf[rule_f]], t[rule_mf[rule_f]])
        g = _imp(fis.imp_method, w[iw][:, live].T, fl)  # (R', N)
        cols = np.arange(iw.size)
        best = g.argmax(axis=0)
        ends = np.maximum(g[pos[ra[sw]], cols], g[pos[rb[sw]], cols])
        more = g[best, cols] > ends * (1 + 1e-12)
        k = np.nonzero(more)[0]
        mid, top = root[sw][k], rule_f[best[k]]
        i = np.concatenate([iw[k], iw[k]])
        a = np.concatenate([a[sw][k], mid])
        b = np.concatenate([mid, b[sw][k]])
        ra = np.concatenate([ra[sw][k], top])
        rb = np.concatenate([top, rb[sw][k]])
        clip = np.zeros(i.size, bool)
    if not roots:
        return [np.empty(0) for _ in range(n)]
    i = np.concatenate([r[0] for r in roots])
    root = np.concatenate([r[1] for r in roots])
    order = np.argsort(i, kind="stable")
    split = np.searchsorted(i[order], np.arange(n + 1))
    return [root[order[split[k] : split[k + 1]]] for k in range(n)]


def _clip_brackets(W, F, sub, rule_f) -> tuple[np.ndarray, ...]:
    """(row, low, high, rule, rule, clip) of every sub-sample cell where a consequent
    crosses its rule's clip level (min implication)."""
    d = F[None, :, :] - W[:, :, None] > 0  # (n, R', S)
    i, r, j = np.nonzero(d[:, :, :-1] != d[:, :, 1:])
    return i, sub[j], sub[j + 1], rule_f[r], rule_f[r], np.ones(i.size, bool)


def _top_brackets(imp_method, W, F, sub, rule_f) -> tuple[np.ndarray, ...]:
    """(row, low, high, rule before, rule after, clip) of every sub-sample cell where
    the largest rule changes (max aggregation)."""
    top = _imp(imp_method, W[:, :, None], F[None, :, :]).argmax(axis=1)  # (n, S)
    i, j = np.nonzero(top[:, :-1] != top[:, 1:])
    r1, r2 = rule_f[top[i, j]], rule_f[top[i, j + 1]]
    return i, sub[j], sub[j + 1], r1, r2, np.zeros(i.size, bool)


def _solve(fis, table, pick, w, i, a, b, ra, rb, clip) -> np.ndarray:
    """Bisect every problem to adjacent floats: a clip crossing F_ra = w_ra (``clip``)
    or a change of the largest rule g_ra = g_rb, between ``a`` and ``b``."""
    w1, w2 = w[i, ra], w[i, rb]

    def h(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = table(y)
        f1 = pick(t, ra)
        g1, g2 = _imp(fis.imp_method, w1, f1), _imp(fis.imp_method, w2, pick(t, rb))
        return np.where(clip, f1 - w1, g1 - g2), f1

    s_lo = h(a)[0] > 0
    for _ in range(_BISECT):
        mid = 0.5 * (a + b)
        same = (h(mid)[0] > 0) == s_lo
        a = np.where(same, mid, a)
        b = np.where(same, b, mid)
    # a clip crossing: the end inside the clipped part, where mu equals the level exactly
    return np.where(clip & (h(a)[1] < w1), b, a)


def _pieces(fis, m: int, w: np.ndarray, cons: np.ndarray) -> np.ndarray:
    """Per input, the mesh with its kinks: (n, P) sorted (padded with the range's end)."""
    mesh = _mesh(fis, m)
    frac = np.arange(_SUB) / _SUB
    sub = np.append((mesh[:-1, None] + frac * np.diff(mesh)[:, None]).ravel(), mesh[-1])
    kinks = _kinks(fis, m, sub, w, cons)
    extra = max((k.size for k in kinks), default=0)
    pts = np.full((w.shape[0], mesh.size + extra), mesh[-1])
    pts[:, : mesh.size] = mesh
    for row, k in enumerate(kinks):
        pts[row, mesh.size : mesh.size + k.size] = k
    return np.sort(pts, axis=1)


def _gauss(fis, m, a: np.ndarray, b: np.ndarray, w, cons) -> tuple[np.ndarray, ...]:
    """Per interval [a, b] (n, K): nodes (n, K, Q) and the integrals of mu, y mu."""
    half = 0.5 * (b - a)
    y = (0.5 * (a + b))[..., None] + half[..., None] * _NODES
    mu = aggregate(fis, m, y, w, cons)
    area = half * (mu @ _WEIGHTS)
    moment = half * ((mu * y) @ _WEIGHTS)
    return y, mu, area, moment


def exact_defuzz(fis, m: int, w: np.ndarray, cons: np.ndarray) -> np.ndarray:
    """The defuzzified output ``m`` per input, exactly (see the module's docstring);
    the middle of the range where the aggregate has no area."""
    out = np.empty(w.shape[0])
    step = block_inputs(len(cons))
    for s in range(0, w.shape[0], step):
        out[s : s + step] = _exact_block(fis, m, w[s : s + step], cons)
    return out


def _exact_block(fis, m, w, cons) -> np.ndarray:
    var = fis.outputs[m]
    pts = _pieces(fis, m, w, cons)
    a, b = pts[:, :-1], pts[:, 1:]
    y, mu, area, moment = _gauss(fis, m, a, b, w, cons)
    total = area.sum(axis=1)
    has = total > 0
    safe = np.where(has, total, 1.0)
    method = fis.defuzz_method
    if method == "centroid":
        out = moment.sum(axis=1) / safe
    elif method == "bisector":
        out = _bisector(fis, m, w, cons, a, b, area, total)
    else:
        out = _of_max(fis, m, w, cons, pts, y, mu, method)
    return np.where(has, out, var.mid)


def _bisector(fis, m, w, cons, a, b, area, total) -> np.ndarray:
    rows = np.arange(w.shape[0])
    cum = np.cumsum(area, axis=1)
    half = 0.5 * total
    j = np.argmax(cum >= half[:, None], axis=1)
    before = np.where(j > 0, cum[rows, np.maximum(j - 1, 0)], 0.0)
    need = half - before
    left, lo, hi = a[rows, j], a[rows, j].copy(), b[rows, j].copy()
    for _ in range(_BISECT):
        x = 0.5 * (lo + hi)
        got = _gauss(fis, m, left[:, None], x[:, None], w, cons)[2][:, 0]
        reached = got >= need
        hi = np.where(reached, x, hi)
        lo = np.where(reached, lo, x)
    return hi


def _of_max(fis, m, w, cons, pts, y, mu, method) -> np.ndarray:
    n = w.shape[0]
    var_range = fis.outputs[m].range
    at_pts = aggregate(fis, m, pts, w, cons)
    top_pts = at_pts.max(axis=1)
    flat = mu.reshape(n, -1)
    top_nodes = flat.max(axis=1)
    out = np.empty(n)
    # a maximum inside a smooth piece: golden section on that piece
    inner = top_nodes > top_pts
    if inner.any():
        cell = flat[inner].argmax(axis=1) // _Q
        lo, hi = pts[inner, cell], pts[inner, cell + 1]
        wi = w[inner]
        g = (np.sqrt(5) - 1) / 2

        def f(x):
            return aggregate(fis, m, x[:, None], wi, cons)[:, 0]

        for _ in range(_GOLDEN):
            x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
            left_better = f(x1) >= f(x2)
            hi = np.where(left_better, x2, hi)
            lo = np.where(left_better, lo, x1)
        out[inner] = 0.5 * (lo + hi)
    rest = ~inner
    if rest.any():
        top = top_pts[:, None]
        eq = at_pts == top
        plateau = eq[:, :-1] & eq[:, 1:] & (mu == top[..., None]).all(axis=2)
        a, b = pts[:, :-1], pts[:, 1:]
        length = np.where(plateau, b - a, 0.0).sum(axis=1)
        if method == "mom":
            by_length = np.where(plateau, 0.5 * (a + b) * (b - a), 0.0).sum(axis=1)
            distinct = eq & np.concatenate([np.ones((n, 1), bool), np.diff(pts, axis=1) > 0], 1)
            by_points = (pts * distinct).sum(axis=1) / np.maximum(distinct.sum(axis=1), 1)
            res = np.where(length > 0, by_length / np.where(length > 0, length, 1.0), by_points)
        else:
            # a tie within rounding (1e-12 of the range: mirror-image kinks found by
            # bisection differ in the last bits) goes to the smaller y, as the Toolbox's
            tie = 1e-12 * (var_range[1] - var_range[0])
            res = _nearest(pts, eq, method == "lom", tie)
            if method == "som":  # 0 inside a plateau is its nearest point
                zero = (plateau & (a <= 0) & (b >= 0)).any(axis=1)
                res = np.where(zero, 0.0, res)
        out[rest] = res[rest]
    return out
