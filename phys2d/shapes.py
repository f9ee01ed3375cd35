"""Shapes: circles, convex polygons, capsules, segments and chain segments; their validation
and mass properties.

Every body has exactly one shape. A capsule, a segment and a chain segment are rounded
two-vertex polygons: a core segment v_0 v_1 (edge 0 runs v_0 -> v_1, edge 1 back) swept by a
disc of ``radius`` (0 for a bare segment), so the polygon narrowphase serves them with a
radius (docs/formulation.md#rounded-polygons-capsules-segments-and-chains). A chain segment
also keeps its neighbours' far ends, its ghost vertices, which make it one-sided and smooth.

A shape is described in the body frame, whose
origin is the body's centre of mass ``x_b`` (docs/formulation.md#symbols-arrays-and-units): a polygon
given with its centroid elsewhere is re-centred, so the body's position is always
the centre of mass the lecture integrates.

Units: metres, kilograms, kg/m^2 for density (2D), kg*m^2 for inertia. Sizes: every radius, half
extent and half length, and a polygon's reach from its centroid, lies in [MIN_SIZE, MAX_SIZE] =
[1 mm, 100 km]; densities in [1e-6, 1e6] kg/m^2 (``bodies.MIN_DENSITY``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from .validation import non_negative_float, positive_float, vec2

__all__ = [
    "CAPSULE", "CHAIN", "CIRCLE", "KIND_NAMES", "MAX_SIZE", "MIN_SIZE", "POLYGON", "SEGMENT", "ShapeSpec", "box",
    "capsule", "chain", "circle", "mass_properties", "polygon", "positive_float", "rounded_area_properties", "segment",
    "size",
]  # fmt: skip

CIRCLE = 0
POLYGON = 1
CAPSULE = 2  # a rounded segment, dynamic like any body
SEGMENT = 3  # a static segment, two-sided, optionally rounded
CHAIN = 4  # a static segment of a chain: one-sided, with ghost vertices
KIND_NAMES = ("circle", "polygon", "capsule", "segment", "chain")  # by kind

MAX_POLYGON_VERTICES = 64
MIN_EDGE_LENGTH = 1e-4  # m: shorter edges make normals meaningless
# The sizes a shape may have (Box2D's are the guide: its linear slop of 5 mm, its 100 km "huge"):
# every radius, half extent and half length, a polygon's reach from its centroid (its largest
# |x| or |y|), a segment's half length. Smaller shapes slip through the contact margin and slop; larger ones lose the
# millimetres of float64 that contact needs.
MIN_SIZE = 1e-3  # m
MAX_SIZE = 1e5  # m
_COLLINEAR_TOL = 1e-7  # sin of the smallest turn accepted between two edges


@dataclass(frozen=True)
class ShapeSpec:
    """A validated shape in its body frame, ready to be stored in the world's arrays."""

    kind: int  # CIRCLE, POLYGON, CAPSULE, SEGMENT or CHAIN
    radius: float  # m: the circle's, or the rounding of a capsule or segment (0 for polygons)
    vertices: np.ndarray  # (n, 2) counter-clockwise, centroid at the origin (empty for circles)
    normals: np.ndarray  # (n, 2) outward unit normal of edge k = (v_k, v_k+1)
    centroid: np.ndarray  # (2,) where the given vertices' centroid was, in the given frame
    area: float  # m^2
    unit_inertia: float  # m^4: polar second moment of area about the centroid
    ghosts: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # (2, 2) chain segments only:
    # the previous segment's first point and the next one's last, in the body frame


def size(value, name: str) -> float:
    """``value`` as a length in [MIN_SIZE, MAX_SIZE] (m): a radius, half extent or half length."""
    v = positive_float(value, name)
    if not MIN_SIZE <= v <= MAX_SIZE:
        raise ValueError(f"{name} must be between {MIN_SIZE:g} m and {MAX_SIZE:g} m (phys2d's sizes), got {v:g}")
    return v


def _reach(vertices: np.ndarray, name: str) -> None:
    """Check a polygon's reach, the largest |x| or |y| of its vertices about the centroid (a box's
    larger half extent), against the sizes."""
    reach = float(np.max(np.abs(vertices)))
    if not MIN_SIZE <= reach <= MAX_SIZE:
        raise ValueError(
            f"{name} reach {reach:.3g} m from their centroid: a shape must reach between {MIN_SIZE:g} m and "
            f"{MAX_SIZE:g} m (phys2d's sizes)"
        )


