"""The built-in responders' report cards in docs/your-responder.md, regenerated from the code.

    python -m tests.card_docs            write the --quick cards into the doc, between its markers
    python -m tests.card_docs --check    exit 1 when the doc's cards differ from the code's

tests/test_check.py runs the check. Lines are compared word for word, figures to within 5 %
(or 1e-9 of their unit: the figures at rounding level, such as 1e-14 %, differ with the
machine).
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import phys2d
from phys2d.checks import Card

DOC = Path(__file__).resolve().parents[1] / "docs" / "your-responder.md"
RESPONDERS = ("pgs", "soft-step", "iterative", "naive")  # phys2d.make_responder's names
BEGIN = "<!-- the built-in responders' --quick cards, from `python -m tests.card_docs` -->"
END = "<!-- end of the built-in responders' cards -->"
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?")


def card_lines(card: Card) -> list[str]:
    """A card as the doc shows it: the summary, each line without its note, the hints."""
    lines = [card.summary()] + [r.line(notes=False) for r in card.results]
    hints = card.hints()
    if hints:
        lines += ["hints, from what the card measured:"] + [f"  {h}" for h in hints]
    return lines


def block(cards: list[Card]) -> str:
    """The doc's block of cards: a fenced text block, the cards one after another."""
    body = "\n\n".join("\n".join(card_lines(c)) for c in cards)
    return f"{BEGIN}\n\n```text\n{body}\n```\n\n{END}"


def in_doc(text: str) -> str:
    """The block of cards the doc holds now."""
    start, end = text.index(BEGIN), text.index(END) + len(END)
    return text[start:end]


def differences(shown: str, measured: str) -> list[str]:
    """The lines where the doc's block differs from the code's: words exactly, figures to 5 %."""
    a, b = shown.splitlines(), measured.splitlines()
    if len(a) != len(b):
        return [f"{len(a)} lines in the doc, {len(b)} measured"]
    out = []
    for x, y in zip(a, b, strict=True):
        if NUMBER.sub("#", x) != NUMBER.sub("#", y):
            out.append(f"doc:  {x}\ncode: {y}")
            continue
        for p, q in zip(NUMBER.findall(x), NUMBER.findall(y), strict=True):
            if not math.isclose(float(p), float(q), rel_tol=0.05, abs_tol=1e-9):
                out.append(f"doc:  {x}\ncode: {y}")
                break
    return out


def cards() -> list[Card]:
    """The --quick cards of the built-in responders (nothing recorded, nothing printed)."""
    return [phys2d.check(phys2d.make_responder(name), quick=True, out=None, echo=None) for name in RESPONDERS]


def main(argv: list[str]) -> int:
    text = DOC.read_text()
    measured = block(cards())
    if "--check" in argv:
        diff = differences(in_doc(text), measured)
        print("\n".join(diff) if diff else "the doc's cards are the code's")
        return 1 if diff else 0
    DOC.write_text(text.replace(in_doc(text), measured))
    print(f"wrote the cards of {', '.join(RESPONDERS)} into {DOC}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
