"""How a number is judged against its paper: the verdict's words and the systematic error.

:func:`verdict` compares ours with the paper's value or range in units of the combined error;
:func:`systematic` makes the systematic error of a value from the same value measured other ways.
:mod:`granflow.validation` uses both for every row of the record.
"""
from __future__ import annotations

import math

#: a difference within this many standard errors is called "within error"
SIGMAS = 2.0

def systematic(central: float, variants: dict, central_se: float = float("nan")) -> tuple[float, str]:
    """``(systematic error, text)`` of a value measured one way, from the same value measured others.

    Each variant is a value, or ``(value, standard error)`` when it is measured on a subset or a
    superset of the same data (a shorter fit range, half the window): then, with ``central_se``
    given, the part of its shift that the statistics of the data it adds or drops explain,
    :math:`|\\sigma_v^2 - \\sigma^2|`, is taken out in quadrature (Barlow 2002, "Systematic errors:
    facts and fictions"), :math:`\\sqrt{\\max(0, \\Delta^2 - |\\sigma_v^2 - \\sigma^2|)}`. The systematic
    error is the largest remaining shift over the finite variants (NaN when there is none); the text
    lists every variant with its value, e.g. ``slab ±0.25 r_b: 0.52; slab ±1 r_b: 0.55``.
    """
    shifts, parts = [], []
    for name, v in variants.items():
        value, se = (v if isinstance(v, tuple) else (v, float("nan")))
        value = float(value)
        parts.append(f"{name}: {value:.4g}")
        if not (math.isfinite(value) and math.isfinite(float(central))):
            continue
        shift = abs(value - float(central))
        if math.isfinite(float(se)) and math.isfinite(float(central_se)):
            shift = math.sqrt(max(0.0, shift ** 2 - abs(float(se) ** 2 - float(central_se) ** 2)))
            parts[-1] += f" (± {float(se):.2g}, beyond its statistics {shift:.2g})"
        shifts.append(shift)
    return (max(shifts) if shifts else float("nan")), "; ".join(parts)


#: the kinds of a check: only a ``comparison`` can fail against the paper
KINDS = {
    "comparison": "can fail against the paper",
    "consistency": "forced by the quantity's definition or an exact identity of our own code: a test of the code, "
                   "never a verdict against the paper",
    "diagnostic": "a reading of a measurement choice: no verdict",
}
#: a comparison whose SIGMAS combined errors exceed this fraction of the paper's value cannot tell a
#: difference of that size from none: ``not resolved``
RESOLUTION = 0.25


def combined_error(error: float, syst: float = float("nan"), paper_error: float = 0.0,
                   run_to_run: float = float("nan")) -> float:
    """stat ⊕ run-to-run ⊕ syst ⊕ the paper's own error (NaN parts count as 0)."""
    parts = [x for x in (error, syst, paper_error, run_to_run) if x is not None and math.isfinite(x)]
    return math.sqrt(sum(x * x for x in parts))


def verdict(ours: float, error: float, paper_range, paper_error: float = 0.0,
            syst: float = float("nan"), kind: str = "comparison", run_to_run: float = float("nan"),
            n_replicates: int = 1) -> tuple[str, float]:
    """``(words, relative difference)`` of ours against the paper's range.

    Only a ``comparison`` (:data:`KINDS`) is judged: a ``consistency`` or ``diagnostic`` check says
    what it is and carries no verdict. The difference is measured to the nearest end of the range
    (0 inside it); the combined error is stat ⊕ run-to-run ⊕ syst ⊕ the paper's error
    (:func:`combined_error`). ``within the systematic error`` when the difference is no larger than
    ``syst`` alone (the measurement choices explain it); ``within error`` when it is within
    :data:`SIGMAS` combined errors; ``not resolved (± x)`` instead of either when :data:`SIGMAS`
    combined errors exceed :data:`RESOLUTION` of the paper's (non-zero) value: such an error could
    not tell a 25 % difference from none. Outside :data:`SIGMAS` errors: ``differs by X % (Y σ)``
    with at least two replicates (``n_replicates``), else ``one sample: off by X % (Y σ)``; beyond a bound about
    zero (a range holding 0) X is the distance past the bound
    (the run-to-run scatter is not counted: a replicate decides). ``no statistical error`` when ours
    has none and lies outside the range. Against a paper value of 0 the difference is absolute.
    ``not measured`` when ours is NaN.
    """
    if kind not in KINDS:
        raise ValueError(f"check kind {kind!r}: allowed one of {', '.join(KINDS)}")
    if kind != "comparison":
        return f"{kind}: no verdict against the paper", float("nan")
    if not math.isfinite(ours):
        return "not measured", float("nan")
    if paper_range is None:
        return "shape compared (see note)", float("nan")
    lo, hi = sorted(float(v) for v in paper_range)
    nearest = min(max(ours, lo), hi)
    diff = ours - nearest
    rel = diff / abs(nearest) if nearest else diff
    stat = error if math.isfinite(error) else 0.0
    sys_ = syst if math.isfinite(syst) else 0.0
    sig = combined_error(error, syst, paper_error, run_to_run)
    unresolved = nearest != 0 and SIGMAS * sig > RESOLUTION * abs(nearest)
    if diff == 0.0 and hi > lo:
        return "within the paper's range", 0.0
    if unresolved and abs(diff) <= SIGMAS * sig:
        return f"not resolved (± {sig:.2g}: {SIGMAS:g} errors exceed {RESOLUTION:.0%} of the paper's value)", rel
    if diff == 0.0:
        return "equal", 0.0
    if sys_ > 0 and abs(diff) <= sys_:
        return f"within the systematic error (the difference {abs(diff):.3g} ≤ syst {sys_:.3g})", rel
    if sig > 0 and abs(diff) <= SIGMAS * sig:
        return f"within error ({abs(diff) / sig:.1f} σ)", rel
    # a bound about zero (|x| < b, 0 ≤ x < b): how far beyond the bound, not a percentage of it
    bound = bool(nearest) and lo <= 0.0 <= hi
    size = (f"{diff:+.3g} (the paper's value is 0)" if not nearest else
            f"{diff:+.3g}" if bound else f"{100 * rel:+.1f} %")
    words = f"differs by {size}" if n_replicates >= 2 else f"one sample: off by {size}"
    if sig > 0:
        parts = [name for name, x in (("syst", sys_), ("run-to-run", run_to_run)) if math.isfinite(x) and x > 0]
        counted = ["stat"] + parts
        counted = ", ".join(counted[:-1]) + " and " + counted[-1] if parts else ""
        words += f" ({abs(diff) / sig:.0f} σ{' with ' + counted if parts else ''})"
    elif not math.isfinite(error):
        words += " (no statistical error)"
    if bound:
        words += f", past the paper's bound {nearest:g}"
    if n_replicates < 2:
        words += "; 'differs' needs two replicates"
    return words, rel
