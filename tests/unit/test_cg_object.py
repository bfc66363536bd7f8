"""Characterisation of :func:`postproc.cg.coarse_grain` (issue 30, item 3): fields, meta and refusals
on a seeded synthetic dump for a range of choices, bit for bit; and :class:`postproc.cg.CoarseGraining`
(with its :class:`postproc.cg.CGOptions`) giving exactly what the function gives.

``GRANFLOW_CG_REFERENCE=/some/file.npz`` (outside git) writes that file when it does not exist and
compares every case against it when it does, so that the outputs of one revision of the code can be
checked against another's, bit for bit. Without it the cases still run and their invariants hold.
Compare with the numba cache of ``postproc.cg_compiled`` warm in both runs: the compiled ``rz``
deposit, freshly compiled, differs from its cached self in the last bits (~1e-16 relative), one
thread or several.
"""
from __future__ import annotations

import dataclasses
import gzip
import io
import json
import os
import struct
from pathlib import Path

import numba
import numpy as np
import pytest

from postproc.cg import CGInputError, CGOptions, CoarseGraining, FrameSelection, coarse_grain

BOX = np.array([[0.0, 6.0], [0.0, 6.0], [0.0, 8.0]])
COLUMNS = ["id", "type", "x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz", "radius", "mass"]
STRESS = [f"c_stress[{k}]" for k in range(1, 7)]
STEPS = (0, 100, 200, 300, 400, 500)
REFERENCE = os.environ.get("GRANFLOW_CG_REFERENCE")


# --------------------------------------------------------------------------- inputs


def synthetic_frames(n=300, seed=11):
    """Seeded particles in :data:`BOX`: ids, two types, spins, radii 0.15..0.25, a per-atom stress."""
    rng = np.random.default_rng(seed)
    out = []
    for k, step in enumerate(STEPS):
        radius = rng.uniform(0.15, 0.25, n)
        data = {
            "id": np.arange(1, n + 1, dtype=float), "type": rng.integers(1, 3, n).astype(float),
            **dict(zip("xyz", rng.uniform(BOX[:, 0], BOX[:, 1], size=(n, 3)).T)),
            **dict(zip(("vx", "vy", "vz"), (rng.normal(size=(n, 3)) + [0.2, 0.0, -1.0]).T)),
            **dict(zip(("omegax", "omegay", "omegaz"), rng.normal(size=(n, 3)).T)),
            "radius": radius, "mass": 2500.0 * 4.0 / 3.0 * np.pi * radius**3,
            **dict(zip(STRESS, rng.normal(size=(n, 6)).T)),
        }
        order = rng.permutation(n)
        out.append((step, 1e-4 * step, {c: v[order] for c, v in data.items()}))
    return out


def synthetic_contacts(frames, seed=12):
    """Contacts between random id pairs at the atoms' steps, with branch vectors and forces."""
    rng = np.random.default_rng(seed)
    out = []
    for step, _, _ in frames:
        ids = rng.choice(np.arange(1, 301), size=(80, 2), replace=True)
        ids = ids[ids[:, 0] != ids[:, 1]]
        branch = rng.normal(scale=0.3, size=(len(ids), 3))
        force = rng.normal(scale=5.0, size=(len(ids), 3))
        out.append((step, np.column_stack([ids, branch, force])))
    return out


def write_text(path, frames, columns):
    with open(path, "w") as fh:
        for k, (step, t, data) in enumerate(frames):
            if k == 0:
                fh.write("ITEM: UNITS\nsi\n")
            fh.write(f"ITEM: TIME\n{t!r}\nITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{len(data['id'])}\n")
            fh.write("ITEM: BOX BOUNDS pp pp ff\n" + "".join(f"{float(lo)!r} {float(hi)!r}\n" for lo, hi in BOX))
            fh.write("ITEM: ATOMS " + " ".join(columns) + "\n")
            table = np.column_stack([data[c] for c in columns])
            fh.write("".join(" ".join(repr(float(v)) for v in row) + "\n" for row in table))


