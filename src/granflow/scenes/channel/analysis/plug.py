"""Is the channel steady, and is its plug one frozen configuration?

Two questions of Debnath et al.'s set-up that a thin periodic cell (B = 5 d_p, H = 12 d_p) can
answer differently from the paper's (B = 40, H = 60 + ΔH):

* **steadiness**: :math:`u_{max}/u_{slip}` in each of ``n`` consecutive blocks of the averaging
  window (:func:`block_ratios`) and the drift of a straight line through them;
* **the plug's structure** (:func:`plug_structure`): per frame, over the particles of the plug
  (distance from the nearer wall ≥ the plug edge of the averaged profile), the Steinhardt
  :math:`q_6` and the plug's global :math:`Q_6` (Steinhardt et al. 1983, Kumaran 2009's order
  parameter), the fraction of crystal-like particles (ten Wolde et al. 1996,
  :mod:`postproc.structure`), the layering along the periodic depth z, and the root-mean-square
  *non-affine* displacement: each plug particle's displacement since the first frame less what
  the mean flow carries it (the time-averaged u_y at its x, frame by frame, then the plug's
  remaining mean shift). A plug that rearranges (as the paper's, φ ≈ 0.63, random close
  packing) gathers displacements of order a diameter over the window; a plug frozen into one
  configuration moves with the mean flow, a small fraction of a diameter: its bin-to-bin scatter of φ
  is then structure, which no time average removes.

Units: :math:`d_p`, :math:`\\sqrt{d_p/g}`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from postproc import series
from postproc.structure import bond_order, layering

#: neighbour distance for the bond order, d_p: between the first shell (1 d_p) and the second (√2 d_p)
BOND_CUTOFF = 1.3
#: layer spacings looked for along the depth, d_p (the species are 0.9-1.1 d_p)
LAYER_SPACING = (0.8, 1.2)
#: distance from a wall inside which particles layer against it (the paper's wall layer, 2 d_p)
WALL_LAYER = 2.0
#: the bond cutoff's variants for the plug's global Q6 (the systematic error of its row), d_p
Q6_CUTOFF_VARIANTS = (1.2, 1.4)
#: on about this many of the structure frames (the variant's shift from the central value is read there)
Q6_VARIANT_FRAMES = 8
#: at most this many frames of the window are analysed for structure (evenly spaced; all for displacement)
MAX_STRUCTURE_FRAMES = 40


def _circular_shift(d: np.ndarray, length: float) -> float:
    """Mean of displacements ``d`` on a periodic axis of ``length`` (the circular mean, exact for a rigid shift)."""
    angle = np.angle(np.mean(np.exp(2j * np.pi * d / length)))
    return float(angle * length / (2.0 * np.pi))


def _wrap(d: np.ndarray, length: float) -> np.ndarray:
    return d - length * np.round(d / length)


@dataclass
class PlugStructure:
    """Per-frame structure of the plug and the shear zone (:func:`plug_structure`), with the window's means.

    ``frames`` has the columns ``t``, ``q6_plug``, ``Q6_plug`` (global; ``Q6_plug_inner``, ``Q6_plug_cut<c>``
    its variants), ``crystal_plug``, ``q6_shear``, ``crystal_shear``,
    ``layering_plug`` (with ``layer_spacing``), ``nonaffine_rms_plug`` (NaN where not measured),
    ``n_plug``; ``summary`` the means and the last non-affine displacement.
    """

    frames: pd.DataFrame
    summary: dict


def plug_structure(frames, W: float, plug_edge: float, periodic=(False, True, True),
                   dt: float | None = None, mean_velocity=None) -> PlugStructure:
    """Structure of the plug, frame by frame (module docstring).

    Parameters
    ----------
    frames : iterable of postproc.frame.ParticleFrame
        The averaging window's frames, in time order, with ``id`` (the same atoms in each).
    W : float
        Channel width (walls at x = 0 and W), :math:`d_p`.
    plug_edge : float
        Distance from the wall where the plug starts (the analysis's ``x_dense_plug``), :math:`d_p`.
    periodic : three bools
        Which axes wrap: the channel's y (flow) and z (depth).
    dt : float, optional
        Time step: a frame's time is its step times ``dt`` (else the dump's own time, else the step).
    mean_velocity : callable, optional
        The mean flow: ``mean_velocity(x)`` gives the time-averaged velocity (3 components, shape
        (N, 3)) at positions ``x`` across the channel. Each step first takes away what it carries a
        particle (the affine part, a shear across the plug included); without it only the plug's
        mean shift is taken away (a rigid plug).
    """
    frames = list(frames)
    if not frames or not np.isfinite(plug_edge) or plug_edge >= 0.5 * W:
        return PlugStructure(pd.DataFrame(), {"why": "no plug" if frames else "no frames"})
    first = frames[0]
    lengths = first.box[:, 1] - first.box[:, 0]
    dist0 = np.minimum(first.position[:, 0], W - first.position[:, 0])
    tracked = dist0 >= plug_edge
    ids = first.id
    cumulative = np.zeros((int(tracked.sum()), 3))
    previous = first.position[tracked]
    pick = set(np.linspace(0, len(frames) - 1, min(len(frames), MAX_STRUCTURE_FRAMES)).round().astype(int))
    variant_frames = set(sorted(pick)[::max(1, len(pick) // Q6_VARIANT_FRAMES)])
    rows = []
    for k, frame in enumerate(frames):
        if ids is not None and frame.id is not None and not np.array_equal(frame.id, ids):
            raise ValueError(f"frame at step {frame.timestep}: the atoms differ from the first frame's")
        here = frame.position[tracked]
        t = frame.timestep * dt if dt is not None else frame.time if frame.time is not None else frame.timestep
        if k:
            step = here - previous
            if mean_velocity is not None:
                step -= np.asarray(mean_velocity(previous[:, 0]), dtype=float) * (t - t_previous)
            for axis in range(3):
                if periodic[axis]:
                    step[:, axis] = _wrap(step[:, axis] - _circular_shift(step[:, axis], lengths[axis]),
                                          lengths[axis])
                else:
                    step[:, axis] -= step[:, axis].mean()
            cumulative += step
        previous, t_previous = here, t
        row = {"t": float(t),
               "nonaffine_rms_plug": float(np.sqrt(np.mean(np.sum(cumulative**2, axis=1))))}
        if k in pick:
            dist = np.minimum(frame.position[:, 0], W - frame.position[:, 0])
            plug = dist >= plug_edge
            shear = (dist >= WALL_LAYER) & ~plug
            bo = bond_order(frame.position, frame.box, periodic, BOND_CUTOFF)
            crystal = bo.crystal_like()
            s, spacing = layering(frame.position[plug, 2], float(lengths[2]), LAYER_SPACING)
            # the global Q6 over the plug's bonds (Kumaran 2009's order parameter, the paper's "< 0.4"), with
            # the bond cutoff and the plug's edge (1 d_p further in) as variants
            row.update({"Q6_plug": bo.global_q(plug), "Q6_plug_inner": bo.global_q(dist >= plug_edge + 1.0)})
            if k in variant_frames:              # the cutoff's variants on fewer frames (each a full bond search)
                for cut in Q6_CUTOFF_VARIANTS:
                    row[f"Q6_plug_cut{cut:g}"] = bond_order(frame.position, frame.box, periodic, cut).global_q(plug)
            row.update({"q6_plug": float(np.nanmean(bo.q[plug])), "crystal_plug": float(crystal[plug].mean()),
                        "q6_shear": float(np.nanmean(bo.q[shear])) if shear.any() else np.nan,
                        "crystal_shear": float(crystal[shear].mean()) if shear.any() else np.nan,
                        "layering_plug": s, "layer_spacing": spacing, "n_plug": int(plug.sum())})
        rows.append(row)
    table = pd.DataFrame(rows)
    table["t"] -= table["t"].iloc[0]
    measured = table.dropna(subset=["q6_plug"])
    summary = {key: float(measured[key].mean()) for key in
               ("q6_plug", "crystal_plug", "q6_shear", "crystal_shear", "layering_plug", "Q6_plug", "Q6_plug_inner")}
    for cut in Q6_CUTOFF_VARIANTS:   # the central value plus the variant's mean shift on the frames it was read on
        key = f"Q6_plug_cut{cut:g}"
        both = measured.dropna(subset=[key]) if key in measured else measured.iloc[0:0]
        summary[key] = (summary["Q6_plug"] + float((both[key] - both["Q6_plug"]).mean())) if len(both) else float("nan")
    n_q6 = int(measured["Q6_plug"].notna().sum())
    summary["Q6_plug_se"] = float(measured["Q6_plug"].std(ddof=1) / np.sqrt(n_q6)) if n_q6 > 1 else float("nan")
    summary.update({"nonaffine_rms_plug": float(table["nonaffine_rms_plug"].iloc[-1]),
                    "window": float(table["t"].iloc[-1]), "n_tracked": int(tracked.sum()),
                    "layering_random": float(1.0 / np.sqrt(max(1.0, measured["n_plug"].mean())))})
    return PlugStructure(table, summary)


def block_ratios(profiles: list[tuple[float, float, pd.DataFrame]], W: float) -> pd.DataFrame:
    """:math:`u_{max}/u_{slip}` and the plug's φ of each block of the averaging window.

    ``profiles`` holds ``(t_lo, t_hi, unfolded profile)`` per block; the columns of the result are
    ``t_lo``, ``t_hi``, ``t_mid``, ``u_slip``, ``u_max``, ``ratio``, ``ratio_se`` (the block's own
    error of its bins) and ``plug_phi``.
    """
    from . import analyse_profile, plug_phi

    rows = []
    for lo, hi, profile in profiles:
        a = analyse_profile(profile, W)
        rows.append({"t_lo": lo, "t_hi": hi, "t_mid": 0.5 * (lo + hi), "u_slip": a.scales.u_slip,
                     "u_max": a.scales.u_max, "ratio": a.scales.ratio, "ratio_se": a.scales.ratio_se,
                     "plug_phi": plug_phi(a)[0]})
    return pd.DataFrame(rows)


def drift(blocks: pd.DataFrame, key: str = "ratio") -> tuple[float, float]:
    """Change of ``key`` over the window from a straight line through the block values, and its error
    (:func:`postproc.series.change_across`: the slope's error from the scatter of the blocks about the line,
    blocks independent; NaN with fewer than 3 blocks)."""
    b = blocks.dropna(subset=[key])
    return series.change_across(b["t_mid"].to_numpy(float), b[key].to_numpy(float))[:2]
