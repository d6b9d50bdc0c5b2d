"""From a planned periodic gait cycle to a whole-body walk: lateral sway, many steps, rest."""
