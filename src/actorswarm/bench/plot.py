"""Pictures of the collective-core benchmark: the figures of docs/design.md §8 against swarm size.

Three panels, log-scaled swarm size on the x axis: barrier latency (no loss and with loss)
with the 35 ms target and the paper's measured switch times; time to a new master after a
crash, with its target; and the barrier packets the master handles, with the linear
reference 3·N. Each point is the median over the repetitions; bars span min to max.
"""

from __future__ import annotations

import math
import statistics
from pathlib import Path

from actorswarm.bench.core import SizeResult
from actorswarm.bench.paper import TABLE2


def _series(values: list[list[float]]) -> tuple[list[float], list[float], list[float]]:
    med, lo, hi = [], [], []
    for vs in values:
        clean = [v for v in vs if not math.isnan(v)] or [float("nan")]
        m = statistics.median(clean)
        med.append(m)
        lo.append(m - min(clean))
        hi.append(max(clean) - m)
    return med, lo, hi


def plot_core(
    results: list[SizeResult], out: Path, *, latency: float, loss: float, t_leave: float
) -> None:
    """Draw the benchmark as a PNG at ``out`` (needs matplotlib)."""
    import matplotlib

    matplotlib.use("Agg")  # no display: files only
    import matplotlib.pyplot as plt

    sizes = [r.size for r in results]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5), constrained_layout=True)
    ax = axes[0]
    for label, runs, marker in (
        ("no loss", [[b.latency * 1000 for b in r.barrier] for r in results], "o"),
        (f"{loss:.0%} loss", [[b.latency * 1000 for b in r.barrier_lossy] for r in results], "s"),
    ):
        med, lo, hi = _series(runs)
        ax.errorbar(sizes, med, yerr=[lo, hi], marker=marker, capsize=3, label=label)
    ax.axhline((3 * latency + 0.005) * 1000, color="grey", ls="--", label="target")
    # The paper's collective Actor switch times (Table II a, one plugin), for comparison.
    paper = sorted(
        (n, p.transition_ms) for (case, n, k), p in TABLE2.items() if case == "switch" and k == 1
    )
    ax.plot([n for n, _ in paper], [ms for _, ms in paper], "k^:", label="paper (Table II a)")
    ax.set(
        xscale="log",
        yscale="log",
        xlabel="platforms",
        ylabel="ms",
        title="barrier: last request → last release",
    )
    ax.legend()
    ax = axes[1]
    for label, runs, marker in (
        ("a survivor claims", [[f.to_claim * 1000 for f in r.failover] for r in results], "o"),
        (
            "all acknowledged",
            [[f.to_acknowledged * 1000 for f in r.failover] for r in results],
            "s",
        ),
    ):
        med, lo, hi = _series(runs)
        ax.errorbar(sizes, med, yerr=[lo, hi], marker=marker, capsize=3, label=label)
    ax.axhline((t_leave + 0.1) * 1000, color="grey", ls="--", label="target")
    ax.set(xscale="log", xlabel="platforms", ylabel="ms", title="master crash → new master")
    ax.set_ylim(bottom=0)
    ax.legend()
    ax = axes[2]
    med, lo, hi = _series([[float(b.master_barrier_packets) for b in r.barrier] for r in results])
    ax.errorbar(sizes, med, yerr=[lo, hi], marker="o", capsize=3, label="measured")
    ax.plot(sizes, [3 * n for n in sizes], color="grey", ls="--", label="3·N")
    ax.set(
        xscale="log",
        yscale="log",
        xlabel="platforms",
        ylabel="packets",
        title="barrier packets at the master",
    )
    ax.legend()
    fig.suptitle(
        f"actorswarm collective core, virtual time, one-way latency {latency * 1000:.0f} ms"
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
