"""Where each species travels down the heap: the share of its streamwise flux carried above the surface.

In the moving frame (z = 0 on each column's free surface, :func:`.layer.local_surface`), the
streamwise volume flux of species k through a column is

.. math:: q_k = \\int \\phi_k\\, u\\, dz ,

with the mixture's mean velocity u of each bin standing in for the species' own (the kinematics are
volume-weighted per bin, not per species). The share above the surface,
:math:`f_k = \\int_{z>0} \\phi_k u\\, dz / \\int \\phi_k u\\, dz`, summed over every column of the flowing
length, measures how much of a species bounces or saltates over the heap instead of flowing in the
layer: a species carried above the surface travels to the end wall without taking part in the
percolation that puts small particles upstream (Fan et al. 2013, §2.2, Fig. 3c).
"""
from __future__ import annotations

import numpy as np
import pandas as pd


def species_flux_above(profile: pd.DataFrame, n_types: int, z_above: float = 0.0,
                       name: str = "flux_above_surface") -> dict:
    """``{"<name>_<k>": f_k}`` for each species k (module docstring), NaN without flux.

    ``profile`` is the moving-frame profile with its z measured from the local surface (``x, z, z_lo,
    z_hi, u, phi_<k>``); only bins whose lower edge lies at or above ``z_above`` count as above.
    """
    out = {}
    if profile.empty or "u" not in profile:
        return {f"{name}_{k}": float("nan") for k in range(1, n_types + 1)}
    dz = (profile["z_hi"] - profile["z_lo"]).to_numpy(float) if {"z_lo", "z_hi"} <= set(profile) else \
        np.full(len(profile), np.nan)
    u = profile["u"].to_numpy(float)
    above = profile["z_lo"].to_numpy(float) >= z_above - 1e-12 if "z_lo" in profile else \
        profile["z"].to_numpy(float) > z_above
    for k in range(1, n_types + 1):
        col = f"phi_{k}"
        if col not in profile:
            out[f"{name}_{k}"] = float("nan")
            continue
        q = profile[col].to_numpy(float) * u * dz
        ok = np.isfinite(q) & (q > 0)
        total = float(np.sum(q[ok]))
        out[f"{name}_{k}"] = float(np.sum(q[ok & above]) / total) if total > 0 else float("nan")
    return out
