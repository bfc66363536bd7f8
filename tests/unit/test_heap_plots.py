"""Figures of the heap scene on synthetic cases with a known structure.

Each synthetic case follows the paper's kinematics: q = q0 (1 - x/L); the
flowing layer obeys delta/d_bar = C q*^0.22 exactly (times 2 % log-normal
noise); the streamwise profile is u = u_s(x) exp(z/z0) with u_s linear in x and
delta = z0 ln 10 (so the 0.1 u_s cutoff sits at z = -delta and the tail is
u/u_s = exp(ln(10) z/delta)); the normal velocity is eq. (3.6) with k = ln 10;
the free surface rises at v_r with slope tan(alpha).
"""
from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from granflow.scenes.heap import figures as hp

G = 9.81
L = 0.40                 # flowing-layer length, m
ALPHA = 25.7             # dynamic angle of repose, degrees
V_R = 1.0e-3             # rise velocity, m/s
A_TRUE = 0.22            # exponent of delta/d_bar = C q*^a
C_TRUE = 2.0
SIGMA = 0.02             # log-normal noise on delta/d_bar
X = np.arange(0.005, L, 0.01)          # streamwise bin centres, m (40 bins)
EXPECTED_AXES = {"fig03_segregation": 1, "fig04_surface": 4, "fig04b_surface_shape": 2, "fig05_velocity": 2, "fig06_streamwise": 4,
                 "fig07_collapse": 2, "fig08_normal": 1, "fig09_all_cases": 2, "fig10_scaled": 4,
                 "fig11_qstar": 1}


def make_case(i: int, q0: float, d_mean: float, bidisperse: bool, rng) -> dict:
    """One synthetic case; ``d_mean`` in m, ``q0`` in m^2/s."""
    xl = X / L
    # bidisperse: small particles deposit upstream, so d_bar grows along x
    d_bar = d_mean * (0.85 + 0.3 * xl) if bidisperse else np.full_like(X, d_mean)
    q = q0 * (1 - xl)
    q_star = q / (d_bar * np.sqrt(G * d_bar))
    delta = d_bar * C_TRUE * q_star ** A_TRUE * np.exp(SIGMA * rng.standard_normal(X.size))
    z0 = delta / np.log(10)
    u_s = 2 * q0 / delta.mean() * (1 - xl)
    k = np.log(10)
    v_rp = V_R * np.cos(np.radians(ALPHA))

    rows = []
    for xi, usi, z0i, di in zip(X, u_s, z0, delta):
        z = -np.arange(0.5e-3, 3 * di, 1e-3)
        u = usi * np.exp(z / z0i) * (1 + 0.01 * rng.standard_normal(z.size))
        w = v_rp * (np.exp(k * z / di) - 1) / (1 - np.exp(-k))
        rows.append(pd.DataFrame(dict(x=xi, z=z, phi=0.6, u=u, w=w, u_std=0.1 * usi, u_se=0.005 * usi,
                                      w_se=1e-5, n=100, d_mean=d_mean)))
    profile = pd.concat(rows, ignore_index=True)
    per = profile.merge(pd.DataFrame(dict(x=X, u_s=u_s, delta=delta)), on="x")
    collapse = pd.DataFrame(dict(x=per["x"], zt=per["z"] / per["delta"], ut=per["u"] / per["u_s"],
                                 wt=per["w"] / v_rp))
    gamma_bar = 0.9 * u_s / delta
    per_x = pd.DataFrame(dict(x=X, x_over_L=xl, q=q, u_s=u_s, gamma_bar=gamma_bar,
                              delta_exp=delta * 1.02, delta_lin=delta * 0.95, delta_cut=delta, delta=delta,
                              delta_eq31=np.sqrt(delta[-1] ** 2 + 2 * V_R * (L - X) / gamma_bar),
                              d_bar=d_bar, q_star=q_star, n_profile=30))
    if bidisperse:
        per_x["c_s"] = 0.9 - 0.8 * xl

    t = np.linspace(10.0, 15.0, 11)
    x_lab = np.arange(0.1, 0.45, 0.02)
    tt, xx = np.meshgrid(t, x_lab, indexing="ij")
    z_surf0 = 0.30
    zs = z_surf0 - xx * np.tan(np.radians(ALPHA)) + V_R * tt + 2e-4 * rng.standard_normal(tt.shape)
    surface = pd.DataFrame(dict(t=tt.ravel(), x_lab=xx.ravel(), z_s=zs.ravel()))
    z_lab = np.arange(0.0, 0.35, 5e-4)
    cols = []
    for xv in x_lab[::3]:
        zsurf = z_surf0 - xv * np.tan(np.radians(ALPHA)) + V_R * 12.5
        cols.append(pd.DataFrame(dict(x_lab=xv, z_lab=z_lab,
                                      phi=0.62 / (1 + np.exp((z_lab - zsurf) / 1.5e-3)))))
    scalars = dict(alpha_deg=ALPHA, alpha_se=0.07, v_r=V_R, v_r_se=2e-5, v_r_predicted=1.01 * V_R, L=L,
                   delta_mean=delta.mean(), delta_over_d=(delta / d_bar).mean(), tail_A=1.0, tail_k=k,
                   q_star_exponent=A_TRUE, q_star_prefactor=C_TRUE, q0=q0, t_start=10.0, t_end=15.0,
                   surface_z0=z_surf0, x_feed=0.08, W=0.46)
    return dict(label=f"case {i}: {d_mean * 1e3:g} mm, q0={q0 * 1e4:g} cm²/s", bidisperse=bidisperse,
                provenance=f"rung synthetic · W=0.46 m · T=0.013 m · t_c=1e-3 s · N={1000 * (i + 1)} · steady",
                scalars=scalars, per_x=per_x, profile=profile, collapse=collapse, surface=surface,
                alpha_t=pd.DataFrame(dict(t=t, alpha_deg=ALPHA + 0.05 * rng.standard_normal(t.size))),
                rise_by_x=pd.DataFrame(dict(x_lab=x_lab, v_r=V_R, v_r_se=2e-5)),
                phi_columns=pd.concat(cols, ignore_index=True),
                deposit=pd.DataFrame(dict(x_lab=x_lab, c_s=0.9 - 0.8 * x_lab / 0.46)) if bidisperse else None)


