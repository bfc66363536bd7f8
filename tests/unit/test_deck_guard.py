"""What may reach a deck (issue 41, defect 1): a rung name holding a newline wrote
``shell touch ...`` into a deck's header, and LAMMPS ran it; the schemas' ``$`` let a trailing
newline through. Every registered scene, at every rung, with hostile names: refused before
anything is rendered, and, with the name checks taken away, no line the templates could not
have written reaches a deck."""
import copy
import functools
import re
from pathlib import Path

import pytest
import yaml

from granflow import deck, registry, scene_files, schema
from granflow.cli import main
from granflow.config import ConfigError
from granflow.schema import PROJECT_ROOT
from granflow.deck import environment, render_case
from granflow.deck_guard import (FORBIDDEN, DeckError, check_deck, check_name, commands, logical_lines,
                                 template_commands)

#: a file the hostile names try to create (a run of LAMMPS would make it; rendering never may)
MARKER = "/tmp/granflow-deck-guard-marker"
#: what a hostile name appends to a real rung's name: line breaks of every kind Python or LAMMPS
#: might split at (\n, \r, \v, \f, \x1c-\x1e, \x85, U+2028, U+2029), LAMMPS's own separators and
#: continuation (;, &, #, quotes, $), and a name that only differs in case or letters
SUFFIXES = [
    f"\nshell touch {MARKER}", "\n", f"\r\nshell touch {MARKER}", f"\rshell touch {MARKER}",
    f"\x0bshell touch {MARKER}", f"\x0cshell touch {MARKER}", f"\x1cshell touch {MARKER}",
    f"\x1eshell touch {MARKER}", f"\x85shell touch {MARKER}", f"\u2028shell touch {MARKER}",
    f"\u2029shell touch {MARKER}", f"; shell touch {MARKER}", f" & shell touch {MARKER}", " &",
    "&", f" # x\nshell touch {MARKER}", '"""', "'", " ${x}", "\x00", "\t", "é", "\u200b", "-x", ".x",
]
NEVER_IN_A_DECK = tuple(FORBIDDEN)


def _scene(name: str) -> dict:
    return copy.deepcopy(_loaded(name))


@functools.lru_cache(maxsize=None)
def _loaded(name: str) -> dict:
    return scene_files.load_scene(PROJECT_ROOT / "config" / "scenes" / f"{name}.yaml")


#: a case each rung renders with where the scene file's own case is refused by preflight at that
#: rung (the smoke heap's feed zone delivers 5.7 g/s at most; the smoke silo's R_c = 6 takes R <= 4)
RENDERABLE = {("heap", "smoke"): {"feed_rate": 0.005}, ("silo", "smoke"): {"R": 3.5}}
SCENE_RUNGS = [(name, rung) for name in registry.names() for rung in _scene(name)["rungs"]]


def _case(name: str, rung: str, scene: dict) -> dict | None:
    extra = RENDERABLE.get((name, rung))
    return None if extra is None else {**scene["case"], **extra}


def _with_rung(scene: dict, rung: str, hostile: str) -> dict:
    out = copy.deepcopy(scene)
    out["rungs"][hostile] = copy.deepcopy(scene["rungs"][rung])
    for key in ("snapshots",):  # a scene whose snapshots name the rung names the hostile one too
        if rung in out.get("effects", {}).get(key, []):
            out["effects"][key] = [*out["effects"][key], hostile]
    return out


def _forbidden_lines(text: str) -> list[str]:
    """Lines of a written deck that start a command LAMMPS must never run, split at every line
    break Python knows (wider than LAMMPS's \\n), or that hold anything but printable ASCII.
    Written independently of granflow.deck_guard's reading of a deck."""
    bad = [line for line in text.splitlines()
           if line.strip().split(" ", 1)[0] in NEVER_IN_A_DECK]
    bad += [line for line in text.split("\n") if re.search(r"[^ -~]", line)]
    return bad


