"""Figures of the silo scene on small synthetic cases with a known structure.

Each synthetic case follows the paper's picture on a coarse (r, z) grid of
spacing r_b: the velocity across the orifice is v0 sqrt(1 - (r/R)^2) with
v0 = a sqrt(R); the kinetic pressure on the axis is a Gaussian bump centred
at h_c = 1.2 R, shared among the sizes in fixed fractions; the contact
pressure falls to zero at the outlet; the discharge follows Beverloo's law
with C = 0.58, k = 1.5 after a short start-up.  The scalars are produced by
:mod:`granflow.scenes.silo.analysis` itself, so the figures see what the glue will pass them.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from granflow.scenes.silo import analysis as silo
from granflow.scenes.silo import figures as sp

R_B = 1.0 / 64
RADII = list(R_B * np.arange(10, 17) / 16)       # 7 sizes (the glue passes its own list)
RHO_P, G, PHI_B = 7520.0, 10.0, 0.60
R_C = 24 * R_B
C_BEV, K_BEV = 0.58, 1.5
A_VC = 2.0                                        # v_c = A_VC sqrt(R), m^1/2/s
EXPECTED_AXES = {"fig02_flow_rate": 2, "fig03_fields": 2, "fig04_phi_orifice": 2, "fig05_vz_orifice": 3,
                 "fig05d_orifice_plane": 3,
                 "fig06_contact_pressure": 2, "fig07_kinetic_pressure_maps": None, "fig08_kinetic_axis": 2,
                 "fig09_kinetic_w": 2, "fig10_cumulative": 2, "fig11_partial": 2, "fig12_partial_over_phi": 1,
                 "fig13_beverloo": 2}


def field_table(R: float, rng, scale: float = 1.0) -> pd.DataFrame:
    """Main-field table on r = 0 .. R_c, z = -2 r_b .. 40 r_b (spacing r_b), r-major."""
    r = np.arange(0, R_C + R_B / 2, R_B)
    z = np.arange(-2, 41) * R_B
    rr, zz = (a.ravel() for a in np.meshgrid(r, z, indexing="ij"))
    x = np.clip(rr / R, 0, 1)
    inside = rr < R
    phi = PHI_B - 0.12 * np.exp(-(rr ** 2 + zz ** 2) / R ** 2)
    phi = np.where((zz < 0) & ~inside, 0.0, phi)
    v0 = A_VC * np.sqrt(R)
    u_z = np.where(inside, -v0 * np.sqrt(1 - x ** 2), -0.02 * v0) * np.exp(-np.clip(zz, 0, None) / (2 * R))
    pk = scale * 50.0 * np.exp(-(zz - 1.2 * R) ** 2 / (2 * (0.5 * R) ** 2)) * np.exp(-rr ** 2 / R ** 2) + 1e-3
    pc = 2e4 * (1 - np.exp(-np.clip(zz, 0, None) / R)) * (1 + 0.1 * rr / R_C)
    out = dict(r=rr, z=zz, phi=phi, rho=RHO_P * phi, u_r=0.0 * rr, u_t=0.0 * rr, u_z=u_z, pk=pk, pc=pc)
    weights = np.arange(1, 8, dtype=float) ** 0.5
    weights /= weights.sum()
    vol = np.asarray(RADII) ** 3 / np.sum(np.asarray(RADII) ** 3)
    for s in range(1, 8):
        out[f"pk_s{s}"] = pk * weights[s - 1]
        out[f"phi_s{s}"] = phi * vol[s - 1]
    df = pd.DataFrame(out)
    for col in list(df.columns[2:]):
        df[f"{col}_se"] = 0.02 * np.abs(df[col]) * (1 + 0.1 * rng.random(len(df)))
    return df


def thermo_series(R: float, rng) -> pd.DataFrame:
    """Discharge with a 50 ms start-up, Beverloo rate and counting noise, surface falling accordingly."""
    d = silo.mean_diameter(RADII)
    W0 = silo.beverloo_law(2 * R, C_BEV, K_BEV, RHO_P * PHI_B, G, d)
    t = np.arange(0.0, 1.0, 2e-3)
    rate = W0 * (1 - np.exp(-t / 0.05))
    m_del = np.cumsum(rate * 2e-3) + np.cumsum(0.02 * rng.standard_normal(t.size)) * np.sqrt(W0 * 0.06)
    z_s = 0.5 - (m_del / (RHO_P * PHI_B * np.pi * R_C ** 2)) + 2e-4 * rng.standard_normal(t.size)
    return pd.DataFrame(dict(Step=np.arange(t.size) * 100, Time=t, Atoms=1000, v_mtot=100 - m_del,
                             v_mdel=m_del, v_mins=0.0, v_zs=z_s, c_ke=1.0, v_overlap=1e-3))


def plane_reading(R: float, rng, n_frames: int = 8, n: int = 3000):
    """The kernel-free orifice reading of particles falling at A_VC sqrt(R) sqrt(1 - (r/R)^2)."""
    from types import SimpleNamespace

    from granflow.scenes.silo.analysis.orifice import PlaneCrossing

    plane = PlaneCrossing(R, R_B, n_blocks=4)
    radius = 0.8 * R_B
    for step in range(n_frames):
        r = 1.5 * R * np.sqrt(rng.random(n))
        th = 2 * np.pi * rng.random(n)
        pos = np.column_stack([r * np.cos(th), r * np.sin(th), rng.uniform(-R_B, R_B, n)])
        vel = np.zeros((n, 3))
        vel[:, 2] = -A_VC * np.sqrt(R) * np.sqrt(np.clip(1 - (r / R) ** 2, 0, None)) * (1 + 0.02 * rng.standard_normal(n))
        plane.accumulate(SimpleNamespace(position=pos, velocity=vel, mass=np.full(n, RHO_P * 4 / 3 * np.pi * radius**3),
                                         volume=np.full(n, 4 / 3 * np.pi * radius**3)))
    return plane.conclude()


def make_case(n_R: int, rng, rung: str = "demo") -> dict:
    R = n_R * R_B
    thermo = thermo_series(R, rng)
    flow = silo.flow_rates(thermo, RHO_P, PHI_B, R_C, window=0.05)
    t0, t1, _ = silo.steady_window(flow["t"], flow["W_f"], rel_tol=0.15, window=0.05)
    W, W_se = silo.steady_flow_rate(thermo, t0, t1)
    fields = field_table(R, rng)
    o = silo.orifice_profiles(fields, R)
    axis = silo.axis_profile(fields, "pk")
    h_c, h_c_se = silo.transition_height(axis["z"], axis["value"], axis["value_se"], n_resample=50)
    contact = fields[["r", "z", "pc", "pc_se"]].assign(sigmac_zz=fields["pc"], sigmac_zz_se=fields["pc_se"])
    scan = {w * R_B: field_table(R, rng, scale=1 / w)[["r", "z", "pk", "pk_se"]] for w in (0.5, 1.0, 2.0)}
    provenance = f"rung {rung} · R_c={R_C:.3f} m · N={2000 * n_R} · Y=1.2e8 · t_c=1e-4 s · status ok"
    scalars = dict(R=R, R_c=R_C, r_b=R_B, radii=RADII, density=RHO_P, gravity=G, rung=rung, reinsert=False,
                   provenance=provenance, label=f"R = {n_R} r_b", phi_b=PHI_B, W_f=W, W_se=W_se, t_start=t0,
                   t_end=t1, phi_c=o["phi_c"], phi_c_se=o["phi_c_se"], v_c=o["v_c"], v_c_se=o["v_c_se"],
                   h_c=h_c, h_c_se=h_c_se, sqrt_profile_deviation=o["sqrt_profile_deviation"])
    plane, plane_scalars = plane_reading(R, rng)
    scalars.update(plane_scalars)
    return dict(label=f"R = {n_R} r_b", provenance=provenance, scalars=scalars, flow=flow, fields=fields,
                contact=contact, kinetic_scan=scan, orifice_plane=plane)


@pytest.fixture(scope="module")
def cases():
    rng = np.random.default_rng(2016)
    return [make_case(n, rng) for n in (8, 12, 16)]


def data_axes(fig) -> list:
    """Axes holding data: figure axes and insets, without colour bars."""
    axes = [a for ax in fig.axes for a in (ax, *ax.child_axes)]
    return [a for a in axes if a.get_label() != "<colorbar>"]


def all_texts(fig) -> str:
    return " ".join(t.get_text() for ax in data_axes(fig) for t in ax.texts)


def expected_axes(name: str, n_cases: int) -> int:
    return max(1, n_cases) if EXPECTED_AXES[name] is None else EXPECTED_AXES[name]


def test_registry_names():
    assert list(sp.SILO_FIGURES) == list(EXPECTED_AXES)
    assert all(f.__name__ == name for name, f in sp.SILO_FIGURES.items())
    # the scene declares them by name, drawn on call (granflow.registry.Deferred): the same figures, in order
    from granflow.scenes.silo.scene import SiloScene

    assert list(SiloScene.figures) == list(sp.SILO_FIGURES)
    assert all(spec.draw.function() is sp.SILO_FIGURES[name] for name, spec in SiloScene.figures.items())


def test_synthetic_cases_are_steady(cases):
    # the analysis chain behind the fixture found what was built in
    for c in cases:
        s = c["scalars"]
        assert np.isfinite(s["t_start"]) and s["t_start"] > 0.05   # after the 50 ms start-up
        assert s["sqrt_profile_deviation"] < 1e-12                 # exact sqrt profile on the nodes
        assert abs(s["h_c"] - 1.2 * s["R"]) < 0.25 * R_B           # bump plus 1e-3 floor: well within a node


@pytest.fixture(scope="module")
def rendered(cases, tmp_path_factory):
    """Every figure drawn once from the three cases: name -> (figure, path)."""
    out = tmp_path_factory.mktemp("silo_figures")
    return {name: (f(cases, out / f"{name}.png"), out / f"{name}.png") for name, f in sp.SILO_FIGURES.items()}


@pytest.mark.parametrize("name", list(EXPECTED_AXES))
def test_figure_written_with_provenance(cases, rendered, check_png, name):
    fig, path = rendered[name]
    # a rendered 150 dpi PNG with data is well above 10 kB; an empty or failed figure is a few kB
    assert path.stat().st_size > 10_000
    check_png(path)
    assert len(data_axes(fig)) == expected_axes(name, len(cases))
    footer = "".join(" ".join(t.get_text() for t in fig.texts).split())
    for c in cases:
        assert "".join(c["provenance"].split()) in footer   # the footer wraps at spaces
    assert "rung:demo" in footer
    assert "not available" not in all_texts(fig)


def test_flow_rate_and_orifice_figures_plot_the_tables(cases, rendered, assert_plotted):
    """Figure 2 shows each case's W_f (and W_r) of its flow table against t/t_d; figure 4 the
    volume fraction of the orifice row of its field table against r: nothing lost or moved."""
    fig2 = rendered["fig02_flow_rate"][0]
    fig4 = rendered["fig04_phi_orifice"][0]
    for case in cases:
        s, flow = case["scalars"], case["flow"]
        t_d = np.sqrt(2 * s["r_b"] / s["gravity"])
        assert_plotted(fig2.axes[0], flow["t"] / t_d, flow["W_f"])
        assert_plotted(fig2.axes[0], flow["t"] / t_d, flow["W_r"])
        orifice = case["fields"][case["fields"]["z"] == 0.0].sort_values("r")  # the node row at z = 0
        assert_plotted(fig4.axes[0], orifice["r"], orifice["phi"])


def test_demo_rung_is_flagged_in_red(rendered):
    fig = rendered["fig08_kinetic_axis"][0]
    badge = [t for t in fig.texts if t.get_text().startswith("rung:")]
    assert len(badge) == 1 and "demo" in badge[0].get_text() and badge[0].get_color() == "red"


def test_beverloo_legend_and_refusal(cases, rendered, tmp_path):
    fig = rendered["fig13_beverloo"][0]
    labels = " ".join(fig.axes[0].get_legend_handles_labels()[1])
    assert "Beverloo fit: C = " in labels and "k = " in labels
    fig = sp.fig13_beverloo(cases[:2], tmp_path / "b2.png")
    assert "at least 3 orifice sizes" in all_texts(fig)


def test_the_plane_figure_plots_the_plane_profile_and_fits_the_square_root(cases, rendered, assert_plotted):
    fig = rendered["fig05d_orifice_plane"][0]
    for case in cases:
        p = case["orifice_plane"]
        p = p[(p["slab_half"] == 0.5) & (p["r_over_R"] <= 1.3)]
        v_c = abs(case["scalars"]["v_c_plane"])
        assert v_c == pytest.approx(A_VC * np.sqrt(case["scalars"]["R"]), rel=0.02)
        assert_plotted(fig.axes[0], p["r_over_R"], -p["vz"] / v_c)
        assert_plotted(fig.axes[1], p["r_over_R"], p["phi"])
    labels = " ".join(fig.axes[2].get_legend_handles_labels()[1])
    exponent = float(labels.split("a = ")[1].split(" ")[0])
    assert exponent == pytest.approx(0.5, abs=0.03)     # v_c = A_VC sqrt(R) built in
    assert "kernel node" in labels and "sqrt{2gR}" in labels


def test_sqrt_reference_is_labelled(rendered):
    fig = rendered["fig05_vz_orifice"][0]
    labels = fig.axes[1].get_legend_handles_labels()[1]
    assert any(lab.startswith("reference") for lab in labels)


@pytest.mark.parametrize("name", list(EXPECTED_AXES))
def test_empty_cases(tmp_path, check_png, name):
    path = tmp_path / f"{name}.png"
    fig = sp.SILO_FIGURES[name]([], path)
    check_png(path)
    assert "no averaged case" in all_texts(fig)


@pytest.mark.parametrize("name", list(EXPECTED_AXES))
def test_missing_tables(cases, tmp_path, check_png, name):
    bare = dict(label="bare", provenance="rung smoke · bare", scalars=dict(rung="smoke"))  # no tables at all
    nan = dict(cases[1], provenance="rung smoke · all NaN", scalars={k: np.nan for k in cases[1]["scalars"]},
               fields=pd.DataFrame(np.nan, index=cases[1]["fields"].index, columns=cases[1]["fields"].columns),
               flow=None, contact=pd.DataFrame(), kinetic_scan={})
    path = tmp_path / f"{name}.png"
    sample = [bare, nan, cases[0]]
    fig = sp.SILO_FIGURES[name](sample, path)
    check_png(path)
    assert len(data_axes(fig)) == expected_axes(name, len(sample))
    texts = " ".join(t.get_text() for t in fig.texts)
    assert "rung smoke · bare" in texts and "smoke" in texts


def test_kinetic_maps_wrap_into_rows(cases, tmp_path):
    five = cases + [dict(c, label=f"copy {i}") for i, c in enumerate(cases[:2])]
    fig = sp.fig07_kinetic_pressure_maps(five, tmp_path / "k.png")
    assert len(data_axes(fig)) == 5  # 4 + 1 panels, the empty grid slots removed
