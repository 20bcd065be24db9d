"""BallCamera, BallFlightEstimator and HittingPointPredictor through their ports, a Drake
diagram that matches the offline pipeline, and the ball model vs Drake at the hitting plane."""

import math

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from tt_drake.camera_model import CameraConfig
from tt_drake.constants import PLANES
from tt_drake.diagrams.predictor import (
    BallOnlySimulation,
    camera_seed,
    generate_samples,
    model_vs_drake,
    run_pipeline,
)
from tt_drake.diagrams.python_calls import count_drake_calls
from tt_drake.estimation import BallFlightEKF, EstimatorConfig
from tt_drake.hitting_point import PhysicalPredictor
from tt_drake.hitting_time import HittingBand
from tt_drake.systems.ball_camera import BallCamera
from tt_drake.systems.ball_flight_estimator import BallFlightEstimator
from tt_drake.systems.hitting_point_predictor import HittingPointPredictor

PERIOD = 1.0 / 60


def ball_state(p, v=(0.0, 0.0, 0.0)):
    return np.r_[1.0, 0.0, 0.0, 0.0, p, 0.0, 0.0, 0.0, v]


def step(system, context, t):
    """One periodic discrete update at time t, applied to the context."""
    context.SetTime(t)
    xd = system.EvalUniquePeriodicDiscreteUpdate(context)
    context.get_mutable_discrete_state().SetFrom(xd)


def test_camera_without_noise_reports_the_true_position():
    cam = BallCamera(CameraConfig(sigma=0.0, latency=0.0))
    ctx = cam.CreateDefaultContext()
    cam.GetInputPort("ball_state").FixValue(ctx, ball_state([0.1, 0.2, 0.9]))
    assert math.isnan(cam.GetOutputPort("measurement").Eval(ctx)[3])
    step(cam, ctx, 0.0)
    assert cam.GetOutputPort("measurement").Eval(ctx) == pytest.approx([0.1, 0.2, 0.9, 0.0, 1.0])


def test_the_default_camera_delivers_each_frame_one_frame_late():
    """Default latency: one 60 Hz frame, so the frame captured at 0 arrives at the next capture,
    stamped with its own capture time and position."""
    assert CameraConfig().latency_frames == 1
    cam = BallCamera(CameraConfig(sigma=0.0))
    ctx = cam.CreateDefaultContext()
    port = cam.GetInputPort("ball_state")
    port.FixValue(ctx, ball_state([0.1, 0.2, 0.9]))
    step(cam, ctx, 0.0)
    assert math.isnan(cam.GetOutputPort("measurement").Eval(ctx)[3])
    port.FixValue(ctx, ball_state([0.1, 0.1, 0.9]))
    step(cam, ctx, PERIOD)
    assert cam.GetOutputPort("measurement").Eval(ctx) == pytest.approx([0.1, 0.2, 0.9, 0.0, 1.0])


def test_camera_latency_dropouts_and_seed():
    cam = BallCamera(CameraConfig(latency=2 * PERIOD, dropout=0.5))
    ctx = cam.CreateDefaultContext()
    cam.set_seed(ctx, 42)
    port = cam.GetInputPort("ball_state")
    out = []
    for k in range(12):
        port.FixValue(ctx, ball_state([0.0, 1.0 - 0.1 * k, 1.0]))
        step(cam, ctx, k * PERIOD)
        out.append(cam.GetOutputPort("measurement").Eval(ctx).copy())
    out = np.array(out)
    assert np.all(np.isnan(out[:2, 3]))  # nothing delivered yet
    assert out[2:, 3] == pytest.approx(np.arange(10) * PERIOD)  # capture times, 2 frames late
    dropped = cam.model.episode_draws(42).dropped[:10]
    assert np.array_equal(out[2:, 4] == 0.0, dropped)
    ok = ~dropped
    assert out[2:][ok, 1] == pytest.approx(1.0 - 0.1 * np.arange(10)[ok], abs=0.02)


