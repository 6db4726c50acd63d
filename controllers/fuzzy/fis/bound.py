"""The lookup table's proven error bound for a MATLAB FIS term (docs/fuzzy.md, "Any MATLAB
FIS"): :func:`fis_cell_bound`, what :func:`~controllers.fuzzy.table.table_bound` gives
for a table of a :class:`~controllers.fuzzy.fis.matlab.FisTerm`.

The argument, per table cell (a box of inputs):

1. *The interpolant* is a convex combination of the cell's four corner values, so it lies
   in [min corner, max corner]. If the term lies in [u-, u+] on the whole cell, then
   |u(x) - I u(x)| <= max(u+ - min corner, max corner - u-).
2. *Memberships.* Every Toolbox membership function f has a largest slope L (trimf
   1/(b - a) and 1/(c - b); gaussmf 1/(sigma sqrt(e)); gbellmf, for b >= 1/2,
   (2b/a) s^(2b-1)/(1 + s^2b)^2 at s^2b = (2b - 1)/(2b + 1); sigmf |a|/4; ...). On an input
   interval a unimodal function (trimf, trapmf, gaussmf, gauss2mf, gbellmf, sigmf, smf,
   zmf, pimf with b <= c) is least at an end and largest at an end or its peak, so its
   values there are its range; the others (dsigmf, psigmf, an overlapping pimf) are
   evaluated there too and every point is within h / 2 of an end, so they lie within
   L h / 2 of those values, clipped to [0, 1].
3. *Firing strengths.* min, prod, max, probor are increasing in every argument and NOT
   decreasing, so each rule's strength lies in [w-, w+] from the memberships' ranges.
4. *The output.* A Mamdani aggregate mu(y; w) increases with every w (min / prod
   implication, max / sum / probor aggregation), so on the cell mu(w-) <= mu <= mu(w+).
   Over all g between them the centroid is least for g = mu(w+) left of t and mu(w-)
   right of it, at the t with t = centroid (C(t) falls while t < C(t) and rises after):
   that is u-; u+ likewise with the sides swapped. The integrals are the exact
   evaluation's (:mod:`controllers.fuzzy.fis.exact`). The bisector b satisfies
   int_lo^b g = int_b^hi g, so it is above the least x with int_lo^x mu(w+) >=
   int_x^hi mu(w-), and below the largest x with int_lo^x mu(w-) <= int_x^hi mu(w+).
   A Sugeno output (wtaver) is a weighted mean of the rules' outputs z (linear: their
   range on the cell from its corners): its least value over the boxes of w and z is at
   z = z-, with w = w+ on the rules of smallest z and w- on the others, the split tried at
   every rule; wtsum is sum_r min(w- z-, w+ z-) and its maximum alike.
5. *Where nothing may fire* (the total of w- is 0) the term may be the middle of the
   output's range (the Toolbox's rule), so that joins [u-, u+]: a *jump cell*.

A margin of 1e-9 of the output's range covers the integration (1e-12) and rounding.
mom, som and lom (maximum-based, discontinuous in w) get no bound: a one-line refusal.
"""

from __future__ import annotations

import math

import numpy as np

from twolink.controllers.fuzzy.fis import exact as mx

__all__ = ["fis_cell_bound", "mf_range", "mf_slope"]

MARGIN = 1e-9  # of the output's range


def mf_slope(mf) -> float:
    """The largest |slope| of a Toolbox membership function (inf where it has none)."""
    p, k = mf.params, mf.kind

    def ratio(num: float, den: float) -> float:
        return num / den if den > 0 else math.inf

    if k == "trimf":
        return max(ratio(1, p[1] - p[0]), ratio(1, p[2] - p[1]))
    if k == "trapmf":
        return max(ratio(1, p[1] - p[0]), ratio(1, p[3] - p[2]))
    if k == "gaussmf":
        return 1 / (abs(p[0]) * math.sqrt(math.e))
    if k == "gauss2mf":
        return max(1 / (abs(p[0]) * math.sqrt(math.e)), 1 / (abs(p[2]) * math.sqrt(math.e)))
    if k == "gbellmf":
        a, b = abs(p[0]), p[1]
        if b < 0.5:
            return math.inf
        s2b = (2 * b - 1) / (2 * b + 1)
        s = s2b ** (1 / (2 * b))
        return 2 * b / a * s ** (2 * b - 1) / (1 + s2b) ** 2
    if k == "sigmf":
        return abs(p[0]) / 4
    if k in ("dsigmf", "psigmf"):
        return abs(p[0]) / 4 + abs(p[2]) / 4
    if k in ("smf", "zmf"):
        return ratio(2, p[1] - p[0])
    if k == "pimf":
        return ratio(2, p[1] - p[0]) + ratio(2, p[3] - p[2])
    raise ValueError(k)


