"""Shapes: circles and convex polygons, their validation and mass properties.

Every body has exactly one shape. A shape is described in the body frame, whose
origin is the body's centre of mass ``x_b`` (docs/formulation.md#symbols-arrays-and-units): a polygon
given with its centroid elsewhere is re-centred, so the body's position is always
the centre of mass the lecture integrates.

Units: metres, kilograms, kg/m^2 for density (2D), kg*m^2 for inertia.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .validation import positive_float, vec2

__all__ = ["CIRCLE", "POLYGON", "ShapeSpec", "box", "circle", "mass_properties", "polygon", "positive_float"]

CIRCLE = 0
POLYGON = 1

MAX_POLYGON_VERTICES = 64
MIN_EDGE_LENGTH = 1e-4  # m: shorter edges make normals meaningless
_COLLINEAR_TOL = 1e-7  # sin of the smallest turn accepted between two edges


@dataclass(frozen=True)
class ShapeSpec:
    """A validated shape in its body frame, ready to be stored in the world's arrays."""

    kind: int  # CIRCLE or POLYGON
    radius: float  # m (0 for polygons)
    vertices: np.ndarray  # (n, 2) counter-clockwise, centroid at the origin (empty for circles)
    normals: np.ndarray  # (n, 2) outward unit normal of edge k = (v_k, v_k+1)
    centroid: np.ndarray  # (2,) where the given vertices' centroid was, in the given frame
    area: float  # m^2
    unit_inertia: float  # m^4: polar second moment of area about the centroid


def circle(radius) -> ShapeSpec:
    r = positive_float(radius, "radius")
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
    return ShapeSpec(POLYGON, 0.0, a.copy(), normals, centroid, area, float(second))


def mass_properties(spec: ShapeSpec, density: float) -> tuple[float, float]:
    """Mass (kg) and moment of inertia about the centre of mass (kg m^2)."""
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
