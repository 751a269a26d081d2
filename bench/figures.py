"""One table for a whole ``bash run.sh bench``: every figure beside its anchor, with the ratio.

A figure alone says little on a noisy 2-core machine; beside what it is measured against in the
same run (the direct path, the hand-written relay, topic_tools, or a fixed target) it says how
ipyros does. Each bench turns its results into :class:`Figure` records, prints its targets from
them (:func:`target_lines`) and keeps them (:func:`keep`, a JSON file a bench under
``bench/results/figures/``); ``python -m bench.figures`` then prints all of them as one table
and saves it to ``bench/results/summary.md``. ``bash run.sh bench`` clears the folder first, so
the table is that run's, ROS 1 and ROS 2 (two venvs, so the benches meet in files).
"""

from __future__ import annotations

import json
import os
import platform
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Iterable, Optional

__all__ = ["FOLDER", "Figure", "compare", "keep", "machine", "main", "table", "target_lines"]

FOLDER = Path(__file__).resolve().parent / "results" / "figures"


@dataclass(frozen=True)
class Figure:
    """A measured figure, what it is measured against, and the target it must meet, if any.

    ``most``/``least`` bound the ratio to the anchor (``value <= most * anchor_value``), or the
    value itself when there is no anchor (``value <= 5`` ms, ``lost <= 0``).
    """

    ros: str  # "ROS 1" or "ROS 2"
    what: str
    value: float
    unit: str
    anchor: str = ""
    anchor_value: Optional[float] = None
    most: Optional[float] = None
    least: Optional[float] = None
    note: str = ""  # what explains a miss, measured in the same run

    @property
    def ratio(self) -> Optional[float]:
        return self.value / self.anchor_value if self.anchor_value else None

    @property
    def passed(self) -> Optional[bool]:
        """True or False against the target; None for a figure shown for its own sake."""
        base = 1.0 if self.anchor_value is None else self.anchor_value
        if self.most is not None:
            return self.value <= self.most * base
        if self.least is not None:
            return self.value >= self.least * base
        return None

    @property
    def target(self) -> str:
        bound = "<=" if self.most is not None else ">=" if self.least is not None else ""
        if not bound:
            return "-"
        limit = self.most if self.most is not None else self.least
        if limit == 0:
            return "0"
        if self.anchor_value is None:
            return f"{bound} {_number(limit, self.unit)}"
        return f"{bound} {limit:.3g}x"


def _number(value: Optional[float], unit: str) -> str:
    if value is None:  # a path that delivered nothing has no such figure
        return "-"
    if unit == "ms":
        return f"{value:.3f} ms" if value < 10 else f"{value:.1f} ms"
    if unit in ("s", "µs"):
        return f"{value:.1f} {unit}"
    if unit in ("msg/s", "KiB", "MiB"):
        return f"{value:,.0f} {unit}"
    return f"{value:g} {unit}".rstrip()


def target_lines(figures: Iterable[Figure]) -> list[str]:
    """``- PASS what: value vs anchor (ratio)``, a line a figure that has a target."""
    lines = []
    for f in figures:
        if f.passed is None:
            continue
        against = f" vs {f.anchor} {_number(f.anchor_value, f.unit)} ({f.ratio:.2f}x)" if f.ratio is not None else (
            f" vs {f.anchor} {_number(f.anchor_value, f.unit)}" if f.anchor else "")
        note = f"; {f.note}" if f.note else ""
        lines.append(f"- {'PASS' if f.passed else 'FAIL'} {f.ros} {f.what}: {_number(f.value, f.unit)}{against}, "
                     f"target {f.target}{note}")
    return lines


def keep(name: str, figures: list[Figure]) -> Path:
    """Save one bench's figures for :func:`main`'s table (``bench/results/figures/NAME.json``)."""
    FOLDER.mkdir(parents=True, exist_ok=True)
    out = FOLDER / f"{name}.json"
    out.write_text(json.dumps({"machine": machine(), "figures": [asdict(f) for f in figures]}, indent=1))
    return out


