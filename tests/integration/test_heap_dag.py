"""Smoke heaps (one monodisperse, one bidisperse) through the whole Snakemake DAG, and the physics they must obey."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from postproc.dump import read_dump

pytestmark = pytest.mark.lammps
BIN = Path(sys.executable).parent
MIXTURES = ("mono1.5", "bi1.5-2.25")


@pytest.fixture(scope="module")
def heap_campaign(tmp_path_factory, root, scenes_off):
    work = tmp_path_factory.mktemp("heap")
    results = work / "results"
    cfg = work / "config.yaml"
    cfg.write_text(
        "rung: smoke\n"
        f"results_dir: {results}\n"
        "scenes:\n"
        + scenes_off(keep=("heap",)) +
        "  heap:\n"
        "    enabled: true\n"
        f"    scene_file: {root / 'config' / 'scenes' / 'heap.yaml'}\n"
        "    sweep:\n"
        f"      mixture: [{', '.join(MIXTURES)}]\n"
        "      feed_rate: [0.003]\n"
    )
    cmd = [str(BIN / "snakemake"), "--snakefile", str(root / "Snakefile"), "--directory", str(work),
           "--configfile", str(cfg), "--cores", "2", "--quiet", "rules"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    base = results / "heap" / "smoke"
    return {"base": base, "table": pd.read_csv(base / "table.csv").set_index("mixture"),
            "case": {m: base / f"mix~{m}" / "mdot~3" for m in MIXTURES}}


def test_dag_produces_table_and_figures(heap_campaign, check_png):
    table = heap_campaign["table"]
    assert sorted(table.index) == sorted(MIXTURES) and set(table["rung"]) == {"smoke"}
    for name in ("fig03_segregation", "fig04_surface", "fig05_velocity", "fig06_streamwise", "fig07_collapse",
                 "fig08_normal", "fig09_all_cases", "fig10_scaled", "fig11_qstar"):
        assert (heap_campaign["base"] / "figures" / f"{name}.png").stat().st_size > 10_000
        check_png(heap_campaign["base"] / "figures" / f"{name}.png")
    # every row says which fidelity produced it, and nothing was stopped by a guard
    assert table["provenance"].str.contains("rung smoke").all()
    assert set(table["status"]) <= {"steady", "unsteady"}


def test_delivered_feed_rate_matches_request(heap_campaign):
    """The pour delivers the requested mass rate within protocol.feed_rate_tol (5 %) over the window."""
    table = heap_campaign["table"]
    assert (table["feed_rate_error"].abs() <= 0.05).all(), table["feed_rate_error"]


@pytest.mark.parametrize("mixture", [
    "mono1.5",
    # the smoke bidisperse heap rose 11.6 +- 3.7 % faster than mass balance (+3.2 sigma) with the
    # deck's `neighbor bin`; since the deck bins neighbours per species for size ratios >= 1.5
    # (faster; the same physics, a different but equally valid chaotic trajectory) the same case
    # gives -5.4 +- 4.8 % (-1.1 sigma), the mono heap -1.6 +- 2.5 %: the +3.2 sigma was that one
    # trajectory's window, not a bias (it was an xfail until commit 931c90a, 2026-11-24).
    "bi1.5-2.25",
])
def test_mass_conservation_predicts_the_rise_velocity(heap_campaign, mixture):
    """v_r measured from the free surface against v_r = m_dot/(rho phi_bed T W), within 3 standard errors.

    The error of the ratio is the one the validation record reports
    (:func:`granflow.scenes.heap.validation.rise_check`): the least-squares error of v_r
    times sqrt(g) for correlated surface residuals, and the error of the delivered rate,
    in quadrature. phi_bed's own error is left out: its per-frame mean scatters by
    ~0.1-0.3 %, against 2-4 % for the ratio. 3 sigma: a 0.3 % chance per case of a false alarm.
    """
    from granflow.scenes.heap.validation import load_case, rise_check

    table = heap_campaign["table"]
    assert np.isfinite(table["phi_bed"]).all() and (table["phi_bed"].between(0.5, 0.7)).all()
    check = rise_check(load_case(mixture, heap_campaign["case"][mixture]))
    assert np.isfinite(check.ours) and 0 < check.error < 0.1 * check.ours, (mixture, vars(check))
    # the ratio is v_r/v_r_predicted of the table
    row = table.loc[mixture]
    assert check.ours == pytest.approx(1 + row["mass_balance_residual"], rel=1e-9)
    assert abs(check.ours - 1.0) <= 3 * check.error, (
        f"{mixture}: v_r/v_r_predicted = {check.ours:.4f} +- {check.error:.4f} "
        f"({(check.ours - 1) / check.error:+.2f} sigma); {check.note}")


def test_no_mass_appears_or_vanishes(heap_campaign):
    """Mass enters only through the pour, in whole insertions, and never leaves or changes.

    From the particle ids of consecutive frames of the averaging window: every particle of a
    frame is in the next with the same type and mass (nothing leaves, nothing changes mass);
    the new ones are nper_s particles of each species s per insertion, the same number of
    insertions for every species, one every n_feed steps; every particle's mass is that of a
    sphere of its diameter at the material density, within its species' diameter range.
    LAMMPS's own total (thermo v_mtot, 8 significant digits: 1e-7) never decreases, matches
    the particles of each frame and grows by exactly the mass of the new ones.
    """
    for mixture, case in heap_campaign["case"].items():
        record = json.loads((case / "params.json").read_text())
        status = json.loads((case / "run" / "status.json").read_text())
        thermo = pd.read_csv(case / "run" / "thermo.csv").drop_duplicates("Step").set_index("Step")
        pours = record["feed"]["pours"]
        n_feed, n_dump = record["parameters"]["n_feed"], record["parameters"]["n_dump"]
        frames = [f for name in status["dumps"] for f in read_dump(case / "run" / name)]
        assert len(frames) > 10, (mixture, len(frames))
        assert (np.diff(thermo["v_mtot"]) >= 0).all() and (np.diff(thermo["Atoms"]) >= 0).all(), mixture
        insertions = 0
        for before, after in zip(frames[:-1], frames[1:]):
            assert after.timestep - before.timestep == n_dump
            old = dict(zip(before.columns["id"].astype(int), zip(before.columns["type"], before.columns["mass"])))
            now = dict(zip(after.columns["id"].astype(int), zip(after.columns["type"], after.columns["mass"])))
            assert set(old) <= set(now), f"{mixture}: particles vanished at step {after.timestep}"
            assert all(now[i] == old[i] for i in old), f"{mixture}: a particle changed type or mass"
            new = [now[i] for i in set(now) - set(old)]
            counts = [sum(1 for t, _ in new if int(t) == p["type"]) for p in pours]
            k = counts[0] // pours[0]["nper"]
            assert counts == [k * p["nper"] for p in pours], (mixture, after.timestep, counts)
            assert k <= -(-n_dump // n_feed)  # at most one insertion per n_feed steps
            insertions += k
            np.testing.assert_allclose(sum(m for _, m in new),
                                       thermo.loc[after.timestep, "v_mtot"] - thermo.loc[before.timestep, "v_mtot"],
                                       rtol=0, atol=2e-7 * thermo.loc[after.timestep, "v_mtot"])
        span = frames[-1].timestep - frames[0].timestep
        assert span // n_feed <= insertions <= -(-span // n_feed), (mixture, insertions, span / n_feed)
        assert insertions > 0
        for frame in frames:
            c = frame.columns
            d = 2 * c["radius"]
            np.testing.assert_allclose(c["mass"], record["density"] * np.pi * d ** 3 / 6, rtol=1e-12)
            for s in record["species"]:
                sel = d[c["type"].astype(int) == s["type"]]
                assert sel.min() >= s["d_lo"] * (1 - 1e-9) and sel.max() <= s["d_hi"] * (1 + 1e-9)
            np.testing.assert_allclose(c["mass"].sum(), thermo.loc[frame.timestep, "v_mtot"], rtol=1e-7)


def test_bidisperse_case_tags_species_and_reports_c_s(heap_campaign):
    case = heap_campaign["case"]["bi1.5-2.25"]
    record = json.loads((case / "params.json").read_text())
    status = json.loads((case / "run" / "status.json").read_text())
    frame = list(read_dump(case / "run" / status["dumps"][-1]))[-1]
    types, d = frame.columns["type"].astype(int), 2 * frame.columns["radius"]
    assert set(types) == {1, 2}
    for s in record["species"]:  # each type's diameters lie in its species' uniform range
        sel = d[types == s["type"]]
        assert sel.min() >= s["d_lo"] * (1 - 1e-9) and sel.max() <= s["d_hi"] * (1 + 1e-9)
    # equal volumes were fed: the volume of each species agrees within the rounding of whole particles
    vol = [np.sum(d[types == k] ** 3) for k in (1, 2)]
    assert vol[0] / vol[1] == pytest.approx(1.0, abs=0.25)
    per_x = pd.read_csv(case / "analysis" / "per_x.csv")
    deposit = pd.read_csv(case / "analysis" / "deposit.csv")
    assert "c_s" in per_x and per_x["c_s"].dropna().between(0, 1).all() and per_x["c_s"].notna().any()
    assert len(deposit) and deposit["c_s"].dropna().between(0, 1).all()
    mono = pd.read_csv(heap_campaign["case"]["mono1.5"] / "analysis" / "deposit.csv")
    assert mono.empty  # c_s only where there are two species


def test_the_analysis_reads_each_dump_once(heap_campaign, monkeypatch):
    """Issue 18: a dump is read once per analysis (the surface fit and the moving-frame kinematics share
    the frames), and reading it once gives the table's numbers."""
    import postproc.dump as dump
    from granflow import registry

    reads = []
    original = dump.read_dump

    def counting(path, *args, **kwargs):
        reads.append(Path(path).name)
        return original(path, *args, **kwargs)

    monkeypatch.setattr(dump, "read_dump", counting)
    case = heap_campaign["case"]["mono1.5"]
    _, scalars = registry.get("heap").analyse(case)
    status = json.loads((case / "run" / "status.json").read_text())
    assert sorted(reads) == sorted(status["dumps"]) and len(status["dumps"]) >= 1
    assert scalars["alpha_deg"] == pytest.approx(heap_campaign["table"].loc["mono1.5", "alpha_deg"], rel=1e-9)
