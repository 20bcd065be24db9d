"""Every geometric and physical constant of the table-tennis world, in one place.

The model files in ``models/`` are generated from these values (``tt-drake models``; a test checks
that the committed files are up to date), and the numpy ball model, the launcher, the referee and
the tests all read them from here.

Frame (docs/world.md, "Frames and layout"): SI units; world origin on the floor under the table
centre, z up, +y along the table from the robot's end to the launcher's end, x completing a
right-handed frame, so +x is the robot's forehand (right-hand) side.

Sources: ITTF Laws 2.1-2.3 for table, net and ball; the MPI table-tennis simulator
(RobotLearning/optimpoly) for drag, Magnus and the lab's layout; the Barrett WAM manual and
inertial specification AC-02 for the arm (``tt_drake/wam_params.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

GRAVITY = 9.81  # m/s^2


@dataclass(frozen=True)
class Table:
    """ITTF table (Law 2.1): 2.74 m x 1.525 m, playing surface 0.76 m above the floor."""

    length: float = 2.74
    width: float = 1.525
    surface_z: float = 0.76
    thickness: float = 0.03
    collision_thickness: float = 0.05
    leg_inset: float = 0.2

    @property
    def robot_edge_y(self) -> float:
        """The table edge on the robot's side (y = -1.37)."""
        return -0.5 * self.length

    @property
    def opponent_edge_y(self) -> float:
        return 0.5 * self.length


@dataclass(frozen=True)
class Net:
    """ITTF net (Law 2.2): top 15.25 cm above the surface, posts 15.25 cm outside the side lines."""

    height: float = 0.1525
    overhang: float = 0.1525
    thickness: float = 0.02  # collision box; >= 5-10 mm against tunnelling (docs/constants.md)
    post_radius: float = 0.01

    @property
    def half_span(self) -> float:
        return 0.5 * TABLE.width + self.overhang


@dataclass(frozen=True)
class Ball:
    """ITTF ball (Law 2.3) and its aerodynamics.

    Drag acceleration a = -k |v| v with k = rho C_D A / (2 m) ~ 0.14 1/m; Magnus acceleration
    a = C_L (omega x v) with the MPI simulator's C_L = 0.001 (docs/constants.md, "Aerodynamics").
    """

    radius: float = 0.020
    mass: float = 0.0027
    drag_k: float = 0.14
    magnus_cl: float = 0.001

    @property
    def inertia(self) -> float:
        """Thin hollow sphere: I = 2/3 m R^2."""
        return 2.0 / 3.0 * self.mass * self.radius**2


@dataclass(frozen=True)
class RobotMount:
    """The WAM hangs from the ceiling above the robot's end of the table, as in the MPI lab.

    ``mount_*`` is the base plate (0.95 m above the table surface, 1.15 m behind the robot's table
    edge); the shoulder (where joints 1 and 2 intersect, the origin of DH frame 0) hangs
    ``base_to_shoulder`` below it (Barrett WAM manual: 0.346 m).
    """

    mount_x: float = 0.0
    mount_y: float = -1.37 - 1.15
    mount_z: float = 0.76 + 0.95
    base_to_shoulder: float = 0.346

    @property
    def shoulder(self) -> tuple[float, float, float]:
        return (self.mount_x, self.mount_y, self.mount_z - self.base_to_shoulder)


@dataclass(frozen=True)
class Planes:
    """Virtual planes across the table's long axis (constant y).

    ``hitting_y``: the virtual hitting plane, 0.7 m in front of the robot base (the MPI lab used
    0.3-0.7 m). ``observation_y``: the virtual plane s after which the hitting-point predictor
    collects its four observations (paper section II-C.1); the net plane.
    """

    hitting_y: float = -1.37 - 1.15 + 0.70
    observation_y: float = 0.0


@dataclass(frozen=True)
class HittingRegion:
    """The rectangle on the virtual hitting plane that ``default`` serves cross, on the robot's
    forehand: 1.0 m x 0.7 m = 0.7 m^2 (the paper's launcher covers "approximately 1 m^2",
    section III-A). Its size is set by what is both servable and reachable: a ball that bounces
    once on the robot's half crosses the plane 0.45 m behind the table edge below z ~ 1.5 m
    unless lobbed, and the racket centre reaches about 1.15 m from the shoulder."""

    x_min: float = -0.2
    x_max: float = 0.8
    z_min: float = 0.8
    z_max: float = 1.5

    @property
    def area(self) -> float:
        return (self.x_max - self.x_min) * (self.z_max - self.z_min)

    def contains(self, x: float, z: float) -> bool:
        return self.x_min <= x <= self.x_max and self.z_min <= z <= self.z_max


