"""The PNG plots of the ``tt-drake reproduce`` report.

* :func:`plot_learning_curve`: success (or return / target rate) in percent against rollouts or
  policy-iteration steps, with the paper's figures as dashed reference lines.
* :func:`plot_gamma_histogram`: the responsibilities gamma of the primitives before and after
  responsibility learning, on log-spaced bins, with the pruning threshold.
* :func:`plot_landing_points`: top view of the table with where the returned balls landed and the
  landing target in the opponent's court.
* :func:`plot_before_after`: figures before and after learning on the same serves, side by
  side (the hard profile's ``gamma1`` and ``final``).
* :func:`plot_prediction_errors`: predicted-minus-true hitting point, velocity and time on
  held-out serves, one histogram per output with its RMSE.

Each ``*_figure`` function validates its inputs (``ValueError`` on empty data or mismatched
shapes) and returns a :class:`matplotlib.figure.Figure` drawn on an Agg canvas (no pyplot state);
each ``plot_*`` function builds that figure, renders it to PNG in memory and only then replaces
``path`` atomically, so a bad input never leaves a file behind. Images are exactly
``figsize * DPI`` pixels (no tight bounding box).
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Rectangle

from tt_drake.constants import NET, TABLE
from tt_drake.outputs import atomic_file, check_writable

DPI = 100
CURVE_FIGSIZE = (7.0, 4.5)  # inches: learning curve and gamma histogram (700 x 450 px)
TABLE_FIGSIZE = (5.0, 7.0)  # landing points (500 x 700 px)
ERRORS_FIGSIZE = (10.0, 6.0)  # prediction errors (1000 x 600 px)
TABLE_MARGIN = 0.3  # m of floor shown around the table in the landing-point plot
GAMMA_MIN = 1e-3  # lower edge of the gamma histogram; smaller gammas go into the first bin
GAMMA_BINS = 30
ERRORS_COLUMNS = 3  # histograms per row in the prediction-error plot


def pixel_size(figsize: tuple[float, float]) -> tuple[int, int]:
    """(width, height) in pixels of a PNG written with ``figsize`` inches."""
    return round(figsize[0] * DPI), round(figsize[1] * DPI)


def table_extent(margin: float = TABLE_MARGIN) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) of the landing-point view: the table plus ``margin`` metres."""
    half_w, half_l = 0.5 * TABLE.width, 0.5 * TABLE.length
    return -half_w - margin, half_w + margin, -half_l - margin, half_l + margin


def gamma_bin_edges() -> np.ndarray:
    """Log-spaced bin edges of the gamma histogram, from ``GAMMA_MIN`` to 1."""
    return np.logspace(math.log10(GAMMA_MIN), 0.0, GAMMA_BINS + 1)


