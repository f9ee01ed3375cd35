"""Collision at a world's current positions, outside its step: a second method for the tests."""

from __future__ import annotations

import numpy as np

import phys2d
from phys2d import shapes as shapes_module
from phys2d.collision.broadphase import find_pairs, update_geometry
from phys2d.collision.narrowphase import collide_pairs
from phys2d.pipeline import records
from phys2d.pipeline.step import ContactBuffers


def records_now(w: phys2d.World, V: np.ndarray, pairs: np.ndarray, dt: float = 1 / 60) -> tuple:
    """Records of w's bodies (moving with V) and shapes (with ``pairs``) over fresh geometry buffers
    (rotations NaN until written), the geometry at the current positions (``update_geometry``) for a
    step of dt, and that geometry: (bodies, shapes, geometry, whether the fat boxes held)."""
    b = w._bodies
    n, nv = b.n, b.n_verts
    rotation = np.full((n, 2), np.nan)
    geometry = (rotation, np.empty((nv, 2)), np.empty((nv, 2)), np.empty((n, 4)), np.zeros((n, 4)), np.empty(n))
    shapes = records.new_shapes(
        (b.static, b.uid, b.friction, b.restitution, b.kind, b.radius, b.vstart, b.vcount, b.local_v, b.local_n,
         *geometry, pairs, np.zeros(pairs.shape[0], np.int32), w._joints.excluded, b.category, b.mask, b.group,
         np.zeros(n, np.int32))
    )  # fmt: skip
    bodies = records.new_bodies((b.x, b.theta, V, b.M_inv, V))
    fits = update_geometry(bodies, shapes, dt, w.contact_margin)
    return bodies, shapes, geometry, fits


def manifolds_of(w: phys2d.World, bodies, shapes, n_pairs: int) -> phys2d.Contacts:
    """The narrowphase's contacts (``collide_pairs``) of the first n_pairs pairs of ``shapes``."""
    out = ContactBuffers(n_pairs)
    rounded = True if bool(np.any(w.body_kinds > shapes_module.POLYGON)) else None  # as the tick's
    k = collide_pairs(bodies, shapes, n_pairs, w.contact_margin, records.new_contacts(
        records.arrays_of(out, records.CONTACT_FIELDS)), rounded)  # fmt: skip
    return out.contacts(k)


def contacts_now(w: phys2d.World) -> phys2d.Contacts:
    """The contacts of w at its current positions, nothing moved: the broadphase (``find_pairs``) and
    the narrowphase, with no travel (dt = 0)."""
    n = len(w.bodies)
    pairs = np.zeros((max(1, n * (n - 1) // 2), 2), np.int32)
    bodies, shapes, _, _ = records_now(w, w.V, pairs, dt=0.0)
    n_pairs = find_pairs(shapes)
    return manifolds_of(w, bodies, shapes, n_pairs)