def write_binary(path, frames, columns):
    """LAMMPS binary custom dump, format revision 2, one chunk per frame."""
    names = " ".join(columns).encode()
    with open(path, "wb") as fh:
        for step, t, data in frames:
            n = len(data["id"])
            fh.write(struct.pack("<q", -10) + b"DUMPCUSTOM" + struct.pack("<ii", 1, 2))
            fh.write(struct.pack("<qqi", step, n, 0) + struct.pack("<6i", 0, 0, 0, 0, 0, 0))
            fh.write(struct.pack("<6d", *BOX.ravel()) + struct.pack("<ii", len(columns), 0))
            fh.write(struct.pack("<b", 1) + struct.pack("<d", t))
            fh.write(struct.pack("<i", len(names)) + names + struct.pack("<i", 1))
            values = np.column_stack([np.asarray(data[c], float) for c in columns]).ravel()
            fh.write(struct.pack("<i", values.size) + values.astype("<f8").tobytes())


def write_contacts(path, contacts):
    with open(path, "w") as fh:
        for step, rows in contacts:
            fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{len(rows)}\n")
            fh.write("ITEM: BOX BOUNDS pp pp ff\n" + "".join(f"{float(lo)!r} {float(hi)!r}\n" for lo, hi in BOX))
            fh.write("ITEM: ENTRIES id1 id2 dx dy dz fx fy fz\n")
            fh.write("".join(" ".join(repr(float(v)) for v in row) + "\n" for row in rows))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """The dumps of the cases, by name."""
    folder = tmp_path_factory.mktemp("cg_object")
    frames = synthetic_frames()
    paths = {name: folder / name for name in
             ("atoms.dump", "atoms.dump.gz", "atoms.bin", "stress.bin", "nomass.dump", "nan.dump",
              "cut.bin", "atoms.local", "gap.local")}
    write_text(paths["atoms.dump"], frames, COLUMNS)
    # gzip with no time stamp or name in its header: the same bytes (and sha256 in the meta) every run
    paths["atoms.dump.gz"].write_bytes(gzip.compress(paths["atoms.dump"].read_bytes(), mtime=0))
    write_binary(paths["atoms.bin"], frames, COLUMNS)
    write_binary(paths["stress.bin"], frames, COLUMNS + STRESS)
    write_text(paths["nomass.dump"], frames, [c for c in COLUMNS if c != "mass"])
    dirty = [(s, t, {c: v.copy() for c, v in d.items()}) for s, t, d in frames]
    dirty[1][2]["vx"][7] = np.nan
    dirty[3][2]["z"][20] = np.inf
    dirty[3][2]["omegay"][21] = np.nan
    write_text(paths["nan.dump"], dirty, COLUMNS)
    data = paths["atoms.bin"].read_bytes()
    paths["cut.bin"].write_bytes(data[: len(data) - 700])
    contacts = synthetic_contacts(frames)
    write_contacts(paths["atoms.local"], contacts)
    write_contacts(paths["gap.local"], contacts[:2] + contacts[3:])
    return paths


# --------------------------------------------------------------------------- cases

