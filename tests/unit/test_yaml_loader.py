"""Hostile YAML is refused with bounded work (issue 31): alias bombs, deep nesting, oversize and
non-UTF-8 files, keys given twice; through `granflow` and through `snakemake --configfile`. Also
the refusals around it: `--set` names holding a dot, `plan --config` rooted in the working
directory, a relative `results_dir` leaving the project. Each refusal exits 2 and names the
key, line or byte offset."""
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from granflow.cli import main
from granflow.config import parse_override
from granflow.scene_files import load_scene
from granflow.yamlio import (
    MAX_DEPTH,
    MAX_DOCUMENT_BYTES,
    MAX_NODES,
    ConfigError,
    _Loader,
    check_extent,
    load_yaml,
    yaml_load,
)

ROOT = Path(__file__).resolve().parents[2]
BAD = ROOT / "tests" / "data" / "bad_yaml"
SNAKEMAKE = Path(sys.executable).with_name("snakemake")


def refused(capsys, argv) -> str:
    assert main(argv) == 2, argv
    err = capsys.readouterr().err
    assert err.startswith("granflow: refused: ") and "Traceback" not in err and "fault" not in err, err
    return err


def bomb(levels: int, width: int = 9, mapping: bool = False) -> str:
    """``levels`` nested anchors, each value ``width`` aliases of the one before: width**levels
    values once expanded, in O(levels * width) characters."""
    def value(item: str) -> str:
        if mapping:
            return "{" + ", ".join(f"k{j}: {item}" for j in range(width)) + "}"
        return "[" + ", ".join([item] * width) + "]"
    lines = [f"l0: &l0 {value('x')}"]
    lines += [f"l{i}: &l{i} {value(f'*l{i - 1}')}" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


@pytest.fixture
def compose_calls(monkeypatch):
    """How many nodes the loader composes (its work), counted by wrapping _Loader.compose_node."""
    calls = [0]
    original = _Loader.compose_node

    def counted(self, parent, index):
        calls[0] += 1
        return original(self, parent, index)

    monkeypatch.setattr(_Loader, "compose_node", counted)
    return calls


# ------------------------------------------------------------------------------ alias bombs
def test_the_committed_bomb_is_refused_by_check_config(capsys):
    err = refused(capsys, ["check-config", str(BAD / "alias_bomb.yaml")])
    assert "alias_bomb.yaml: the value &f at line 8, column 4 holds 597,871 nodes" in err
    assert f"allowed at most {MAX_NODES:,} nodes" in err


@pytest.mark.parametrize("levels", [6, 9, 20, 60])
@pytest.mark.parametrize("mapping", [False, True])
def test_bomb_refusal_costs_work_in_proportion_to_the_text(compose_calls, levels, mapping):
    """The refusal composes each node written once, never an expansion: at most the (levels x
    width + keys) nodes of the text, whatever 9**levels is (20 levels: 1.2e19 values)."""
    text = bomb(levels, mapping=mapping)
    with pytest.raises(ConfigError, match="holds .* nodes, an alias counting as many as the value it repeats"):
        yaml_load(text, "bomb.yaml")
    written = levels * (9 * (2 if mapping else 1) + 2) + 1  # per line: its key, its collection, its 9 items (+ keys)
    assert compose_calls[0] <= written, (compose_calls[0], written)


def test_aliases_within_the_bound_still_load():
    """Anchors are allowed: 3 levels of 9 expand to 9 + 81 + 729 values, well under the bound."""
    data = yaml_load(bomb(3), "small.yaml")
    assert len(data["l2"]) == 9 and all(len(v) == 9 and all(len(w) == 9 for w in v) for v in data["l2"])
    merged = yaml_load("base: &b {x: 1, y: 2}\nother:\n  <<: *b\n  y: 3\n")
    assert merged["other"] == {"x": 1, "y": 3}  # a key beside a merge overrides it: not a duplicate


def test_alias_inside_its_own_anchor_is_refused():
    with pytest.raises(ConfigError) as exc:
        yaml_load("a: &a [1, *a]\n", "f.yaml")
    assert "f.yaml: line 1, column 11: the alias *a is inside the value its anchor names" in str(exc.value)


def test_nesting_is_bounded_also_through_aliases():
    deep = "x: " + "[" * (MAX_DEPTH + 5) + "]" * (MAX_DEPTH + 5) + "\n"
    with pytest.raises(ConfigError, match=f"nested more than {MAX_DEPTH} levels deep"):
        yaml_load(deep, "f.yaml")
    with pytest.raises(ConfigError, match="nested more than"):  # far past Python's recursion limit: still a refusal
        yaml_load("x: " + "[" * 5000 + "]" * 5000, "f.yaml")
    half = MAX_DEPTH // 2 + 2  # each within the bound, the alias stacks them past it
    text = f"a: &a {'[' * half}1{']' * half}\nb: {'[' * half}*a{']' * half}\n"
    with pytest.raises(ConfigError, match=f"levels deep with its aliases expanded: allowed at most {MAX_DEPTH}"):
        yaml_load(text, "f.yaml")


def test_document_size_is_bounded(capsys, tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text("# padding\n" * (MAX_DOCUMENT_BYTES // 10 + 1) + "rung: demo\n")
    err = refused(capsys, ["check-config", str(path)])
    assert f"big.yaml: {path.stat().st_size:,} bytes: allowed a config file of at most {MAX_DOCUMENT_BYTES:,} bytes" in err
    with pytest.raises(ConfigError, match="characters: allowed a document of at most"):
        yaml_load("x: " + "1" * MAX_DOCUMENT_BYTES)


def test_data_merged_by_snakemake_is_bounded_too():
    """Snakemake parses --config values itself (aliases shared, not copied): check_extent counts
    each as often as it is referred to and stops at the bound."""
    level = ["x"] * 9
    for _ in range(8):
        level = [level] * 9
    with pytest.raises(ConfigError, match=f"config: more than {MAX_NODES:,} values"):
        check_extent({"scenes": level}, "config")
    loop = []
    loop.append(loop)
    with pytest.raises(ConfigError, match=f"nested more than {MAX_DEPTH} levels"):
        check_extent({"x": loop})
    check_extent(load_yaml(ROOT / "config" / "config.yaml"))


def test_shipped_files_are_well_inside_the_bounds():
    """The bounds leave room: every shipped YAML file has under 1 % of MAX_NODES and a third of MAX_DEPTH."""
    for path in sorted((ROOT / "config").rglob("*.yaml")):
        loader = _Loader(path.read_text(), str(path))
        try:
            node = loader.get_single_node()
            nodes, depth = loader._extent[id(node)]
        finally:
            loader.dispose()
        assert nodes < MAX_NODES / 100 and depth <= MAX_DEPTH / 2 and path.stat().st_size < MAX_DOCUMENT_BYTES / 10, path


# ---------------------------------------------------------------------------- duplicate keys
def test_duplicate_key_is_refused_naming_key_and_both_lines(capsys, tmp_path):
    err = refused(capsys, ["check-config", str(BAD / "duplicate_keys.yaml")])
    assert "duplicate_keys.yaml: the key sweep of scenes.channel appears twice, on line 6 and line 9" in err
    path = tmp_path / "campaign.yaml"
    path.write_text((ROOT / "config" / "config.yaml").read_text() + "rung: smoke\n")
    err = refused(capsys, ["check-config", str(path)])
    first = next(i for i, line in enumerate(path.read_text().splitlines(), 1) if line.startswith("rung:"))
    n = len(path.read_text().splitlines())
    assert f"campaign.yaml: the key rung at the top level appears twice, on line {first} and line {n}" in err


def test_duplicate_key_in_a_scene_file_is_refused(capsys, tmp_path):
    text = (ROOT / "config" / "scenes" / "channel.yaml").read_text()
    path = tmp_path / "channel.yaml"
    path.write_text(text.replace("\ncontact:\n", "\ncontact:\n  e_n: 0.5\n", 1))
    err = refused(capsys, ["check-config", str(path)])
    assert "the key e_n of contact appears twice, on line" in err


@pytest.mark.parametrize("text, message", [
    ("a: {x: 1, 'x': 2}\n", "the key x of a appears twice, on line 1 (columns 5 and 11)"),
    ("a: {1: p, 1.0: q}\n", "the key 1.0 of a appears twice"),  # the same key once read
    ("a:\n- {k: 1}\n- {k: 1, k: 2}\n", "the key k of a[1] appears twice"),
])
def test_keys_are_compared_as_read(text, message):
    with pytest.raises(ConfigError) as exc:
        yaml_load(text, "f.yaml")
    assert message in str(exc.value)


def test_duplicate_key_in_a_set_value_is_refused(capsys):
    err = refused(capsys, ["check-config", str(ROOT / "config" / "scenes" / "channel.yaml"), "--set", "case={W: 20, W: 30}"])
    assert "--set: the key W of case appears twice" in err


# ------------------------------------------------------------------------------- encoding
def test_non_utf8_is_refused_with_the_byte_offset(capsys):
    raw = (BAD / "not_utf8.yaml").read_bytes()
    offset = raw.index(b"\xe9")
    err = refused(capsys, ["check-config", str(BAD / "not_utf8.yaml")])
    assert f"not_utf8.yaml: byte e9 at offset {offset} (line 2) is not UTF-8" in err and "save it as UTF-8" in err


def test_non_utf8_scene_file_is_refused(tmp_path):
    path = tmp_path / "silo.yaml"
    path.write_bytes((ROOT / "config" / "scenes" / "silo.yaml").read_bytes() + b"# \xff\xfe\n")
    with pytest.raises(ConfigError, match=r"byte ff at offset \d+ \(line \d+\) is not UTF-8"):
        load_scene(path)


# ------------------------------------------------------------------- through Snakemake
def snakemake_n(*args) -> subprocess.CompletedProcess:
    """``snakemake -n`` in the project; a hang fails on the timeout (the bomb took minutes before)."""
    return subprocess.run([str(SNAKEMAKE), "-n", "--cores", "1", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)


@pytest.mark.skipif(not SNAKEMAKE.exists(), reason="snakemake is not installed in this environment")
@pytest.mark.parametrize("name, message", [
    ("alias_bomb.yaml", "alias_bomb.yaml: the value &f at line 8, column 4 holds 597,871 nodes"),
    ("duplicate_keys.yaml", "duplicate_keys.yaml: the key sweep of scenes.channel appears twice, on line 6 and line 9"),
])
def test_snakemake_configfile_is_read_by_the_same_loader(name, message):
    proc = snakemake_n("--configfile", str(BAD / name))
    out = proc.stdout + proc.stderr
    assert proc.returncode == 2, out[-2000:]
    assert "invalid configuration, nothing was run:" in out and message in out and "Traceback" not in out


@pytest.mark.skipif(not SNAKEMAKE.exists(), reason="snakemake is not installed in this environment")
def test_snakemake_config_value_bomb_is_refused():
    proc = snakemake_n("--config", "scenes=" + "{" + bomb(7).strip().replace("\n", ", ") + "}")
    out = proc.stdout + proc.stderr
    assert proc.returncode == 2 and f"config: more than {MAX_NODES:,} values" in out, out[-2000:]


# ------------------------------------------------------------------- --set names with dots
@pytest.mark.parametrize("text, parts, value", [
    ('particles.mixtures."mono1.5".diameters=[1.6e-3]', ["particles", "mixtures", "mono1.5", "diameters"], [1.6e-3]),
    ("particles.mixtures.'mono1.5'.diameters=[1.6e-3]", ["particles", "mixtures", "mono1.5", "diameters"], [1.6e-3]),
    ('a."x=y".b=3', ["a", "x=y", "b"], 3),  # the = inside quotes is part of the name
    ("case.phi_mean=0.61", ["case", "phi_mean"], 0.61),  # plain keys as before
    ('case.phi_mean="0.6; x"', ["case", "phi_mean"], "0.6; x"),  # quotes in the value are the value's
    ("a..b=1", ["a", "b"], 1),
])
def test_set_key_quoting(text, parts, value):
    assert parse_override(text) == (parts, value)


def test_set_reaches_a_mixture_whose_name_holds_a_dot():
    heap = ROOT / "config" / "scenes" / "heap.yaml"
    scene = load_scene(heap, ['particles.mixtures."mono1.5".diameters=[1.6e-3]'])
    assert scene["particles"]["mixtures"]["mono1.5"]["diameters"] == [1.6e-3]
    assert "mono1" not in scene["particles"]["mixtures"]


@pytest.mark.parametrize("text, message", [
    ('particles.mixtures."mono1.5.diameters=[1]', 'the quote " at character 20 is not closed'),
    ('particles."mixtures"x.y=1', "'x' follows the quoted name 'mixtures'"),
])
def test_set_key_quoting_mistakes_are_refused(capsys, text, message):
    err = refused(capsys, ["check-config", str(ROOT / "config" / "scenes" / "heap.yaml"), "--set", text])
    assert message in err


def test_set_help_shows_the_quoting(capsys):
    with pytest.raises(SystemExit):
        main(["check-config", "--help"])
    assert '"mono1.5"' in capsys.readouterr().out


# ------------------------------------------------------------------------- plan's root
def test_plan_with_a_config_elsewhere_uses_the_working_directory_as_root(capsys, monkeypatch, tmp_path):
    """The campaign file lies in a temporary directory; its scene files and its relative
    results_dir are found from the working directory (the project), as check-config does."""
    elsewhere = tmp_path / "a" / "b"
    elsewhere.mkdir(parents=True)
    shutil.copy(ROOT / "config" / "config.yaml", elsewhere / "campaign.yaml")
    monkeypatch.chdir(ROOT)
    sets = ["--set", "scenes.heap.sweep.feed_rate=[0.005]", "--set", "scenes.silo.sweep.R=[3.0]",
            "--set", "results_dir=results-plan-root-test"]
    assert main(["plan", "--config", str(elsewhere / "campaign.yaml"), "--rung", "smoke", *sets, "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)
    assert plan["rows"] and all(Path(r["case_dir"]).is_relative_to(ROOT / "results-plan-root-test")
                                for r in plan["rows"])
    assert not (ROOT / "results-plan-root-test").exists()  # plan writes nothing
    # from another working directory the same file's scene files are looked for there, and missing
    monkeypatch.chdir(tmp_path)
    err = refused(capsys, ["plan", "--config", str(elsewhere / "campaign.yaml"), "--rung", "smoke", *sets])
    assert f"config file not found: {tmp_path / 'config' / 'scenes' / 'channel.yaml'}" in err


# -------------------------------------------------------------------------- results_dir
@pytest.mark.parametrize("value, where", [("..", ""), ("../x", "/x"), ("a/../../b", "/b")])
def test_relative_results_dir_outside_the_project_is_refused(capsys, monkeypatch, value, where):
    monkeypatch.chdir(ROOT)
    err = refused(capsys, ["check-config", "config/config.yaml", "--set", f"results_dir={value}"])
    assert (f"config/config.yaml: results_dir = {value!r} resolves to {ROOT.parent}{where}, outside the project "
            f"root {ROOT}: allowed a relative path that stays inside the project; give an absolute path") in err


@pytest.mark.parametrize("value", ["results", "a/../b", "out/run1"])
def test_results_dir_inside_the_project_or_absolute_passes(capsys, monkeypatch, tmp_path, value):
    monkeypatch.chdir(ROOT)
    for v in (value, str(tmp_path / value)):
        assert main(["check-config", "config/config.yaml", "--set", f"results_dir={v}"]) == 0, capsys.readouterr().err

