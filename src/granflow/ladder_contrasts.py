"""A ladder's contrasts: one rung read against a reference, row by row, for a paper's claim that a knob changes
nothing ("insensitive to the feed at constant ṁ", "independent of k_n") or moves a quantity one way.

A ladder file's ``contrasts:`` entry names its ``rung`` (the knob turned), its ``reference`` (another rung, or
``record``: the committed validation record's case at the ladder's sweep point, with its replicates) and
``rows``: each a check ``quantity`` (a unique start of the scene validation's quantity), the paper's ``claim``
(``equal``, ``rises`` or ``falls`` as the rung turns the knob) and the ``form`` of the contrast (``ratio``:
rung over reference; ``difference``: rung minus reference). A row is a comparison of its own:

- ours: the rung's value over (or minus) the reference's;
- stat: both statistical errors propagated as independent;
- syst: each measurement choice (the checks' ``variants``, e.g. where the wall bin is read) applied to both
  sides at once: the largest shift of the contrast over the choices both sides report (a choice that moves
  both alike leaves the contrast alone); a pooled reference's variants are its first replicate's, read against
  that replicate's own value (its note). Without a common choice: the larger of the two sides' syst;
- run-to-run: one run's scatter ``s`` read from the side with replicates (``run_to_run`` is the mean's,
  ``s/√n``), for the contrast ``s √(1/n_ref + 1/n_rung)``; without replicates on either side none is counted
  and the row can say "one sample", never "differs";
- the paper's range: ``equal`` 1 (ratio) or 0 (difference); ``rises`` above it, ``falls`` below.

Nothing here reads files: :mod:`granflow.ladder` hands in the two sides' checks.
"""
from __future__ import annotations

import math
import re

from granflow.config import ConfigError
from granflow.validation import Check

#: a claim's range as (low, high) for each form; inf bounds leave a side open
CLAIMS = {
    "equal": {"ratio": (1.0, 1.0), "difference": (0.0, 0.0)},
    "rises": {"ratio": (1.0, math.inf), "difference": (0.0, math.inf)},
    "falls": {"ratio": (-math.inf, 1.0), "difference": (-math.inf, 0.0)},
}
#: the paper's claim in words, after its text in a contrast row
CLAIM_WORDS = {"equal": "no change", "rises": "rises", "falls": "falls"}
#: the word between the two sides in a contrast row's quantity
FORM_WORDS = {"ratio": "over", "difference": "minus"}
#: a contrast's reference that is the committed validation record rather than a rung
RECORD = "record"


def check_contrasts(ladder: dict, path) -> None:
    """Refuse (:class:`ConfigError`, naming the file, the contrast, the key and what is allowed) a contrast
    without its keys, with a rung or reference that is not a rung of the ladder (or ``record``), or a row with an
    unknown claim or form."""
    rungs = {r.get("name") for r in ladder.get("rungs") or []}
    for c in ladder.get("contrasts") or []:
        where = f"ladder: {path}: contrast {c.get('name')!r}"
        for key in ("name", "knob", "rung", "reference", "rows", "paper", "source"):
            if key not in c:
                raise ConfigError(f"{where}: missing key {key!r}")
        if c["rung"] not in rungs:
            raise ConfigError(f"{where}: rung = {c['rung']!r}: allowed a rung of this ladder ({', '.join(sorted(rungs))})")
        if c["reference"] not in rungs | {RECORD} or c["reference"] == c["rung"]:
            raise ConfigError(f"{where}: reference = {c['reference']!r}: allowed another rung of this ladder or "
                              f"{RECORD!r} (the committed validation record)")
        if not isinstance(c["rows"], list) or not c["rows"]:
            raise ConfigError(f"{where}: rows = {c['rows']!r}: allowed a list of {{quantity, claim, form}}")
        for row in c["rows"]:
            if not isinstance(row, dict) or not isinstance(row.get("quantity"), str):
                raise ConfigError(f"{where}: row {row!r}: allowed {{quantity: <start of a check's quantity>, ...}}")
            if row.get("claim") not in CLAIMS:
                raise ConfigError(f"{where}: row {row['quantity']!r}: claim = {row.get('claim')!r}: allowed one of "
                                  f"{', '.join(CLAIMS)}")
            if row.get("form", "ratio") not in FORM_WORDS:
                raise ConfigError(f"{where}: row {row['quantity']!r}: form = {row.get('form')!r}: allowed one of "
                                  f"{', '.join(FORM_WORDS)}")


def reference_label(contrast: dict) -> str:
    """The reference in words: the rung's name, or the record's."""
    return "the record" if contrast["reference"] == RECORD else contrast["reference"]


def row_quantity(contrast: dict, row: dict, quantity: str) -> str:
    """A contrast row's quantity: ``<the check's quantity>: <rung> over <reference>``."""
    return f"{quantity}: {contrast['rung']} {FORM_WORDS[row.get('form', 'ratio')]} {reference_label(contrast)}"


def _pick(checks: list, start: str):
    """The one check whose quantity is ``start``, else the one whose quantity starts with it (a case's before a
    sweep-wide one: a contrast reads one case per side); None when there is none or more than one."""
    found = ([c for c in checks if c.quantity == start] or
             [c for c in checks if c.quantity.startswith(start) and c.case != "sweep"] or
             [c for c in checks if c.quantity.startswith(start)])
    return found[0] if len(found) == 1 else None