#: name: (atom dump, contact dumps, choices). Every kernel and coordinate family, the compiled and
#: numpy rz paths, exact volume, species, contacts, per-atom stress, a frame selection, fewer blocks,
#: density for mass, dropped non-finite atoms, a truncated dump, gzip and binary inputs.
CASES = {
    "z_heaviside": ("atoms.dump", (), dict(coords="z", kernel="heaviside", spacing=1.0)),
    "z_heaviside_exact": ("atoms.dump", (), dict(coords="z", kernel="heaviside", spacing=0.5, volume="exact")),
    "x_heaviside_exact_range": ("atoms.dump.gz", (), dict(coords="x", kernel="heaviside", spacing=0.7,
                                                          ranges=[(0.5, 5.5)], volume="exact")),
    "xyz_heaviside": ("atoms.bin", (), dict(coords="xyz", kernel="heaviside", spacing=2.0)),
    "xz_gaussian": ("atoms.dump", (), dict(coords="xz", kernel="gaussian", width=0.4, cutoff=1.0,
                                           spacing=[0.5, 1.0])),
    "yz_gaussian_default_cutoff": ("atoms.dump", (), dict(coords="yz", width=0.3, spacing=0.5, n_blocks=3)),
    "y_lucy_range": ("atoms.dump", (), dict(coords="y", kernel="lucy", width=0.6, spacing=0.5, ranges=[(1, 5)])),
    "xy_lucy_species": ("atoms.dump", (), dict(coords="xy", kernel="lucy", width=0.8, spacing=0.6,
                                               species="auto")),
    "rz_gaussian_compiled": ("atoms.dump", (), dict(coords="rz", axis=(3.0, 3.0), width=0.4, spacing=0.5,
                                                    ranges=[(0, 2.5), (0, 8)])),
    "rz_gaussian_numpy": ("atoms.dump", (), dict(coords="rz", axis=(3.0, 3.0), width=0.4, spacing=0.5,
                                                 ranges=[(0, 2.5), (0, 8)], method="numpy")),
    "rz_gaussian_compiled_species": ("atoms.bin", (), dict(coords="rz", axis=(2.8, 3.1), width=0.35,
                                                           spacing=[0.4, 0.8], species=[1, 2], method="compiled")),
    "r_lucy_default_axis": ("atoms.dump", (), dict(coords="r", kernel="lucy", width=0.5, spacing=0.5)),
    "rz_heaviside_contacts": ("atoms.dump", ("atoms.local",), dict(coords="rz", kernel="heaviside", axis=(3, 3),
                                                                   spacing=1.0, species="auto")),
    "xz_gaussian_contacts_frames": ("atoms.dump", ("atoms.local",), dict(coords="xz", width=0.5, spacing=0.75,
                                                                         frames="100:400", n_blocks=2)),
    "z_lucy_per_atom_stress_every": ("stress.bin", (), dict(coords="z", kernel="lucy", width=0.7, spacing=0.4,
                                                            frames="0:500:200")),
    "z_gaussian_density": ("nomass.dump", (), dict(coords="z", width=0.5, spacing=0.5, density=2500.0)),
    "z_heaviside_drop_nonfinite": ("nan.dump", (), dict(coords="z", kernel="heaviside", spacing=1.0,
                                                        drop_nonfinite=True)),
    "x_gaussian_truncated": ("cut.bin", (), dict(coords="x", width=0.5, spacing=0.5, allow_truncated=True)),
    "xz_gaussian_progress": ("atoms.bin", (), dict(coords="xz", width=0.5, spacing=1.0, progress=io.StringIO())),
}

#: name: (atom dump, contact dumps, choices) that coarse_grain refuses.
REFUSALS = {
    "no_dump": (None, (), dict(coords="z", spacing=1.0, kernel="heaviside")),
    "missing_dump": ("absent.dump", (), dict(coords="z", spacing=1.0, width=-1)),
    "coords": ("atoms.dump", (), dict(coords="q", spacing=1.0)),
    "kernel": ("atoms.dump", (), dict(coords="z", kernel="box", spacing=1.0)),
    "no_width": ("atoms.dump", (), dict(coords="z", spacing=1.0)),
    "no_width_lucy": ("atoms.dump", (), dict(coords="z", kernel="lucy", spacing=1.0)),
    "width_negative": ("atoms.dump", (), dict(coords="z", spacing=1.0, width=-0.5)),
    "width_nan": ("atoms.dump", (), dict(coords="z", spacing=1.0, width=float("nan"))),
    "cutoff_zero": ("atoms.dump", (), dict(coords="z", spacing=1.0, width=0.5, cutoff=0.0)),
    "volume": ("atoms.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside", volume="sphere")),
    "exact_gaussian": ("atoms.dump", (), dict(coords="z", spacing=1.0, width=0.5, volume="exact")),
    "exact_two_axes": ("atoms.dump", (), dict(coords="xz", spacing=1.0, kernel="heaviside", volume="exact")),
    "density": ("atoms.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside", density=0.0)),
    "blocks": ("atoms.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside", n_blocks=1)),
    "frames_order": ("atoms.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside", frames="400:100")),
    "frames_text": ("atoms.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside", frames="a:b")),
    "frames_none_selected": ("atoms.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside", frames="600:700")),
    "axis_for_z": ("atoms.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside", axis=(1, 1))),
    "axis_outside": ("atoms.dump", (), dict(coords="rz", spacing=1.0, kernel="heaviside", axis=(9, 1))),
    "axis_nan": ("atoms.dump", (), dict(coords="r", spacing=1.0, kernel="heaviside", axis=(float("nan"), 1))),
    "spacing_count": ("atoms.dump", (), dict(coords="xz", spacing=[1.0, 1.0, 1.0], kernel="heaviside")),
    "spacing_negative": ("atoms.dump", (), dict(coords="z", spacing=-1.0, kernel="heaviside")),
    "range_empty": ("atoms.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside", ranges=[(3, 3)])),
    "one_node": ("atoms.dump", (), dict(coords="z", spacing=20.0, width=0.5)),
    "max_nodes": ("atoms.dump", (), dict(coords="xyz", spacing=0.1, width=0.5)),
    "width_below_radius": ("atoms.dump", (), dict(coords="z", spacing=0.5, width=0.1)),
    "no_mass": ("nomass.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside")),
    "nonfinite": ("nan.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside")),
    "truncated": ("cut.bin", (), dict(coords="z", spacing=1.0, kernel="heaviside")),
    "contacts_unmatched": ("atoms.dump", ("gap.local",), dict(coords="z", spacing=1.0, kernel="heaviside")),
    "method": ("atoms.dump", (), dict(coords="z", spacing=1.0, kernel="heaviside", method="fast")),
}


