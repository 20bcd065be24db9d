"""The report's PNG plots: real PNGs of the documented pixel size, written atomically, inputs
validated before anything is written, and the landing-point view covering the whole table."""

import matplotlib.image
import numpy as np
import pytest

from tt_drake.constants import TABLE, TARGET
from tt_drake.diagrams import report_plots as rp

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
NAMES = ["p_x", "p_z", "v_x", "v_y", "v_z", "t_hit"]
UNITS = ["mm", "mm", "mm/s", "mm/s", "mm/s", "ms"]


def assert_png(path, figsize):
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    height, width = matplotlib.image.imread(path).shape[:2]
    assert (width, height) == rp.pixel_size(figsize)


def curve(label="momp", n=5):
    return {"label": label, "x": np.arange(n), "y": np.linspace(0.2, 0.7, n)}


def test_learning_curve_png(tmp_path):
    out = tmp_path / "curve.png"
    written = rp.plot_learning_curve(
        out, [curve("momp"), curve("crkr", 8)], xlabel="rollouts", ylabel="success (%)",
        title="Responsibility learning", paper={"momp": 0.69},
    )
    assert written == out
    assert_png(out, rp.CURVE_FIGSIZE)
    assert list(tmp_path.iterdir()) == [out]  # no temporary file left


def test_learning_curve_draws_percent_and_paper_lines():
    fig = rp.learning_curve_figure(
        [curve("momp")], xlabel="x", ylabel="y", title="t", paper={"momp": 0.69, "crkr": 0.5}
    )
    ax = fig.axes[0]
    assert np.allclose(ax.lines[0].get_ydata(), 100.0 * curve()["y"])
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "paper: momp 69 %" in texts and "paper: crkr 50 %" in texts
    # the reference line of a series shares its colour
    assert ax.lines[1].get_color() == ax.lines[0].get_color()
    assert ax.lines[1].get_linestyle() == "--"


@pytest.mark.parametrize(
    "series, paper",
    [
        ([{"label": "a", "x": [0, 1, 2], "y": [0.1, 0.2]}], None),  # x, y lengths differ
        ([], None),  # nothing to plot
        ([{"label": "a", "x": [], "y": []}], None),  # empty series
        ([{"label": "a", "x": [0, 1], "y": [10.0, 20.0]}], None),  # percent, not fractions
        ([{"label": "a", "y": [0.1]}], None),  # no x
        ([curve()], {"momp": 69.0}),  # paper value in percent
    ],
)
def test_learning_curve_rejects_bad_input(tmp_path, series, paper):
    with pytest.raises(ValueError):
        rp.plot_learning_curve(tmp_path / "c.png", series, xlabel="x", ylabel="y", title="t",
                               paper=paper)
    assert list(tmp_path.iterdir()) == []


def test_gamma_histogram_png_and_counts(tmp_path):
    before = np.ones(5)
    after = np.array([0.0, 1e-5, 0.05, 0.5, 0.9])
    out = rp.plot_gamma_histogram(tmp_path / "gamma.png", before, after, threshold=0.1)
    assert_png(out, rp.CURVE_FIGSIZE)

    fig = rp.gamma_histogram_figure(before, after, threshold=0.1)
    ax = fig.axes[0]
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("pruned: 3 of 5" in t for t in texts)
    assert "before learning (n = 5)" in texts
    heights_after = [p.get_height() for p in ax.containers[1]]
    assert heights_after[0] == 2  # 0 and 1e-5 are clipped into the first bin
    assert sum(heights_after) == 5 and sum(p.get_height() for p in ax.containers[0]) == 5
    edges = rp.gamma_bin_edges()
    assert edges[0] == pytest.approx(rp.GAMMA_MIN) and edges[-1] == pytest.approx(1.0)
    assert np.allclose(np.diff(np.log(edges)), np.log(edges[1] / edges[0]))  # log-spaced
    assert ax.get_xlim() == pytest.approx((rp.GAMMA_MIN, 1.0))


@pytest.mark.parametrize(
    "before, after, threshold",
    [
        ([1.0, 1.0], [0.5], 0.1),  # not the same primitives
        ([], [], 0.1),
        ([1.0, 1.5], [0.5, 0.5], 0.1),  # gamma above 1
        ([1.0, np.nan], [0.5, 0.5], 0.1),
        ([1.0], [0.5], 2.0),  # threshold outside [0, 1]
    ],
)
def test_gamma_histogram_rejects_bad_input(tmp_path, before, after, threshold):
    with pytest.raises(ValueError):
        rp.plot_gamma_histogram(tmp_path / "g.png", before, after, threshold=threshold)
    assert list(tmp_path.iterdir()) == []