def circle(radius) -> ShapeSpec:
    r = size(radius, "radius")
    area = math.pi * r * r
    unit_inertia = 0.5 * area * r * r
    if not (0.0 < unit_inertia < math.inf):  # r^4 underflows to 0 or overflows
        raise ValueError(f"radius {r:g} m is too small or too large for finite, non-zero area and inertia")
    empty = np.zeros((0, 2))
    return ShapeSpec(CIRCLE, r, empty, empty, np.zeros(2), area, unit_inertia)


def box(half_extents) -> ShapeSpec:
    h = vec2(half_extents, "half_extents")
    if np.any(h <= 0.0):
        raise ValueError(f"half_extents must both be > 0, got {h.tolist()}")
    if not np.all((MIN_SIZE <= h) & (h <= MAX_SIZE)):
        raise ValueError(
            f"half_extents must both be between {MIN_SIZE:g} m and {MAX_SIZE:g} m (phys2d's sizes), got {h.tolist()}"
        )
    return _box(float(h[0]), float(h[1]))


@functools.lru_cache(maxsize=256)
def _box(hx: float, hy: float) -> ShapeSpec:
    """The box of half extents hx, hy (m), checked and measured once per size: a scene of many
    equal boxes shares one spec (its arrays are read-only; a body copies them)."""
    spec = polygon([(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)], name="half_extents")
    for array in (spec.vertices, spec.normals, spec.centroid):
        array.flags.writeable = False
    return spec


def polygon(vertices, name: str = "vertices") -> ShapeSpec:
    """Validate a convex counter-clockwise polygon and compute its area properties."""
    if isinstance(vertices, (str, bytes)):
        raise TypeError(f"{name} must be a sequence of (x, y) points")
    try:
        v = np.asarray(vertices)
    except Exception as exc:
        raise TypeError(f"{name} must be a sequence of (x, y) points: {exc}") from None
    if v.dtype == object or v.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be a sequence of (x, y) points of numbers")
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"{name} must have shape (n, 2), got shape {v.shape}")
    n = v.shape[0]
    if n < 3:
        raise ValueError(f"{name} needs at least 3 points, got {n}")
    if n > MAX_POLYGON_VERTICES:
        raise ValueError(f"{name} may have at most {MAX_POLYGON_VERTICES} points, got {n}")
    v = v.astype(np.float64)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite")
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # checked below, named
        return _convex_polygon(v, name)


def _convex_polygon(v: np.ndarray, name: str) -> ShapeSpec:
    """The checks and area properties of ``polygon`` for finite (n, 2) vertices."""
    n = v.shape[0]
    e = np.roll(v, -1, axis=0) - v  # edge k runs from v_k to v_k+1
    length = np.hypot(e[:, 0], e[:, 1])
    if not np.all(np.isfinite(length)):
        raise ValueError(f"{name} is too large: its edges overflow a float")
    if np.any(length < MIN_EDGE_LENGTH):
        k = int(np.argmin(length))
        raise ValueError(
            f"{name}: edge {k} is {length[k]:.3g} m long (shorter than {MIN_EDGE_LENGTH} m): "
            "repeated or too-close points"
        )
    e_next = np.roll(e, -1, axis=0)
    turn = (e[:, 0] * e_next[:, 1] - e[:, 1] * e_next[:, 0]) / (length * np.roll(length, -1))
    if not np.all(np.isfinite(turn)):
        raise ValueError(f"{name} is too large: its turning angles overflow a float")
    if np.all(turn < -_COLLINEAR_TOL):
        raise ValueError(f"{name} must be counter-clockwise, got clockwise order")
    if np.any(np.abs(turn) <= _COLLINEAR_TOL):
        k = int(np.argmin(np.abs(turn)))
        raise ValueError(f"{name}: points {k}, {(k + 1) % n}, {(k + 2) % n} are collinear")
    if np.any(turn < 0.0):
        raise ValueError(f"{name} must be convex (it turns both ways)")
    # all turns are left: convex unless it winds more than once (a star such as a pentagram)
    total_turn = float(np.sum(np.arctan2(turn, np.einsum("ij,ij->i", e, e_next) / (length * np.roll(length, -1)))))
    if total_turn > 2.0 * math.pi + 1e-6:
        raise ValueError(f"{name} is self-intersecting (it winds {total_turn / (2 * math.pi):.0f} times)")
    # area, centroid and polar moment by a fan of triangles from the origin
    a, b = v, np.roll(v, -1, axis=0)
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    area = 0.5 * float(np.sum(cross))
    if not area > 0.0 or not math.isfinite(area):
        raise ValueError(f"{name} encloses no positive finite area (area = {area})")
    centroid = np.sum((a + b) * cross[:, None], axis=0) / (6.0 * area)
    a, b = a - centroid, b - centroid
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    second = (
        np.sum(cross * (np.einsum("ij,ij->i", a, a) + np.einsum("ij,ij->i", a, b) + np.einsum("ij,ij->i", b, b))) / 12.0
    )
    if not (0.0 < second < math.inf):
        raise ValueError(f"{name} is too large: its moment of inertia overflows")
    normals = np.stack([e[:, 1], -e[:, 0]], axis=1) / length[:, None]
    _reach(a, name)
    return ShapeSpec(POLYGON, 0.0, a.copy(), normals, centroid, area, float(second))