#: The refusals of choices alone, which CGOptions makes when made (the others come as the frames are read).
AT_CONSTRUCTION = ("coords", "kernel", "no_width", "no_width_lucy", "width_negative", "width_nan", "cutoff_zero",
                   "volume", "exact_gaussian", "exact_two_axes", "density", "blocks", "frames_order", "frames_text")


@pytest.fixture
def one_thread():
    """The compiled rz deposit sums its threads' buffers in an order that varies with more than one."""
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(before)


def run_case(inputs, name):
    dump, contacts, choices = CASES[name]
    choices = dict(choices)
    if "progress" in choices:
        choices["progress"] = io.StringIO()
    return coarse_grain([inputs[dump]], contacts=[inputs[c] for c in contacts], **choices)


def comparable_meta(meta: dict, folder: Path) -> str:
    """The meta without what changes from run to run: the timings and the (temporary) input folder."""
    meta = {k: v for k, v in meta.items() if k not in ("elapsed_s", "particle_frames_per_s")}
    return json.dumps(meta, sort_keys=True).replace(str(folder), "<tmp>")


def arrays(result, folder: Path) -> dict[str, np.ndarray]:
    out = {"columns": np.array(list(result.fields.columns)), "meta": np.array(comparable_meta(result.meta, folder))}
    for column in result.fields.columns:
        out[f"field:{column}"] = result.fields[column].to_numpy()
    return out


def refusal(inputs, name, tmp: Path) -> tuple[str, str]:
    dump, contacts, choices = REFUSALS[name]
    dumps = [] if dump is None else [inputs.get(dump, tmp / dump)]
    try:
        coarse_grain(dumps, contacts=[inputs[c] for c in contacts], **choices)
    except Exception as exc:  # noqa: BLE001 (the type is what is recorded)
        return type(exc).__name__, str(exc).replace(str(tmp), "<tmp>")
    raise AssertionError(f"{name} was not refused")


