"""Constraints as Jacobian rows (docs/formulation.md#constraint-rows)."""
