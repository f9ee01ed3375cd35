"""Constraints as Jacobian rows (docs/formulation.md, "Constraint rows")."""