# ---------------------------------------------------------------------------------- reproduce
@pytest.mark.parametrize("name", registry.names())
def test_the_schema_refuses_a_hostile_rung_name(name):
    """A rung named in the scene file (each schema: fixed names, or the chute's any name) with
    anything but a-z, 0-9 and _ is refused by check-config's validation, before any deck."""
    scene = _scene(name)
    for suffix in SUFFIXES:
        with pytest.raises(ConfigError, match="rungs"):
            scene_files.validate_scene(_with_rung(scene, "demo", "demo" + suffix), "scene")


@pytest.mark.parametrize("value", ["results\n", "results\r", "results\n\n", "results\u2028"])
def test_results_dir_with_a_newline_is_refused(value):
    data = yaml.safe_load((PROJECT_ROOT / "config" / "config.yaml").read_text())
    data["results_dir"] = value
    with pytest.raises(ConfigError, match=r"results_dir = .*does not match"):
        schema.validate(data, "config")


def test_a_heap_mixture_named_with_a_newline_is_refused():
    scene = _scene("heap")
    mixtures = scene["particles"]["mixtures"]
    mixtures["evil\n"] = mixtures[scene["case"]["mixture"]]
    scene["case"]["mixture"] = "evil\n"
    with pytest.raises(ConfigError, match=r"case.mixture = 'evil\\n'.*does not match"):
        scene_files.validate_scene(scene, "heap")


def test_every_schema_pattern_is_anchored_at_the_very_end():
    r"""jsonschema matches a pattern with re.search, where $ also matches before a final newline:
    every pattern starts with ^ and ends with \Z, and has no $ anywhere."""
    def patterns(node):
        if isinstance(node, dict):
            for key, value in node.items():
                if key == "pattern":
                    yield value
                else:
                    yield from patterns(value)
        elif isinstance(node, list):
            for value in node:
                yield from patterns(value)

    found = 0
    for path in sorted((PROJECT_ROOT / "config" / "schema").glob("*.schema.yaml")):
        for pattern in patterns(yaml.safe_load(path.read_text())):
            found += 1
            assert pattern.startswith("^") and pattern.endswith(r"\Z") and "$" not in pattern, (path, pattern)
            assert re.compile(pattern)  # Python's re reads it
    assert found >= 9


# ------------------------------------------------------------- refused before anything is rendered
@pytest.mark.parametrize("name, rung", SCENE_RUNGS)
def test_render_refuses_a_hostile_rung_before_anything(name, rung, tmp_path):
    """Given straight to render_case (as Snakemake's render rule and `granflow render` do, past the
    schema): refused by name, no directory made, nothing run."""
    scene = _scene(name)
    for suffix in SUFFIXES:
        hostile = rung + suffix
        out = tmp_path / "case"
        with pytest.raises(DeckError, match=r"rung = .* is not allowed in a deck: allowed a name of a-z"):
            render_case(_with_rung(scene, rung, hostile), hostile, out, _case(name, rung, scene))
        assert not out.exists() and not Path(MARKER).exists(), suffix


@pytest.mark.parametrize("value", ["demo", "a", "smoke_2", "x" * 32])
def test_check_name_takes_names(value):
    assert check_name("rung", value) == value


@pytest.mark.parametrize("value", ["", "Demo", "2demo", "_demo", "x" * 33, "demo\n", None, 3, "de mo", "dé"])
def test_check_name_refuses_the_rest(value):
    with pytest.raises(DeckError, match="is not allowed in a deck"):
        check_name("rung", value)


# ---------------------------------------------- with the name checks taken away: the lines guard
@functools.lru_cache(maxsize=None)
def _cached_environment(package_dir=None):
    return environment(package_dir)


@pytest.fixture
def decks_only(monkeypatch):
    """render_case writing the decks and params.json only (the data files, e.g. the silo's
    atoms.data, are no decks and take seconds at the large rungs), with one Jinja environment."""
    real = deck.scene_parameters

    def parameters(*args, **kwargs):
        params, context = real(*args, **kwargs)
        context.pop("data_files", None)
        return params, context

    monkeypatch.setattr(deck, "scene_parameters", parameters)
    monkeypatch.setattr(deck, "environment", _cached_environment)


