"""Charts drawn with matplotlib (the ``model`` and ``rl`` extras): the paper's interpolation
figure, the benchmark's bar chart and a baseline's learning curve.

matplotlib is imported inside the functions, so the harness runs without it; files are written
atomically.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.core.atomic import atomic_path


def _pyplot() -> Any:
    """``matplotlib.pyplot`` on the file-only Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: str | os.PathLike, dpi: int) -> Path:
    """Write ``fig`` as a PNG atomically and close it."""
    plt = _pyplot()
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png", dpi=dpi)
    finally:
        plt.close(fig)
    return Path(path)


def save_interpolation_png(
    path: str | os.PathLike,
    interpolation: np.ndarray,
    start: np.ndarray,
    goal: np.ndarray,
    planned: np.ndarray | None = None,
    real: np.ndarray | None = None,
    title: str = "",
) -> Path:
    """The paper's Fig. 2: decoded shapes along the latent line from start to goal.

    With ``planned`` and ``real`` a second panel compares a plan's shapes with what the
    simulator did under the same end motion (where they part ways).

    Args:
        path: The PNG to write.
        interpolation: ``(T, n, 2)`` decoded shapes of the latent line.
        start: ``(n, 2)`` the real start shape.
        goal: ``(n, 2)`` the real goal shape.
        planned: ``(K, n, 2)`` a plan's shapes (optional).
        real: ``(K, n, 2)`` the simulator's shapes at the same end positions (optional).
        title: Figure title.

    Returns:
        The path written.
    """
    plt = _pyplot()

    path = Path(path)
    panels = 2 if planned is not None and real is not None else 1
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 5.0), squeeze=False)
    colours = plt.cm.viridis(np.linspace(0.0, 1.0, len(interpolation)))
    ax = axes[0, 0]
    for shape, colour in zip(interpolation, colours):
        ax.plot(shape[:, 0], shape[:, 1], "-", color=colour, lw=1.5)
        ax.plot(shape[0, 0], shape[0, 1], "o", color=colour, ms=3)
    ax.plot(start[:, 0], start[:, 1], "k--", lw=1, label="start (real)")
    ax.plot(goal[:, 0], goal[:, 1], "k:", lw=1.5, label="goal (real)")
    ax.set_title("latent interpolation, start (purple) to goal (yellow)", fontsize=9)
    ax.legend(fontsize=8, loc="best")
    if panels == 2:
        ax = axes[0, 1]
        idx = np.unique(np.linspace(0, len(planned) - 1, min(len(planned), 8)).round().astype(int))
        colours = plt.cm.plasma(np.linspace(0.0, 0.85, len(idx)))
        for i, colour in zip(idx, colours):
            ax.plot(planned[i, :, 0], planned[i, :, 1], "-", color=colour, lw=1.5)
            ax.plot(real[i, :, 0], real[i, :, 1], "--", color=colour, lw=1.0)
        ax.plot([], [], "k-", label="planned (surrogate)")
        ax.plot([], [], "k--", label="real (simulator)")
        ax.set_title("latent-tree plan vs the real cord at the same head positions", fontsize=9)
        ax.legend(fontsize=8, loc="best")
    for ax in axes[0]:
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return _save(fig, path, dpi=110)


def _bar_style(i: int) -> dict[str, Any]:
    """The ``i``-th agent's bars: the ten colours of matplotlib's cycle, hatched from the
    eleventh agent on, so that no two agents look alike."""
    style: dict[str, Any] = {"color": f"C{i % 10}"}
    if i >= 10:
        style.update(hatch="//" if i < 20 else "..", edgecolor="white", linewidth=0)
    return style


def plot_results(rows: list[dict[str, Any]], png: str | os.PathLike) -> None:
    """Bar charts of success rate, median error at rest and seconds per episode (missing rows
    skipped), at the headline threshold when the rows have several."""
    plt = _pyplot()

    from dlo_bench.report import cell_label, headline_first, threshold_label, thresholds_of

    threshold = headline_first(thresholds_of(rows))[0] if rows else None
    rows = [r for r in rows if r.get("threshold") == threshold]
    agents = list(dict.fromkeys(r["agent"] for r in rows))
    cells = list(dict.fromkeys(cell_label(r) for r in rows))
    by = {(r["agent"], cell_label(r)): r for r in rows}
    panels = (("success_rate", "success rate", 1.0, False),
              ("median_rest_error", "median error at rest (cm)", 100.0, False),
              ("seconds_per_episode", "seconds per episode", 1.0, True))
    fig, axes = plt.subplots(3, 1, figsize=(max(8.0, 1.3 * len(cells)), 9.5))
    width = 0.8 / max(1, len(agents))
    x = np.arange(len(cells))
    for ax, (key, label, scale, log) in zip(axes, panels):
        for i, agent in enumerate(agents):
            values = []
            for cell in cells:
                v = by.get((agent, cell), {}).get(key)
                values.append(np.nan if v is None else v * scale)
            ax.bar(x + (i - (len(agents) - 1) / 2) * width, values, width, label=agent,
                   **_bar_style(i))
        ax.set_xticks(x, [c.replace(" ", "\n", 1) for c in cells], fontsize=8)  # env, cell
        ax.set_ylabel(label)
        if log:
            ax.set_yscale("log")
        if key == "success_rate":
            ax.set_ylim(0, 1)
        if key == "median_rest_error" and threshold is not None:
            ax.axhline(100 * threshold, color="k", lw=0.8, ls="--")  # the success threshold
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(agents), 5), fontsize=8,
               frameon=False)
    title = "dlo benchmark (test suites)"
    if threshold is not None:
        title += f", success within {threshold_label(threshold)} at rest"
    if any(r["status"] != "ok" for r in rows):
        title += ": a missing cell has no bar (results.md says why)"
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    _save(fig, png, dpi=100)


