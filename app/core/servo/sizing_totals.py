"""What the servos a sizing chose add up to: count, mass and price (the `size` CLI's and the
Servos folder's total line)."""

from __future__ import annotations

import dataclasses
import math

from app.core.servo.catalogue import ServoRecord
from app.core.servo.sizing import Sizing

__all__ = ["Totals", "totals"]


@dataclasses.dataclass(frozen=True)
class Totals:
    """What the servos a sizing chose add up to (the joints no servo holds left out)."""

    servos: int
    mass_kg: float
    price: float | None
    """Their summed price, None when a chosen servo has none published or currencies differ."""
    currency: str | None
    unpriced: tuple[str, ...]
    """The chosen servos without a published price."""

    def line(self) -> str:
        """One line: count, mass and price (or why there is no price)."""
        text = f"{self.servos} servos, {self.mass_kg * 1000:.0f} g"
        if self.price is not None:
            return text + f", {self.price:.2f} {self.currency}"
        if self.unpriced:
            return text + f"; price unpublished for {', '.join(self.unpriced)}"
        return text + "; prices in different currencies, not summed"


def totals(sizing: Sizing, catalogue: dict[str, ServoRecord]) -> Totals:
    """The chosen servos' count, mass and price (catalogue: the records sized over)."""
    chosen = [catalogue[j.choice] for j in sizing.joints if j.choice is not None]
    unpriced = tuple(sorted({r.key for r in chosen if r.price is None}))
    currencies = {r.price_currency for r in chosen if r.price is not None}
    price = None
    if chosen and not unpriced and len(currencies) == 1:
        price = math.fsum(r.price for r in chosen if r.price is not None)
    return Totals(
        len(chosen),
        math.fsum(r.mass_kg for r in chosen),
        price,
        next(iter(currencies)) if len(currencies) == 1 else None,
        unpriced,
    )
