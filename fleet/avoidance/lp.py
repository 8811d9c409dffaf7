"""The 2D linear programs of ORCA, after RVO2 (van den Berg et al. 2011, `Agent.cpp`).

A constraint is a directed line (px, py, dx, dy) with |d| = 1; the permitted half-plane lies to its left.
`solve` returns the velocity inside the speed disc closest to the preferred one that satisfies every line;
when the lines conflict (a crowded robot), it minimises the largest violation of the reciprocal lines while
keeping the first `hard` lines (static obstacles) satisfied, as RVO2's linearProgram3 does.
Pure Python floats on purpose: a robot has ~10 lines, where numpy call overhead would dominate.
"""

from __future__ import annotations

import math

Line = tuple[float, float, float, float]
Vec = tuple[float, float]
EPS = 1e-9


def _det(ax: float, ay: float, bx: float, by: float) -> float:
    return ax * by - ay * bx


def _lp1(lines: list[Line], i: int, radius: float, opt: Vec, direction_opt: bool) -> Vec | None:
    """Best point on line i within the disc and the half-planes of lines[:i]; None if empty."""
    px, py, dx, dy = lines[i]
    dot = px * dx + py * dy
    disc = dot * dot + radius * radius - (px * px + py * py)
    if disc < 0.0:
        return None
    s = math.sqrt(disc)
    t_left, t_right = -dot - s, -dot + s
    for j in range(i):
        qx, qy, ex, ey = lines[j]
        denom = _det(dx, dy, ex, ey)
        numer = _det(ex, ey, px - qx, py - qy)
        if abs(denom) <= EPS:  # parallel lines
            if numer < 0.0:
                return None
            continue
        t = numer / denom
        if denom >= 0.0:
            t_right = min(t_right, t)
        else:
            t_left = max(t_left, t)
        if t_left > t_right:
            return None
    if direction_opt:
        t = t_right if opt[0] * dx + opt[1] * dy > 0.0 else t_left
    else:
        t = min(max(dx * (opt[0] - px) + dy * (opt[1] - py), t_left), t_right)
    return px + t * dx, py + t * dy


def _lp2(lines: list[Line], radius: float, opt: Vec, direction_opt: bool) -> tuple[int, Vec]:
    """Returns (index of the first line that could not be satisfied or len(lines), result)."""
    if direction_opt:
        result = (opt[0] * radius, opt[1] * radius)
    else:
        n = math.hypot(*opt)
        result = (opt[0] / n * radius, opt[1] / n * radius) if n > radius else opt
    for i, (px, py, dx, dy) in enumerate(lines):
        if _det(dx, dy, px - result[0], py - result[1]) > 0.0:  # result violates line i
            r = _lp1(lines, i, radius, opt, direction_opt)
            if r is None:
                return i, result
            result = r
    return len(lines), result


def _lp3(lines: list[Line], hard: int, begin: int, radius: float, result: Vec) -> Vec:
    """Minimise the largest violation of lines[hard:], lines[:hard] kept (RVO2 linearProgram3)."""
    distance = 0.0
    for i in range(begin, len(lines)):
        px, py, dx, dy = lines[i]
        if _det(dx, dy, px - result[0], py - result[1]) <= distance:
            continue
        proj = list(lines[:hard])
        for j in range(hard, i):
            qx, qy, ex, ey = lines[j]
            det = _det(dx, dy, ex, ey)
            if abs(det) <= EPS:
                if dx * ex + dy * ey > 0.0:
                    continue  # same direction: line j is implied
                point = (0.5 * (px + qx), 0.5 * (py + qy))
            else:
                t = _det(ex, ey, px - qx, py - qy) / det
                point = (px + t * dx, py + t * dy)
            ux, uy = ex - dx, ey - dy
            n = math.hypot(ux, uy)
            proj.append((point[0], point[1], ux / n, uy / n))
        fail, r = _lp2(proj, radius, (-dy, dx), True)
        if fail >= len(proj):  # otherwise keep the previous result (numerical corner case, as RVO2)
            result = r
        distance = _det(dx, dy, px - result[0], py - result[1])
    return result


def solve(lines: list[Line], hard: int, radius: float, preferred: Vec) -> Vec:
    """The velocity closest to `preferred` within `radius` that satisfies `lines` (first `hard` strictly)."""
    fail, result = _lp2(lines, radius, preferred, False)
    if fail < len(lines):
        result = _lp3(lines, hard, fail, radius, result)
    return result
