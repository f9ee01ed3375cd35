"""Collision detection: broadphase candidate pairs, then narrowphase manifolds."""