def bitwise_equal(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def max_abs_difference(a: np.ndarray, b: np.ndarray) -> float:
    if a.dtype.kind != "f" or a.shape != b.shape:
        return float("nan")
    both = np.isfinite(a) & np.isfinite(b)
    return float(np.max(np.abs(a[both] - b[both]), initial=0.0))


def reference_store() -> dict[str, np.ndarray] | None:
    if not REFERENCE or not Path(REFERENCE).exists():
        return None
    with np.load(REFERENCE) as data:
        return {k: data[k] for k in data.files}


# --------------------------------------------------------------------------- tests


def test_cases_match_the_reference(inputs, one_thread, tmp_path):
    """Every case, and every refusal's type and message, against the stored reference (when given)."""
    found: dict[str, np.ndarray] = {}
    folder = next(iter(inputs.values())).parent
    for name in CASES:
        for key, value in arrays(run_case(inputs, name), folder).items():
            found[f"{name}/{key}"] = value
    for name in REFUSALS:
        kind, message = refusal(inputs, name, folder)
        found[f"refusal:{name}"] = np.array([kind, message])
    reference = reference_store()
    if REFERENCE and reference is None:
        Path(REFERENCE).parent.mkdir(parents=True, exist_ok=True)
        np.savez(REFERENCE, **found)
        pytest.skip(f"wrote the reference {REFERENCE} ({len(found)} arrays)")
    if reference is None:
        return
    assert sorted(found) == sorted(reference)
    differ = {key: max_abs_difference(found[key], reference[key])
              for key in found if not bitwise_equal(found[key], reference[key])}
    assert not differ, differ


def test_cases_hold_their_invariants(inputs, one_thread):
    """What the cases are meant to exercise did happen (so that the reference is worth comparing)."""
    results = {name: run_case(inputs, name) for name in
               ("rz_gaussian_compiled", "rz_gaussian_numpy", "rz_heaviside_contacts", "z_heaviside_drop_nonfinite",
                "x_gaussian_truncated", "z_lucy_per_atom_stress_every", "xy_lucy_species", "r_lucy_default_axis")}
    compiled, numpy_path = results["rz_gaussian_compiled"], results["rz_gaussian_numpy"]
    np.testing.assert_allclose(compiled.fields["rho"], numpy_path.fields["rho"], rtol=1e-6, atol=1e-9)
    assert {"sigmac_rr", "p", "rho_s1", "rho_s2"} <= set(results["rz_heaviside_contacts"].fields.columns)
    assert results["z_heaviside_drop_nonfinite"].meta["frames"]["dropped_nonfinite"]["atom_frames"] == 3
    assert results["x_gaussian_truncated"].meta["frames"]["truncated"]
    assert results["z_lucy_per_atom_stress_every"].meta["frames"]["count"] == 3
    assert "sigmac_zz" in results["z_lucy_per_atom_stress_every"].fields.columns
    assert results["xy_lucy_species"].meta["species"] == [1, 2]
    assert any("axis not given" in w for w in results["r_lucy_default_axis"].warnings)


def compare(found: dict[str, np.ndarray], expected: dict[str, np.ndarray]) -> dict[str, float]:
    """The keys whose arrays differ in any bit, with their largest absolute difference."""
    assert sorted(found) == sorted(expected)
    return {key: max_abs_difference(found[key], expected[key])
            for key in found if not bitwise_equal(found[key], expected[key])}


def test_the_object_gives_what_the_function_gives(inputs, one_thread):
    """Every case through CoarseGraining(CGOptions(...)).compute, twice on one object: bit for bit."""
    folder = next(iter(inputs.values())).parent
    for name, (dump, contacts, choices) in CASES.items():
        choices = dict(choices)
        progress = choices.pop("progress", None)
        expected = arrays(run_case(inputs, name), folder)
        cg = CoarseGraining(CGOptions(**choices))
        for _ in range(2):
            result = cg.compute([inputs[dump]], [inputs[c] for c in contacts],
                                progress=None if progress is None else io.StringIO())
            assert cg.result is result
            assert not compare(arrays(result, folder), expected), name


def test_one_object_computes_on_other_dumps_from_scratch(inputs, one_thread):
    """A refusal or other dumps in between change neither the next result nor the ones returned before."""
    folder = next(iter(inputs.values())).parent
    cg = CoarseGraining(coords="xz", width=0.5, spacing=0.75, species="auto")
    first = cg.compute([inputs["atoms.dump"]], [inputs["atoms.local"]])
    kept = arrays(first, folder)
    with pytest.raises(CGInputError, match="column vx = nan"):
        cg.compute([inputs["nan.dump"]])
    assert cg.result is None
    other = cg.compute([inputs["stress.bin"]], progress=io.StringIO())
    assert "sigmac_xx" in other.fields and other.meta["inputs"][0]["format"] == "binary"
    again = cg.compute([inputs["atoms.dump"]], [inputs["atoms.local"]])
    assert not compare(arrays(again, folder), kept)
    assert not compare(arrays(first, folder), kept)
    assert cg.result is again


@pytest.mark.parametrize("name", [n for n in REFUSALS if n != "missing_dump"])
def test_the_object_refuses_what_the_function_refuses(inputs, name):
    """Choices alone are refused when CGOptions is made, the rest by compute, with the function's type and message."""
    folder = next(iter(inputs.values())).parent
    expected = refusal(inputs, name, folder)
    dump, contacts, choices = REFUSALS[name]
    if name in AT_CONSTRUCTION:
        for make in (lambda: CGOptions(**choices), lambda: CoarseGraining(**choices)):
            with pytest.raises(Exception) as caught:
                make()
            assert (type(caught.value).__name__, str(caught.value)) == expected
        return
    cg = CoarseGraining(CGOptions(**choices))
    with pytest.raises(Exception) as caught:
        cg.compute([] if dump is None else [inputs[dump]], [inputs[c] for c in contacts])
    assert (type(caught.value).__name__, str(caught.value).replace(str(folder), "<tmp>")) == expected
    assert cg.result is None


def test_the_function_refuses_a_missing_file_before_the_choices(inputs):
    """As before the object: the missing file is named even when a choice is refused too."""
    folder = next(iter(inputs.values())).parent
    assert refusal(inputs, "missing_dump", folder) == ("CGInputError", "dump file <tmp>/absent.dump does not exist")
    with pytest.raises(CGInputError, match="--width -1 must be a positive finite length"):
        CGOptions(**REFUSALS["missing_dump"][2])


def test_options_are_held_frozen_and_normalised():
    roles = {"id1": "c_ids[1]"}
    options = CGOptions(coords="rz", spacing=[0.5, 1.0], ranges=[(0, 2), (0, 8)], species=[1, 2],
                        frames="100:400:100", width=0.4, contact_roles=roles)
    assert options.spacing == (0.5, 1.0) and options.ranges == ((0, 2), (0, 8)) and options.species == (1, 2)
    assert options.frames == FrameSelection(100, 400, 100)
    assert CGOptions(spacing=1.0, kernel="heaviside").frames == FrameSelection()
    roles["id2"] = "c_ids[2]"
    assert dict(options.contact_roles) == {"id1": "c_ids[1]"}
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.width = 0.1
    with pytest.raises(TypeError):
        options.contact_roles["id2"] = "c_ids[2]"
    assert options.kernel_cutoff == pytest.approx(1.2)
    assert CGOptions(spacing=1, kernel="lucy", width=0.5).kernel_cutoff == 0.5
    assert CGOptions(spacing=1, kernel="heaviside").kernel_cutoff is None
    with pytest.raises(TypeError, match="not both"):
        CoarseGraining(options, coords="z")
    with pytest.raises(TypeError):
        CGOptions("z", spacing=1.0)  # keyword only


def test_one_range_pair_is_every_coordinates_range(inputs, one_thread):
    """``ranges=(lo, hi)``, as documented, is the range of every coordinate: the same grid and fields as
    ``ranges=[(lo, hi)]`` (one coordinate) and as one pair per coordinate (two)."""
    dump = str(inputs["atoms.dump"])
    base = dict(kernel="heaviside", spacing=1.0)
    one = coarse_grain([dump], coords="z", ranges=(1.0, 6.0), **base)
    listed = coarse_grain([dump], coords="z", ranges=[(1.0, 6.0)], **base)
    assert one.meta["grid"]["ranges"] == [[1.0, 6.0]] and bitwise_equal(one.fields["rho"].to_numpy(), listed.fields["rho"].to_numpy())
    two = coarse_grain([dump], coords="xz", ranges=(1.0, 6.0), **base)
    each = coarse_grain([dump], coords="xz", ranges=[(1.0, 6.0), (1.0, 6.0)], **base)
    assert two.meta["grid"]["ranges"] == [[1.0, 6.0], [1.0, 6.0]]
    assert bitwise_equal(two.fields["rho"].to_numpy(), each.fields["rho"].to_numpy())