def test_the_surface_shape_figure_reads_the_plane_of_a_planar_surface(cases, tmp_path):
    from granflow.scenes.heap import figures as hf

    fig = hf.fig04b_surface_shape(cases, tmp_path / "shape.png")
    labels = " ".join(fig.axes[1].get_legend_handles_labels()[1])
    angles = [float(part.split("°")[0]) for part in labels.split("α = ")[1:]]
    assert angles and all(abs(a - ALPHA) < 0.1 for a in angles)    # a plane: middle and whole agree
    # the residual from the planar middle's plane is the noise (0.2 mm), nothing more
    for line in fig.axes[0].get_lines()[:3]:
        y = np.asarray(line.get_ydata(), float)
        if y.size > 2:
            assert np.nanmax(np.abs(y)) < 0.5


@pytest.fixture(scope="module")
def cases():
    rng = np.random.default_rng(2013)
    return [make_case(0, 1.7e-3, 1.5e-3, False, rng), make_case(1, 6.2e-3, 1.5e-3, False, rng),
            make_case(2, 1.7e-3, 1.4e-3, True, rng)]


def nan_case(case: dict) -> dict:
    """Same structure, every number NaN."""
    out = dict(case, scalars={k: np.nan for k in case["scalars"]}, provenance="rung nan · all NaN")
    for key, val in case.items():
        if isinstance(val, pd.DataFrame):
            out[key] = pd.DataFrame(np.nan, index=val.index, columns=val.columns)
    return out


def holey_case(case: dict, rng) -> dict:
    """Same case with a third of every numeric column (and of the scalars) set to NaN."""
    out = dict(case, provenance="rung holey · 1/3 NaN")
    out["scalars"] = {k: (np.nan if rng.random() < 1 / 3 else v) for k, v in case["scalars"].items()}
    for key, val in case.items():
        if isinstance(val, pd.DataFrame):
            out[key] = val.mask(rng.random(val.shape) < 1 / 3)
    return out


def data_axes(fig) -> list:
    """Axes holding data: figure axes and insets, without colour bars."""
    axes = [a for ax in fig.axes for a in (ax, *ax.child_axes)]
    return [a for a in axes if a.get_label() != "<colorbar>"]


def all_texts(fig) -> str:
    return " ".join(t.get_text() for ax in data_axes(fig) for t in ax.texts)


@pytest.fixture
def checked_fits(monkeypatch):
    """Fail if any fit in the module is attempted on fewer than two finite points."""
    polyfit = np.polyfit

    def guarded(x, y, deg, *args, **kw):
        ok = np.isfinite(np.asarray(x, float)) & np.isfinite(np.asarray(y, float))
        assert ok.sum() >= 2, "fit on fewer than two finite points"
        return polyfit(x, y, deg, *args, **kw)

    monkeypatch.setattr(hp.np, "polyfit", guarded)


def test_registry_names():
    assert list(hp.HEAP_FIGURES) == list(EXPECTED_AXES)
    assert all(f.__name__ == name for name, f in hp.HEAP_FIGURES.items())
    # the scene declares them by name, drawn on call (granflow.registry.Deferred): the same figures, in order
    from granflow.scenes.heap.scene import HeapScene

    assert list(HeapScene.figures) == list(hp.HEAP_FIGURES)
    assert all(spec.draw.function() is hp.HEAP_FIGURES[name] for name, spec in HeapScene.figures.items())


