"""Where the particles fed during the window go: their rest position and their flight above the heap.

The segregation the paper measures (small particles deposit upstream, its Fig. 3c) happens in the
flowing layer: small particles percolate to its bottom and are laid down early. A particle that
bounces or saltates over the surface skips that. For every particle fed (first seen) in the first
part of the averaging window, followed by its atom id through the frames:

- its rest position, :math:`(x_{lab} - x_{feed}) / (W - x_{feed})` at the last frame (0 at the feed
  zone's edge, 1 at the end wall);
- its flight: the streamwise distance it travels while more than ``d_above`` above the free surface
  of the frame (the surface of each column, interpolated at the particle's x),
  :math:`\\sum_f |x_{f+1} - x_f| \\, \\tfrac12 (a_f + a_{f+1})` with :math:`a_f` = 1 when above;
- its flight's share of its whole streamwise travel :math:`\\sum_f |x_{f+1} - x_f|`.

Frames are a dump interval apart (0.02 s at the validation rung: a bounce of 0.1–0.2 s spans 5–10
frames), so a flight is sampled, not resolved; the per-species means compare species, which the
sampling treats alike.
"""
from __future__ import annotations

import numpy as np

from .surface import HeapGeometry


def fed_travel(frames, x_lab, z_s, geometry: HeapGeometry, n_types: int, d_above: float,
               born_before: float = 0.5) -> dict:
    """Per species k: ``travel_n_<k>``, ``travel_rest_x_over_L_<k>`` (mean rest position over the
    flowing length), ``travel_flight_<k>`` (mean flight, m) and ``travel_flight_share_<k>`` (flight
    over all streamwise travel, summed over the species' particles); module docstring.

    Parameters
    ----------
    frames : sequence of :class:`postproc.frame.ParticleFrame`
        The window's frames in time order, with ``id``, ``type`` and ``position``.
    x_lab, z_s : ndarray
        Column centres (m) and the free surface height of every frame and column (m, NaN where a
        column has none), shape ``(len(frames), len(x_lab))``.
    d_above : float
        Height above the surface counted as flight, m (e.g. a large particle's diameter).
    born_before : float
        Followed particles are those first seen by this fraction of the window (they have the rest
        of it to come to rest).
    """
    nan = float("nan")
    keys = ("travel_n", "travel_rest_x_over_L", "travel_flight", "travel_flight_share")
    empty = {f"{key}_{k}": (0 if key == "travel_n" else nan) for key in keys for k in range(1, n_types + 1)}
    n_f = len(frames)
    if n_f < 3 or any(f.id is None or f.type is None for f in frames):
        return empty
    cut = max(1, int(np.floor(born_before * (n_f - 1))))
    ids = np.setdiff1d(frames[cut].id, frames[0].id)
    if not len(ids):
        return empty
    x = np.full((n_f, len(ids)), np.nan)
    z = np.full((n_f, len(ids)), np.nan)
    for f, frame in enumerate(frames):
        where = np.searchsorted(frame.id, ids)
        found = where < len(frame.id)
        found[found] &= frame.id[where[found]] == ids[found]
        x[f, found] = frame.position[where[found], 0]
        z[f, found] = frame.position[where[found], 2]
    kind = np.asarray(frames[cut].type)[np.searchsorted(frames[cut].id, ids)].astype(int)
    z_s = np.asarray(z_s, dtype=float)
    height = np.full_like(z, np.nan)
    for f in range(n_f):
        ok = np.isfinite(z_s[f])
        seen = np.isfinite(x[f])
        if ok.sum() >= 2 and seen.any():
            height[f, seen] = z[f, seen] - np.interp(x[f, seen], x_lab[ok], z_s[f, ok])
    above = np.where(np.isfinite(height), height > d_above, False).astype(float)
    step = np.abs(np.diff(x, axis=0))
    moved = np.isfinite(step)
    step = np.where(moved, step, 0.0)
    flight = np.sum(step * 0.5 * (above[:-1] + above[1:]), axis=0)
    travel = np.sum(step, axis=0)
    rest = (x[-1] - geometry.x_feed) / (geometry.W - geometry.x_feed)
    out = dict(empty)
    for k in range(1, n_types + 1):
        sel = (kind == k) & np.isfinite(rest)
        if not sel.any():
            continue
        out[f"travel_n_{k}"] = int(sel.sum())
        out[f"travel_rest_x_over_L_{k}"] = float(np.mean(rest[sel]))
        out[f"travel_flight_{k}"] = float(np.mean(flight[sel]))
        out[f"travel_flight_share_{k}"] = float(np.sum(flight[sel]) / np.sum(travel[sel])) if np.sum(travel[sel]) > 0 else nan
    return out
