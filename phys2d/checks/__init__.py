"""The report card of a responder: the lecture's claims, measured (``phys2d check``).

``claims`` holds the claims (a scene, a measure and a bar each), ``card`` runs them on a
responder, prints the card, records failing scenes and is the command line's glue.
"""

from .card import Card, CheckError, Result, Stage, check, load
from .claims import CLAIMS, Claim, Outcome, Run

__all__ = ["CLAIMS", "Card", "CheckError", "Claim", "Outcome", "Result", "Run", "Stage", "check", "load"]
