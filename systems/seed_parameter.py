"""The episode's seed as a LeafSystem's numeric parameter, for systems that draw from it.

A system that draws random numbers keyed by the episode (the launcher's serve, the camera's
noise, a rally player's per-stroke aims) keeps the seed in its context, not in itself: contexts
then clone and replay exactly, and Drake recomputes whatever depends on the seed when it
changes (:meth:`SeedParameter.seed_ticket`).
"""

from pydrake.systems.framework import BasicVector, NumericParameterIndex


class SeedParameter:
    """Mixin for a LeafSystem: :meth:`declare_seed` in its constructor, then
    :meth:`set_seed` per episode and :meth:`seed` where it draws."""

    def declare_seed(self) -> None:
        """Declare the seed parameter (0 until :meth:`set_seed`)."""
        self._seed_index = self.DeclareNumericParameter(BasicVector([0.0]))

    def seed_ticket(self):
        """The dependency ticket of the seed parameter (an output computed from the seed)."""
        return self.numeric_parameter_ticket(NumericParameterIndex(self._seed_index))

    def set_seed(self, context, seed: int) -> None:
        """The episode's seed: what the system draws is a pure function of it."""
        context.get_mutable_numeric_parameter(self._seed_index).SetAtIndex(0, float(seed))

    def seed(self, context) -> int:
        """The seed set by :meth:`set_seed` (0 if none was)."""
        return int(context.get_numeric_parameter(self._seed_index).GetAtIndex(0))
