"""Draw the package's import graph by layer: ``docs/architecture.png``.

The graph and the layer table are the ones ``tests/test_architecture.py`` checks (it is loaded
from there, so the picture and the test cannot disagree).  Each box is one layer (a row of
``LAYERS``), placed by its rank, lowest at the bottom; an arrow ``A -> B`` means that modules
of A import modules of B, labelled with the number of importing modules.  Every arrow points
down: an upward one would fail the test.

Usage::

    python tools/import_graph.py [--output docs/architecture.png] [--overwrite]
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from collections import Counter, defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _architecture_test():
    spec = importlib.util.spec_from_file_location("_architecture_test", REPO / "tests" / "test_architecture.py")
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module


def layer_graph() -> tuple[dict[str, int], Counter[tuple[str, str]], dict[str, int]]:
    """Layer ranks, layer-to-layer edges (count of importing modules) and modules per layer."""
    arch = _architecture_test()
    graph = {m: t - arch.SHIMS for m, t in arch.import_graph().items() if m not in arch.SHIMS}
    edges: Counter[tuple[str, str]] = Counter()
    sizes: dict[str, int] = defaultdict(int)
    for module, targets in graph.items():
        source = arch.layer_of(module)
        sizes[source] += 1
        for layer in {arch.layer_of(t) for t in targets} - {source}:
            edges[(source, layer)] += 1
    return dict(arch.LAYERS), edges, dict(sizes)


#: imported by nearly every layer; drawn as a box, its arrows left out for legibility
_NOT_DRAWN = frozenset({"pcmm_geo.errors", "pcmm_geo"})


def _label(layer: str) -> str:
    return "pcmm_geo (__init__)" if layer == "pcmm_geo" else layer.removeprefix("pcmm_geo.")


def draw(output: Path) -> Path:
    """Write the picture to ``output`` (PNG or SVG by suffix) and return the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import FancyBboxPatch

    ranks, edges, sizes = layer_graph()
    rows: dict[int, list[str]] = defaultdict(list)
    for layer, rank in sorted(ranks.items(), key=lambda item: (item[1], item[0])):
        rows[rank].append(layer)
    position = {}
    width = max(len(row) for row in rows.values())
    for rank, row in rows.items():
        for k, layer in enumerate(row):
            # lone boxes zigzag so that arrows between far ranks pass beside the boxes in between
            zigzag = (0.9 if rank % 2 else -0.9) if len(row) == 1 else 0.0
            position[layer] = ((k - (len(row) - 1) / 2) * 2.5 + zigzag, rank * 1.0)
    fig, ax = plt.subplots(figsize=(11, 12))
    box_w, box_h = 1.9, 0.42
    drawn = {edge: count for edge, count in edges.items() if edge[1] not in _NOT_DRAWN}
    for (source, target), count in sorted(drawn.items()):
        (x0, y0), (x1, y1) = position[source], position[target]
        rad = 0.25 if abs(x1 - x0) < 0.1 and y0 - y1 > 1.5 else 0.08
        ax.annotate(
            "", xy=(x1, y1 + box_h / 2), xytext=(x0, y0 - box_h / 2),
            arrowprops={"arrowstyle": "-|>", "color": "#4a6fa5", "alpha": 0.55, "lw": 0.6 + 0.25 * count ** 0.5,
                        "connectionstyle": f"arc3,rad={rad}", "shrinkA": 2, "shrinkB": 2},
        )
    colours = {0: "#eeeeee", 1: "#eeeeee", 2: "#d9ead3", 3: "#d9ead3", 4: "#fce5cd", 5: "#f4cccc", 6: "#fce5cd",
               7: "#cfe2f3", 8: "#d9d2e9", 9: "#d9d2e9", 10: "#fff2cc"}
    for layer, (x, y) in position.items():
        ax.add_patch(FancyBboxPatch((x - box_w / 2, y - box_h / 2), box_w, box_h, boxstyle="round,pad=0.02",
                                    facecolor=colours.get(ranks[layer], "#ffffff"), edgecolor="#333333", lw=0.8))
        ax.text(x, y + 0.04, _label(layer), ha="center", va="center", fontsize=9, fontweight="bold")
        ax.text(x, y - 0.14, f"{sizes.get(layer, 0)} files", ha="center", va="center", fontsize=7, color="#555555")
    half = 1.25 * width + 0.6
    for rank in rows:
        ax.text(-half, rank, f"rank {rank}", ha="left", va="center", fontsize=8, color="#777777")
    ax.set_xlim(-half - 0.1, half)
    ax.set_ylim(-0.6, max(rows) + 0.6)
    ax.axis("off")
    ax.set_title("pcmm_geo: layers and imports (arrow A -> B: A imports B; label: number of importing modules)\n"
                 "every layer also imports errors (not drawn); no arrow points up or sideways", fontsize=10)
    for (source, target), count in sorted(drawn.items()):
        (x0, y0), (x1, y1) = position[source], position[target]
        ax.text(x0 + 0.3 * (x1 - x0), y0 - box_h / 2 - 0.3 * (y0 - y1 - box_h), str(count), fontsize=6,
                color="#4a6fa5", ha="center", va="center",
                bbox={"boxstyle": "round,pad=0.1", "facecolor": "white", "edgecolor": "none", "alpha": 0.8})
    fig.tight_layout()
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=110)
    plt.close(fig)
    return output


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=REPO / "docs" / "architecture.png")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing picture")
    args = parser.parse_args(argv)
    if args.output.exists() and not args.overwrite:
        print(f"{args.output}: already exists; use --overwrite to replace it", file=sys.stderr)
        return 2
    print(draw(args.output))
    ranks, edges, _ = layer_graph()
    for (source, target), count in sorted(edges.items(), key=lambda item: (-ranks[item[0][0]], item[0])):
        print(f"  {_label(source):>22} -> {_label(target):<22} {count}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
