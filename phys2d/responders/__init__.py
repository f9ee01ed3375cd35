"""Collision responders: swappable strategies that turn constraint rows into impulses."""