def plot_shapes(panels: list[tuple[str, dict[str, tuple[Any, ...]]]],
                png: str | os.PathLike, *,
                title: str = "designed goals (green) and the cord at rest after the last step\n"
                             "(blue, head red); direction-free error") -> None:
    """Goals and the shapes agents left the cord in: one row per task, one column per agent;
    each panel shows the goal (green), the cord at rest after the last step (blue, its head a
    red dot), the task's pegs when it has any (grey discs) and the error.

    Args:
        panels: ``(row label, {agent: (goal, rest shape, error in metres[, pegs' centres
            (k, 2), their radius])})`` per task.
        png: Output file.
        title: The figure's title.
    """
    plt = _pyplot()
    agents = list(dict.fromkeys(a for _, entry in panels for a in entry))
    rows, cols = max(1, len(panels)), max(1, len(agents))
    fig, axes = plt.subplots(rows, cols, figsize=(max(1.9 * cols + 0.6, 5.0), 1.9 * rows + 0.9),
                             squeeze=False)
    for i, (label, entry) in enumerate(panels):
        for j, agent in enumerate(agents):
            ax = axes[i, j]
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_aspect("equal", adjustable="datalim")
            if i == 0:
                ax.set_title(agent, fontsize=8)
            if j == 0:
                ax.set_ylabel(label, fontsize=7)
            if agent not in entry:
                continue
            goal, rest, err, *pegs = entry[agent]
            for x, y in (pegs[0] if pegs else []):
                ax.add_patch(plt.Circle((x, y), pegs[1], color="0.55", zorder=0))
            ax.plot(goal[:, 0], goal[:, 1], "-", color="tab:green", lw=4, alpha=0.45)
            ax.plot(rest[:, 0], rest[:, 1], "-", color="tab:blue", lw=1.4)
            ax.plot(rest[0, 0], rest[0, 1], "o", color="tab:red", ms=3)
            ax.text(0.03, 0.03, f"{100 * err:.1f} cm", transform=ax.transAxes, fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.5 / (1.9 * rows + 0.9)))
    _save(fig, png, dpi=90)


def plot_learning_curve(logs: dict[str, Any], png: str | os.PathLike, title: str = "") -> None:
    """Episode return and success rate (moving averages) against environment steps.

    Args:
        logs: Episodes as ``dlo_bench.baselines.read_monitor_logs`` returns them.
        png: Output file.
        title: Prefix of the panels' titles.
    """
    plt = _pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.2))
    if len(logs["reward"]):
        k = max(1, len(logs["reward"]) // 50)
        kernel = np.ones(k) / k
        steps = logs["timesteps"][k - 1:]
        ax1.plot(steps, np.convolve(logs["reward"], kernel, mode="valid"))
        ax2.plot(steps, np.convolve(logs["is_success"], kernel, mode="valid"))
    ax1.set(xlabel="environment steps", ylabel="episode return", title=f"{title} return")
    ax2.set(xlabel="environment steps", ylabel="success rate", ylim=(0, 1),
            title=f"{title} success")
    fig.tight_layout()
    _save(fig, png, dpi=100)


def plot_scaling(sizes: np.ndarray, unseen: dict[str, np.ndarray], own: dict[str, np.ndarray],
                 fits: dict[str, tuple[float, float] | None], floors: dict[str, float],
                 png: str | os.PathLike, title: str = "",
                 reference: tuple[float, dict[str, float], str] | None = None) -> None:
    """Misses (shares of moves off by more than 1 cm) against training transitions, log-log.

    Args:
        sizes: Training transitions of each run.
        unseen: Per group, each run's misses on moves it never saw.
        own: Per group, each run's misses on its own training moves.
        fits: Per group, ``(a, b)`` of the power law ``exp(a) * size ** b`` (None: no fit),
            drawn to 30 times the largest size.
        floors: Per group, the share within 1 cm to reach (drawn as ``1 - floor``).
        png: Output file.
        title: The axes' title.
        reference: ``(size, misses per group, label)`` of another model, drawn as stars.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    grid = np.geomspace(sizes.min(), sizes.max() * 30, 50)
    for i, group in enumerate(unseen):
        color = f"C{i}"
        ax.loglog(sizes, 100 * unseen[group], "o-", color=color, label=f"{group}: unseen moves")
        ax.loglog(sizes, 100 * np.maximum(own[group], 1e-4), "x:", color=color, alpha=0.6,
                  label=f"{group}: its training moves")
        if fits.get(group) is not None:
            a, b = fits[group]
            ax.loglog(grid, 100 * np.exp(a) * grid ** b, "--", color=color, alpha=0.4)
        ax.axhline(100 * (1 - floors[group]), color=color, lw=0.7, ls="-.")
        if reference is not None and group in reference[1]:
            ax.loglog([reference[0]], [100 * reference[1][group]], "*", color=color, ms=11,
                      label=f"{group}: {reference[2]}")
    ax.set(xlabel="training transitions", ylabel="moves off by more than 1 cm (%)")
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, png, dpi=120)