def test_table_extent_is_the_table_plus_margin():
    xmin, xmax, ymin, ymax = rp.table_extent()
    m = rp.TABLE_MARGIN
    assert m == pytest.approx(0.3)
    assert (xmin, xmax) == pytest.approx((-0.5 * TABLE.width - m, 0.5 * TABLE.width + m))
    assert (ymin, ymax) == pytest.approx((-0.5 * TABLE.length - m, 0.5 * TABLE.length + m))
    assert ymin <= TABLE.robot_edge_y - m and ymax >= TABLE.opponent_edge_y + m


def test_landing_points_png_and_view(tmp_path):
    rng = np.random.default_rng(0)
    points = {
        "momp": rng.normal([TARGET.x, TARGET.y], 0.2, size=(50, 2)),
        "missed": np.empty((0, 2)),
    }
    out = rp.plot_landing_points(tmp_path / "landing.png", points, target=(TARGET.x, TARGET.y),
                                 target_radius=0.2)
    assert_png(out, rp.TABLE_FIGSIZE)

    fig = rp.landing_points_figure(points, target=(TARGET.x, TARGET.y, TARGET.z),
                                   target_radius=0.2)
    ax = fig.axes[0]
    xmin, xmax, ymin, ymax = rp.table_extent()
    assert ax.get_xlim() == pytest.approx((xmin, xmax))
    assert ax.get_ylim() == pytest.approx((ymin, ymax))
    assert ax.get_aspect() == 1.0
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "momp (n = 50)" in texts and "missed (n = 0)" in texts


@pytest.mark.parametrize(
    "points, target, radius",
    [
        ({"a": np.zeros((4, 3))}, (0.0, 0.7), 0.2),  # not (N, 2)
        ({"a": np.zeros(4)}, (0.0, 0.7), 0.2),
        ({}, (0.0, 0.7), 0.2),
        ({"a": [[0.0, np.inf]]}, (0.0, 0.7), 0.2),
        ({"a": np.zeros((4, 2))}, (0.0,), 0.2),  # bad target
        ({"a": np.zeros((4, 2))}, (0.0, 0.7), 0.0),  # bad radius
    ],
)
def test_landing_points_reject_bad_input(tmp_path, points, target, radius):
    with pytest.raises(ValueError):
        rp.plot_landing_points(tmp_path / "l.png", points, target=target, target_radius=radius)
    assert list(tmp_path.iterdir()) == []


def test_prediction_errors_png_and_rmse(tmp_path):
    errors = np.tile([3.0, -4.0, 10.0, 20.0, 30.0, 1.5], (40, 1))
    errors[::2, 1] = 4.0  # RMSE 4 with zero mean
    out = rp.plot_prediction_errors(tmp_path / "errors.png", errors, NAMES, UNITS)
    assert_png(out, rp.ERRORS_FIGSIZE)

    fig = rp.prediction_errors_figure(errors, NAMES, UNITS)
    titles = [ax.get_title() for ax in fig.axes if ax.get_visible()]
    assert titles == [
        "p_x: RMSE 3 mm", "p_z: RMSE 4 mm", "v_x: RMSE 10 mm/s", "v_y: RMSE 20 mm/s",
        "v_z: RMSE 30 mm/s", "t_hit: RMSE 1.5 ms",
    ]


def test_prediction_errors_hide_unused_panels():
    fig = rp.prediction_errors_figure(np.ones((3, 4)), NAMES[:4], UNITS[:4])
    assert sum(ax.get_visible() for ax in fig.axes) == 4


@pytest.mark.parametrize(
    "errors, names, units",
    [
        (np.zeros((10, 6)), NAMES[:5], UNITS),  # too few names
        (np.zeros((10, 6)), NAMES, UNITS[:5]),  # too few units
        (np.zeros((10, 5)), NAMES, UNITS),
        (np.zeros(6), NAMES, UNITS),  # not (N, K)
        (np.zeros((0, 6)), NAMES, UNITS),  # no serves
        (np.full((2, 6), np.nan), NAMES, UNITS),
    ],
)
def test_prediction_errors_reject_bad_input(tmp_path, errors, names, units):
    with pytest.raises(ValueError):
        rp.plot_prediction_errors(tmp_path / "e.png", errors, names, units)
    assert list(tmp_path.iterdir()) == []


def test_bad_input_keeps_the_previous_file(tmp_path):
    out = tmp_path / "curve.png"
    out.write_bytes(b"previous")
    with pytest.raises(ValueError):
        rp.plot_learning_curve(out, [{"label": "a", "x": [0, 1], "y": [0.5]}], xlabel="x",
                               ylabel="y", title="t")
    assert out.read_bytes() == b"previous"
    assert list(tmp_path.iterdir()) == [out]


def test_png_replaces_an_existing_file(tmp_path):
    out = tmp_path / "curve.png"
    out.write_bytes(b"previous")
    rp.plot_learning_curve(out, [curve()], xlabel="x", ylabel="y", title="t")
    assert_png(out, rp.CURVE_FIGSIZE)
    assert list(tmp_path.iterdir()) == [out]
