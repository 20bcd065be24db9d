"""What the Gymnasium environments show (:mod:`tt_drake.diagrams.gym_envs`): ``rgb_array`` frames
and ``human`` Meshcat pages.

Both are observation only, as the recordings of ``tt-drake serve --html`` (docs/recording.md):
the serve diagram has no renderer or visualizer, and nothing here changes its numbers.

- :class:`FrameRenderer`: a world of its own (the scenario's) with Drake's VTK render engine
  and one colour camera (``RgbdSensor``); :meth:`FrameRenderer.frame` sets the arm's and the
  ball's poses on its plant and renders them offscreen (VTK's EGL/OSMesa back end, no display
  needed): an (H, W, 3) uint8 image, from behind the robot's forehand side, above it (the arm,
  the whole table and the ball's flight in view).
- :class:`EpisodePages`: the episodes played so far as one Meshcat recording
  (:class:`tt_drake.diagrams.recording.Recording`), written as a self-contained HTML page.
"""

from __future__ import annotations

import numpy as np
from pydrake.geometry import (
    ClippingRange,
    ColorRenderCamera,
    DepthRange,
    DepthRenderCamera,
    MakeRenderEngineVtk,
    RenderCameraCore,
    RenderEngineVtkParams,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.sensors import CameraInfo, RgbdSensor

from tt_drake.diagrams.episodes import EpisodeResult, summarize
from tt_drake.diagrams.recording import Recording
from tt_drake.diagrams.station import add_station
from tt_drake.outputs import write_text_atomic

#: Frame size (pixels) and vertical field of view (rad) of ``rgb_array`` frames.
FRAME_WIDTH, FRAME_HEIGHT, FRAME_FOV = 480, 360, np.pi / 3
#: Where the camera looks from and at (m, world frame; the robot hangs at (0, -2.52, 1.71)).
FRAME_EYE, FRAME_TARGET = (2.3, -3.9, 2.3), (-0.1, -1.2, 0.9)


def camera_pose(eye, target):
    """The camera's pose X_WC looking from ``eye`` at ``target`` with the world's z up: Drake's
    camera frame has +z along the view, +x to the right and +y down the image."""
    eye, target = np.asarray(eye, dtype=float), np.asarray(target, dtype=float)
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return RigidTransform(RotationMatrix(np.c_[x, np.cross(z, x), z]), eye)


class FrameRenderer:
    """Offscreen frames of the arm and the ball in the scenario's world (module docstring)."""

    def __init__(self, world_config, width: int = FRAME_WIDTH, height: int = FRAME_HEIGHT):
        builder = DiagramBuilder()
        # The station with only its plant: the world built as every diagram builds it.
        self.world = add_station(builder, None, 1, launcher=False, referee=False,
                                 aerodynamics=False, controllers=False,
                                 world_config=world_config).world
        self.world.scene_graph.AddRenderer("vtk", MakeRenderEngineVtk(RenderEngineVtkParams()))
        core = RenderCameraCore("vtk", CameraInfo(width, height, FRAME_FOV),
                                ClippingRange(0.05, 20.0), RigidTransform())
        self.sensor = builder.AddSystem(RgbdSensor(
            self.world.scene_graph.world_frame_id(), camera_pose(FRAME_EYE, FRAME_TARGET),
            ColorRenderCamera(core, False), DepthRenderCamera(core, DepthRange(0.06, 19.0))))
        builder.Connect(self.world.scene_graph.get_query_output_port(),
                        self.sensor.query_object_input_port())
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = self.world.plant.GetMyMutableContextFromRoot(self.context)
        self.sensor_context = self.sensor.GetMyContextFromRoot(self.context)

    def frame(self, arm_q, ball_q) -> np.ndarray:
        """The image (H, W, 3, uint8) with the arm at joint angles ``arm_q`` (7) and the ball at
        ``ball_q`` (7: quaternion w, x, y, z, then position)."""
        plant = self.world.plant
        plant.SetPositions(self.plant_context, self.world.robot, np.asarray(arm_q, dtype=float))
        plant.SetPositions(self.plant_context, self.world.ball, np.asarray(ball_q, dtype=float))
        image = self.sensor.color_image_output_port().Eval(self.sensor_context)
        return np.array(image.data[:, :, :3], dtype=np.uint8)


class EpisodePages:
    """The episodes an environment played, as one Meshcat recording written to ``path``."""

    def __init__(self, scenario, path: str, label: str):
        self.scenario, self.path, self.label = scenario, path, label
        self.episodes: list[tuple[EpisodeResult, tuple]] = []

    def add(self, result: EpisodeResult, poses: tuple) -> None:
        self.episodes.append((result, poses))

    def write(self) -> None:
        """Write the page of every episode so far (a new recording each time, so that it can be
        written again with more episodes)."""
        recording = Recording(self.scenario)
        for i, (result, poses) in enumerate(self.episodes):
            recording.add(i, result, poses)
        results = [result for result, _ in self.episodes]
        data = {"player": self.label, "distribution": self.scenario.launcher.distribution,
                "seed": results[0].seed if results else 0, "summary": summarize(results),
                "episodes": [r.as_dict() for r in results]}
        write_text_atomic(self.path, recording.html(data))
