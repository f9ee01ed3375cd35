"""Constraints as Jacobian rows (FORMULATION.md, "Constraint rows")."""