@pytest.fixture
def names_unchecked(monkeypatch, decks_only):
    """render_case with its name and context checks taken away (what a future template or scene
    could let through): only the check of the deck's lines is left."""
    monkeypatch.setattr(deck, "check_name", lambda what, value: value)
    monkeypatch.setattr(deck, "check_context", lambda params, context: None)


@pytest.mark.parametrize("name, rung", SCENE_RUNGS)
def test_no_hostile_rung_name_puts_a_command_in_a_deck(name, rung, tmp_path, names_unchecked):
    """Every rung of every scene, each hostile name: the deck check refuses it, or every deck
    written holds no line LAMMPS would run as shell, python, include, log or plugin (split at
    every line break Python knows) and only printable ASCII."""
    scene = _scene(name)
    refused = 0
    for i, suffix in enumerate(SUFFIXES):
        hostile = rung + suffix
        out = tmp_path / f"case{i}"
        try:
            render_case(_with_rung(scene, rung, hostile), hostile, out, _case(name, rung, scene))
        except DeckError as exc:
            assert "no deck was written" in str(exc) and "line " in str(exc)
            assert not out.exists(), suffix
            refused += 1
            continue
        decks = sorted(out.glob("*.lmp"))
        assert decks, suffix
        for path in decks:
            text = path.read_text()
            assert not _forbidden_lines(text), (suffix, path.name, _forbidden_lines(text))
            assert f"rung {hostile}\n" in text  # the name did reach the header: the check saw it
    assert not Path(MARKER).exists()
    # the names that carry a line break or a non-ASCII character are all refused by the deck check
    assert refused >= sum(bool(re.search(r"[^ -~]", s)) for s in SUFFIXES) + 1, refused


# ---------------------------------------------------------------------------------- the check
ALLOWED = frozenset({"units", "run", "print", "if", "variable", "quit", "group", "velocity", "set"})


@pytest.mark.parametrize("text", [
    "units lj\n# a comment: shell touch x; include y\nprint \"shell is only a word here\"\n",
    'run 10 every 5 "group a b" "velocity a set 0 0 0" NULL\n',
    'if "1 == 1" then &\n  "print \'x\'" &\n  "quit 3"\nunits lj\n',
    "units &\n lj\n",
])
def test_deck_check_passes_what_the_templates_write(text):
    check_deck(text, ALLOWED, "init.lmp")


@pytest.mark.parametrize("text, line, why", [
    ("units lj\nshell touch x\n", "line 2", "the command shell runs a program"),
    ("python f here x\n", "line 1", "the command python runs Python code"),
    ("include other.lmp\n", "line 1", "the command include reads another input file"),
    ("log /tmp/x append\n", "line 1", "the command log moves the log"),
    ("plugin load x.so\n", "line 1", "the command plugin loads a shared library"),
    ("fix 1 all nve\n", "line 1", "'fix' is not a command the scene's templates write"),
    ('if "1 == 1" then "print x" "shell touch y"\n', "line 1", "the command shell"),
    ('if "0" then "print x" elif "1" "include y" else "quit"\n', "line 1", "the command include"),
    ('run 10 every 5 "print a" "log /tmp/x"\n', "line 1", "the command log"),
    ("sh&\nell touch x\n", "line 1-2", "the command shell"),  # LAMMPS joins at & with nothing between
    ("# rung demo &\nunits lj\n", "line 1-2", "a comment continued with &"),
    ("# rung demo\u2028shell touch x\n", "line 1", r"U\+2028 \(LINE SEPARATOR\)"),
    ("# rung demo\x85shell touch x\n", "line 1", r"U\+0085"),
    ("# rung demo\rshell touch x\n", "line 1", r"U\+000D"),
    ("print \"\"\"\nshell touch x\n\"\"\"\n", "line 1", "triple quote"),
    ("print \"abc\n", "line 1", "the quote \" at character 7 is not closed"),
    ("${cmd} x\n", "line 1", "'\\$\\{cmd\\}' is not a command"),
    ("Shell touch x\n", "line 1", "'Shell' is not a command"),
])
def test_deck_check_refuses_a_line_the_templates_never_write(text, line, why):
    with pytest.raises(DeckError, match=rf"^init\.lmp, {line}: .*{why}.*no deck was written"):
        check_deck(text, ALLOWED, "init.lmp")