def _peaks(mf) -> list[float]:
    """Points where the function takes its largest values (or may have a local maximum)."""
    p, k = mf.params, mf.kind
    if k == "trimf":
        return [p[1]]
    if k in ("trapmf", "pimf"):
        return [p[1], p[2]]
    if k in ("gaussmf",):
        return [p[1]]
    if k == "gauss2mf":
        s1, s2 = p[0] ** 2, p[2] ** 2
        return [p[1], p[3], (p[1] * s2 + p[3] * s1) / (s1 + s2)]
    if k == "gbellmf":
        return [p[2]]
    if k in ("dsigmf", "psigmf"):
        return [p[1], p[3]]
    return []


def _unimodal(mf) -> bool:
    """Non-decreasing then non-increasing, largest on :func:`_peaks` (or monotone)."""
    if mf.kind in ("trimf", "trapmf", "gaussmf", "gauss2mf", "gbellmf", "sigmf", "smf", "zmf"):
        return mf.kind != "gbellmf" or mf.params[1] > 0
    return mf.kind == "pimf" and mf.params[1] <= mf.params[2]


def mf_range(mf, x0: np.ndarray, x1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Proven [least, largest] value of ``mf`` on each interval [x0, x1] (step 2 of the
    module's argument): for a unimodal function its values at the ends and at its peaks
    inside; otherwise those values widened by its largest slope times h / 2."""
    pts = [x0, x1] + [np.clip(c, x0, x1) for c in _peaks(mf)]
    vals = np.stack([mf(p) for p in pts])
    lo, hi = vals.min(axis=0), vals.max(axis=0)
    if _unimodal(mf):
        return lo, hi
    slope = mf_slope(mf)
    if math.isinf(slope):
        return np.zeros_like(lo), np.ones_like(hi)
    pad = slope * (x1 - x0) / 2
    return np.maximum(lo - pad, 0.0), np.minimum(hi + pad, 1.0)


def _combine(method: str, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    if method in ("min",):
        return np.minimum(a, b)
    if method == "max":
        return np.maximum(a, b)
    if method == "prod":
        return a * b
    return a + b - a * b  # probor


def _firing_range(fis, boxes) -> tuple[np.ndarray, np.ndarray]:
    """[w-, w+] per rule: arrays (cells, rules); ``boxes`` per input (x0, x1) per cell."""
    ranges = [[mf_range(mf, *boxes[i]) for mf in var.mfs] for i, var in enumerate(fis.inputs)]
    cells = boxes[0][0].size
    lo = np.empty((cells, len(fis.rules)))
    hi = np.empty_like(lo)
    for r, rule in enumerate(fis.rules):
        is_and = rule.connection == 1
        method = fis.and_method if is_and else fis.or_method
        acc_lo = acc_hi = None
        for i, idx in enumerate(rule.antecedent):
            if idx == 0:
                v = np.full(cells, 1.0 if is_and else 0.0)
                v_lo, v_hi = v, v
            elif idx > 0:
                v_lo, v_hi = ranges[i][idx - 1]
            else:
                m_lo, m_hi = ranges[i][-idx - 1]
                v_lo, v_hi = 1.0 - m_hi, 1.0 - m_lo
            if acc_lo is None:
                acc_lo, acc_hi = v_lo, v_hi
            else:
                acc_lo, acc_hi = _combine(method, acc_lo, v_lo), _combine(method, acc_hi, v_hi)
        lo[:, r], hi[:, r] = acc_lo * rule.weight, acc_hi * rule.weight
    return lo, hi


def _least_crossing(fis, pts, w_left, w_right, cons, crossed) -> np.ndarray:
    """Per row, the least t in the output range with ``crossed(t, AL, ML, AR, MR)``: AL,
    ML the integrals of mu(w_left) and y mu(w_left) left of t, AR, MR those of
    mu(w_right) right of t. ``crossed`` must be false up to some t and true beyond."""
    a, b = pts[:, :-1], pts[:, 1:]
    _, _, al, ml = mx._gauss(fis, 0, a, b, w_left, cons)
    _, _, ar, mr = mx._gauss(fis, 0, a, b, w_right, cons)
    zero = np.zeros((pts.shape[0], 1))
    cal, cml = np.hstack([zero, al.cumsum(1)]), np.hstack([zero, ml.cumsum(1)])
    rar = ar.sum(1, keepdims=True) - np.hstack([zero, ar.cumsum(1)])
    rmr = mr.sum(1, keepdims=True) - np.hstack([zero, mr.cumsum(1)])
    hit = crossed(pts, cal, cml, rar, rmr)  # at every piece boundary
    hit[:, -1] = True
    k = np.argmax(hit, axis=1)
    rows = np.arange(pts.shape[0])
    j = np.maximum(k - 1, 0)  # the crossing lies in piece j (or at the range's start)
    lo, hi = pts[rows, j], pts[rows, k]
    base = [v[rows, j] for v in (cal, cml, rar, rmr)]
    start = lo.copy()
    for _ in range(mx._BISECT):
        t = 0.5 * (lo + hi)
        _, _, pl, pml = mx._gauss(fis, 0, start[:, None], t[:, None], w_left, cons)
        _, _, pr, pmr = mx._gauss(fis, 0, start[:, None], t[:, None], w_right, cons)
        now = crossed(
            t, base[0] + pl[:, 0], base[1] + pml[:, 0], base[2] - pr[:, 0], base[3] - pmr[:, 0]
        )
        hi = np.where(now, t, hi)
        lo = np.where(now, lo, t)
    return np.where(k == 0, pts[:, 0], hi)


def _centroid(t, al, ml, ar, mr):
    area = al + ar
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(area > 0, (ml + mr) / area, np.inf)


def _mamdani_range(fis, w_lo, w_hi, cons) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """[u-, u+] of the output over the cells' boxes of w (step 4), and where the least
    aggregate has no area (the output may be the range's middle there)."""
    lo_out, hi_out, empty = [], [], []
    for s in range(0, w_lo.shape[0], mx._CHUNK):
        wl, wh = w_lo[s : s + mx._CHUNK], w_hi[s : s + mx._CHUNK]
        pts = np.sort(np.hstack([mx._pieces(fis, 0, wl, cons), mx._pieces(fis, 0, wh, cons)]), 1)
        area_lo = mx._gauss(fis, 0, pts[:, :-1], pts[:, 1:], wl, cons)[2].sum(1)
        empty.append(area_lo <= 0)
        if fis.defuzz_method == "centroid":

            def past(left, right):
                return lambda t, al, ml, ar, mr: t >= _centroid(t, al, ml, ar, mr)

            u_lo = _least_crossing(fis, pts, wh, wl, cons, past(wh, wl))
            u_hi = _least_crossing(fis, pts, wl, wh, cons, past(wl, wh))
            # the extreme centroid is the fixed point t = C(t) that the crossing finds
        else:  # bisector: the least x with F_left(x) >= G_right(x)
            u_lo = _least_crossing(fis, pts, wh, wl, cons, lambda t, al, ml, ar, mr: al >= ar)
            u_hi = _least_crossing(fis, pts, wl, wh, cons, lambda t, al, ml, ar, mr: al >= ar)
        lo_out.append(u_lo)
        hi_out.append(u_hi)
    return np.concatenate(lo_out), np.concatenate(hi_out), np.concatenate(empty)


def _sugeno_range(fis, w_lo, w_hi, boxes) -> tuple[np.ndarray, np.ndarray]:
    """[u-, u+] of a Sugeno output over the cells' boxes of w and x (step 4)."""
    var = fis.outputs[0]
    corners = [(boxes[0][i], boxes[1][j]) for i in (0, 1) for j in (0, 1)]
    z = []
    for rule in fis.rules:
        k = rule.consequent[0]
        if k == 0:
            z.append((np.zeros_like(w_lo[:, 0]),) * 2)
            continue
        mf = var.mfs[k - 1]
        vals = np.stack([mx_value(mf, np.stack(c, axis=1)) for c in corners])
        z.append((vals.min(axis=0), vals.max(axis=0)))
    z_lo = np.stack([v[0] for v in z], axis=1)
    z_hi = np.stack([v[1] for v in z], axis=1)
    if fis.defuzz_method == "wtsum":
        return (np.minimum(w_lo * z_lo, w_hi * z_lo).sum(1),
                np.maximum(w_lo * z_hi, w_hi * z_hi).sum(1))  # fmt: skip
    return _mean_extreme(w_lo, w_hi, z_lo, False), _mean_extreme(w_lo, w_hi, z_hi, True)


def mx_value(mf, x: np.ndarray) -> np.ndarray:
    from twolink.controllers.fuzzy.fis.matlab import _sugeno_value

    return _sugeno_value(mf, x)


def _mean_extreme(w_lo, w_hi, z, largest: bool) -> np.ndarray:
    """Least (largest) sum(w z) / sum(w) over w in [w_lo, w_hi]: w_hi on the rules of
    smallest (largest) z, w_lo on the others, the split tried at every rule."""
    order = np.argsort(-z if largest else z, axis=1)
    zs = np.take_along_axis(z, order, 1)
    lo, hi = np.take_along_axis(w_lo, order, 1), np.take_along_axis(w_hi, order, 1)
    zero = np.zeros((z.shape[0], 1))
    head_w, head_m = np.hstack([zero, hi.cumsum(1)]), np.hstack([zero, (hi * zs).cumsum(1)])
    tail_w = lo.sum(1, keepdims=True) - np.hstack([zero, lo.cumsum(1)])
    tail_m = (lo * zs).sum(1, keepdims=True) - np.hstack([zero, (lo * zs).cumsum(1)])
    w, m = head_w + tail_w, head_m + tail_m
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = np.where(w > 0, m / w, -np.inf if largest else np.inf)
    return mean.max(1) if largest else mean.min(1)


def fis_cell_bound(table) -> tuple[np.ndarray, np.ndarray]:
    """Per cell of a lookup table of a :class:`FisTerm`: the proven bound on |term - table|
    (normalised output; before the table's rounding margin) and the jump cells, by the
    module's argument. :func:`~controllers.fuzzy.table.table_bound` makes it a
    ``TableBound``."""
    term = table.exact
    fis = term.fis
    if fis.type == "mamdani" and fis.defuzz_method in ("mom", "som", "lom"):
        raise ValueError(
            f"{fis.source}: the table's proven bound covers centroid, bisector, wtaver and "
            f"wtsum; {fis.defuzz_method} (maximum-based, discontinuous) has none"
        )
    re_, rd, ru = term._scale
    (e_lo, e_hi), (d_lo, d_hi) = fis.inputs[0].range, fis.inputs[1].range
    ex = np.clip(table.e_nodes * re_, e_lo, e_hi)
    dx = np.clip(table.de_nodes * rd, d_lo, d_hi)
    n1 = table.points - 1
    boxes = [(np.repeat(ex[:-1], n1), np.repeat(ex[1:], n1)),
             (np.tile(dx[:-1], n1), np.tile(dx[1:], n1))]  # fmt: skip
    w_lo, w_hi = _firing_range(fis, boxes)
    var = fis.outputs[0]
    if fis.type == "sugeno":
        u_lo, u_hi = _sugeno_range(fis, w_lo, w_hi, boxes)
        jump = w_lo.sum(1) <= 0
    else:
        cons = np.array([r.consequent[0] for r in fis.rules])
        u_lo, u_hi, empty = _mamdani_range(fis, w_lo, w_hi, cons)
        jump = (w_lo.sum(1) <= 0) | empty
    never = w_hi.sum(1) <= 0  # nothing can fire: the middle of the range, exactly
    u_lo = np.where(never, var.mid, np.where(jump, np.minimum(u_lo, var.mid), u_lo))
    u_hi = np.where(never, var.mid, np.where(jump, np.maximum(u_hi, var.mid), u_hi))
    v = table.values
    c = np.stack([v[:-1, :-1], v[1:, :-1], v[:-1, 1:], v[1:, 1:]]).reshape(4, -1)
    span = max(var.range[1] - var.range[0], abs(var.mid), 1.0)
    cell = np.maximum(u_hi / ru - c.min(0), c.max(0) - u_lo / ru)
    cell = np.maximum(cell, 0.0) + MARGIN * span / ru
    return cell.reshape(n1, n1), jump.reshape(n1, n1)
