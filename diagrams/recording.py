"""Meshcat recordings saved as one self-contained HTML file.

Drake's Meshcat runs offline on localhost; ``StaticHtml()`` inlines three.js and the recorded
animation, so the file opens in any browser with no network (facts.md section 4). Episodes are
laid end to end on the recording's timeline; each ball path is drawn as a line and each landing
point after a hit is marked (green: legal return, red: fault).
"""

import numpy as np

from tt_drake.diagrams.episodes import EpisodeResult

RETURN_COLOUR = (0.1, 0.8, 0.2, 1.0)
FAULT_COLOUR = (0.9, 0.1, 0.1, 1.0)
PATH_COLOUR = (1.0, 0.55, 0.1, 0.8)


def make_meshcat():
    """A Meshcat server bound to localhost (the recording is saved with ``StaticHtml``).

    ``DRAKE_ALLOW_NETWORK`` is left alone: restricting it to ``meshcat`` makes every ``Parser``
    fail at construction in pydrake 1.51 (its package map registers the remote ``drake_models``),
    and our models reference no remote package."""
    from pydrake.geometry import Meshcat, MeshcatParams

    meshcat = Meshcat(MeshcatParams(host="localhost"))
    meshcat.SetProperty("/Background", "visible", False)
    # From the robot's forehand side, behind it: the strokes and the ball's flight both show.
    meshcat.SetCameraPose([2.0, -3.6, 1.75], [0.0, -0.8, 0.95])
    return meshcat


ESTIMATE_COLOUR = (0.2, 0.6, 1.0, 0.9)
PREDICTION_COLOUR = (1.0, 0.0, 1.0, 0.8)


def draw_beliefs(meshcat, animation, index: int, beliefs: dict) -> None:
    """What the robot believed: the estimated ball path (blue line) and the predicted hitting
    point (magenta sphere), moved in the recording each time the prediction changed."""
    from pydrake.geometry import Rgba, Sphere
    from pydrake.math import RigidTransform

    path = beliefs.get("estimated_path")
    if path is not None and len(path) > 1:
        meshcat.SetLine(f"/episodes/{index:04d}/estimated_path", np.asarray(path).T, 2.0,
                        Rgba(*ESTIMATE_COLOUR))
    times, points = beliefs.get("prediction_times"), beliefs.get("predictions")
    if times is None or len(times) == 0:
        return
    name = f"/episodes/{index:04d}/predicted_hit"
    meshcat.SetObject(name, Sphere(0.025), Rgba(*PREDICTION_COLOUR))
    previous = None
    for t, p in zip(times, points, strict=True):
        if previous is None or np.linalg.norm(p - previous) > 1e-4:
            animation.SetTransform(animation.frame(t), name, RigidTransform(p))
            previous = p


def draw_episode(meshcat, index: int, result: EpisodeResult) -> None:
    """The ball's path as a line and the landing point as a small sphere."""
    from pydrake.geometry import Rgba, Sphere
    from pydrake.math import RigidTransform

    if result.ball_path is not None and len(result.ball_path) > 1:
        meshcat.SetLine(f"/episodes/{index:04d}/ball_path", np.asarray(result.ball_path).T, 2.0,
                        Rgba(*PATH_COLOUR))
    if result.outcome.landing is not None:
        colour = RETURN_COLOUR if result.outcome.returned else FAULT_COLOUR
        name = f"/episodes/{index:04d}/landing"
        meshcat.SetObject(name, Sphere(0.03), Rgba(*colour))
        x, y = result.outcome.landing
        meshcat.SetTransform(name, RigidTransform([x, y, 0.76]))


def mark_target(meshcat, x: float, y: float, radius: float) -> None:
    from pydrake.geometry import Cylinder, Rgba
    from pydrake.math import RigidTransform

    meshcat.SetObject("/target", Cylinder(radius, 0.002), Rgba(1.0, 1.0, 0.0, 0.35))
    meshcat.SetTransform("/target", RigidTransform([x, y, 0.761]))


PRIMITIVE_COLOUR = (0.55, 0.25, 0.95, 0.9)
FALLBACK_COLOUR = (0.5, 0.5, 0.5, 0.6)


def draw_stroke(meshcat, index: int, stroke: dict | None, library) -> None:
    """Which hitting primitives carried the learned player's stroke: each one's demonstrated
    hitting point x_i (its stimulus' position, on the hitting plane) as a sphere whose volume is
    its mixture weight nu_i (Eq. 6), the five heaviest; grey if the primitives' plan left the
    joint limits and the teacher's quintics moved the arm instead."""
    from pydrake.geometry import Rgba, Sphere
    from pydrake.math import RigidTransform

    if not stroke or library is None or not stroke["primitives"]:
        return
    colour = FALLBACK_COLOUR if stroke["fallback"] else PRIMITIVE_COLOUR
    order = np.argsort(stroke["mixture"])[::-1][:5]
    for rank, k in enumerate(order):
        i, nu = stroke["primitives"][k], stroke["mixture"][k]
        name = f"/episodes/{index:04d}/primitives/{rank}_primitive_{i}"
        meshcat.SetObject(name, Sphere(0.04 * float(nu) ** (1.0 / 3.0)), Rgba(*colour))
        meshcat.SetTransform(name, RigidTransform(library.stimuli[i, :3]))