def test_estimator_matches_the_numpy_filter():
    est = BallFlightEstimator()
    ctx = est.CreateDefaultContext()
    ekf = BallFlightEKF()
    rng = np.random.default_rng(0)
    for k in range(10):
        t = k * PERIOD
        p = [0.1, 1.5 - 5.0 * t, 0.9 + 2.0 * t - 4.9 * t * t]
        z = np.asarray(p) + rng.normal(0, 0.003, 3)
        est.GetInputPort("measurement").FixValue(ctx, np.r_[z, t, 1.0])
        step(est, ctx, t + PERIOD / 3)
        ekf.step(t, z)
    status = est.GetOutputPort("status").Eval(ctx)
    assert status == pytest.approx([1.0, 9 * PERIOD])
    assert est.GetOutputPort("state").Eval(ctx) == pytest.approx(ekf.x[:6], abs=1e-12)
    assert est.GetOutputPort("spin").Eval(ctx) == pytest.approx(ekf.x[6:9], abs=1e-12)
    assert est.GetOutputPort("covariance").Eval(ctx) == pytest.approx(
        ekf.P[:6, :6].ravel(), abs=1e-15)
    assert est.GetOutputPort("spin_covariance").Eval(ctx) == pytest.approx(
        ekf.P[6:9, 6:9].ravel(), abs=1e-12)


def test_ticks_without_a_new_frame_or_estimate_report_that_they_did_nothing():
    """A planning tick that finds no new camera frame (estimator) or no new estimate (predictor)
    returns "did nothing", so that the simulator does not write the unchanged state back (and
    nothing downstream is recomputed); a tick with something new updates the state."""
    from pydrake.systems.framework import EventStatus

    nothing = EventStatus.Severity.kDidNothing
    est = BallFlightEstimator()
    ctx = est.CreateDefaultContext()
    values = est.AllocateDiscreteVariables()
    port = est.GetInputPort("measurement")
    port.FixValue(ctx, [math.nan] * 4 + [0.0])  # nothing delivered yet
    assert est._update(ctx, values).severity() == nothing
    port.FixValue(ctx, [0.1, 1.5, 0.9, 0.0, 1.0])
    values.SetFrom(ctx.get_discrete_state())
    status = est._update(ctx, values)
    assert status is None or status.severity() != nothing
    assert values.get_vector(0).CopyToVector()[-1] == 0.0  # the frame's time, recorded
    ctx.get_mutable_discrete_state().SetFrom(values)
    assert est._update(ctx, values).severity() == nothing  # the same frame again

    pred = HittingPointPredictor()
    pctx = pred.CreateDefaultContext()
    pvalues = pred.AllocateDiscreteVariables()
    pred.GetInputPort("state").FixValue(pctx, [0.1, 0.1, 0.95, 0.1, -5.4, -1.0])
    pred.GetInputPort("status").FixValue(pctx, [0.0, 0.0])  # not tracking
    assert pred._update(pctx, pvalues).severity() == nothing
    pred.GetInputPort("status").FixValue(pctx, [1.0, 0.1])
    pvalues.SetFrom(pctx.get_discrete_state())
    status = pred._update(pctx, pvalues)
    assert status is None or status.severity() != nothing
    assert pvalues.get_vector(0).GetAtIndex(1) == 0.1  # the estimate's time, taken
    pctx.get_mutable_discrete_state().SetFrom(pvalues)
    assert pred._update(pctx, pvalues).severity() == nothing  # the same estimate again


def test_predictor_collects_four_observations_after_the_plane():
    pred = HittingPointPredictor()  # physical model
    ctx = pred.CreateDefaultContext()
    states = [np.array([0.1, 0.15 - 0.09 * k, 0.95, 0.1, -5.4, -1.0 - 0.16 * k]) for k in range(8)]
    for k, s in enumerate(states):
        pred.GetInputPort("state").FixValue(ctx, s)
        pred.GetInputPort("status").FixValue(ctx, [1.0, k * PERIOD])
        step(pred, ctx, k * PERIOD + 2 * PERIOD / 3)
        valid = pred.GetOutputPort("valid").Eval(ctx)[0]
        after = sum(1 for j in range(k + 1) if states[j][1] < PLANES.observation_y)
        assert valid == (1.0 if after >= 4 else 0.0)
    first_after = next(j for j, s in enumerate(states) if s[1] < 0.0)
    fourth = states[first_after + 3]
    expected = PhysicalPredictor().predict(fourth)
    assert pred.GetOutputPort("p_hit").Eval(ctx) == pytest.approx(expected[:3])
    assert pred.GetOutputPort("v_hit").Eval(ctx) == pytest.approx(expected[3:6])
    assert pred.GetOutputPort("t_hit").Eval(ctx)[0] == pytest.approx(
        (first_after + 3) * PERIOD + expected[6])


