"""BallLauncher LeafSystem: serves one ball per episode, reproducible from the episode seed.

The serve is a pure function of the seed (a numeric parameter of the system), drawn by
:class:`tt_drake.serves.ServeSampler` from the configured distribution (``default``, ``spin``,
``real``, ``real-train``, ``real-test``, ``rally``, ``rally-train``, ``rally-test`` or ``fixed``;
see that module and docs/serves.md). Outputs:

- ``launch_state``: the ball's launch state (p, v, omega), 9 floats; the episode runner puts the
  plant's ball there when the episode starts;
- ``serve``: the :class:`tt_drake.serves.Serve` (launch state and the model's predicted crossing
  of the virtual hitting plane), for recordings and analysis.

Both outputs depend only on the seed parameter and are cached, so the sampling (tens of ms) runs
once per episode.
"""


import math
from dataclasses import dataclass, field

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from tt_drake.serves import DEFAULT_VY_RANGE, DEFAULT_X_RANGE, Serve, serve_sampler
from tt_drake.systems.seed_parameter import SeedParameter


@dataclass
class LauncherConfig:
    distribution: str = "default"
    # rad/s per spin component; 0: the distribution's default (``default``: no spin, ``spin``:
    # 100 rad/s); the pools and ``fixed`` ignore it.
    spin_max: float = 0.0
    real_serves: str = ""  # path to serves.json; empty: $TT_DRAKE_SERVES or the shipped copy
    rallies: str = ""  # path to rallies.json; empty: $TT_DRAKE_RALLIES or the shipped copy
    # Base seed of the run being served (set by ``tt-drake serve``), -1 for none: a pool
    # distribution then serves its pool in an order keyed by it, without repeats
    # (tt_drake.serves.ServeSampler).
    run_seed: int = -1
    # The ``default`` launcher's lateral position x0 (m) and forward launch speed v_y (m/s)
    # ranges; v_z and v_x follow from them (tt_drake.serves.default_proposal). Narrower ranges
    # than these defaults only: the proposal band was measured inside them.
    x_range: list[float] = field(default_factory=lambda: list(DEFAULT_X_RANGE))
    vy_range: list[float] = field(default_factory=lambda: list(DEFAULT_VY_RANGE))

    def problems(self, prefix: str = "launcher.") -> list[str]:
        """What is wrong with the ranges (one phrase per field, named with ``prefix``): two
        finite values lo <= hi inside the defaults'."""
        out = []
        for name, default in (("x_range", DEFAULT_X_RANGE), ("vy_range", DEFAULT_VY_RANGE)):
            r = getattr(self, name)
            if (len(r) != 2 or not all(math.isfinite(v) for v in r)
                    or not default[0] <= r[0] <= r[1] <= default[1]):
                out.append(f"{prefix}{name} must be two finite values lo <= hi within "
                           f"[{default[0]}, {default[1]}], got {list(r)}")
        return out


class BallLauncher(SeedParameter, LeafSystem):
    def __init__(self, config: LauncherConfig | None = None):
        super().__init__()
        self.config = config or LauncherConfig()
        self.sampler = serve_sampler(self.config)
        self.declare_seed()
        depends_on_seed = {self.seed_ticket()}
        self._serve_port = self.DeclareAbstractOutputPort(
            "serve", lambda: AbstractValue.Make(object()), self._calc_serve,
            prerequisites_of_calc=depends_on_seed)
        self.DeclareVectorOutputPort("launch_state", 9, self._calc_launch_state,
                                     prerequisites_of_calc={self._serve_port.cache_entry().ticket()})

    def _calc_serve(self, context, output):
        output.set_value(self.sampler.sample(self.seed(context)))

    def serve(self, context) -> Serve:
        return self._serve_port.Eval(context)

    def _calc_launch_state(self, context, output):
        output.SetFromVector(self._serve_port.Eval(context).launch_state)
