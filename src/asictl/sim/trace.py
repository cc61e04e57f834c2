"""Signal traces of a simulation, and their three forms: VCD, CSV and a PNG timing diagram.

A trace keeps only changes (time, value) per signal, so an hour of master time with a few
edges costs a few entries. All three writers are deterministic: the same run gives the
same bytes. Marks are the moments people look for first: failed expectations (on the
lane of their operand) and program stops; the timing diagram draws them in red.
"""

from __future__ import annotations

import bisect
import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

from asictl.errors import missing_extra
from asictl.files import shown_name, write_atomic


@dataclass
class Signal:
    #: the lane's name: the operand, or its symbol
    name: str
    width: int  # 1 for a bit, 8 for a byte, 12 for a count, 16 for milliseconds
    changes: list[tuple[float, int]] = field(default_factory=list)
    #: the operand it shows (``Q 2.0``, ``CV 0``, ``running``)
    operand: str = ""

    def record(self, t_ms: float, value: int) -> None:
        if not self.changes or self.changes[-1][1] != value:
            if self.changes and self.changes[-1][0] == t_ms:
                self.changes[-1] = (t_ms, value)
            else:
                self.changes.append((t_ms, value))

    def value_at(self, t_ms: float) -> int:
        i = bisect.bisect_right(self.changes, t_ms, key=lambda change: change[0])
        return self.changes[i - 1][1] if i else 0


@dataclass(frozen=True)
class Mark:
    """Something that happened at a moment: a failed expectation, a program stop."""

    at_ms: float
    text: str
    #: the operand of the lane it belongs to (``running`` for stops)
    lane: str = ""


@dataclass
class Trace:
    signals: list[Signal]
    end_ms: float = 0.0
    marks: list[Mark] = field(default_factory=list)
    start_ms: float = 0.0

    def times(self) -> list[float]:
        return sorted({t for s in self.signals for t, _ in s.changes} | {self.start_ms})

    def window(self, start: float, end: float | None) -> Trace:
        """The part from ``start`` to ``end`` (None: the end of the run)."""
        stop = self.end_ms if end is None else min(end, self.end_ms)
        signals = []
        for signal in self.signals:
            changes = [(start, signal.value_at(start))]
            changes += [(t, v) for t, v in signal.changes if start < t <= stop]
            signals.append(Signal(signal.name, signal.width, changes, signal.operand))
        marks = [m for m in self.marks if start <= m.at_ms <= stop]
        return Trace(signals, end_ms=stop, marks=marks, start_ms=start)


def _vcd_id(index: int) -> str:
    chars = [chr(c) for c in range(33, 127)]
    out = ""
    index += 1
    while index:
        index, rest = divmod(index - 1, len(chars))
        out = chars[rest] + out
    return out


def _vcd_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]", "_", name)


def to_vcd(trace: Trace, *, comment: str = "asictl sim") -> str:
    """Value change dump (IEEE 1364), 1 us resolution, viewable in GTKWave."""
    out = [f"$comment {comment} $end", "$timescale 1us $end", "$scope module plc $end"]
    ids = {}
    for i, signal in enumerate(trace.signals):
        ids[signal.name] = _vcd_id(i)
        out.append(f"$var wire {signal.width} {ids[signal.name]} {_vcd_name(signal.name)} $end")
    out += ["$upscope $end", "$enddefinitions $end"]
    events: dict[int, list[str]] = {}
    for signal in trace.signals:
        changes = signal.changes
        if not changes or changes[0][0] != trace.start_ms:
            changes = [(trace.start_ms, 0), *changes]
        for t, value in changes:
            text = (f"{value}{ids[signal.name]}" if signal.width == 1
                    else f"b{value:b} {ids[signal.name]}")
            events.setdefault(round(t * 1000), []).append(text)
    for t in sorted(events):
        out.append(f"#{t}")
        out.extend(events[t])
    out.append(f"#{round(trace.end_ms * 1000)}")
    return "\n".join(out) + "\n"


def to_csv(trace: Trace) -> str:
    """One row per time at which any signal changes: time_ms, then every signal's value."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    # a plant model's name is the user's text: an escape sequence in it must not reach
    # the terminal of whoever views the file
    writer.writerow(["time_ms", *(shown_name(s.name) for s in trace.signals)])
    for t in trace.times():
        writer.writerow([f"{t:g}", *(s.value_at(t) for s in trace.signals)])
    return buffer.getvalue()


def write_plot(trace: Trace, path: Path, *, title: str) -> None:
    """A timing diagram: one lane per signal, bits as logic levels, values as numbers;
    failed expectations and stops in red."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise missing_extra("--plot", "plot") from None
    signals = trace.signals
    start = trace.start_ms
    end = trace.end_ms if trace.end_ms > start else max(
        (t for s in signals for t, _ in s.changes), default=start + 1.0
    )
    if end <= start:
        end = start + 1.0
    height = max(2.0, 0.45 * len(signals) + 1.0)
    fig, axes = plt.subplots(len(signals) or 1, 1, sharex=True, figsize=(11, height),
                             squeeze=False)
    unit, scale = ("s", 1000.0) if end - start > 5000 else ("ms", 1.0)
    lanes = {signal.operand: i for i, signal in enumerate(signals)}
    for ax, signal in zip(axes[:, 0], signals, strict=False):
        xs, ys = [start / scale], [signal.value_at(start)]
        for t, v in signal.changes:
            if start < t <= end:
                xs.append(t / scale)
                ys.append(v)
        xs.append(end / scale)  # the last level lasts to the end of the run
        ys.append(ys[-1])
        ax.step(xs, ys, where="post", linewidth=1.4,
                color="tab:blue" if signal.width == 1 else "tab:green")
        if signal.width == 1:
            ax.fill_between(xs, ys, step="post", alpha=0.25)
            ax.set_ylim(-0.2, 1.3)
            ax.set_yticks([])
        else:
            top = max(ys) or 1
            ax.set_ylim(-0.1 * top, 1.25 * top)
            ax.set_yticks([0, top])
            ax.tick_params(axis="y", labelsize=7)
            span = (end - start) / scale
            for (x0, y), x1 in zip(zip(xs, ys, strict=False), xs[1:], strict=False):
                if x1 > x0 and (x1 - x0) > span / 40:
                    text = f"{y:02X}h" if signal.width == 8 else str(y)
                    ax.text((x0 + x1) / 2, y, text, ha="center", va="bottom", fontsize=7)
        label = signal.name
        if signal.operand and signal.operand != signal.name:
            label += f"\n{signal.operand}"  # a symbol, and what it stands for
        ax.set_ylabel(label, rotation=0, ha="right", va="center", fontsize=9)
        ax.grid(axis="x", alpha=0.3)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
    for mark in trace.marks:
        lane = lanes.get(mark.lane)
        targets = [axes[lane, 0]] if lane is not None else list(axes[:, 0])
        for ax in targets:
            ax.axvline(mark.at_ms / scale, color="red", linewidth=1.2)
        late = mark.at_ms - start > 0.6 * (end - start)  # label to the left near the end
        targets[0].annotate(mark.text, (mark.at_ms / scale, 1.0),
                            xycoords=("data", "axes fraction"), color="red", fontsize=7,
                            ha="right" if late else "left", va="bottom")
    axes[-1, 0].set_xlabel(f"master time ({unit})")
    axes[-1, 0].set_xlim(start / scale, end / scale)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110, metadata={"Software": None})
    plt.close(fig)
    write_atomic(path, buffer.getvalue())