def test_early_predictions_until_the_final_one():
    """With an early physical predictor: a prediction from the first approaching estimate on,
    re-published only when it moves more than the tolerance, then the final prediction from the
    four observations after plane s, held. The estimates follow the physical model's own flight,
    switching once to a flight launched 0.3 m/s faster sideways (new information)."""
    early = PhysicalPredictor()
    model = early.model
    serve = np.array([-0.08, 1.57, 0.91, 1.46, -6.14, 2.17])
    changed = serve + np.r_[0, 0, 0, 0.3, 0, 0]
    switch = 6

    def flight(launch, t):
        c = model.predict_time(launch, t)
        return np.r_[c.position, c.velocity]

    states = [np.r_[serve[:3], -serve[3:]]]  # moving away from the robot: no prediction
    states += [flight(serve if k < switch else changed, k * PERIOD) for k in range(1, 26)]
    pred = HittingPointPredictor(early=early, early_tolerance=(0.02, 0.01))
    ctx = pred.CreateDefaultContext()
    published, last = 0, None
    for k, s in enumerate(states):
        pred.GetInputPort("state").FixValue(ctx, s)
        pred.GetInputPort("status").FixValue(ctx, [1.0, k * PERIOD])
        step(pred, ctx, k * PERIOD + 2 * PERIOD / 3)
        out = np.r_[pred.GetOutputPort("p_hit").Eval(ctx), pred.GetOutputPort("v_hit").Eval(ctx),
                    pred.GetOutputPort("t_hit").Eval(ctx)]
        after = sum(1 for j in range(1, k + 1) if states[j][1] < PLANES.observation_y)
        assert pred.GetOutputPort("valid").Eval(ctx)[0] == (0.0 if k == 0 else 1.0)
        assert pred.GetOutputPort("final").Eval(ctx)[0] == (1.0 if after >= 4 else 0.0)
        if k == 0 or after >= 4:
            continue
        if last is None or not np.array_equal(out, last):
            published, last = published + 1, out
            here = early.predict(s)
            assert out == pytest.approx(np.r_[here[:6], k * PERIOD + here[6]], abs=1e-12)
    assert published == 2  # the first estimate, then the switch of flight
    first_after = next(j for j, s in enumerate(states) if j and s[1] < PLANES.observation_y)
    expected = PhysicalPredictor().predict(states[first_after + 3])
    assert out[:6] == pytest.approx(expected[:6])
    assert out[6] == pytest.approx((first_after + 3) * PERIOD + expected[6])


def test_diagram_matches_the_offline_pipeline():
    """Camera -> estimator -> predictor in a Drake world equals the numpy pipeline on the log."""
    sample = generate_samples(1, 5, None, workers=1, progress=False)
    seed = int(sample["seed"][0])
    camera, estimator = CameraConfig(), EstimatorConfig()
    offline = run_pipeline(sample["frames_p"][0], sample["crossing"][0], seed, camera, estimator)
    assert offline.ok

    sim = BallOnlySimulation()  # reuse its recipe, add the vision systems to a new diagram
    from tt_drake.systems.aerodynamics import add_aerodynamics
    from tt_drake.systems.world import WorldConfig, add_world, make_simulator, set_ball_state

    builder = DiagramBuilder()
    world = add_world(builder, WorldConfig(with_robot=False))
    plant = world.plant
    add_aerodynamics(builder, world)
    cam = builder.AddSystem(BallCamera(camera))
    est = builder.AddSystem(BallFlightEstimator(estimator))
    pred = builder.AddSystem(HittingPointPredictor(physical=PhysicalPredictor()))
    builder.Connect(plant.get_state_output_port(world.ball), cam.get_input_port(0))
    builder.Connect(cam.GetOutputPort("measurement"), est.GetInputPort("measurement"))
    builder.Connect(est.GetOutputPort("state"), pred.GetInputPort("state"))
    builder.Connect(est.GetOutputPort("status"), pred.GetInputPort("status"))
    diagram = builder.Build()
    simulator = make_simulator(diagram, sim.config)
    ctx = simulator.get_mutable_context()
    cam.set_seed(cam.GetMyMutableContextFromRoot(ctx), camera_seed(seed))
    set_ball_state(world, plant.GetMyMutableContextFromRoot(ctx), sample["launch"][0])
    simulator.Initialize()
    simulator.AdvanceTo(float(sample["crossing"][0][6]) - 0.05)
    pctx = pred.GetMyContextFromRoot(ctx)
    assert pred.GetOutputPort("valid").Eval(pctx)[0] == 1.0
    obs = pred.GetMyContextFromRoot(ctx).get_discrete_state(0).get_value()[2:26].reshape(4, 6)
    assert obs == pytest.approx(offline.features.reshape(4, 6), abs=2e-4)
    expected = PhysicalPredictor().predict(offline.state4)
    assert pred.GetOutputPort("p_hit").Eval(pctx) == pytest.approx(expected[:3], abs=2e-3)


