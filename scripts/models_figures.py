"""The figures of docs/MODELS.md: GMS hysteresis with nested minor loops, drawn from the
engine through the brought system ``mylab.rigs:Stroke`` (docs/examples).

    .venv/bin/python scripts/models_figures.py      # -> docs/gms_hysteresis.png
"""
from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "docs" / "examples")]

from mylab.rigs import stroke_run  # noqa: E402


def main():
    k, alpha, C = [20.0, 60.0, 200.0], [0.3, 0.3, 0.4], 2000.0
    path = [0.0, 0.12, -0.04, 0.08, 0.0, 0.08, 0.03, 0.06, 0.12, -0.12]
    x, F, marks = stroke_run(k, alpha, C, path)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(x, F, lw=1.2, color="k")
    for j, m in enumerate(marks[1:-1], start=1):
        ax.plot(x[m], F[m], "o", ms=4, color="C3")
        ax.annotate(str(j), (x[m], F[m]), textcoords="offset points", xytext=(4, 4),
                    fontsize=8, color="C3")
    ax.set_xlabel("displacement x")
    ax.set_ylabel("friction force F")
    ax.set_title("GMS, 3 elements: minor loops close where they began (reversals numbered)",
                 fontsize=9)
    ax.grid(alpha=0.3)
    out = ROOT / "docs" / "gms_hysteresis.png"
    fig.tight_layout()
    fig.savefig(out, dpi=130)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
