"""The ground the feet are planted on: flat, a slope, or a height map; heights and surface normals.

A floor maps horizontal positions ``(..., 2)`` as ``(x, z)`` to heights ``(...)``, vectorized.
A plain function ``height(x, z)`` works too (:class:`FunctionFloor`); normals come from its gradient.

Height map files are NumPy ``.npz`` archives with ``heights (H, W)`` (metres; rows run along z,
columns along x), ``spacing`` (metres between samples) and optionally ``origin`` (``(x, z)`` of
``heights[0, 0]``, default ``(0, 0)``); heights between samples are bilinear, and beyond the edge the
edge value continues.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from ..errors import AdverbsError
from . import quat


class Floor:
    """Base: subclasses give :meth:`height`; the normal is taken from it by central differences."""

    step = 1e-3  # metres, for the gradient

    def height(self, xz: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def normal(self, xz: np.ndarray) -> np.ndarray:
        """Unit surface normals ``(..., 3)`` at ``xz (..., 2)``."""
        xz = np.asarray(xz, dtype=float)
        dx = np.array([self.step, 0.0])
        dz = np.array([0.0, self.step])
        gx = (self.height(xz + dx) - self.height(xz - dx)) / (2 * self.step)
        gz = (self.height(xz + dz) - self.height(xz - dz)) / (2 * self.step)
        n = np.stack([-gx, np.ones_like(gx), -gz], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    @property
    def is_flat(self) -> bool:
        return False


LEVEL_LIMIT = 1e4  # metres: a floor level or height beyond this is a mistake (and would overflow what is built on it)


def _level(level: float, what: str = "floor level") -> float:
    if not (math.isfinite(level) and abs(level) <= LEVEL_LIMIT):
        raise AdverbsError(f"{what} must be a height in metres from {-LEVEL_LIMIT:g} to {LEVEL_LIMIT:g}, got {level}")
    return float(level)


class FlatFloor(Floor):
    """A horizontal floor at ``level`` metres."""

    def __init__(self, level: float = 0.0):
        self.level = _level(level)

    def height(self, xz: np.ndarray) -> np.ndarray:
        return np.full(np.shape(xz)[:-1], self.level)

    def normal(self, xz: np.ndarray) -> np.ndarray:
        n = np.zeros(np.shape(xz)[:-1] + (3,))
        n[..., 1] = 1.0
        return n

    @property
    def is_flat(self) -> bool:
        return True


class SlopeFloor(Floor):
    """A plane through ``(0, level, 0)`` rising ``degrees`` towards the horizontal ``direction`` (default +Z)."""

    def __init__(self, degrees: float, direction: tuple[float, float] = (0.0, 1.0), level: float = 0.0):
        level = _level(level)
        if not (math.isfinite(degrees) and -80.0 < degrees < 80.0):
            raise AdverbsError(f"slope must be between -80 and 80 degrees, got {degrees}")
        d = np.asarray(direction, dtype=float)
        self.direction = d / np.linalg.norm(d)
        self.gradient = math.tan(math.radians(degrees))
        self.level = float(level)

    def height(self, xz: np.ndarray) -> np.ndarray:
        return self.level + self.gradient * (np.asarray(xz, dtype=float) @ self.direction)


class FunctionFloor(Floor):
    """A floor given by any vectorized function ``height(x, z)``."""

    def __init__(self, height: Callable[[np.ndarray, np.ndarray], np.ndarray]):
        self._fn = height

    def height(self, xz: np.ndarray) -> np.ndarray:
        xz = np.asarray(xz, dtype=float)
        return np.broadcast_to(np.asarray(self._fn(xz[..., 0], xz[..., 1]), dtype=float), xz.shape[:-1])


class HeightMapFloor(Floor):
    """Heights sampled on a regular grid (see the module docstring for the file format), bilinear between them.

    Attributes ``x (nx,)`` and ``z (nz,)``: the grid lines, metres; ``heights (nz, nx)``: the height at each
    crossing (not to be changed: the interpolator and a compiled planter read the same grid).
    """

    def __init__(self, heights: np.ndarray, spacing: float, origin: tuple[float, float] = (0.0, 0.0), name: str = ""):
        heights = np.asarray(heights, dtype=float)
        if heights.ndim != 2 or min(heights.shape) < 2:
            raise AdverbsError(
                f"{name or 'height map'}: heights must be a 2-D grid of at least 2 × 2, got {heights.shape}"
            )
        if not np.all(np.isfinite(heights) & (np.abs(heights) <= LEVEL_LIMIT)):
            raise AdverbsError(f"{name or 'height map'}: heights must be finite, from {-LEVEL_LIMIT:g} to {LEVEL_LIMIT:g} m")
        if not (math.isfinite(spacing) and spacing > 0):
            raise AdverbsError(f"{name or 'height map'}: spacing must be positive, got {spacing}")
        z = origin[1] + spacing * np.arange(heights.shape[0])
        x = origin[0] + spacing * np.arange(heights.shape[1])
        self._lo = np.array([x[0], z[0]])
        self._hi = np.array([x[-1], z[-1]])
        self._grid = RegularGridInterpolator((z, x), heights, method="linear")
        self.x, self.z, self.heights = x, z, np.ascontiguousarray(self._grid.values, dtype=float)
        self.step = spacing / 4

    @classmethod
    def load(cls, path: str | Path) -> HeightMapFloor:
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                missing = {"heights", "spacing"} - set(data.files)
                if missing:
                    raise AdverbsError(f"{path}: height map needs arrays {', '.join(sorted(missing))}")
                origin = np.asarray(data["origin"], dtype=float) if "origin" in data.files else np.zeros(2)
                spacing = np.asarray(data["spacing"], dtype=float)
                if origin.shape != (2,) or not np.all(np.isfinite(origin)):
                    raise AdverbsError(f"{path}: origin must be two finite numbers (x, z), got shape {origin.shape}")
                if spacing.ndim != 0:
                    raise AdverbsError(f"{path}: spacing must be one number (metres), got shape {spacing.shape}")
                return cls(data["heights"], float(spacing), (float(origin[0]), float(origin[1])), name=str(path))
        except FileNotFoundError:
            raise AdverbsError(f"{path}: no such height map") from None
        except (OSError, ValueError) as e:
            if isinstance(e, AdverbsError):
                raise
            raise AdverbsError(f"{path}: not a height map (.npz with heights and spacing): {e}") from None

    def height(self, xz: np.ndarray) -> np.ndarray:
        xz = np.clip(np.asarray(xz, dtype=float), self._lo, self._hi)
        return self._grid(xz[..., ::-1])


def parse_floor(text: str) -> Floor:
    """``"flat"``, ``"flat:LEVEL"``, ``"slope:DEGREES"`` (rising along +Z) or a height map file."""
    kind, _, value = text.partition(":")
    if kind not in ("flat", "slope"):
        return HeightMapFloor.load(text)
    try:
        number = float(value) if value or kind == "slope" else 0.0
    except ValueError:
        raise AdverbsError(f"--floor {text!r}: {value!r} is not a number") from None
    try:
        return FlatFloor(number) if kind == "flat" else SlopeFloor(number)
    except AdverbsError as e:
        raise AdverbsError(f"--floor {text!r}: {e}") from None


def tilt(normals: np.ndarray) -> np.ndarray:
    """Rotations ``(..., 3, 3)`` taking the vertical onto each normal ``(..., 3)`` by the shortest turn."""
    axis = np.cross(np.array([0.0, 1.0, 0.0]), normals)
    s = np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = np.arctan2(s, normals[..., 1:2])
    return quat.rotvec_matrix(axis / np.where(s > 1e-12, s, 1.0) * angle)