def test_continuation_joins_as_lammps_does():
    assert logical_lines("a &\n b\nc") == [(1, 2, "a  b"), (3, 3, "c")]
    assert logical_lines("sh&  \nell x\n") == [(1, 2, "shell x"), (3, 3, "")]
    assert commands('if "c" then "print x" "quit 3"') == ["if", "print", "quit"]


@pytest.mark.parametrize("name", registry.names())
def test_the_allow_list_is_what_the_templates_write(name):
    """Found in the scene's template and the snippets it imports: LAMMPS commands only, none of
    the forbidden ones, and each the first word of some line of those templates."""
    env = environment()
    allowed = template_commands(env, f"{name}.lmp.j2")
    assert {"units", "variable", "fix", "run", "pair_style", "write_restart"} <= allowed
    assert not allowed & set(FORBIDDEN)
    texts = "\n".join(env.loader.get_source(env, t)[0] for t in env.list_templates() if t.endswith(".lmp.j2"))
    for command in allowed:
        assert re.search(rf"(^|[\"'])\s*{re.escape(command)}\b", texts, re.M), command


def test_every_rendered_deck_passes_the_check(tmp_path, decks_only):
    """The check refuses nothing granflow writes: every rung of every scene renders, each deck
    checked by render_case."""
    for name, rung in SCENE_RUNGS:
        scene = _scene(name)
        render_case(scene, rung, tmp_path / f"{name}-{rung}", _case(name, rung, scene))
        assert sorted(p.name for p in (tmp_path / f"{name}-{rung}").glob("*.lmp"))


# ------------------------------------------------------------------------------------- the CLI
def test_cli_render_refuses_a_hostile_rung(capsys, tmp_path):
    out = tmp_path / "out"
    assert main(["render", "chute", "--rung", f"demo\nshell touch {MARKER}", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("granflow: refused: ") and "Traceback" not in err
    assert not out.exists() and not Path(MARKER).exists()


def test_cli_render_refuses_a_deck_line_with_exit_2(capsys, tmp_path, monkeypatch):
    """A deck line outside the allow-list (here: the allow-list without `run`) is a refusal naming
    the line: exit 2, no traceback, nothing written."""
    real = deck.template_commands
    monkeypatch.setattr(deck, "template_commands", lambda env, name: real(env, name) - {"run"})
    out = tmp_path / "out"
    assert main(["render", "chute", "--rung", "smoke", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert re.search(r"^granflow: refused: init\.lmp of chute at rung smoke, line \d+: 'run .*': 'run' is not "
                     r"a command the scene's templates write", err), err
    assert not out.exists()


@pytest.mark.parametrize("line", [f"shell touch {MARKER}", "python evil here", "bond_style harmonic",
                                  "log /tmp/granflow-deck-guard.log",
                                  "print \"\"\"", "run 0 every 1 \"shell touch x\""])
def test_run_refuses_a_deck_edited_after_rendering(line, capsys, tmp_path):
    """``granflow run`` reads the case's decks as they are on disk: a line added after ``render`` wrote
    them (a shell command, a command no template writes, a triple quote, a shell inside ``run every``)
    is refused before anything runs, naming the file and the line: exit 2, no LAMMPS, no run directory,
    the marker never made. The decks as rendered pass the same check (granflow.deck.check_case_decks)."""
    out = tmp_path / "case"
    assert main(["render", "chute", "--rung", "smoke", "--out", str(out)]) == 0
    deck.check_case_decks(out, yaml.safe_load((out / "params.json").read_text()))   # as rendered: passes
    flow = out / "flow.lmp"
    flow.write_text(flow.read_text() + line + "\n")
    capsys.readouterr()
    assert main(["run", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"granflow: refused: {flow}, line ") and "nothing ran: render the case again" in err, err
    assert "Traceback" not in err and not Path(MARKER).exists() and not (out / "run").exists()