def test_ball_model_matches_drake_at_the_hitting_plane():
    """From the true launch state, within 5 mm and 2 ms on 20 default serves."""
    s = generate_samples(20, 2024, None, workers=1, progress=False)
    r = model_vs_drake(s)
    assert r["serves"] == 20
    assert r["position_max_mm"] <= 5.0 and r["time_max_ms"] <= 2.0, r


def _spinning_serve_frames(physical):
    """(model, launch, frames): the model's states of a spinning serve (backspin and sidespin)
    at every camera frame until 0.1 m before the hitting plane, its robot-side bounce among
    them."""
    model = physical.model
    launch = np.array([-0.08, 1.57, 0.91, 1.46, -6.14, 2.17, -120.0, 0.0, 60.0])
    frames = [model.predict_time(launch, k * PERIOD) for k in range(1, 40)]
    return model, launch, [c for c in frames if c.position[1] > PLANES.hitting_y + 0.1]


def _predictions(pred, frames, spin_at):
    """Feed ``pred`` the frames as estimates (the estimated spin of frame k: ``spin_at(k,
    frame)``) and return, after each, (final flag, [p_hit, t_hit])."""
    ctx = pred.CreateDefaultContext()
    outs = []
    for k, c in enumerate(frames):
        pred.GetInputPort("state").FixValue(ctx, np.r_[c.position, c.velocity])
        pred.GetInputPort("spin").FixValue(ctx, spin_at(k, c))
        pred.GetInputPort("status").FixValue(ctx, [1.0, (k + 1) * PERIOD])
        step(pred, ctx, (k + 1) * PERIOD + PERIOD / 3)
        outs.append((pred.GetOutputPort("final").Eval(ctx)[0],
                     np.r_[pred.GetOutputPort("p_hit").Eval(ctx),
                           pred.GetOutputPort("t_hit").Eval(ctx)]))
    return outs


def test_final_prediction_follows_the_ball_after_the_robot_side_bounce():
    """With a ``refresh`` predictor the final prediction is re-made from the estimated state and
    spin once the robot-side bounce is behind (and only then), when it moves more than the
    tolerance; without one it is held. The estimates follow a spinning serve (backspin and
    sidespin) whose spin the estimator 'learns' at the bounce: before it the estimated spin is
    zero, after it the model's own."""
    physical = PhysicalPredictor()
    model, launch, frames = _spinning_serve_frames(physical)
    bounced = [bool(c.bounces) for c in frames]
    assert any(bounced) and not all(bounced)

    def run(refresh):
        pred = HittingPointPredictor(physical=physical, refresh=refresh)
        return _predictions(pred, frames, lambda k, c: c.spin if c.bounces else np.zeros(3))

    held, followed = run(None), run(PhysicalPredictor())
    first_final = next(k for k, (final, _) in enumerate(held) if final == 1.0)
    assert not bounced[first_final]  # the final prediction is made before the bounce
    truth = model.predict_plane(launch, PLANES.hitting_y)
    for k in range(first_final, len(frames)):
        assert np.array_equal(held[k][1], held[first_final][1])
        if not bounced[k]:
            assert np.array_equal(followed[k][1], held[k][1])
    # The zero-spin final prediction misses the spinning ball's crossing by centimetres; once
    # the bounce is behind, the refreshed one is the model's own crossing.
    assert np.linalg.norm(held[-1][1][:3] - truth.position) > 0.02
    assert followed[-1][1][:3] == pytest.approx(truth.position, abs=1e-6)
    assert followed[-1][1][3] == pytest.approx(truth.t, abs=1e-6)


