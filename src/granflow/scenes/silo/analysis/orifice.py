"""The orifice measured without a kernel: the particles inside a thin slab about the orifice plane.

The coarse-grained fields read :math:`v_z(0)` at one node of a Gaussian of width w = 2 r_b whose
lower part is cut by the deletion plane 1.05 r_b below the orifice, which biases the apparent
scaling of :math:`v_z(0)` with R (the issue's forward test: particles falling at exactly
:math:`\\sqrt{2gR}` read as :math:`R^{0.8-0.9}`). :class:`PlaneCrossing` instead takes, frame by
frame, every particle whose centre lies within ``±h`` of the orifice plane, bins it by its
distance r from the axis, and keeps per bin its mass, its momentum along z and its volume:

- :math:`v_z(r) = \\sum m v_z / \\sum m` over the bin (the discrete mass-weighted mean velocity,
  the kernel-free counterpart of the paper's momentum density over density);
- :math:`\\phi(r) = \\sum V / (A_{bin} \\, 2h \\, n_{frames})` (particle volume counted where its
  centre is);
- :math:`v_c` from the weighted fit of :math:`v_c\\sqrt{1-(r/R)^2}` (averaged over each bin) to
  the bins with :math:`r_{mid} < 0.9R` (the paper's Fig. 5b shape), and, as the other measurement choice, the
  mass-weighted mean of :math:`v_z` over the disc :math:`r < R/4` (which, on that shape, reads
  0.984 :math:`v_c`).

Errors come from the spread of the values over ``n_blocks`` consecutive blocks of frames.
Several slab half-widths are kept in one pass: they are the systematic variants of the reading.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd

#: slab half-widths about the orifice plane, in r_b; the first is the headline's
SLAB_HALVES = (0.5, 0.25, 1.0)
#: radial bin width, in r_b
BIN_WIDTH = 0.5
#: the shape fit uses bins whose middle lies below this fraction of R
FIT_RANGE = 0.9
#: the disc of the direct reading of v_z(0), as a fraction of R
CORE_FRACTION = 0.25


def sqrt_shape(r, R):
    """:math:`\\sqrt{1-(r/R)^2}` (0 beyond R): the paper's Fig. 5b profile of :math:`v_z(r)/v_z(0)`."""
    s = np.clip(1.0 - (np.asarray(r, dtype=float) / R) ** 2, 0.0, None)
    return np.sqrt(s)


def bin_shape(r_lo, r_hi, R):
    """The area average of :func:`sqrt_shape` over the annulus ``r_lo < r < r_hi``:
    :math:`\\tfrac23[(1-a^2)^{3/2}-(1-b^2)^{3/2}]/(b^2-a^2)` with :math:`a, b = r_{lo}/R, r_{hi}/R`
    (clipped at 1): what a uniform bin of that profile reads, without the midpoint's bias."""
    a = np.clip(np.asarray(r_lo, dtype=float) / R, 0.0, 1.0)
    b_true = np.asarray(r_hi, dtype=float) / R
    b = np.clip(b_true, 0.0, 1.0)
    num = (2.0 / 3.0) * ((1 - a * a) ** 1.5 - (1 - b * b) ** 1.5)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(b_true > a, num / (b_true**2 - a * a), sqrt_shape(a * R, R))


def shape_fit(r_lo, r_hi, vz, vz_se, R, fit_range: float = FIT_RANGE) -> tuple[float, float]:
    """``(v_c, se)`` of the weighted least-squares fit :math:`v_z(r) = v_c\\sqrt{1-(r/R)^2}` to bins.

    Each bin ``r_lo < r < r_hi`` is compared with the profile's area average over it
    (:func:`bin_shape`); bins with a finite value and a middle below ``fit_range R`` take part;
    weights :math:`1/se^2` (equal weights, and a NaN error, when any error is zero or missing).
    NaN without bins.
    """
    r_lo, r_hi, vz, vz_se = (np.asarray(a, dtype=float) for a in (r_lo, r_hi, vz, vz_se))
    ok = (0.5 * (r_lo + r_hi) < fit_range * R) & np.isfinite(vz)
    if not ok.any():
        return float("nan"), float("nan")
    f, y, se = bin_shape(r_lo[ok], r_hi[ok], R), vz[ok], vz_se[ok]
    w = 1.0 / se**2 if np.all(np.isfinite(se) & (se > 0)) else np.ones_like(y)
    sff = np.sum(w * f * f)
    v_c = float(np.sum(w * f * y) / sff)
    if np.all(np.isfinite(se) & (se > 0)):
        return v_c, float(1.0 / math.sqrt(sff))
    return v_c, float("nan")