@dataclass(frozen=True)
class LandingTarget:
    """Default landing target: the centre of the opponent's half."""

    x: float = 0.0
    y: float = 0.25 * 2.74
    z: float = 0.76


@dataclass(frozen=True)
class ContactSurface:
    """Point-contact properties of one collision geometry (Hunt-Crossley dissipation d in s/m)."""

    stiffness: float
    dissipation: float
    friction: float


def combined_friction(mu_a: float, mu_b: float) -> float:
    """Drake's rule for two geometries' friction: mu = 2 mu_a mu_b / (mu_a + mu_b)."""
    return 2.0 * mu_a * mu_b / (mu_a + mu_b)


def surface_friction_for(combined: float, ball_mu: float) -> float:
    """The surface friction that gives ``combined`` with the ball's by Drake's rule."""
    return combined * ball_mu / (2.0 * ball_mu - combined)


@dataclass(frozen=True)
class Contact:
    """Calibrated contact model (docs/constants.md, "Drake contact and integration";
    tests/systems/test_world_physics.py).

    The ball is stiff and lossless so that each surface sets its own bounce. Hunt-Crossley
    restitution depends only on d * v_impact (``ball_model.hunt_crossley_restitution``):
    table d = 0.064 s/m makes a 30 cm drop rebound 23.0 cm with drag included (ITTF Law 2.1.3;
    e = 0.90 at 2.4 m/s, 0.84 at 5 m/s); racket d = 0.0425 s/m gives e = 0.81 at 8 m/s on a fixed
    plate and 0.78 when the arm holds the racket under inverse-dynamics control (the arm absorbs
    some of the impact), the MPI simulator's racket value.
    """

    ball_stiffness: float = 1.0e7
    ball_friction: float = 1.0
    table_stiffness: float = 1.0e5
    table_dissipation: float = 0.064
    table_friction_combined: float = 0.25
    racket_stiffness: float = 3.0e4
    racket_dissipation: float = 0.0425
    racket_friction_combined: float = 0.9
    floor_stiffness: float = 1.0e5
    floor_dissipation: float = 0.5
    floor_friction_combined: float = 0.5
    net_stiffness: float = 1.0e4
    net_dissipation: float = 2.0
    net_friction_combined: float = 0.5
    robot_stiffness: float = 1.0e5
    robot_dissipation: float = 0.2
    robot_friction_combined: float = 0.5

    def _surface(self, name: str) -> ContactSurface:
        combined = getattr(self, f"{name}_friction_combined")
        return ContactSurface(
            stiffness=getattr(self, f"{name}_stiffness"),
            dissipation=getattr(self, f"{name}_dissipation"),
            friction=surface_friction_for(combined, self.ball_friction),
        )

    def surface(self, name: str) -> ContactSurface:
        """Properties of ``ball``, ``table``, ``racket``, ``floor``, ``net`` or ``robot``."""
        if name == "ball":
            return ContactSurface(self.ball_stiffness, 0.0, self.ball_friction)
        return self._surface(name)

    def effective_dissipation(self, name: str) -> float:
        """Dissipation of the ball-``name`` pair, by Drake's rule for combining d:
        d = k_ball / (k_ball + k_surface) * d_surface (the ball's own d is zero)."""
        s = self.surface(name)
        return self.ball_stiffness / (self.ball_stiffness + s.stiffness) * s.dissipation


TABLE = Table()
NET = Net()
BALL = Ball()
MOUNT = RobotMount()
PLANES = Planes()
HITTING_REGION = HittingRegion()
TARGET = LandingTarget()
CONTACT = Contact()

#: Runs: base seeds are whole numbers in [0, MAX_SEED]; a run has at most MAX_SERVES serves (its
#: per-serve results are kept for the summary, ~2 kB each).
MAX_SEED = 2**32 - 1
MAX_SERVES = 100_000
#: A rally stops after at most MAX_EXCHANGES exchanges: its simulated time is bounded by
#: (MAX_EXCHANGES + 1) exchange timeouts (about 50 min at 3 s; 50 exchanges play in ~55 s), and
#: a recorded rally logs both arms and the ball at the referee's rate for all of it.
MAX_EXCHANGES = 1000