def machine(ros: str = "") -> str:
    """CPU model, cores, kernel, ``ros`` (which ROS, its version) and Python, on one line."""
    model = platform.machine()
    try:
        model = next(line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                     if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return ", ".join(filter(None, [model, f"{os.cpu_count()} cores", f"Linux {platform.release()}", ros,
                                   f"Python {platform.python_version()}"]))


def table(figures: list[Figure]) -> str:
    """Every figure as a markdown row: ROS, figure, value, anchor, the anchor's value, ratio, target, verdict."""
    lines = ["| ROS | figure | ipyros | anchor | anchor's | ratio | target | |",
             "|---|---|---:|---|---:|---:|---|---|"]
    for f in figures:
        anchor_value = _number(f.anchor_value, f.unit) if f.anchor_value is not None else ""
        ratio = f"{f.ratio:.2f}x" if f.ratio is not None else ""
        verdict = {True: "PASS", False: "**FAIL**", None: ""}[f.passed]
        what = f"{f.what} ({f.note})" if f.note and f.passed is False else f.what
        lines.append(f"| {f.ros} | {what} | {_number(f.value, f.unit)} | {f.anchor} | {anchor_value} | {ratio} "
                     f"| {f.target} | {verdict} |")
    return "\n".join(lines)


def load(folder: Path = FOLDER) -> tuple[list[str], list[Figure]]:
    """(machines, figures) of every bench that kept its figures in ``folder``, in the order they ran."""
    machines, figures = [], []
    for path in sorted(folder.glob("*.json"), key=lambda p: p.stat().st_mtime):
        kept = json.loads(path.read_text())
        machines.append(kept["machine"])
        figures += [Figure(**f) for f in kept["figures"]]
    return machines, figures


def compare(before: list[Figure], now: list[Figure]) -> str:
    """The figures both runs have, side by side: each run's value and its ratio to its own run's anchor.

    Two runs of a noisy machine differ in their anchors too; the ratio to the anchor measured in the
    same run is what says whether a change made ipyros slower. A figure only one run has is left out.
    """
    earlier = {(f.ros, f.what, f.anchor): f for f in before}  # one figure may stand beside two anchors
    lines = ["| ROS | figure | anchor | before | ratio before | now | ratio now | target | |",
             "|---|---|---|---:|---:|---:|---:|---|---|"]
    for f in now:
        old = earlier.get((f.ros, f.what, f.anchor))
        if old is None:
            continue
        ratios = [f"{x.ratio:.2f}x" if x.ratio is not None else "" for x in (old, f)]
        verdict = {True: "PASS", False: "**FAIL**", None: ""}[f.passed]
        lines.append(f"| {f.ros} | {f.what} | {f.anchor} | {_number(old.value, old.unit)} | {ratios[0]} "
                     f"| {_number(f.value, f.unit)} | {ratios[1]} | {f.target} | {verdict} |")
    return "\n".join(lines)


def main(argv: Optional[list[str]] = None) -> int:
    """``python -m bench.figures`` (this run's table) or ``--before FOLDER`` (an earlier run's figures beside it)."""
    argv = sys.argv[1:] if argv is None else argv
    machines, figures = load()
    if argv[:1] == ["--before"] and len(argv) == 2:
        _, earlier = load(Path(argv[1]))
        if not earlier:
            print(f"no figures in {argv[1]}: give the bench/results/figures folder of an earlier run", file=sys.stderr)
            return 1
        print(compare(earlier, figures))
        return 0
    if not figures:
        print(f"no bench has kept its figures in {FOLDER} yet: run bash run.sh bench", file=sys.stderr)
        return 1
    missed = sum(f.passed is False for f in figures)
    with_target = sum(f.passed is not None for f in figures)
    text = (f"All benchmarks of one run on {' / '.join(dict.fromkeys(machines))}: each figure beside its anchor "
            f"in the same run.\n\n{table(figures)}\n\n{with_target - missed} of {with_target} targets met.\n")
    out = FOLDER.parent / "summary.md"
    out.write_text(text)
    print("\n" + text + f"(saved to {out})")
    return int(missed > 0)


if __name__ == "__main__":
    sys.exit(main())