def rounded_area_properties(half_length: float, radius: float) -> tuple[float, float]:
    """Area (m^2) and polar second moment about the centre (m^4) of a capsule: a rectangle
    2 h x 2 r and two half discs of radius r on its ends (h = half_length, r = radius, m).

    A = 4 h r + pi r^2. J = 4 h r (4 h^2 + 4 r^2) / 12 for the rectangle, and for the discs
    pi r^2 (r^2 / 2 + h^2 + 2 h l_c) by the parallel axis theorem, each half's centroid
    l_c = 4 r / (3 pi) beyond its end of the core.
    """
    h, r = half_length, radius
    rectangle = 4.0 * h * r
    disc = math.pi * r * r
    j_rectangle = rectangle * (4.0 * h * h + 4.0 * r * r) / 12.0
    j_discs = disc * (0.5 * r * r + h * h + 2.0 * h * (4.0 * r / (3.0 * math.pi)))
    return rectangle + disc, j_rectangle + j_discs


def _core(a: np.ndarray, b: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The core segment a -> b as a two-vertex polygon centred on its midpoint: (vertices, normals,
    midpoint, half length m); edge 0 runs a -> b with its normal on the right, edge 1 back."""
    d = b - a
    with np.errstate(over="ignore", invalid="ignore"):
        length = float(np.hypot(d[0], d[1]))
    if not math.isfinite(length):
        raise ValueError(f"{name} is too large: its length overflows a float")
    if length < MIN_EDGE_LENGTH:
        raise ValueError(
            f"{name}: its points are {length:.3g} m apart (closer than {MIN_EDGE_LENGTH} m): "
            "repeated or too-close points"
        )
    if 0.5 * length > MAX_SIZE:
        raise ValueError(f"{name}: its points are {length:.3g} m apart: a segment is at most {2 * MAX_SIZE:g} m long")
    mid = 0.5 * (a + b)
    n = np.array([d[1], -d[0]]) / length
    return np.stack([a - mid, b - mid]), np.stack([n, -n]), mid, 0.5 * length


def _rounded(kind: int, vertices: np.ndarray, normals: np.ndarray, centre: np.ndarray, h: float, r: float) -> ShapeSpec:
    area, second = rounded_area_properties(h, r)
    if not (math.isfinite(area) and math.isfinite(second)):
        raise ValueError(f"radius {r:g} m and half_length {h:g} m are too large for a finite area and inertia")
    return ShapeSpec(kind, r, vertices, normals, centre, area, second)


def capsule(half_length, radius) -> ShapeSpec:
    """A capsule along the body's x axis: the core from (-half_length, 0) to (half_length, 0) (m),
    rounded by ``radius`` (m): a stadium 2 (half_length + radius) long and 2 radius wide."""
    h = positive_float(half_length, "half_length")
    r = size(radius, "radius")
    if 2.0 * h < MIN_EDGE_LENGTH:
        raise ValueError(f"half_length must be >= {0.5 * MIN_EDGE_LENGTH} m, got {h:g}: use add_circle for a disc")
    if h > MAX_SIZE:
        raise ValueError(f"half_length must be at most {MAX_SIZE:g} m (phys2d's sizes), got {h:g}")
    vertices, normals, _, _ = _core(np.array([-h, 0.0]), np.array([h, 0.0]), "half_length")
    spec = _rounded(CAPSULE, vertices, normals, np.zeros(2), h, r)
    if not spec.unit_inertia > 0.0:
        raise ValueError(f"radius {r:g} m is too small for a non-zero inertia")
    return spec


def segment(a, b, radius=0.0) -> ShapeSpec:
    """A static segment from world point ``a`` to ``b`` (m), rounded by ``radius`` (m, >= 0); its
    centroid (the body's position) is their midpoint. Two-sided."""
    pa, pb = vec2(a, "a"), vec2(b, "b")
    r = non_negative_float(radius, "radius")
    if r != 0.0:  # 0: a bare segment
        size(r, "radius")
    vertices, normals, mid, h = _core(pa, pb, "a, b")
    return _rounded(SEGMENT, vertices, normals, mid, h, r)


def chain(points, loop: bool = False) -> list[ShapeSpec]:
    """The segments of a chain through ``points`` (m, world), each a CHAIN spec whose centroid is
    its midpoint and whose ghosts are its neighbours' far ends.

    A chain segment collides from its right only (the side its normal, the right-hand
    perpendicular of p_k -> p_k+1, points to): the outside of a counter-clockwise loop,
    the top of a ground listed right to left. An open chain's free ends get a ghost a
    quarter turn back (p_0 - n_0 and p_n - n_last): a quarter-round end on the colliding side.
    """
    if isinstance(points, (str, bytes)):
        raise TypeError("points must be a sequence of (x, y) points")
    try:
        p = np.asarray(points)
    except Exception as exc:
        raise TypeError(f"points must be a sequence of (x, y) points: {exc}") from None
    if p.dtype == object or p.dtype.kind not in "iuf":
        raise TypeError("points must be a sequence of (x, y) points of numbers")
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got shape {p.shape}")
    p = p.astype(np.float64)
    n = p.shape[0]
    if n < (3 if loop else 2):
        need = 3 if loop else 2
        raise ValueError(f"points needs at least {need} points for {'a loop' if loop else 'a chain'}, got {n}")
    if not np.all(np.isfinite(p)):
        k = int(np.flatnonzero(~np.all(np.isfinite(p), axis=1))[0])
        raise ValueError(f"points must be finite: point {k} is {p[k].tolist()}")
    ends = [(k, (k + 1) % n) for k in range(n if loop else n - 1)]
    cores = []
    for k, (i, j) in enumerate(ends):
        cores.append(_core(p[i], p[j], f"points {i} and {j} (segment {k})"))
    specs = []
    for k, (i, j) in enumerate(ends):
        vertices, normals, mid, h = cores[k]
        if loop or k > 0:
            before = p[(i - 1) % n]
        else:  # a free end: a quarter turn back along the normal
            before = p[i] - normals[0]
        if loop or k < len(ends) - 1:
            after = p[(j + 1) % n]
        else:
            after = p[j] - normals[0]
        ghosts = np.stack([before - mid, after - mid])
        specs.append(ShapeSpec(CHAIN, 0.0, vertices, normals, mid, 0.0, 0.0, ghosts))
    return specs


def mass_properties(spec: ShapeSpec, density: float) -> tuple[float, float]:
    """Mass (kg) and moment of inertia about the centre of mass (kg m^2); (0, 0) for a bare
    segment or chain segment, which has no area (it is always static)."""
    if spec.kind in (SEGMENT, CHAIN) and spec.area == 0.0:
        return 0.0, 0.0
    mass = density * spec.area
    inertia = density * spec.unit_inertia
    # M^-1 = (1/m, 1/m, 1/I) must be finite too: a subnormal mass would give an infinite one
    if not (
        0.0 < mass < math.inf
        and 0.0 < inertia < math.inf
        and math.isfinite(1.0 / mass)
        and math.isfinite(1.0 / inertia)
    ):
        raise ValueError(
            f"density and size give a mass of {mass:.3g} kg and inertia {inertia:.3g} kg m^2: "
            "both must be finite and > 0, with finite inverses"
        )
    return mass, inertia
