"""Particle snapshots: LAMMPS's own images of a case, side by side for the report.

A scene that declares a :class:`granflow.registry.SnapshotView` and whose effect
``snapshots`` names the rung has its decks write ``run/snapshot_<segment>.jpg``
(``write_dump ... image``) at the end of every segment of the view's stages. This
module picks a few moments of the case, the first image (the filled or first
poured state), the end of the flow stage (when the run judged the flow steady or
the schedule ended) and the last image (the end of averaging), and sets them
side by side with their simulated times, the rung, the colour key and the
case's status. Generic: it never names a scene.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd

#: segment order within a case
STAGE_ORDER = {"init": 0, "flow": 1, "average": 2}
#: LAMMPS colours of the ``type`` view (``acolor *`` cycles these over the atom types)
TYPE_COLORS = ("red", "blue", "green", "orange", "purple", "cyan", "yellow")
_NAME = re.compile(r"^snapshot_(init|flow|average)(?:_(\d+))?\.jpg$")


class SnapshotError(ValueError):
    """The case has no snapshot to show (said in one line)."""


def segment_key(name: str) -> tuple[int, int]:
    """Order of a segment name (``init``, ``flow_003``, ``average_001``) within its case."""
    stage, _, index = name.partition("_")
    return STAGE_ORDER[stage], int(index or 0)


def images(run_dir: str | Path) -> dict[str, Path]:
    """The snapshots of completed segments in ``run_dir``, segment name -> path, in run order.

    A segment whose restart is missing (killed part-way, or still running) is left out.
    """
    run_dir = Path(run_dir)
    found = {}
    for path in run_dir.glob("snapshot_*.jpg"):
        m = _NAME.match(path.name)
        if not m:
            continue
        name = path.name[len("snapshot_"):-len(".jpg")]
        if (run_dir / f"{name}.restart").exists():
            found[name] = path
    return dict(sorted(found.items(), key=lambda kv: segment_key(kv[0])))


def pick(names: list[str]) -> list[str]:
    """Up to three moments of the run-ordered ``names``: the first image, the last of the flow
    stage and the last image; when those are fewer than three distinct ones (no flow stage,
    or no averaging), the middle image stands in for the flow stage's end."""
    if not names:
        return []
    flows = [n for n in names if n.startswith("flow")]
    chosen = list(dict.fromkeys([names[0]] + flows[-1:] + [names[-1]]))
    if len(chosen) < 3:
        chosen = list(dict.fromkeys([names[0], names[len(names) // 2], names[-1]]))
    return chosen


def segment_times(thermo_csv: str | Path) -> dict[str, float]:
    """Simulated time at the end of each segment, from the run's ``thermo.csv`` (``segment`` column)."""
    path = Path(thermo_csv)
    if not path.exists():
        return {}
    df = pd.read_csv(path)
    if "segment" not in df or "Time" not in df:
        return {}
    return {str(k): float(v) for k, v in df.groupby("segment")["Time"].max().items()}


def label(name: str) -> str:
    stage, _, index = name.partition("_")
    what = {"init": "end of the initial stage", "flow": "flow segment", "average": "averaging segment"}[stage]
    return what + (f" {int(index)}" if index else "")


def compose(case_dir: str | Path, out: str | Path, title: str = "", time_unit: str = "simulation units") -> list[str]:
    """Write ``out`` (PNG): the picked snapshots of ``case_dir`` side by side; returns their segment names.

    Raises :class:`SnapshotError` if the case wrote none (e.g. it stopped before its first segment ended).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    case_dir = Path(case_dir)
    record = json.loads((case_dir / "params.json").read_text())
    view = record.get("snapshots")
    if not view:
        raise SnapshotError(f"{case_dir}: the case's decks write no snapshots at rung {record.get('rung')!r} "
                            "(effect snapshots)")
    found = images(case_dir / "run")
    if not found:
        raise SnapshotError(f"{case_dir}/run holds no snapshot of a completed segment")
    chosen = pick(list(found))
    times = segment_times(case_dir / "run" / "thermo.csv")
    status = {}
    if (case_dir / "run" / "status.json").exists():
        status = json.loads((case_dir / "run" / "status.json").read_text())
    pics = [plt.imread(found[n]) for n in chosen]
    widths = [p.shape[1] / p.shape[0] for p in pics]
    fig, axes = plt.subplots(1, len(pics), figsize=(max(3.2 * sum(widths) + 0.4, 7.5), 4.2),
                             gridspec_kw={"width_ratios": widths}, squeeze=False)
    for ax, name, pic in zip(axes[0], chosen, pics):
        ax.imshow(pic)
        ax.set_axis_off()
        t = times.get(name)
        ax.set_title(label(name) + ("" if t is None else f"\nt = {t:.4g} {time_unit}"), fontsize=9)
    if view["color"] == "speed":
        key = "colour: particle speed, blue = slowest, yellow = middle, red = fastest particle of each frame"
    else:
        key = "colour: atom type (species) " + ", ".join(f"{i + 1} {c}" for i, c in enumerate(TYPE_COLORS))
    rung = record.get("rung", "?")
    head = f"{title}  ·  rung {rung}" + (f"  ·  {status['status']}" if status.get("status") else "")
    fig.suptitle(head, fontsize=10)
    fig.text(0.5, 0.01, key + "  ·  LAMMPS dump image", ha="center", fontsize=8)
    fig.tight_layout(rect=(0, 0.04, 1, 0.95))
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return chosen


__all__ = ["compose", "images", "pick", "placeholder", "segment_times", "SnapshotError", "TYPE_COLORS"]


def placeholder(out: str | Path, title: str, why: str) -> None:
    """A small PNG that says why a case has no snapshot."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(6, 1.6))
    fig.text(0.5, 0.65, title, ha="center", fontsize=10)
    fig.text(0.5, 0.35, "no particle snapshot: " + why, ha="center", fontsize=8, wrap=True)
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