def test_refresh_ahead_follows_the_spin_before_the_robot_side_bounce():
    """With ``refresh_ahead`` the refresh starts at the final prediction: once the estimated spin
    moves the physical prediction by more than the tolerance, before the robot-side bounce, the
    published prediction is the model's own crossing from that estimate and spin; without it
    the prediction stays the final one until the bounce is behind."""
    physical = PhysicalPredictor()
    model, launch, frames = _spinning_serve_frames(physical)
    bounced = [bool(c.bounces) for c in frames]

    def run(ahead, spin_from):
        pred = HittingPointPredictor(physical=physical, refresh=PhysicalPredictor(),
                                     refresh_ahead=ahead)
        # The filter has seen no spin until frame spin_from, then the ball's own.
        return _predictions(pred, frames,
                            lambda k, c: c.spin if k >= spin_from else np.zeros(3))

    first_final = next(k for k, (final, _) in enumerate(run(False, len(frames))) if final)
    seen = first_final + 1  # the spin is seen one frame after the final prediction
    assert not bounced[seen]
    behind, ahead = run(False, seen), run(True, seen)
    truth = model.predict_plane(launch, PLANES.hitting_y)
    assert np.linalg.norm(behind[first_final][1][:3] - truth.position) > 0.02
    for k in range(first_final, len(frames)):
        if not bounced[k]:
            assert np.array_equal(behind[k][1], behind[first_final][1])
        if k >= seen:  # the spinning ball's crossing, before the bounce too
            assert ahead[k][1][:3] == pytest.approx(truth.position, abs=1e-6)
            assert ahead[k][1][3] == pytest.approx(truth.t, abs=1e-6)
        else:
            assert np.array_equal(ahead[k][1], behind[k][1])


@pytest.mark.parametrize("band", [None, HittingBand()], ids=["plane", "band"])
def test_a_ball_bouncing_twice_on_the_robots_half_loses_its_prediction(band):
    """The rules end the hitting window at the second bounce on the receiver's half: a short
    ball bounces at y = -0.52 m and again at -1.01 m, both over the table, before the hitting
    plane. Every prediction the predictor could make, early, final or refreshed, lies after the
    second bounce (the plane crossing), or with the band nowhere (the band's points lie behind
    the table, past the second bounce): none is ever published, so no player strikes."""
    physical = PhysicalPredictor()
    model = physical.model
    launch = np.array([0.0, 0.6, 0.95, 0.0, -3.2, -0.5, 0.0, 0.0, 0.0])
    frames = [model.predict_time(launch, k * PERIOD) for k in range(1, 75)]
    robot = [sum(b.position[1] < 0.0 for b in c.bounces) for c in frames]
    assert max(robot) == 2
    plane = model.predict_plane(launch, PLANES.hitting_y)
    assert sum(b.position[1] < 0.0 for b in plane.bounces) == 2  # the plane: after the second
    pred = HittingPointPredictor(physical=physical, early=PhysicalPredictor(),
                                 refresh=PhysicalPredictor(), band=band)
    ctx = pred.CreateDefaultContext()
    valid = []
    for k, c in enumerate(frames):
        pred.GetInputPort("state").FixValue(ctx, np.r_[c.position, c.velocity])
        pred.GetInputPort("spin").FixValue(ctx, c.spin)
        pred.GetInputPort("status").FixValue(ctx, [1.0, (k + 1) * PERIOD])
        step(pred, ctx, (k + 1) * PERIOD + PERIOD / 3)
        valid.append(pred.GetOutputPort("valid").Eval(ctx)[0])
    assert pred.GetOutputPort("final").Eval(ctx)[0] == 1.0  # a final prediction was made
    assert not any(valid)


