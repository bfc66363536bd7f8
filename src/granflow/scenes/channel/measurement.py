"""The channel's measurement choices: each headline recomputed from the same dumps another way.

The paper's definitions are kept where it states them (the 1.5 d_p wall bin whose speed is
:math:`u_{slip}`, d_p bins elsewhere, §2); what it leaves open, or what a finite run adds, is varied:

* the interior bin width: 0.5 and 2 d_p against 1 d_p (the wall bin stays the paper's);
* where the wall's speed is read: the paper's 1.5 d_p wall bin against 1 and 2 d_p (the interval
  "closest to the wall" is the paper's word, its width a choice; centres lie >= 0.5 d_p from a flat
  wall, so 1 d_p holds about the contact layer alone); :math:`u_{slip}` moves ~1.8 % per 0.1 d_p of
  where it is read, the largest measurement choice of the ratio;
* how :math:`u_{max}` is read: the largest bin of the folded profile (ours, the paper's "maximum
  velocity at the centre"), the centre bin, or the mean over the plug's bins; the largest of noisy
  bins is biased upwards by their noise;
* the averaging window's first and second half, each with its own error (a subset of the same
  data: :func:`granflow.validation.systematic` takes out the part its statistics explain).

:func:`headline_variants` returns, per headline, ``{variant: value or (value, se)}`` for
:func:`granflow.validation.systematic`.
"""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from .analysis import analyse_profile, plug_phi
from .pipeline import channel_profile

#: interior bin widths tried besides the rung's, d_p
BIN_WIDTHS = (0.5, 2.0)
#: wall bin widths tried besides the paper's 1.5 d_p, d_p
WALL_BIN_WIDTHS = (1.0, 2.0)
#: the headlines that get variants: analysis scalar -> how to read it from a ChannelAnalysis
HEADLINES = ("ratio", "fit_exponent", "delta_095_over_W", "plug_phi", "u_slip", "u_max")


def _read(a, key: str) -> tuple[float, float]:
    """``(value, se)`` of one headline from a :class:`~.analysis.ChannelAnalysis`."""
    if key == "ratio":
        return a.scales.ratio, a.scales.ratio_se
    if key == "fit_exponent":
        return a.fit.a, a.fit.a_se
    if key == "delta_095_over_W":
        return a.scales.delta_095 / a.W, float("nan")
    if key in ("u_slip", "u_max"):   # the speeds themselves, for the rows across W (.width_checks)
        return getattr(a.scales, key), getattr(a.scales, f"{key}_se")
    return plug_phi(a)


def u_max_readings(a) -> dict[str, float]:
    """:math:`u_{max}/u_{slip}` with :math:`u_{max}` read as the centre bin and as the plug's mean speed."""
    u = a.folded["u"].to_numpy(float)
    plug = a.zones.labels == "plug"
    slip = a.scales.u_slip
    out = {"u_max = centre bin": float(u[-1] / slip) if slip > 0 else float("nan")}
    out["u_max = mean over the plug"] = float(np.nanmean(u[plug]) / slip) if plug.any() and slip > 0 \
        else float("nan")
    return out


def plug_edge_readings(a) -> dict[str, float]:
    """φ in the plug with its edge read other ways: where the shear rate reaches the plug's frozen scatter with
    that scatter taken from 0.25 W or 0.45 W on (:func:`~.analysis.rheology.flow_zones`; the record's 0.35 W), and
    the paper's own edge, where φ reaches 0.63."""
    from .analysis.rheology import flow_zones

    x = a.folded["x"].to_numpy(float)
    phi = a.folded["phi"].to_numpy(float)

    def beyond(edge: float) -> float:
        keep = (x >= edge) & np.isfinite(phi)
        return float(phi[keep].mean()) if np.isfinite(edge) and keep.any() else float("nan")

    out = {f"plug edge: scatter from {f:g} W": beyond(flow_zones(a.folded, a.rheo, floor_from=f).x_dense_plug)
           for f in (0.25, 0.45)}
    out["plug edge: φ = 0.63 (the paper's)"] = beyond(a.zones.x_plug_phi063)
    return out


def headline_variants(case_dir: Path, record: dict, central) -> dict[str, dict]:
    """Per key of :data:`HEADLINES`, ``{variant name: value or (value, se)}`` (module docstring).

    ``central`` is the case's :class:`~.analysis.ChannelAnalysis` of the whole window (its errors are the
    profile's own, the footing of the halves' errors).
    """
    W = float(record["parameters"]["W"])
    out = {key: {} for key in HEADLINES}
    for knob, widths, label in (("bin_width", BIN_WIDTHS, "bins {:g} d_p"),
                                ("wall_bin_width", WALL_BIN_WIDTHS, "wall bin {:g} d_p")):
        for width in widths:
            rec = copy.deepcopy(record)
            rec["rung_knobs"][knob] = float(width)
            a = analyse_profile(channel_profile(case_dir, record=rec)[0], W)
            for key in HEADLINES:
                out[key][label.format(width)] = _read(a, key)[0]
    out["ratio"].update(u_max_readings(central))
    out["plug_phi"].update(plug_edge_readings(central))
    window = float(record["rung_knobs"]["t_average"])
    halves = {"first half": (0.0, 0.5 * window), "second half": (0.5 * window, window * (1.0 + 1e-9))}
    for name, span in halves.items():
        try:
            a = analyse_profile(channel_profile(case_dir, record=record, t_window=span)[0], W)
        except ValueError:  # no frame in that half
            continue
        for key in HEADLINES:
            out[key][f"window {name}"] = _read(a, key)
    return out


def central_errors(central) -> dict[str, float]:
    """The whole window's profile errors per headline: the footing :func:`systematic` compares the halves on."""
    return {key: _read(central, key)[1] for key in HEADLINES}