class PlaneCrossing:
    """Particles within ``±h`` of the orifice plane, binned by r, frame by frame.

    Parameters
    ----------
    R : float
        Orifice radius, m.
    r_b : float
        Largest particle radius, m (the unit of ``slab_halves`` and ``bin_width``).
    z0 : float
        Height of the orifice plane, m.
    slab_halves : sequence of float
        Half-widths of the slabs, in r_b; one pass fills all of them.
    bin_width : float
        Radial bin width, in r_b; bins reach :math:`1.5 R`.
    n_blocks : int
        Blocks of consecutive frames for the standard errors.
    """

    def __init__(self, R: float, r_b: float, z0: float = 0.0, slab_halves=SLAB_HALVES,
                 bin_width: float = BIN_WIDTH, n_blocks: int = 8):
        self.R, self.r_b, self.z0 = float(R), float(r_b), float(z0)
        self.halves = tuple(float(h) for h in slab_halves)
        self.edges = np.arange(0.0, 1.5 * R + 0.5 * bin_width * r_b, bin_width * r_b)
        self.n_blocks = int(n_blocks)
        self._frames: list[np.ndarray] = []   # per frame: (slabs, bins, 4) of mass, m v_z, volume, count

    @property
    def n_frames(self) -> int:
        return len(self._frames)

    def accumulate(self, frame) -> None:
        """Add one :class:`postproc.frame.ParticleFrame`."""
        pos, vel = np.asarray(frame.position), np.asarray(frame.velocity)
        r = np.hypot(pos[:, 0], pos[:, 1])
        dz = np.abs(pos[:, 2] - self.z0)
        nb = len(self.edges) - 1
        idx = np.searchsorted(self.edges, r, side="right") - 1
        inside = (idx >= 0) & (idx < nb)
        m, vz, vol = np.asarray(frame.mass), vel[:, 2], np.asarray(frame.volume)
        out = np.zeros((len(self.halves), nb, 4))
        for k, h in enumerate(self.halves):
            sel = inside & (dz < h * self.r_b)
            i = idx[sel]
            out[k, :, 0] = np.bincount(i, weights=m[sel], minlength=nb)
            out[k, :, 1] = np.bincount(i, weights=(m * vz)[sel], minlength=nb)
            out[k, :, 2] = np.bincount(i, weights=vol[sel], minlength=nb)
            out[k, :, 3] = np.bincount(i, minlength=nb)
        self._frames.append(out)

    # ------------------------------------------------------------------ results
    def _profile(self, sums: np.ndarray, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
        """``(v_z, phi)`` per slab and bin from summed (slabs, bins, 4) arrays over ``n_frames``."""
        area = np.pi * (self.edges[1:] ** 2 - self.edges[:-1] ** 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            vz = np.where(sums[..., 0] > 0, sums[..., 1] / sums[..., 0], np.nan)
        thick = 2 * np.asarray(self.halves)[:, None] * self.r_b
        phi = sums[..., 2] / (area[None, :] * thick * max(n_frames, 1))
        return vz, phi

    def _core(self, sums: np.ndarray) -> np.ndarray:
        """Mass-weighted mean v_z over the disc r < CORE_FRACTION R, per slab."""
        mid = 0.5 * (self.edges[1:] + self.edges[:-1])
        core = mid < CORE_FRACTION * self.R
        m, p = sums[:, core, 0].sum(axis=1), sums[:, core, 1].sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(m > 0, p / m, np.nan)

    def _blocks(self) -> list[tuple[np.ndarray, int]]:
        n = self.n_frames
        nb = min(self.n_blocks, n)
        bounds = np.linspace(0, n, nb + 1).astype(int)
        stack = np.asarray(self._frames)
        return [(stack[a:b].sum(axis=0), b - a) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]

    def conclude(self) -> tuple[pd.DataFrame, dict]:
        """``(profile table, scalars)``.

        The table has one row per slab and bin: ``slab_half`` (r_b), ``r_lo``, ``r_hi``, ``r_mid``,
        ``r_over_R``, ``vz``, ``vz_se``, ``phi``, ``phi_se``, ``n`` (particle-frames). The scalars,
        per slab ``h`` (e.g. ``_h0.5``): ``v_c_plane_h…`` (shape fit) with ``_se``,
        ``v_core_plane_h…`` (the disc mean) with ``_se``, ``phi_c_plane_h…`` (φ of the bins
        with r < R/4), ``W_plane_h…`` with ``_se`` (the mass flux down through the plane, kg/s:
        :math:`\\langle\\sum -m v_z\\rangle / 2h`, which mass conservation makes the outflow W_f);
        the headline's slab without a suffix (``v_c_plane``, …) and
        ``plane_frames``.
        """
        if not self.n_frames:
            return pd.DataFrame(), {"plane_frames": 0}
        total = np.sum(self._frames, axis=0)
        vz, phi = self._profile(total, self.n_frames)
        blocks = self._blocks()
        per = [self._profile(s, n) for s, n in blocks]
        nbk = len(per)

        def se(values: np.ndarray) -> np.ndarray:
            with warnings.catch_warnings():   # bins empty in every block stay NaN
                warnings.simplefilter("ignore", RuntimeWarning)
                if nbk < 2:
                    return np.full(values.shape[1:], np.nan)
                return np.nanstd(values, axis=0, ddof=1) / math.sqrt(nbk)

        vz_se = se(np.array([p[0] for p in per]))
        phi_se = se(np.array([p[1] for p in per]))
        mid = 0.5 * (self.edges[1:] + self.edges[:-1])
        rows = []
        scalars: dict = {"plane_frames": self.n_frames, "plane_blocks": nbk}
        # the mass flux through the plane, downwards: <sum m v_z over the slab> / (2h), every bin
        flux = -total[:, :, 1].sum(axis=1) / (2 * np.asarray(self.halves) * self.r_b * self.n_frames)
        flux_blocks = np.array([-s[:, :, 1].sum(axis=1) / (2 * np.asarray(self.halves) * self.r_b * n)
                                for s, n in blocks])
        flux_se = se(flux_blocks) if nbk > 1 else np.full(len(self.halves), np.nan)
        core_blocks = np.array([self._core(s) for s, _ in blocks])
        core = self._core(total)
        core_se = se(core_blocks) if nbk > 1 else np.full(len(self.halves), np.nan)
        core_bins = mid < CORE_FRACTION * self.R
        for k, h in enumerate(self.halves):
            v_c, v_c_se = shape_fit(self.edges[:-1], self.edges[1:], vz[k], vz_se[k], self.R)
            suffix = f"_h{h:g}"
            scalars[f"v_c_plane{suffix}"], scalars[f"v_c_plane{suffix}_se"] = v_c, v_c_se
            scalars[f"v_core_plane{suffix}"], scalars[f"v_core_plane{suffix}_se"] = float(core[k]), float(core_se[k])
            scalars[f"W_plane{suffix}"], scalars[f"W_plane{suffix}_se"] = float(flux[k]), float(flux_se[k])
            w = core_bins & (total[k, :, 3] > 0)
            area = np.pi * (self.edges[1:] ** 2 - self.edges[:-1] ** 2)
            scalars[f"phi_c_plane{suffix}"] = (float(np.sum(total[k, w, 2]) / (np.sum(area[w]) * 2 * h * self.r_b
                                                                                   * self.n_frames))
                                               if w.any() else float("nan"))
            rows.append(pd.DataFrame({"slab_half": h, "r_lo": self.edges[:-1], "r_hi": self.edges[1:], "r_mid": mid,
                                      "r_over_R": mid / self.R, "vz": vz[k], "vz_se": vz_se[k], "phi": phi[k],
                                      "phi_se": phi_se[k], "n": total[k, :, 3].astype(int)}))
        head = f"_h{self.halves[0]:g}"
        for key in ("v_c_plane", "v_core_plane", "phi_c_plane", "W_plane"):
            scalars[key] = scalars[key + head]
            if key + head + "_se" in scalars:
                scalars[key + "_se"] = scalars[key + head + "_se"]
        scalars["plane_slab_half"] = self.halves[0]
        return pd.concat(rows, ignore_index=True), scalars
