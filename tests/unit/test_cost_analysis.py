"""Error-against-cost analysis on synthetic records with known answers.

Each test builds a long ``records`` table (one row per run point and
observable) whose errors, noises, costs and scaling are known analytically,
and checks the numbers :mod:`granflow.cost_analysis` derives from it.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from granflow import cost_analysis as cost
from granflow.cost_figure import plot_error_vs_cost


def record(scene="channel", knob="dt_fraction", value=0.1, observable="u", x=1.0, se=0.0, finest="min",
           is_base=False, cpu_s=100.0, n_particles=1000, sim_time=10.0, label=None, **extra) -> dict:
    row = dict(scene=scene, knob=knob, value=float(value), is_base=is_base, finest=finest, observable=observable,
               label=label or f"label of {observable}", x=float(x), se=float(se), cpu_s=float(cpu_s),
               sim_cpu_s=0.9 * float(cpu_s), post_cpu_s=0.1 * float(cpu_s), loop_s=0.8 * float(cpu_s),
               peak_mb=200.0, n_particles=int(n_particles), sim_time=float(sim_time), status="ok")
    row.update(extra)
    return row


def frame(rows: list[dict]) -> pd.DataFrame:
    return pd.DataFrame(rows)


def one(df: pd.DataFrame, **where) -> pd.Series:
    mask = np.ones(len(df), dtype=bool)
    for k, v in where.items():
        mask &= (np.isclose(df[k].to_numpy(dtype=float), v) if isinstance(v, float) else (df[k] == v).to_numpy())
    sub = df[mask]
    assert len(sub) == 1, f"{len(sub)} rows match {where}"
    return sub.iloc[0]


# --------------------------------------------------------------------------- knob_errors
DT_VALUES = (0.02, 0.05, 0.1, 0.2)


def dt_series(c: float, observable: str) -> list[dict]:
    return [record(value=v, observable=observable, x=1 + c * v ** 2, se=1e-7, is_base=(v == 0.1))
            for v in DT_VALUES]


def test_dt_series_errors_are_analytic_with_reference_at_min():
    rec = frame(dt_series(0.5, "up") + dt_series(-0.5, "down"))
    err = cost.knob_errors(rec)
    assert len(err) == len(rec) and list(err.index) == list(rec.index)
    assert set(rec.columns) <= set(err.columns)
    for c, obs in ((0.5, "up"), (-0.5, "down")):
        x_ref = 1 + c * 0.02 ** 2
        for v in DT_VALUES:
            r = one(err, observable=obs, value=v)
            expected = (1 + c * v ** 2 - x_ref) / x_ref
            assert r["error"] == pytest.approx(expected, rel=1e-12, abs=1e-15)
            assert r["abs_error"] == pytest.approx(abs(expected), rel=1e-12, abs=1e-15)
            assert r["x_ref"] == pytest.approx(x_ref)
            assert r["ref_value"] == 0.02
            assert r["relative"]
            assert bool(r["is_ref"]) == (v == 0.02)
            if v != 0.02:
                assert np.sign(r["error"]) == np.sign(c)
                assert r["significant"]        # se = 1e-7, errors >= 1e-3
    assert err["is_ref"].sum() == 2
    # spot value: dt = 0.2, c = 0.5 -> (0.02 - 0.0002) / 1.0002
    assert one(err, observable="up", value=0.2)["error"] == pytest.approx(0.0198 / 1.0002)


def test_significance_against_noise():
    rows = [record(value=0.05, observable="inside", x=1.00, se=0.02),
            record(value=0.10, observable="inside", x=1.01, se=0.02),
            record(value=0.05, observable="outside", x=1.00, se=0.02),
            record(value=0.10, observable="outside", x=1.10, se=0.02),
            record(value=0.05, observable="no_se", x=2.00, se=np.nan),
            record(value=0.10, observable="no_se", x=2.10, se=0.1)]
    err = cost.knob_errors(frame(rows), noise_sigmas=2.0)

    ref = one(err, observable="inside", value=0.05)
    assert ref["is_ref"] and ref["error"] == 0 and not ref["significant"]
    assert ref["noise"] == pytest.approx(0.02)                 # se_ref / |x_ref|

    inside = one(err, observable="inside", value=0.10)
    assert inside["error"] == pytest.approx(0.01)
    assert inside["noise"] == pytest.approx(np.sqrt(2) * 0.02)
    assert not inside["significant"]                            # 0.01 < 2 * 0.0283

    outside = one(err, observable="outside", value=0.10)
    assert outside["error"] == pytest.approx(0.10)
    assert outside["significant"]                               # 0.10 > 0.0566
    assert not cost.knob_errors(frame(rows), noise_sigmas=4.0).pipe(
        one, observable="outside", value=0.10)["significant"]  # 0.10 < 4 * 0.0283

    no_se = one(err, observable="no_se", value=0.10)
    assert no_se["se_missing"] and one(err, observable="no_se", value=0.05)["se_missing"]
    assert no_se["noise"] == pytest.approx(0.1 / 2.0)           # NaN se_ref counts as 0
    assert no_se["error"] == pytest.approx(0.05)
    assert not no_se["significant"]                             # 0.05 < 2 * 0.05
    assert not inside["se_missing"]


def test_finest_max_nan_at_finest_zero_reference_and_no_reference():
    values = (1e4, 1e5, 1e6)
    rows = [record(knob="stiffness", finest="max", value=v, observable="a", x=x, se=0.001)
            for v, x in zip(values, (1.2, 1.05, 1.0))]
    rows += [record(knob="stiffness", finest="max", value=v, observable="b", x=x, se=0.001)
             for v, x in zip(values, (1.2, 1.1, np.nan))]
    rows += [record(knob="stiffness", finest="max", value=v, observable="zero", x=x, se=0.001)
             for v, x in zip(values, (0.3, 0.1, 0.0))]
    rows += [record(knob="stiffness", finest="max", value=v, observable="dead", x=np.nan, se=np.nan)
             for v in values]
    err = cost.knob_errors(frame(rows))

    a = err[err["observable"] == "a"]
    assert (a["ref_value"] == 1e6).all() and (a["x_ref"] == 1.0).all()
    assert one(err, observable="a", value=1e4)["error"] == pytest.approx(0.2)
    assert one(err, observable="a", value=1e6)["is_ref"]

    b = err[err["observable"] == "b"]
    assert (b["ref_value"] == 1e5).all() and (b["x_ref"] == 1.1).all()
    assert one(err, observable="b", value=1e5)["is_ref"]
    assert one(err, observable="b", value=1e4)["error"] == pytest.approx(0.1 / 1.1)
    nan_row = one(err, observable="b", value=1e6)
    assert np.isnan(nan_row["error"]) and not nan_row["significant"] and not nan_row["is_ref"]
    assert nan_row["note"] == "x not finite"

    z = one(err, observable="zero", value=1e4)
    assert not z["relative"] and z["error"] == pytest.approx(0.3)       # absolute error
    assert z["noise"] == pytest.approx(np.sqrt(2) * 0.001)

    dead = err[err["observable"] == "dead"]
    assert dead["error"].isna().all() and dead["x_ref"].isna().all()
    assert (dead["note"] == "no finite reference").all() and not dead["is_ref"].any()


def test_inconsistent_finest_is_rejected():
    rows = [record(value=0.1, finest="min"), record(value=0.2, finest="max")]
    with pytest.raises(ValueError, match="finest"):
        cost.knob_errors(frame(rows))


# --------------------------------------------------------------------------- pareto_front
def test_pareto_front_known_mask_with_nans_and_ties():
    c = [1, 2, 3, 4, 2, np.nan, 5, 1, 1]
    e = [5, 3, 4, 1, 3, 0.1, 1, np.nan, 6]
    # 0 front; 1 and 4 exact duplicates: both front; 2 dominated by 1; 3 front;
    # 5, 7 NaN; 6 dominated by 3 (equal error, cheaper); 8 dominated by 0 (equal cost, smaller error)
    expected = [True, True, False, True, True, False, False, False, False]
    mask = cost.pareto_front(c, e)
    assert mask.dtype == bool
    assert mask.tolist() == expected
    assert cost.pareto_front([], []).tolist() == []
    assert cost.pareto_front([np.nan], [1.0]).tolist() == [False]


# --------------------------------------------------------------------------- within_table
DT = (0.05, 0.1, 0.2, 0.4)
CPU = {0.05: 800.0, 0.1: 400.0, 0.2: 200.0, 0.4: 100.0}
ERR_A = {0.05: 0.0, 0.1: 0.01, 0.2: 0.03, 0.4: 0.08}
ERR_B = {0.05: 0.0, 0.1: 0.02, 0.2: 0.07, 0.4: 0.20}


def within_records() -> pd.DataFrame:
    rows = []
    for v in DT:
        rows.append(record(value=v, observable="A", x=2.0 * (1 + ERR_A[v]), se=1e-5, cpu_s=CPU[v]))
        rows.append(record(value=v, observable="B", x=3.0 * (1 - ERR_B[v]), se=1e-5, cpu_s=CPU[v]))
        rows.append(record(value=v, observable="C", x=1.0, se=0.1, cpu_s=CPU[v]))
    return frame(rows)


def test_within_table_cheapest_qualifying_setting_and_all_row():
    err = cost.knob_errors(within_records())
    table = cost.within_table(err, tolerances=(0.05, 0.10))
    assert list(table.columns)[:14] == ["scene", "observable", "label", "knob", "tolerance", "value", "cpu_s",
                                        "cpu_h", "error", "noise", "significant", "resolved", "paper_cpu_h",
                                        "note"]
    assert len(table) == 2 * (3 + 1)

    # A: the cheapest setting (0.4, 8 %) fails 5 %, the next (0.2, 3 %) passes
    a5 = one(table, observable="A", tolerance=0.05)
    assert a5["value"] == 0.2 and a5["cpu_s"] == 200.0 and a5["cpu_h"] == pytest.approx(200 / 3600)
    assert a5["error"] == pytest.approx(0.03) and a5["resolved"] and a5["significant"]
    assert one(table, observable="A", tolerance=0.10)["value"] == 0.4
    # B: 20 %, 7 %, 2 % -> 0.1 at 5 %, 0.2 at 10 %; error is signed
    b5 = one(table, observable="B", tolerance=0.05)
    assert b5["value"] == 0.1 and b5["error"] == pytest.approx(-0.02)
    assert one(table, observable="B", tolerance=0.10)["value"] == 0.2
    # C never changes but its noise (sqrt(2) * 10 % = 14 %) exceeds 5 % and 10 %
    c5 = one(table, observable="C", tolerance=0.05)
    assert c5["value"] == 0.4 and c5["error"] == 0
    assert not c5["resolved"] and "noise ±14 % exceeds 5 %" in c5["note"]
    assert c5["noise"] == pytest.approx(np.sqrt(2) * 0.1)
    assert not one(table, observable="C", tolerance=0.10)["resolved"]
    assert np.isnan(table["paper_cpu_h"]).all()

    # "all" takes the strictest observable (B), reports B's error and the largest noise
    all5 = one(table, observable="all", tolerance=0.05)
    assert all5["value"] == 0.1 and all5["cpu_s"] == 400.0
    assert all5["error"] == pytest.approx(-0.02) and "worst: B" in all5["note"]
    assert all5["noise"] == pytest.approx(np.sqrt(2) * 0.1) and not all5["resolved"]
    assert one(table, observable="all", tolerance=0.10)["value"] == 0.2

    # without the noisy observable the "all" row is resolved
    table_ab = cost.within_table(err[err["observable"] != "C"], tolerances=(0.05,))
    assert one(table_ab, observable="all")["resolved"]
    assert one(table_ab, observable="all")["value"] == 0.1


def test_within_table_only_reference_and_no_reference():
    rows = [record(value=v, observable="far", x=1.0 + 0.5 * (v > 0.05), se=1e-4, cpu_s=CPU[v]) for v in DT]
    rows += [record(value=v, observable="dead", x=np.nan, se=np.nan, cpu_s=CPU[v]) for v in DT]
    table = cost.within_table(cost.knob_errors(frame(rows)), tolerances=(0.05,))
    far = one(table, observable="far")
    assert far["value"] == 0.05 and far["cpu_s"] == 800.0 and "only the finest setting" in far["note"]
    dead = one(table, observable="dead")
    assert np.isnan(dead["value"]) and dead["note"] == "no finite reference"
    # "all" ignores the observable without a reference
    assert one(table, observable="all")["value"] == 0.05


def test_within_table_paper_extrapolation():
    err = cost.knob_errors(within_records())
    scaling = dict(exponent=1.3, exponent_se=0.01, prefactor=1.0, measured=True, n_points=4)
    paper = dict(n_particles=1e5, sim_time=100.0)
    table = cost.within_table(err, tolerances=(0.05,), scaling=scaling, paper=paper)
    a5 = one(table, observable="A")
    assert a5["paper_cpu_h"] == pytest.approx(200.0 * 100 ** 1.3 * 10 / 3600)
    # per-scene mappings give the same
    table2 = cost.within_table(err, tolerances=(0.05,), scaling={"channel": scaling}, paper={"channel": paper})
    assert np.allclose(table2["paper_cpu_h"], table["paper_cpu_h"])
    # and another scene's entry does not apply
    table3 = cost.within_table(err, tolerances=(0.05,), scaling=scaling, paper={"silo": paper})
    assert table3["paper_cpu_h"].isna().all()


def test_summary_markdown():
    err = cost.knob_errors(within_records())
    md = cost.summary_markdown(cost.within_table(err), tolerance=0.05)
    lines = md.strip().splitlines()
    table_lines = [ln for ln in lines if ln.startswith("|")]
    assert len(table_lines) == 2 + 4                 # header, rule, A, B, C, all
    assert "paper CPU-h (extrapolated)" in table_lines[0]
    row_a = next(ln for ln in table_lines if "label of A" in ln)
    # noise = sqrt(2) * 1e-5 / 2 = 7.1e-6 = 0.00071 %
    assert "| 0.2 |" in row_a and "+3 ± 0.00071" in row_a and "| 200 |" in row_a
    assert "noise ±14 % exceeds 5 %" in md
    assert "no rows" in cost.summary_markdown(cost.within_table(err), tolerance=0.5)


# --------------------------------------------------------------------------- cost scaling
A_COST, B_COST = 2e-3, 1.3


def scaling_records(sizes=(0.5, 1.0, 2.0, 4.0), scene="channel") -> pd.DataFrame:
    rows = []
    for i, s in enumerate(sizes):
        N, t = int(1000 * s), 10.0 * (i + 1)
        sim = A_COST * N ** B_COST * t
        for obs in ("u", "phi"):
            rows.append(record(scene=scene, knob="size", value=s, observable=obs, n_particles=N, sim_time=t,
                               cpu_s=sim * 1.1, sim_cpu_s=sim, is_base=(s == 1.0)))
    # other knobs with costs off the law must be ignored
    rows.append(record(scene=scene, knob="dt_fraction", value=0.05, n_particles=123456, sim_time=1.0,
                       sim_cpu_s=1.0, cpu_s=1.0))
    return frame(rows)


def test_cost_scaling_recovers_exponent():
    sc = cost.cost_scaling(scaling_records())
    assert sc["measured"] and sc["n_points"] == 4
    assert sc["exponent"] == pytest.approx(B_COST, rel=1e-10)
    assert sc["prefactor"] == pytest.approx(A_COST, rel=1e-8)
    assert sc["exponent_se"] == pytest.approx(0.0, abs=1e-8)

    two = cost.cost_scaling(scaling_records(sizes=(1.0, 3.0)))
    assert two["measured"] and two["n_points"] == 2 and np.isnan(two["exponent_se"])
    assert two["exponent"] == pytest.approx(B_COST, rel=1e-10)

    single = cost.cost_scaling(scaling_records(sizes=(1.0,)))
    assert not single["measured"] and single["exponent"] == 1.0 and single["n_points"] == 1
    assert single["prefactor"] == pytest.approx(A_COST * 1000 ** 0.3)   # rate / N

    both = pd.concat([scaling_records(), scaling_records(scene="heap")])
    with pytest.raises(ValueError, match="one scene"):
        cost.cost_scaling(both)


def test_extrapolate_analytic():
    sc = dict(exponent=1.3)
    paper = dict(n_particles=1e5, sim_time=50.0)
    assert cost.extrapolate(100.0, 1e3, 10.0, sc, paper) == pytest.approx(100 * 100 ** 1.3 * 5)
    assert cost.extrapolate(100.0, 1e5, 50.0, sc, paper) == pytest.approx(100.0)
    # chained with the fit: the law itself is reproduced at the paper's size
    fit = cost.cost_scaling(scaling_records())
    assert cost.extrapolate(A_COST * 1000 ** B_COST * 10, 1000, 10.0, fit, paper) == pytest.approx(
        A_COST * 1e5 ** B_COST * 50.0, rel=1e-8)
    assert np.isnan(cost.extrapolate(np.nan, 1e3, 10.0, sc, paper))
    assert np.isnan(cost.extrapolate(100.0, 0, 10.0, sc, paper))
    assert np.isnan(cost.extrapolate(100.0, 1e3, 10.0, sc, {"n_particles": 1e5}))


# --------------------------------------------------------------------------- figure
def figure_records(n_obs: int) -> pd.DataFrame:
    rows = []
    knobs = {"dt_fraction": ("min", (0.05, 0.1, 0.2, 0.4)), "stiffness": ("max", (1e4, 1e5, 1e6)),
             "size": ("max", (0.5, 1.0, 2.0))}
    rng = np.random.default_rng(3)
    for o in range(n_obs):
        for knob, (finest, values) in knobs.items():
            for j, v in enumerate(values):
                fine_rank = j if finest == "min" else len(values) - 1 - j
                x = 1.0 + 0.03 * fine_rank * (o + 1) + rng.normal(0, 0.002)
                if knob == "size" and fine_rank == 0 and o == 0:
                    x = np.nan                                    # failed run at the finest size
                rows.append(record(knob=knob, finest=finest, value=v, observable=f"obs{o}", x=x,
                                   se=0.01 if o == 1 else 0.001, cpu_s=1000.0 / (1 + fine_rank) * (1 + o),
                                   label=f"observable {o}"))
    return frame(rows)


@pytest.mark.parametrize("n_obs, n_axes", [(1, 1), (3, 3), (5, 4)])
def test_plot_error_vs_cost(tmp_path, check_png, assert_plotted, n_obs, n_axes):
    err = cost.knob_errors(figure_records(n_obs))
    assert err["is_ref"].sum() == 3 * n_obs and err["error"].isna().sum() == 1
    fig = plot_error_vs_cost(err, "channel", footer="rung demo · W=20 d_p · k_n=1e5 · N=2700")
    assert isinstance(fig, Figure)
    assert len(fig.axes) == n_axes
    assert [ax.get_title() for ax in fig.axes] == [f"observable {o}" for o in range(n_axes)]
    assert all(ax.get_xscale() == "log" and ax.get_yscale() == "log" for ax in fig.axes)
    assert fig._suptitle.get_text() == "error against cost — channel"
    texts = " ".join(t.get_text() for t in fig.texts)
    assert "rung demo" in texts and "k_n=1e5" in texts
    if n_obs > 4:
        assert "1 more observables not shown" in texts
    # the 5 % guide and the reference markers on the bottom edge
    ax0 = fig.axes[0]
    assert any(np.allclose(ln.get_ydata(), 5.0) for ln in ax0.get_lines() if len(ln.get_ydata()) == 2)
    assert sum(t.get_text().endswith(" ref") for t in ax0.texts) == 3
    # every non-reference point of the first observable is drawn at (CPU-seconds, |error| in %)
    obs0 = err[(err["observable"] == "obs0") & ~err["is_ref"] & np.isfinite(err["abs_error"])]
    assert len(obs0) == 6  # 3 knobs x (values - ref), one failed run left out
    for _, row in obs0.iterrows():
        assert_plotted(ax0, [row["cpu_s"]], [100 * row["abs_error"]])
    path = tmp_path / "error_cost.png"
    fig.savefig(path, dpi=150)
    assert path.stat().st_size > 10_000
    check_png(path)


def test_plot_error_vs_cost_unknown_scene(tmp_path):
    err = cost.knob_errors(figure_records(1))
    fig = plot_error_vs_cost(err, "silo", footer="none")
    assert len(fig.axes) == 1
    assert "not available" in " ".join(t.get_text() for t in fig.axes[0].texts)
    fig.savefig(tmp_path / "empty.png")