#: one measurement choice in a check's ``variants``: ``<label>: <value>`` (then, maybe, ``(± ...)``)
_VARIANT = re.compile(r"^(?P<label>.+): (?P<value>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)(?: \(.*\))?$")
#: the first replicate's value in a pooled check's note (granflow.replicates.pool writes "seed <n>: <value>")
_FIRST_SEED = re.compile(r"Replicates \(.*?seed \d+: (?P<value>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")


def variants(check) -> dict[str, float]:
    """A check's measurement choices and the value each gives (``variants``: ``label: value; ...``)."""
    out = {}
    for part in str(check.variants or "").split("; "):
        m = _VARIANT.match(part.strip())
        if m:
            out[m["label"]] = float(m["value"])
    return out


def nominal(check) -> float:
    """The value its ``variants`` are read against: a pooled check's first replicate's, else its own."""
    m = _FIRST_SEED.search(str(check.note or ""))
    return float(m["value"]) if m and int(check.n_replicates or 1) >= 2 else float(check.ours)


def contrast_syst(form: str, ref, turned) -> tuple[float, str]:
    """(the contrast's systematic error, how it was found): every choice both sides report applied to both."""
    va, vb = variants(ref), variants(turned)
    common = [k for k in va if k in vb]
    a0, b0 = nominal(ref), nominal(turned)
    if common and all(math.isfinite(x) for x in (a0, b0)) and a0 and b0:
        if form == "ratio":
            base = b0 / a0
            shifts = [abs(vb[k] / va[k] - base) / abs(base) for k in common if va[k]]
            return abs(_finite(turned.ours) / _finite(ref.ours)) * max(shifts, default=0.0), \
                f"each of {len(common)} measurement choices applied to both sides"
        shifts = [abs((vb[k] - va[k]) - (b0 - a0)) for k in common]
        return max(shifts, default=0.0), f"each of {len(common)} measurement choices applied to both sides"
    ya, yb = _finite(ref.syst), _finite(turned.syst)
    a, b = _finite(ref.ours), _finite(turned.ours)
    if form == "ratio":
        rel = max((y / abs(v) for y, v in ((ya, a), (yb, b)) if math.isfinite(y) and v), default=float("nan"))
        return abs(b / a) * rel if a else float("nan"), "the larger relative syst of the two sides (no common choice)"
    return max((y for y in (ya, yb) if math.isfinite(y)), default=float("nan")), \
        "the larger syst of the two sides (no common choice)"


def _finite(x) -> float:
    return float(x) if x is not None and math.isfinite(float(x)) else float("nan")


def _one_run_scatter(check) -> tuple[float, int]:
    """(one run's scatter s, replicates n) from a check pooled over replicates (run_to_run = s/√n), else (nan, 1)."""
    n = int(check.n_replicates or 1)
    rtr = _finite(check.run_to_run)
    return (rtr * math.sqrt(n), n) if n >= 2 and math.isfinite(rtr) else (float("nan"), n)


def contrast_check(contrast: dict, row: dict, ref, turned) -> Check:
    """One contrast row from the reference's check ``ref`` and the rung's ``turned`` (see the module)."""
    form, claim = row.get("form", "ratio"), row["claim"]
    a, b = _finite(ref.ours), _finite(turned.ours)
    sa, sb = _finite(ref.error), _finite(turned.error)
    nan = float("nan")
    if form == "ratio":
        ours = b / a if a else nan
        stat = abs(ours) * math.hypot(sa / a if a else nan, sb / b if b else nan)
    else:
        ours, stat = b - a, math.hypot(sa, sb)
    syst, how = contrast_syst(form, ref, turned)
    (s_ref, n_ref), (s_rung, n_rung) = _one_run_scatter(ref), _one_run_scatter(turned)
    s = s_ref if math.isfinite(s_ref) else s_rung
    rtr = s * math.sqrt(1 / n_ref + 1 / n_rung) if math.isfinite(s) else nan
    if form == "ratio" and math.isfinite(rtr):
        rtr *= abs(ours) / abs(a if math.isfinite(s_ref) else b)     # the scatter of one side, relative
    sides = (f"{contrast['rung']} {b:.4g} ± {sb:.2g} ({n_rung} run{'s' if n_rung > 1 else ''}), "
             f"{reference_label(contrast)} {a:.4g} ± {sa:.2g} ({n_ref} run{'s' if n_ref > 1 else ''}, "
             f"case {ref.case})")
    note = (f"{sides}; syst: {how}; run-to-run: one run's scatter "
            + (f"{s:.2g} from the side with replicates, × √(1/{n_ref} + 1/{n_rung})" if math.isfinite(s)
               else "not known (no side has replicates): the row cannot say 'differs'"))
    paper = f"{row.get('paper', contrast['paper'])} ({CLAIM_WORDS[claim]})"
    return Check(row_quantity(contrast, row, turned.quantity), paper, contrast["source"], ours, stat,
                 case=f"{contrast['rung']} vs {reference_label(contrast)}", paper_range=CLAIMS[claim][form],
                 note=note, syst=syst, run_to_run=rtr,
                 n_replicates=max(n_ref, n_rung) if math.isfinite(s) else 1)


def contrast_checks(contrast: dict, ref_checks: list, rung_checks: list) -> tuple[list[Check], list[str]]:
    """(the contrast's rows, the quantities one side lacks) from both sides' checks."""
    out, missing = [], []
    for row in contrast["rows"]:
        ref, turned = _pick(ref_checks, row["quantity"]), _pick(rung_checks, row["quantity"])
        if ref is None or turned is None:
            missing.append(row["quantity"])
            continue
        out.append(contrast_check(contrast, row, ref, turned))
    return out, missing
