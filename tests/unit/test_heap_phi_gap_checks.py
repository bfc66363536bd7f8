"""The heap's rows on φ in depth and across the gap (granflow.scenes.heap.phi_checks, gap_checks) on hand-made
analysis tables: each row recovers the number the tables were built with, passes when the tables hold what the
paper states and fails when they do not; each row is named by an entry of
paper_results.yaml."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

import granflow.scenes.heap.gap_checks as gc
import granflow.scenes.heap.phi_checks as pc
from granflow import coverage
from granflow.scenes.heap.validation import HeapCase, load_case, validation

DELTA, D_BAR, D_L, L = 6e-3, 1e-3, 2e-3, 0.1
GEOMETRY = {"W": 0.12, "T": 0.013, "theta_deg": 24.0, "x_feed": 0.02, "z_base_end": 0.0}
X = (np.arange(10) + 0.5) * L / 10                   # the streamwise bins' centres (moving frame)
X_LAB = np.arange(0.002, 0.12, 0.004)                # the lab columns' centres


def record(species=(1e-3, 2e-3)) -> dict:
    return {"geometry": dict(GEOMETRY), "species": [{"type": i + 1, "d": d} for i, d in enumerate(species)],
            "rung_knobs": {"bin_dx": 4.0, "bin_dz_phi": 0.25, "bin_dz_u": 0.67},
            "case": {"mixture": "bi1-2", "feed_rate": 0.033}}


def scalars() -> dict:
    return {"status": "steady", "d_bar": D_BAR, "delta_mean": DELTA, "L": L, "alpha_deg": 26.0, "phi_bed": 0.62}


def per_x() -> pd.DataFrame:
    return pd.DataFrame({"x": X, "x_over_L": X / L, "u_s": 0.2 * (1 - X / L), "delta": DELTA, "d_bar": D_BAR,
                         "usable": [True] * 9 + [False]})


def make_case(tables: dict, species=(1e-3, 2e-3)) -> HeapCase:
    return HeapCase("mix~bi1-2/mdot~33", Path("."), record(species), {}, scalars(), {"per_x": per_x(), **tables})


# --------------------------------------------------------------------------- hand-made tables
def static_bed(phi: float, shallow: float | None = None) -> pd.DataFrame:
    """Six columns whose bed is ``phi`` ± 0.002; the 1.5δ window ``shallow`` (default: the same), 3δ the same."""
    x = np.linspace(0.035, 0.085, 6)
    parts = [pd.DataFrame({"top_over_delta": k, "depth_lo": k * DELTA, "depth_hi": k * DELTA + 0.02, "x_lab": x,
                           "phi": (shallow if (k == 1.5 and shallow is not None) else phi) + 0.002 * np.sin(x * 300),
                           "n_frames": 75}) for k in (2.0, 1.5, 3.0)]
    return pd.concat(parts, ignore_index=True)


def piecewise(z, creep=0.04, layer=0.05, top=0.4, bounce_up=0.01, bounce_down=0.0, upstream=True):
    """A continuous φ(z) from each bin's surface: 0.64 under −2δ; falling ``creep`` per δ to −δ, ``layer`` from −δ to
    −d̄/2, ``top`` over the top diameter, to 0 at d_l; then the bouncing φ, upstream or downstream."""
    z = np.asarray(z, float)
    a = 0.64 - creep                                  # φ at −δ
    b = a - layer                                     # φ at −d̄/2
    c = b - top                                       # φ at +d̄/2
    return np.select([z < -2 * DELTA, z < -DELTA, z < -D_BAR / 2, z < D_BAR / 2, z < D_L],
                     [0.64, a - creep * (z + DELTA) / DELTA, b - layer * (z + D_BAR / 2) / (DELTA - D_BAR / 2),
                      b - top * (z + D_BAR / 2) / D_BAR, c * (D_L - z) / (D_L - D_BAR / 2)],
                     bounce_up if upstream else bounce_down)


def phi_profile(**kw) -> pd.DataFrame:
    """The analysis's phi_profile table (z from each bin's own surface, the base far below) of :func:`piecewise`."""
    dz = D_BAR / 4
    edges = np.arange(-120, 60) * dz
    zc = 0.5 * (edges[1:] + edges[:-1])
    return pd.concat([pd.DataFrame({"x": x, "z": zc, "z_lo": edges[:-1], "z_hi": edges[1:],
                                    "phi": piecewise(zc, upstream=x / L < 0.3, **kw), "z_surface": 0.0,
                                    "z_base": -1.0}) for x in X], ignore_index=True)


def surface_cutoff(span_over_d: float) -> pd.DataFrame:
    """Tilt-free spans of span_over_d d̄ × (1 − 0.2 cos 50x), the largest 1.2 span_over_d; the vertical columns'
    1.3 d̄ more (their tilt)."""
    span = span_over_d * D_BAR * (1 - 0.2 * np.cos(X_LAB * 50))
    return pd.DataFrame({"x_lab": X_LAB, "span_mean": span + 1.3 * D_BAR, "span_median": span + 1.3 * D_BAR,
                         "span_se": 0.02 * D_BAR, "span_tilt_free_mean": span, "span_tilt_free_median": 0.95 * span,
                         "span_tilt_free_se": 0.02 * D_BAR, "n_frames": 75})


def gap_velocity(wall: float, centre: float) -> pd.DataFrame:
    px = per_x()
    scatter = 0.005 * np.sin(np.arange(10))
    return px[["x", "x_over_L", "usable", "u_s"]].assign(u_s_wall=px["u_s"] * (wall + scatter),
                                                        u_s_centre=px["u_s"] * (centre - scatter))


def deposit_gap(up: tuple, down: tuple, slab_noise=(-0.02, 0.02, -0.02, 0.02)) -> pd.DataFrame:
    """c_s of the wall slices and of the centre, upstream and downstream of 0.6 W, in every variant and slab."""
    rows = []
    x = np.arange(0.005, 0.12, 0.01)
    for variant in ("central", "y by centre", "from 1.5 δ below the surface", "from 0.5 δ below the surface"):
        for k in range(5):
            for i, s in enumerate(("wall", "centre")):
                noise = slab_noise[k - 1] if (k and s == "wall") else 0.0
                c = np.where(x < 0.6 * GEOMETRY["W"], up[i], down[i]) + noise
                rows.append(pd.DataFrame({"variant": variant, "slice": s, "slab": k, "x_lab": x, "c_s": c, "n": 40,
                                          "volume": 1e-8}))
    return pd.concat(rows, ignore_index=True)


def rows(case) -> dict:
    return {c.quantity: c for c in pc.phi_checks(case) + gc.gap_checks(case)}


def passes(check) -> bool:
    return check.verdict in ("within the paper's range", "equal") or check.verdict.startswith("within error")


def fails(check) -> bool:
    return check.verdict.startswith("one sample: off by")


# --------------------------------------------------------------------------- tests
def test_a_heap_as_the_paper_describes_it_passes_every_row():
    case = make_case({"static_bed": static_bed(0.65), "phi_profile": phi_profile(),
                      "surface_cutoff": surface_cutoff(0.6), "gap_surface_velocity": gap_velocity(0.9, 1.1),
                      "deposit_gap": deposit_gap((0.6, 0.4), (0.5, 0.5))})
    got = rows(case)
    assert set(got) == set(pc.QUANTITIES) | set(gc.QUANTITIES)
    for q in set(got) - {pc.Q_ABOVE_UP}:
        assert passes(got[q]), (q, got[q].ours, got[q].verdict)
    assert got[pc.Q_BED].ours == pytest.approx(0.65, abs=0.002)
    # the bands' lines lie on the built pieces: the falls are those built
    assert got[pc.Q_CREEP].ours == pytest.approx(0.04, rel=1e-9)
    layer = 0.05 / (1 - D_BAR / (2 * DELTA))
    assert got[pc.Q_LAYER].ours == pytest.approx(layer, rel=1e-9)
    assert got[pc.Q_TOP].ours == pytest.approx(0.4 * DELTA / D_BAR / layer, rel=1e-9)
    assert got[pc.Q_ABOVE].ours == pytest.approx(0.01, abs=1e-12)
    above = got[pc.Q_ABOVE_UP]
    assert above.kind == "diagnostic" and above.verdict.startswith("diagnostic") and above.ours == pytest.approx(0.01)
    # the largest time-mean tilt-free span (1.2 × 0.6 d̄) over the columns of the surface fit; the vertical columns'
    # reading (1.3 d̄ more) is in the note, not a variant
    cut = got[pc.Q_CUTOFF]
    assert cut.ours == pytest.approx(0.72, rel=1e-3) and cut.error == pytest.approx(0.02)
    assert "vertical" not in cut.variants and "From the vertical columns the largest is 2 d̄" in cut.note
    # "one particle diameter" in the 1/2 mm mixture: the largest, d_l = 2 d̄ here
    assert cut.paper_range == (0.0, pytest.approx(2.0))
    assert "over d_s the value is 0.72, over d_l 0.36" in cut.note
    assert got[gc.Q_US_WALL].ours == pytest.approx(0.9, abs=0.005)
    assert got[gc.Q_US_CENTRE].ours == pytest.approx(1.1, abs=0.005)
    up, down = got[gc.Q_CS_UP], got[gc.Q_CS_DOWN]
    # the slabs' contrasts 0.18, 0.22, 0.18, 0.22: their s/√4
    assert up.ours == pytest.approx(0.2, abs=1e-12)
    assert up.error == pytest.approx(np.std([0.18, 0.22, 0.18, 0.22], ddof=1) / 2, rel=1e-9)
    assert down.ours == pytest.approx(0.0, abs=1e-12) and down.verdict == "equal"


def test_each_row_fails_when_the_heap_differs_from_the_paper():
    case = make_case({"static_bed": static_bed(0.60), "phi_profile": phi_profile(creep=-0.04, top=0.005,
                                                                               bounce_up=0.0, bounce_down=0.01),
                      "surface_cutoff": surface_cutoff(3.0), "gap_surface_velocity": gap_velocity(1.0, 1.0),
                      "deposit_gap": deposit_gap((0.5, 0.5), (0.6, 0.4))})
    got = rows(case)
    for q in (pc.Q_BED, pc.Q_CREEP, pc.Q_TOP, pc.Q_ABOVE, pc.Q_CUTOFF, gc.Q_US_WALL, gc.Q_US_CENTRE, gc.Q_CS_DOWN):
        assert fails(got[q]), (q, got[q].ours, got[q].verdict)
    assert got[pc.Q_CREEP].ours == pytest.approx(-0.04, rel=1e-9)     # φ rising through the creeping region
    assert got[pc.Q_TOP].ours < 1                                      # a top gentler than the layer
    assert got[pc.Q_ABOVE].ours == pytest.approx(-0.01, abs=1e-12)     # bouncing downstream only
    # no difference at the walls upstream: 0 lies on the paper's range's edge, within its error
    assert got[gc.Q_CS_UP].ours == pytest.approx(0.0, abs=1e-12)
    assert got[gc.Q_CS_DOWN].ours == pytest.approx(0.2, abs=1e-12)


def test_measurement_choices_are_the_systematic_error():
    # a bed whose top 1.5δ window reads 0.62: the central 0.65 carries that shift as its syst
    case = make_case({"static_bed": static_bed(0.65, shallow=0.62), "phi_profile": phi_profile(),
                      "surface_cutoff": surface_cutoff(0.6), "gap_surface_velocity": gap_velocity(0.9, 1.1),
                      "deposit_gap": deposit_gap((0.6, 0.4), (0.5, 0.5))})
    got = rows(case)
    assert got[pc.Q_BED].syst == pytest.approx(0.03, abs=1e-3)
    assert "top at 1.5δ (the mass balance's φ_bed window)" in got[pc.Q_BED].variants
    # the cutoff's per-column median (0.95 of the mean) is its largest shift
    assert got[pc.Q_CUTOFF].syst == pytest.approx(0.036, rel=1e-3)
    for q in (pc.Q_CREEP, pc.Q_LAYER, pc.Q_TOP, gc.Q_US_WALL):
        assert "x/L over 0.3-0.9" in got[q].variants
    assert "split at x_lab/W = 0.5" in got[gc.Q_CS_UP].variants and "y by centre" in got[gc.Q_CS_UP].variants


def test_missing_tables_and_a_monodisperse_case_say_why():
    got = rows(make_case({}))
    assert all(math.isnan(c.ours) for c in got.values())
    assert "re-analyse" in got[pc.Q_BED].note and "re-analyse" in got[gc.Q_US_WALL].note
    mono = rows(make_case({"deposit_gap": deposit_gap((0.6, 0.4), (0.5, 0.5))}, species=(1.5e-3,)))
    assert math.isnan(mono[gc.Q_CS_UP].ours) and "monodisperse" in mono[gc.Q_CS_UP].note


def test_the_record_reads_the_new_tables_of_a_case(tmp_path):
    """A case folder with the analysis's tables: load_case reads them and validation() makes the rows."""
    case = tmp_path / "heap" / "validation" / "mix~bi1-2" / "mdot~33"
    (case / "analysis").mkdir(parents=True)
    (case / "run").mkdir()
    rec = dict(record(), dt=5e-5, contacts=[{"name": "pair", "t_c": 5e-4, "e_n": 0.8}], parameters={"k_n": 1.0},
               density=2500.0)
    rec["species"] = [dict(s, volume_fraction=0.5, mean_volume=math.pi / 6 * s["d"] ** 3) for s in rec["species"]]
    rec["rung_knobs"].update(W=0.12, T=0.013, t_c=5e-4, dt_fraction=0.05, t_average=1.5, feed_width=0.02,
                             feed_drop=0.1)
    (case / "params.json").write_text(json.dumps(rec))
    (case / "run" / "status.json").write_text(json.dumps({"status": "completed", "dumps": []}))
    (case / "analysis" / "scalars.json").write_text(json.dumps(scalars()))
    px = per_x().assign(q=lambda d: d["u_s"] * DELTA / 2, gamma_bar=lambda d: 0.9 * d["u_s"] / DELTA,
                        delta_exp=DELTA, delta_lin=DELTA, delta_cut=DELTA, delta_eq31=DELTA, q_star=10.0)
    px.to_csv(case / "analysis" / "per_x.csv", index=False)
    tables = {"static_bed": static_bed(0.65), "phi_profile": phi_profile(), "surface_cutoff": surface_cutoff(0.6),
              "gap_surface_velocity": gap_velocity(0.9, 1.1), "deposit_gap": deposit_gap((0.6, 0.4), (0.5, 0.5))}
    for name, table in tables.items():
        table.to_csv(case / "analysis" / f"{name}.csv", index=False)
    loaded = load_case("mix~bi1-2/mdot~33", case)
    assert all(not loaded.tables[name].empty for name in tables)
    result = validation(case.parents[1], {"mix~bi1-2/mdot~33": case})
    made = {c.quantity: c for c in result.checks}
    assert set(pc.QUANTITIES) | set(gc.QUANTITIES) <= set(made)
    # through the CSVs the numbers are those of the tables in memory
    direct = rows(make_case(tables))
    for q in (pc.Q_BED, pc.Q_TOP, pc.Q_CUTOFF, gc.Q_US_WALL, gc.Q_CS_UP):
        assert made[q].ours == pytest.approx(direct[q].ours, rel=1e-9)


def test_every_row_compares_a_result_of_the_paper():
    # the rows waited in paper_results.yaml's pending file until the record held them (its rewrite of 2026-11-28, two
    # seeds); now each is named by an entry of paper_results.yaml (tests/unit/test_coverage.py requires every
    # compared_by row to be a row of validation/heap/checks.csv)
    from granflow.scenes.heap import shear_checks as sc

    entries = coverage.load(coverage.paper_results_path("heap"))["results"]
    named = {q: kind for e in entries for q, kind in coverage.rows(e)}
    assert set(pc.QUANTITIES) | set(gc.QUANTITIES) | set(sc.QUANTITIES) <= set(named)
    # the one reading row is named as such, the others as comparisons
    rows = set(pc.QUANTITIES) | set(gc.QUANTITIES) | set(sc.QUANTITIES)
    assert {q for q in rows if named[q] != "comparison"} == {pc.Q_ABOVE_UP} and named[pc.Q_ABOVE_UP] == "diagnostic"
    assert not (Path(pc.__file__).with_name("paper_results_pending.yaml")).exists()
