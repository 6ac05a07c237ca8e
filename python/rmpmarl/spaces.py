"""Observation and action spaces: gymnasium.spaces.Box where Gymnasium is installed, else a Box with the same
attributes and methods (shape, dtype, low, high, sample, contains, seed), so code written against Gymnasium's spaces
runs either way. The agents' flat actions mix a categorical option index and a termination flag (whole numbers sent
as floats) with continuous values: ActionBox, a Box whose `integer` elements sample and check as whole numbers."""
import numpy as np

try:  # pragma: no cover - Debian 12 has no Gymnasium package; used when a user's environment has it
    from gymnasium.spaces import Box as _GymBox
except ImportError:  # pragma: no cover
    _GymBox = None


class _Box:
    """A box in R^shape with per-element bounds (Gymnasium's Box, duck-typed)."""

    integer = None

    def __init__(self, low, high, shape=None, dtype=np.float32, seed=None):
        self.dtype = np.dtype(dtype)
        if shape is None:
            shape = np.shape(low)
        self.shape = tuple(int(s) for s in shape)
        self.low = np.broadcast_to(np.asarray(low, dtype=self.dtype), self.shape).copy()
        self.high = np.broadcast_to(np.asarray(high, dtype=self.dtype), self.shape).copy()
        self.np_random = np.random.default_rng(seed)

    def seed(self, seed=None):
        self.np_random = np.random.default_rng(seed)
        return [seed]

    def sample(self):
        """uniform within finite bounds, normal where unbounded."""
        low = np.where(np.isfinite(self.low), self.low, -1.0).astype(np.float64)
        high = np.where(np.isfinite(self.high), self.high, 1.0).astype(np.float64)
        x = self.np_random.uniform(low, high)
        unbounded = ~(np.isfinite(self.low) & np.isfinite(self.high))
        x[unbounded] = self.np_random.normal(size=int(unbounded.sum()))
        if self.integer is not None:
            return _whole_sample(self, x)
        return x.astype(self.dtype)

    def contains(self, x):
        x = np.asarray(x)
        if x.shape != self.shape or not (np.all(x >= self.low) and np.all(x <= self.high)):
            return False
        return self.integer is None or _whole_contains(self, x)

    def __contains__(self, x):
        return self.contains(x)

    def __repr__(self):
        return f"Box({self.low.min()}, {self.high.max()}, {self.shape}, {self.dtype})"


def Box(low, high, shape=None, dtype=np.float32, seed=None):  # noqa: N802 - mirrors gymnasium.spaces.Box
    """gymnasium.spaces.Box when Gymnasium is installed, else the duck-typed box above."""
    if _GymBox is not None:
        return _GymBox(low=low, high=high, shape=shape, dtype=dtype, seed=seed)
    return _Box(low, high, shape, dtype, seed)


def _whole_sample(space, x):
    """x with the space's whole-number elements drawn uniformly from their integers in [low, high]."""
    whole = space.np_random.integers(space.low.astype(np.int64), space.high.astype(np.int64) + 1)
    return np.where(space.integer, whole, x).astype(space.dtype)


def _whole_contains(space, x):
    x = np.asarray(x)
    return bool(np.all(np.round(x[space.integer]) == x[space.integer]))


if _GymBox is not None:
    class ActionBox(_GymBox):
        """The agents' flat actions [option index?, continuous values..., terminate flag?]: a gymnasium Box (so
        Gymnasium's wrappers clip and rescale it as one) whose elements marked in `integer` (same shape, bool) are
        whole numbers in [low, high] (the option index, the 0/1 flag): sample draws them as integers, contains
        checks them."""

        def __init__(self, low, high, integer, shape=None, dtype=np.float32, seed=None):
            shape = np.shape(low) if shape is None else tuple(int(v) for v in shape)
            super().__init__(low=np.broadcast_to(np.asarray(low, dtype), shape),
                             high=np.broadcast_to(np.asarray(high, dtype), shape), shape=shape, dtype=dtype, seed=seed)
            self.integer = np.broadcast_to(np.asarray(integer, dtype=bool), self.shape).copy()

        def sample(self, mask=None, probability=None):
            if mask is not None or probability is not None:
                raise ValueError("ActionBox.sample: expected no mask or probability (a box has none)")
            return _whole_sample(self, super().sample())

        def contains(self, x):
            return super().contains(x) and _whole_contains(self, x)

        def __eq__(self, other):
            return (isinstance(other, ActionBox) and super().__eq__(other) and
                    np.array_equal(self.integer, other.integer))

        def __repr__(self):
            return (f"ActionBox({self.low.min()}, {self.high.max()}, {self.shape}, {self.dtype}, "
                    f"{int(self.integer.sum())} whole)")
else:
    class ActionBox(_Box):
        """The agents' flat actions [option index?, continuous values..., terminate flag?]: a Box whose elements
        marked in `integer` (same shape, bool) are whole numbers in [low, high] (the option index, the 0/1 flag)."""

        def __init__(self, low, high, integer, shape=None, dtype=np.float32, seed=None):
            super().__init__(low, high, shape, dtype, seed)
            self.integer = np.broadcast_to(np.asarray(integer, dtype=bool), self.shape).copy()

        def __repr__(self):
            return (f"ActionBox({self.low.min()}, {self.high.max()}, {self.shape}, {self.dtype}, "
                    f"{int(self.integer.sum())} whole)")