def test_predictor_outputs_are_its_state_read_without_python():
    """The predictor's outputs are state output ports: the layout's slices, read in C++ (no
    call into Python, however often a logger or a player reads them)."""
    pred = HittingPointPredictor()
    ctx = pred.CreateDefaultContext()
    for k in range(6):
        pred.GetInputPort("state").FixValue(
            ctx, [0.1, 0.15 - 0.09 * k, 0.95, 0.1, -5.4, -1.0 - 0.16 * k])
        pred.GetInputPort("status").FixValue(ctx, [1.0, k * PERIOD])
        step(pred, ctx, k * PERIOD + 2 * PERIOD / 3)
    x = pred.layout(ctx)
    # the layout ends with the 12 published values, the bounce count (2) and the ball count
    assert x[1] == 5 * PERIOD and x[-15 + 7] == 1.0  # the estimate's time; valid
    names = ("p_hit", "v_hit", "t_hit", "valid", "final", "spin_hit", "balls")

    def read():
        for name in names:
            pred.GetOutputPort(name).Eval(ctx)
        return 0.0

    assert count_drake_calls(read)["total"] == 0
    published = np.concatenate([pred.GetOutputPort(n).Eval(ctx) for n in names])
    assert np.array_equal(published, np.r_[x[-15:-3], x[-1:]])


def test_estimator_outputs_are_its_state_read_without_python():
    """The estimator's outputs are state output ports written with the filter's vector: read in
    C++, and the filter's values (zeros before it tracks)."""
    est = BallFlightEstimator()
    ctx = est.CreateDefaultContext()
    names = ("state", "spin", "covariance", "spin_covariance", "status")

    def read():
        for name in names:
            est.GetOutputPort(name).Eval(ctx)
        return 0.0

    assert est.GetOutputPort("status").Eval(ctx)[0] == 0.0
    assert not np.any(est.GetOutputPort("state").Eval(ctx))
    ekf = BallFlightEKF()
    for k in range(6):
        t = k * PERIOD
        z = [0.1, 1.5 - 5.0 * t, 0.9 + 2.0 * t - 4.9 * t * t]
        est.GetInputPort("measurement").FixValue(ctx, np.r_[z, t, 1.0])
        step(est, ctx, t + PERIOD / 3)
        ekf.step(t, np.asarray(z))
        assert count_drake_calls(read)["total"] == 0
    assert est.GetOutputPort("status").Eval(ctx) == pytest.approx([1.0, 5 * PERIOD])
    assert np.array_equal(est.GetOutputPort("state").Eval(ctx), ekf.x[:6])
    assert np.array_equal(est.GetOutputPort("spin_covariance").Eval(ctx), ekf.P[6:9, 6:9].ravel())


def test_camera_measurement_is_its_state_read_without_python():
    cam = BallCamera(CameraConfig(latency=PERIOD))
    ctx = cam.CreateDefaultContext()
    port = cam.GetOutputPort("measurement")
    for k in range(3):
        cam.GetInputPort("ball_state").FixValue(ctx, ball_state([0.0, 1.0 - 0.1 * k, 1.0]))
        step(cam, ctx, k * PERIOD)
    assert port.Eval(ctx)[3] == pytest.approx(PERIOD)  # frame 1, one frame late
    assert count_drake_calls(lambda: port.Eval(ctx)[3])["total"] == 0


def test_one_tick_integrates_each_crossing_once():
    """An early prediction and its check under the rules ask the one physical model for the
    same crossing from the same estimate: it is integrated once, and the published prediction
    is that crossing."""
    model = PhysicalPredictor().model
    calls = []

    class Counting(type(model)):
        def predict_plane(self, state, plane_y, max_time=3.0):
            calls.append(tuple(np.asarray(state).tolist()))
            return super().predict_plane(state, plane_y, max_time)

    counting = Counting(model.params, dt=model.dt)
    early = PhysicalPredictor(counting)
    pred = HittingPointPredictor(physical=early, early=early)
    ctx = pred.CreateDefaultContext()
    s = [0.1, 0.6, 0.95, 0.1, -5.4, -1.0]  # toward the robot, before plane s: early only
    pred.GetInputPort("state").FixValue(ctx, s)
    pred.GetInputPort("status").FixValue(ctx, [1.0, 0.0])
    step(pred, ctx, PERIOD / 3)
    assert len(calls) == 1
    hit = model.predict_plane(np.r_[s, 0.0, 0.0, 0.0], early.plane_y)
    assert np.array_equal(pred.GetOutputPort("p_hit").Eval(ctx), hit.position)
    assert pred.GetOutputPort("final").Eval(ctx)[0] == 0.0
