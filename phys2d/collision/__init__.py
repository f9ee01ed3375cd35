"""Collision detection: broadphase candidate pairs, then narrowphase manifolds (recycled while
pairs barely move: ``recycle``)."""

from .narrowphase import Feature, describe_feature

__all__ = ["Feature", "describe_feature"]