# ---------------------------------------------------------------------------- validation
def _vector(values, what: str) -> np.ndarray:
    """A non-empty, finite, one-dimensional float array."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 1:
        raise ValueError(f"{what} must be one-dimensional, got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{what} is empty")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} contains non-finite values")
    return arr


def _fractions(values, what: str) -> np.ndarray:
    arr = _vector(values, what)
    if arr.min() < 0.0 or arr.max() > 1.0:
        raise ValueError(
            f"{what} must be fractions in [0, 1], got [{arr.min():g}, {arr.max():g}]"
        )
    return arr


def _new_figure(figsize: tuple[float, float]) -> Figure:
    fig = Figure(figsize=figsize, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


# ---------------------------------------------------------------------------- writing
def _write_png(path: str | os.PathLike, fig: Figure) -> Path:
    """Render ``fig`` to PNG and replace ``path`` with it atomically."""
    path = check_writable(path)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    with atomic_file(path, binary=True) as f:
        f.write(buf.getvalue())
    return path


# ---------------------------------------------------------------------------- learning curve
def learning_curve_figure(
    series: Sequence[Mapping],
    *,
    xlabel: str,
    ylabel: str,
    title: str,
    paper: Mapping[str, float] | None = None,
) -> Figure:
    """Curves ``{"label", "x", "y"}`` (y fractions, drawn in percent); ``paper`` label -> fraction
    as dashed reference lines (in the colour of the series of the same label, if any)."""
    if len(series) == 0:
        raise ValueError("no series to plot")
    curves = []
    for i, s in enumerate(series):
        missing = {"label", "x", "y"} - set(s)
        if missing:
            raise ValueError(f"series {i} lacks {sorted(missing)}")
        x = _vector(s["x"], f"x of series {s['label']!r}")
        y = _fractions(s["y"], f"y of series {s['label']!r}")
        if x.shape != y.shape:
            raise ValueError(
                f"series {s['label']!r}: x has {x.size} values but y has {y.size}"
            )
        curves.append((str(s["label"]), x, y))
    references = {}
    for label, value in (paper or {}).items():
        v = float(value)
        if not 0.0 <= v <= 1.0:
            raise ValueError(f"paper value for {label!r} must be a fraction in [0, 1], got {v}")
        references[str(label)] = v

    fig = _new_figure(CURVE_FIGSIZE)
    ax = fig.add_subplot()
    colours = {}
    for label, x, y in curves:
        (line,) = ax.plot(x, 100.0 * y, marker="o", markersize=3, label=label)
        colours[label] = line.get_color()
    for label, v in references.items():
        ax.axhline(
            100.0 * v, linestyle="--", linewidth=1.2, color=colours.get(label, "0.4"),
            label=f"paper: {label} {100.0 * v:.0f} %",
        )
    ax.set_ylim(0.0, 105.0)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    return fig


def plot_learning_curve(
    path: str | os.PathLike,
    series: Sequence[Mapping],
    *,
    xlabel: str,
    ylabel: str,
    title: str,
    paper: Mapping[str, float] | None = None,
) -> Path:
    """Write :func:`learning_curve_figure` to ``path`` (PNG); returns the path."""
    fig = learning_curve_figure(series, xlabel=xlabel, ylabel=ylabel, title=title, paper=paper)
    return _write_png(path, fig)


# ---------------------------------------------------------------------------- responsibilities
def gamma_histogram_figure(before, after, *, threshold: float) -> Figure:
    """Histograms of the responsibilities gamma of the same n primitives before and after
    learning. ``after`` must keep the final gamma of pruned primitives too (learn with
    ``prune=False``); "pruned: k of n" counts ``after < threshold``. ``threshold = 0`` (no
    pruning) draws no threshold line."""
    g0 = _fractions(before, "gamma before learning")
    g1 = _fractions(after, "gamma after learning")
    if g0.shape != g1.shape:
        raise ValueError(
            f"gamma before ({g0.size}) and after ({g1.size}) learning must cover the same "
            "primitives"
        )
    threshold = float(threshold)
    if not 0.0 <= threshold <= 1.0:
        raise ValueError(f"pruning threshold must lie in [0, 1], got {threshold}")
    n = g0.size
    pruned = int(np.count_nonzero(g1 < threshold))

    edges = gamma_bin_edges()
    fig = _new_figure(CURVE_FIGSIZE)
    ax = fig.add_subplot()
    for g, label, colour in ((g0, "before learning", "C0"), (g1, "after learning", "C1")):
        ax.hist(
            np.clip(g, GAMMA_MIN, 1.0), bins=edges, color=colour, alpha=0.55,
            edgecolor=colour, label=f"{label} (n = {n})",
        )
    line_label = f"pruning threshold {threshold:g}; pruned: {pruned} of {n}"
    if threshold >= GAMMA_MIN:
        ax.axvline(threshold, color="k", linestyle="--", linewidth=1.2, label=line_label)
    else:
        ax.plot([], [], " ", label=line_label)  # legend entry only: no line on a log axis
    ax.set_xscale("log")
    ax.set_xlim(GAMMA_MIN, 1.0)
    ax.set_xlabel(f"responsibility γ (values below {GAMMA_MIN:g} in the first bin)")
    ax.set_ylabel("primitives")
    ax.set_title("Responsibilities γ of the motor primitives")
    ax.legend(loc="upper left", fontsize="small")
    return fig


def plot_gamma_histogram(path: str | os.PathLike, before, after, *, threshold: float) -> Path:
    """Write :func:`gamma_histogram_figure` to ``path`` (PNG); returns the path."""
    return _write_png(path, gamma_histogram_figure(before, after, threshold=threshold))


# ---------------------------------------------------------------------------- landing points
def landing_points_figure(
    points: Mapping[str, np.ndarray], *, target: Sequence[float], target_radius: float
) -> Figure:
    """Top view of the table (robot's end at the bottom, y < 0; opponent's court y > 0) with the
    landing points ``label -> (N, 2)`` array of (x, y) in metres and the target circle around
    ``target`` = (x, y) (a third coordinate, z, is ignored)."""
    if len(points) == 0:
        raise ValueError("no landing points to plot")
    groups = []
    for label, p in points.items():
        arr = np.asarray(p, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise ValueError(f"landing points {label!r} must have shape (N, 2), got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"landing points {label!r} contain non-finite values")
        groups.append((str(label), arr))
    centre = np.asarray(target, dtype=float).ravel()
    if centre.size not in (2, 3) or not np.all(np.isfinite(centre)):
        raise ValueError(f"target must be finite (x, y) or (x, y, z), got {target!r}")
    target_radius = float(target_radius)
    if not target_radius > 0.0:
        raise ValueError(f"target radius must be positive, got {target_radius}")

    xmin, xmax, ymin, ymax = table_extent()
    half_w, half_l = 0.5 * TABLE.width, 0.5 * TABLE.length
    fig = _new_figure(TABLE_FIGSIZE)
    ax = fig.add_subplot()
    ax.add_patch(Rectangle((-half_w, -half_l), TABLE.width, TABLE.length,
                           facecolor="#1f4e79", edgecolor="white", linewidth=2.0, zorder=0))
    ax.plot([0.0, 0.0], [-half_l, half_l], color="white", linewidth=0.8, zorder=1)
    ax.plot([-NET.half_span, NET.half_span], [0.0, 0.0], color="black", linewidth=3.0,
            zorder=2, label="net")
    ax.add_patch(Circle((centre[0], centre[1]), target_radius, fill=False, edgecolor="gold",
                        linewidth=2.0, zorder=3, label=f"target (r = {target_radius:g} m)"))
    for i, (label, p) in enumerate(groups):
        ax.scatter(p[:, 0], p[:, 1], s=9, alpha=0.6, color=f"C{(i + 1) % 10}", zorder=4,
                   label=f"{label} (n = {p.shape[0]})")
    ax.text(0.0, -half_l - 0.5 * TABLE_MARGIN, "robot", ha="center", va="center")
    ax.text(0.0, half_l + 0.5 * TABLE_MARGIN, "opponent", ha="center", va="center")
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal", adjustable="box")  # keeps the limits, shrinks the axes box
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("Landing points of the returned balls")
    ax.legend(loc="upper right", fontsize="x-small", framealpha=0.8)
    return fig


def plot_landing_points(
    path: str | os.PathLike,
    points: Mapping[str, np.ndarray],
    *,
    target: Sequence[float],
    target_radius: float,
) -> Path:
    """Write :func:`landing_points_figure` to ``path`` (PNG); returns the path."""
    return _write_png(path, landing_points_figure(points, target=target,
                                                  target_radius=target_radius))


# ---------------------------------------------------------------------------- before / after
def before_after_figure(groups: Mapping[str, Mapping[str, Sequence[float]]], *,
                        labels: Sequence[str] = ("before", "after")) -> Figure:
    """One panel per group (an evaluation serve set): for each axis ``name -> (before, after)``
    two horizontal bars side by side with their values (rates and rewards as fractions; a figure
    relative to a ceiling may exceed 1)."""
    if len(groups) == 0:
        raise ValueError("no serve set to plot")
    panels = []
    for title, axes in groups.items():
        if len(axes) == 0:
            raise ValueError(f"serve set {title!r} has no figure to plot")
        names = [str(n) for n in axes]
        values = np.array([_vector(v, f"{title!r}: {n!r}") for n, v in axes.items()])
        if values.shape[1] != 2 or values.min() < 0.0:
            raise ValueError(f"serve set {title!r}: each figure must be (before, after) >= 0")
        panels.append((str(title), names, values))
    fig = _new_figure((CURVE_FIGSIZE[0] * 1.3, 0.5 + 0.55 * sum(len(n) for _, n, _ in panels)))
    top = max(1.0, max(v.max() for _, _, v in panels)) * 1.15
    for k, (title, names, values) in enumerate(panels):
        ax = fig.add_subplot(len(panels), 1, k + 1)
        y = np.arange(len(names))[::-1].astype(float)
        for j, (label, offset) in enumerate(zip(labels, (0.2, -0.2), strict=True)):
            bars = ax.barh(y + offset, values[:, j], height=0.38, color=f"C{j}", label=label)
            ax.bar_label(bars, labels=[f"{v:.3f}" for v in values[:, j]], fontsize="x-small",
                         padding=2)
        ax.set_yticks(y, names, fontsize="small")
        ax.set_xlim(0.0, top)
        ax.set_title(title, fontsize="medium")
        ax.grid(True, axis="x", alpha=0.3)
    handles, names = fig.get_axes()[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="outside upper center", ncols=2, fontsize="small")
    return fig


def plot_before_after(path: str | os.PathLike, groups, *,
                      labels: Sequence[str] = ("before", "after")) -> Path:
    """Write :func:`before_after_figure` to ``path`` (PNG); returns the path."""
    return _write_png(path, before_after_figure(groups, labels=labels))


# ---------------------------------------------------------------------------- predictor errors
def prediction_errors_figure(errors, names: Sequence[str], units: Sequence[str]) -> Figure:
    """One histogram per predicted output of ``errors`` (N, K) = predicted minus true on held-out
    serves, already in ``units``; each titled with its name and RMSE."""
    e = np.asarray(errors, dtype=float)
    if e.ndim != 2:
        raise ValueError(f"errors must have shape (N, K), got {e.shape}")
    n, k = e.shape
    if n == 0 or k == 0:
        raise ValueError(f"errors is empty (shape {e.shape})")
    if len(names) != k or len(units) != k:
        raise ValueError(
            f"errors has {k} outputs but {len(names)} names and {len(units)} units were given"
        )
    if not np.all(np.isfinite(e)):
        raise ValueError("errors contain non-finite values")

    rmse = np.sqrt(np.mean(e**2, axis=0))
    cols = min(ERRORS_COLUMNS, k)
    rows = math.ceil(k / cols)
    fig = _new_figure(ERRORS_FIGSIZE)
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    for j, (name, unit) in enumerate(zip(names, units, strict=True)):
        ax = axes[j]
        ax.hist(e[:, j], bins="auto", color="C0", alpha=0.8)
        ax.axvline(0.0, color="k", linewidth=0.8)
        ax.set_title(f"{name}: RMSE {rmse[j]:.3g} {unit}")
        ax.set_xlabel(f"predicted − true ({unit})")
        ax.set_ylabel("serves")
    for ax in axes[k:]:
        ax.set_visible(False)
    fig.suptitle(f"Hitting-point prediction errors on {n} held-out serves")
    return fig


def plot_prediction_errors(
    path: str | os.PathLike, errors, names: Sequence[str], units: Sequence[str]
) -> Path:
    """Write :func:`prediction_errors_figure` to ``path`` (PNG); returns the path."""
    return _write_png(path, prediction_errors_figure(errors, names, units))
