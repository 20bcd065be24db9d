"""A base for abstract states that are replaced, never mutated.

Drake copies an abstract state value at every unrestricted update and context clone (deep copies
of Python objects). A state object that is never changed after construction can be shared instead:
its copies are itself, which makes those copies O(1) however much the state holds.
"""


class Immutable:
    __slots__ = ()

    def __copy__(self):
        return self

    def __deepcopy__(self, memo):
        return self