@pytest.mark.parametrize("name", list(EXPECTED_AXES))
def test_figure_written_with_axes_and_provenance(cases, tmp_path, checked_fits, check_png, name):
    path = tmp_path / f"{name}.png"
    fig = hp.HEAP_FIGURES[name](cases, path)
    # a rendered 150 dpi PNG with data is well above 10 kB; an empty or failed
    # figure is a few kB
    assert path.stat().st_size > 10_000
    check_png(path)
    assert len(data_axes(fig)) == EXPECTED_AXES[name]
    footer = " ".join(t.get_text() for t in fig.texts)
    for c in cases:
        # the footer wraps lines at spaces: compare without whitespace
        assert "".join(c["provenance"].split()) in "".join(footer.split())
    assert "not available" not in all_texts(fig)


def test_figures_plot_the_per_x_table(cases, tmp_path, assert_plotted):
    """Figure 11 shows each case's delta/d_bar against q* where x/L >= 0.2, figure 6 the first
    case's q (in cm^2/s) and u_s against x: the numbers of the per_x table, none lost or moved."""
    fig = hp.fig11_qstar(cases, tmp_path / "q.png")
    for case in cases:
        px = case["per_x"][case["per_x"]["x_over_L"] >= 0.2]
        assert_plotted(fig.axes[0], px["q_star"], px["delta"] / px["d_bar"])
    fig = hp.fig06_streamwise(cases, tmp_path / "s.png")
    px = cases[0]["per_x"]
    assert_plotted(fig.axes[0], px["x"], px["q"] * 1e4)
    assert_plotted(fig.axes[1], px["x"], px["u_s"])
    assert_plotted(fig.axes[2], px["x"], px["gamma_bar"])


def test_qstar_exponent_in_legend(cases, tmp_path):
    fig = hp.fig11_qstar(cases, tmp_path / "q.png")
    labels = fig.axes[0].get_legend_handles_labels()[1]
    a = float(re.search(r"fit over all cases: a = ([-0-9.]+)", " ".join(labels)).group(1))
    # The slope of a log-log fit with noise sigma on ln(delta/d_bar) has standard
    # error sigma / sqrt(sum (ln q* - mean)^2); 4 standard errors plus the
    # legend's rounding (5e-4) bounds the deviation from the known exponent.
    lq = np.log(np.concatenate([c["per_x"].query("x_over_L >= 0.2")["q_star"] for c in cases]))
    se = SIGMA / np.sqrt(np.sum((lq - lq.mean()) ** 2))
    assert se < 0.005  # the design resolves the exponent
    assert abs(a - A_TRUE) < 4 * se + 5e-4
    assert any("paper (Fan et al. 2013)" in lab for lab in labels)


def test_collapse_labels_paper_tail(cases, tmp_path):
    fig = hp.fig07_collapse(cases, tmp_path / "c.png")
    labels = fig.axes[1].get_legend_handles_labels()[1]
    assert any(lab.startswith("paper (Fan et al. 2013)") for lab in labels)
    assert any(lab.startswith("fit: 1.00 exp(2.30 z/δ)") for lab in labels)


@pytest.mark.parametrize("name", list(EXPECTED_AXES))
def test_nan_only_and_missing_inputs(cases, tmp_path, checked_fits, check_png, name):
    nan = nan_case(cases[2])
    bare = dict(label="bare", provenance="rung bare", bidisperse=True, scalars=None)  # no frames at all
    one_point = dict(cases[0], per_x=cases[0]["per_x"].iloc[[30]], provenance="rung one point")
    holey = holey_case(cases[2], np.random.default_rng(7))
    for i, sample in enumerate(([nan], [bare], [one_point, holey, nan])):
        path = tmp_path / f"{name}_{i}.png"
        fig = hp.HEAP_FIGURES[name](sample, path)
        check_png(path)
        assert len(data_axes(fig)) == EXPECTED_AXES[name]
        assert sample[0]["provenance"] in " ".join(t.get_text() for t in fig.texts)


@pytest.mark.parametrize("name", list(EXPECTED_AXES))
def test_empty_cases(tmp_path, check_png, name):
    path = tmp_path / f"{name}.png"
    fig = hp.HEAP_FIGURES[name]([], path)
    check_png(path)
    assert "no averaged case" in all_texts(fig)


def test_segregation_without_bidisperse_case(cases, tmp_path):
    fig = hp.fig03_segregation(cases[:2], tmp_path / "s.png")
    assert "no bidisperse case" in all_texts(fig)
