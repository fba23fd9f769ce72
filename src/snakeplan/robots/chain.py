"""Serial snake-arm chains: sections joined by universal joints, an optional feed axis, a base pose.

Lengths are mm, angles rad. At zero joint values every chain lies straight along its base frame's local +z
axis, starting at the base origin; the feed (if any) slides the whole arm along that axis.

Kinematics are an elementary transform sequence (ETS, :class:`ET`): fixed or joint-driven rotations about, and
translations along, the current frame's local x, y or z axis. ``Kinematics.frames[k]`` counts the elements
applied before frame ``k`` is recorded: frame 0 is the arm's base after the feed, frame ``i`` the end of section
``i - 1`` (frame ``n`` is the tip). Chains built from sections and chains loaded from DH tables
(:mod:`snakeplan.robots.dh`) share this representation and one numba-compiled forward kinematics. Each recorded
frame is turned by a constant rotation so that, like the base, its local +z points along the section that ends
there (frame 0: along the feed axis).

The default structure of section ``i`` is ``Rx(a_i) · Ry(b_i) · Tz(l_i)``; the feed is ``Tz(q_feed)`` before
section 0. The joint vector is ``q = [feed?, a0, b0, a1, b1, ...]``.
"""

from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.geometry.transforms import normalize, rot_x, rot_y, rot_z
from snakeplan.jit import kernel
from snakeplan.robots.cable_routing import CableRouting
from snakeplan.mapping.models import TIP_CAMERA, CameraModel
from snakeplan.robots.limits import DEFAULT_LIMITS, MotionLimits

SCHEMA = "snakeplan.robot/1"
OPS = ("rx", "ry", "rz", "tx", "ty", "tz")
_ROT = (rot_x, rot_y, rot_z)
_LENGTH_TOL = 1e-6  # mm (relative to 1 + total length): zero-configuration consistency checks
_ORTHO_TOL = 1e-9  # |cos| below which two unit axes count as perpendicular


def _number(where: str, name: str, value: Any) -> float:
    """``value`` as a finite float, or ValueError starting ``where: name`` (just ``where:`` if name is empty)."""
    label = f"{where}: {name}" if name else f"{where}:"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{label} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{label} must be finite, got {v}")
    return v


#: The fields of a ``snakeplan.robot/1`` object and of one of its sections; any other is refused, naming it.
ROBOT_KEYS = ("schema", "name", "sections", "k_ul", "total_length", "dof", "feed_range", "base", "kinematics",
              "limits", "cables", "camera", "description", "source")
SECTION_KEYS = ("length", "radius", "max_bend", "mass_kg", "com_mm")
#: A section's bend limit below this (rad, 1 deg) is taken for a unit mistake, not an arm.
MIN_PLAUSIBLE_BEND_RAD = math.radians(1.0)
#: A section's mean density (kg/mm^3: its mass over its solid cylinder's volume) outside these bounds is taken for
#: a unit mistake (grams for kilograms, metres for mm): 0.01 g/cm^3 is a tenth of a thin carbon-fibre tube's,
#: 25 g/cm^3 more than any metal's.
DENSITY_RANGE_KG_MM3 = (1e-8, 2.5e-5)


def _known_keys(where: str, d: Mapping, known: tuple[str, ...]) -> None:
    """ValueError naming the first key of ``d`` not in ``known`` (and the known ones, and a near one)."""
    for key in d:
        if key not in known:
            near = difflib.get_close_matches(str(key), known, n=1, cutoff=0.5)
            hint = f"; did you mean {near[0]}?" if near else ""
            raise ValueError(f"{where}{key}: unknown field (known: {', '.join(known)}){hint}")


def _check_section_fields(where: str, length: Any, radius: Any, max_bend: Any) -> tuple[float, float, float]:
    """Validated (length mm, radius mm, max_bend rad) of one section; errors start with ``where``."""
    lv = _number(where, "length", length)
    if lv <= 0:
        raise ValueError(f"{where}: length must be > 0, got {lv}")
    rv = _number(where, "radius", radius)
    if rv <= 0:
        raise ValueError(f"{where}: radius must be > 0, got {rv}")
    mv = _number(where, "max_bend", max_bend)
    if not 0 < mv < math.pi:
        hint = (f" (it looks like degrees: {mv:g} deg is {math.radians(mv):.4g} rad)" if math.pi <= mv < 180.0
                else "")
        raise ValueError(f"{where}: max_bend must be in (0, pi) rad, got {mv}{hint}")
    return lv, rv, mv


def _check_mass(where: str, length: float, radius: float, mass: Any, com: Any
                ) -> tuple[float | None, tuple[float, float, float] | None]:
    """Validated (mass kg, centre of mass mm) of a section of ``length`` and ``radius`` mm: the mass positive and
    of a plausible density (:data:`DENSITY_RANGE_KG_MM3`), the centre of mass (default: the middle of the axis)
    inside the section's cylinder. Neither given: (None, None); a centre of mass without a mass is refused."""
    if mass is None:
        if com is not None:
            raise ValueError(f"{where}: com_mm given without mass_kg")
        return None, None
    m = _number(where, "mass_kg", mass)
    if m <= 0:
        raise ValueError(f"{where}: mass_kg must be > 0, got {m}")
    density = m / (math.pi * radius ** 2 * length)
    lo, hi = DENSITY_RANGE_KG_MM3
    if not lo <= density <= hi:
        raise ValueError(f"{where}: mass_kg {m:g} is implausible for a section of {length:g} mm by {radius:g} mm "
                         f"radius ({density * 1e6:.3g} g/cm^3; plausible {lo * 1e6:g} to {hi * 1e6:g}); masses are "
                         f"in kg, lengths in mm")
    if com is None:
        return m, (0.0, 0.0, 0.5 * length)
    if isinstance(com, str) or not isinstance(com, Sequence | np.ndarray) or len(com) != 3:
        raise ValueError(f"{where}: com_mm must be [x, y, z] (mm), got {com!r}")
    c = tuple(_number(where, "com_mm", v) for v in com)
    tol = _LENGTH_TOL * (1.0 + length)
    if not -tol <= c[2] <= length + tol or math.hypot(c[0], c[1]) > radius + tol:
        raise ValueError(f"{where}: com_mm {list(c)} lies outside the section (0 <= z <= {length:g}, "
                         f"x^2 + y^2 <= {radius:g}^2, mm from its start, z along it)")
    return m, c


@dataclass(frozen=True)
class Section:
    """One rigid section: ``length`` (mm), body ``radius`` (mm) and ``max_bend`` (rad), the largest angle
    between its axis and the previous section's axis (for section 0, the base/feed axis); optionally its
    ``mass_kg`` (kg) and centre of mass ``com_mm`` (mm, in the section's frame from its start: z along the axis;
    default the middle of the axis), which the statics (:mod:`snakeplan.robots.statics`) need."""

    length: float
    radius: float
    max_bend: float
    mass_kg: float | None = None
    com_mm: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        lv, rv, mv = _check_section_fields("section", self.length, self.radius, self.max_bend)
        object.__setattr__(self, "length", lv)
        object.__setattr__(self, "radius", rv)
        object.__setattr__(self, "max_bend", mv)
        m, c = _check_mass("section", lv, rv, self.mass_kg, self.com_mm)
        object.__setattr__(self, "mass_kg", m)
        object.__setattr__(self, "com_mm", c)

    def to_dict(self) -> dict[str, Any]:
        """``{"length", "radius", "max_bend"}`` (mm, mm, rad), with ``mass_kg`` and ``com_mm`` where given."""
        out: dict[str, Any] = {"length": self.length, "radius": self.radius, "max_bend": self.max_bend}
        if self.mass_kg is not None:
            out.update(mass_kg=self.mass_kg, com_mm=list(self.com_mm))
        return out


@dataclass(frozen=True)
class ET:
    """One elementary transform: ``op`` is rx, ry, rz (value in rad) or tx, ty, tz (value in mm) about/along
    the current local axis. With ``joint`` set, ``q[joint]`` is added to the fixed ``value``."""

    op: str
    value: float = 0.0
    joint: int | None = None

    def __post_init__(self) -> None:
        if self.op not in OPS:
            raise ValueError(f"ets: op must be one of {', '.join(OPS)}, got {self.op!r}")
        object.__setattr__(self, "value", _number("ets", "value", self.value))
        if self.joint is not None:
            if isinstance(self.joint, bool) or not isinstance(self.joint, numbers.Integral) or self.joint < 0:
                raise ValueError(f"ets: joint must be a non-negative integer or None, got {self.joint!r}")
            object.__setattr__(self, "joint", int(self.joint))

    @property
    def is_rotation(self) -> bool:
        """True for rx, ry, rz."""
        return self.op[0] == "r"

    @property
    def axis(self) -> int:
        """Local axis index: 0 for x, 1 for y, 2 for z."""
        return "xyz".index(self.op[1])

    def matrix(self, q: float = 0.0) -> np.ndarray:
        """4x4 transform of this element with joint value ``q`` (ignored for a fixed element)."""
        v = self.value + (q if self.joint is not None else 0.0)
        T = np.eye(4)
        if self.is_rotation:
            T[:3, :3] = _ROT[self.axis](v)
        else:
            T[self.axis, 3] = v
        return T


@dataclass(frozen=True)
class Kinematics:
    """A chain's structure: the ETS, the frame marks, and per-joint limits (rad or mm) and names.

    ``frames[k]`` is the number of ETS elements applied before frame ``k`` is recorded; every joint index
    ``0 .. dof-1`` drives exactly one element.
    """

    ets: tuple[ET, ...]
    frames: tuple[int, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    joint_names: tuple[str, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "ets", tuple(self.ets))
        object.__setattr__(self, "frames", tuple(int(f) for f in self.frames))
        object.__setattr__(self, "lower", tuple(_number("kinematics", "lower", v) for v in self.lower))
        object.__setattr__(self, "upper", tuple(_number("kinematics", "upper", v) for v in self.upper))
        object.__setattr__(self, "joint_names", tuple(str(s) for s in self.joint_names))
        dof = len(self.lower)
        if len(self.upper) != dof or len(self.joint_names) != dof:
            raise ValueError("kinematics: lower, upper and joint_names must have one entry per joint")
        if len(set(self.joint_names)) != dof:
            raise ValueError("kinematics: joint_names must be unique")
        for j, (lo, hi) in enumerate(zip(self.lower, self.upper)):
            if lo > hi:
                raise ValueError(f"kinematics: joint {j} has lower limit {lo} > upper limit {hi}")
        used = sorted(e.joint for e in self.ets if e.joint is not None)
        if used != list(range(dof)):
            raise ValueError(f"kinematics: ets must drive each joint 0..{dof - 1} exactly once, got {used}")
        if len(self.frames) < 2:
            raise ValueError("kinematics: frames needs at least two marks (base and tip)")
        if any(b < a for a, b in zip(self.frames, self.frames[1:])) or self.frames[0] < 0:
            raise ValueError("kinematics: frames must be non-decreasing and non-negative")
        if self.frames[-1] > len(self.ets):
            raise ValueError(f"kinematics: frames[-1] = {self.frames[-1]} exceeds the {len(self.ets)} elements")
        if any(e.joint is not None for e in self.ets[self.frames[-1]:]):
            raise ValueError("kinematics: a joint after the tip frame would move nothing")

    @property
    def dof(self) -> int:
        """Number of joints."""
        return len(self.lower)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``{"ets": [[op, value, joint|null]...], "frames", "lower", "upper", "joint_names"}``."""
        return {
            "ets": [[e.op, e.value, e.joint] for e in self.ets],
            "frames": list(self.frames),
            "lower": list(self.lower),
            "upper": list(self.upper),
            "joint_names": list(self.joint_names),
        }

    @classmethod
    def from_dict(cls, d: Any) -> Kinematics:
        """Inverse of :meth:`to_dict`; ValueError naming the field on bad input."""
        if not isinstance(d, Mapping):
            raise ValueError("kinematics: must be an object")
        for key in ("ets", "frames", "lower", "upper", "joint_names"):
            if key not in d:
                raise ValueError(f"kinematics.{key}: missing")
            if not isinstance(d[key], Sequence) or isinstance(d[key], str):
                raise ValueError(f"kinematics.{key}: must be a list")
        ets = []
        for i, item in enumerate(d["ets"]):
            if not isinstance(item, Sequence) or isinstance(item, str) or len(item) != 3:
                raise ValueError(f"kinematics.ets[{i}]: must be [op, value, joint]")
            try:
                ets.append(ET(item[0], item[1], item[2]))
            except ValueError as exc:
                raise ValueError(f"kinematics.ets[{i}]: {str(exc).removeprefix('ets: ')}") from None
        for i, f in enumerate(d["frames"]):
            if isinstance(f, bool) or not isinstance(f, numbers.Integral):
                raise ValueError(f"kinematics.frames[{i}]: must be an integer, got {f!r}")
        return cls(tuple(ets), tuple(d["frames"]), tuple(d["lower"]), tuple(d["upper"]), tuple(d["joint_names"]))


@dataclass(frozen=True)
class IKResult:
    """Outcome of :meth:`Chain.ik`: joint vector ``q``, whether the tip is within ``tol``, the remaining tip
    error (mm) and the number of iterations spent over all restarts."""

    q: np.ndarray
    converged: bool
    error_mm: float
    iterations: int


@dataclass(frozen=True)
class _UniversalSection:
    """Section ``R_k · C0 · R_ax1(q[j1]) · C1 · R_ax2(q[j2]) · (RC2, v)`` with its pivot at the section start."""

    C0: np.ndarray
    ax1: int
    j1: int
    C1: np.ndarray
    ax2: int
    j2: int
    v: np.ndarray  # unit section direction in the frame after the second joint
    RC2: np.ndarray  # rotation from the frame after the second joint to the raw end frame
    orthogonal: bool  # joint axes and section mutually perpendicular: bend = arccos(cos a cos b)


@kernel
def _apply(T, kind, v):
    """Right-multiply the 4x4 ``T`` in place by elementary transform ``kind`` (0-2 rot x/y/z, 3-5 trans)."""
    if kind < 3:
        j = (kind + 1) % 3
        k = (kind + 2) % 3
        c = math.cos(v)
        s = math.sin(v)
        for r in range(3):
            tj = T[r, j]
            tk = T[r, k]
            T[r, j] = c * tj + s * tk
            T[r, k] = c * tk - s * tj
    else:
        a = kind - 3
        for r in range(3):
            T[r, 3] += v * T[r, a]


@kernel
def _fk_kernel(kinds, values, qidx, marks, corr, base, Q, out):
    """Frames ``out (m, n+1, 4, 4)`` for joint vectors ``Q (m, dof)``."""
    m = Q.shape[0]
    nm = marks.shape[0]
    T = np.empty((4, 4))
    for s in range(m):
        T[:, :] = base
        k = 0
        e = 0
        while True:
            while k < nm and marks[k] == e:
                F = out[s, k]
                for r in range(3):
                    for c in range(3):
                        F[r, c] = T[r, 0] * corr[k, 0, c] + T[r, 1] * corr[k, 1, c] + T[r, 2] * corr[k, 2, c]
                    F[r, 3] = T[r, 3]
                    F[3, r] = 0.0
                F[3, 3] = 1.0
                k += 1
            if k >= nm:
                break
            v = values[e]
            if qidx[e] >= 0:
                v += Q[s, qidx[e]]
            _apply(T, kinds[e], v)
            e += 1


@kernel
def _jac_kernel(kinds, values, qidx, n_tip, base, Q, J, tip):
    """Geometric tip Jacobians ``J (m, 6, dof)`` (linear rows first) and tip positions ``tip (m, 3)``."""
    m = Q.shape[0]
    T = np.empty((4, 4))
    axes = np.empty((n_tip, 3))
    origins = np.empty((n_tip, 3))
    for s in range(m):
        T[:, :] = base
        for e in range(n_tip):
            a = kinds[e] % 3
            for r in range(3):
                axes[e, r] = T[r, a]
                origins[e, r] = T[r, 3]
            v = values[e]
            if qidx[e] >= 0:
                v += Q[s, qidx[e]]
            _apply(T, kinds[e], v)
        for r in range(3):
            tip[s, r] = T[r, 3]
        J[s, :, :] = 0.0
        for e in range(n_tip):
            j = qidx[e]
            if j < 0:
                continue
            w0, w1, w2 = axes[e, 0], axes[e, 1], axes[e, 2]
            if kinds[e] < 3:
                r0 = T[0, 3] - origins[e, 0]
                r1 = T[1, 3] - origins[e, 1]
                r2 = T[2, 3] - origins[e, 2]
                J[s, 0, j] += w1 * r2 - w2 * r1
                J[s, 1, j] += w2 * r0 - w0 * r2
                J[s, 2, j] += w0 * r1 - w1 * r0
                J[s, 3, j] += w0
                J[s, 4, j] += w1
                J[s, 5, j] += w2
            else:
                J[s, 0, j] += w0
                J[s, 1, j] += w1
                J[s, 2, j] += w2


def _feed_range(value: Any, where: str = "feed_range") -> tuple[float, float]:
    """Validated (min, max) feed stroke in mm."""
    if not isinstance(value, Sequence | np.ndarray) or isinstance(value, str) or len(value) != 2:
        raise ValueError(f"{where}: must be [min, max] in mm, got {value!r}")
    lo, hi = _number(where, "min", value[0]), _number(where, "max", value[1])
    if lo > hi:
        raise ValueError(f"{where}: min {lo} > max {hi}")
    return lo, hi


def _check_base(base: Any, where: str = "base") -> np.ndarray:
    """Validated 4x4 rigid transform (identity for None)."""
    if base is None:
        return np.eye(4)
    try:
        B = np.array(base, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: must be a 4x4 matrix of numbers") from None
    if B.shape != (4, 4) or not np.all(np.isfinite(B)):
        raise ValueError(f"{where}: must be a finite 4x4 matrix, got shape {B.shape}")
    R = B[:3, :3]
    rigid = np.allclose(R.T @ R, np.eye(3), atol=1e-6) and np.linalg.det(R) > 0
    if not rigid or not np.allclose(B[3], [0, 0, 0, 1]):
        raise ValueError(f"{where}: must be a rigid transform (orthonormal rotation, last row [0, 0, 0, 1])")
    return B


def default_kinematics(
    sections: Sequence[Section], feed_range: tuple[float, float] | None = None
) -> Kinematics:
    """The default structure: ``[Tz(feed)] · Π_i Rx(a_i) · Ry(b_i) · Tz(l_i)``, each angle limited to
    ``±max_bend`` of its section and the feed to ``feed_range`` (mm)."""
    ets: list[ET] = []
    lower: list[float] = []
    upper: list[float] = []
    names: list[str] = []
    if feed_range is not None:
        ets.append(ET("tz", 0.0, 0))
        lower.append(feed_range[0])
        upper.append(feed_range[1])
        names.append("feed")
    frames = [len(ets)]
    for i, s in enumerate(sections):
        for op, tag in (("rx", "a"), ("ry", "b")):
            ets.append(ET(op, 0.0, len(names)))
            lower.append(-s.max_bend)
            upper.append(s.max_bend)
            names.append(f"s{i}_{tag}")
        ets.append(ET("tz", s.length))
        frames.append(len(ets))
    return Kinematics(tuple(ets), tuple(frames), tuple(lower), tuple(upper), tuple(names))


class _Encoded:
    """Flat arrays of an ETS for the numba kernels."""

    def __init__(self, kin: Kinematics) -> None:
        self.kinds = np.array([OPS.index(e.op) for e in kin.ets], dtype=np.int64)
        self.values = np.array([e.value for e in kin.ets], dtype=np.float64)
        self.qidx = np.array([-1 if e.joint is None else e.joint for e in kin.ets], dtype=np.int64)
        self.marks = np.array(kin.frames, dtype=np.int64)

    def frames(self, Q: np.ndarray, base: np.ndarray, corr: np.ndarray) -> np.ndarray:
        out = np.empty((Q.shape[0], self.marks.shape[0], 4, 4))
        _fk_kernel(self.kinds, self.values, self.qidx, self.marks, corr, base, Q, out)
        return out


def measure_lengths(kinematics: Kinematics) -> np.ndarray:
    """Section lengths (mm): distances between consecutive frames at zero joint values."""
    enc = _Encoded(kinematics)
    corr = np.broadcast_to(np.eye(3), (len(kinematics.frames), 3, 3)).copy()
    F = enc.frames(np.zeros((1, kinematics.dof)), np.eye(4), corr)[0]
    return np.linalg.norm(np.diff(F[:, :3, 3], axis=0), axis=-1)


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


class Chain:
    """A snake arm: ``n`` sections joined by universal joints, an optional feed axis, a base pose (4x4).

    Build one from sections (default structure ``Rx(a)·Ry(b)·Tz(l)`` per section), from a DH table
    (:func:`snakeplan.robots.dh.load_dh`), from a ``snakeplan.robot/1`` dict (:meth:`from_dict`), from a URDF
    (:func:`snakeplan.robots.urdf.from_urdf`) or with explicit ``kinematics``; the loaders build on this class,
    which imports none of them. :func:`snakeplan.robots.urdf.to_urdf` writes a chain as URDF.
    ``k_ul`` (1/mm) is the curvature upper limit of the smoothness index; by default the curvature of the
    circle through three joints at maximum bend, ``max_i 2 sin(max_bend_i / 2) / length_i``. ``limits``
    (:class:`~snakeplan.robots.limits.MotionLimits`, default ``DEFAULT_LIMITS``) bound a trajectory's feed speed
    and acceleration and its joint rates and accelerations; ``cables`` (a
    :class:`~snakeplan.robots.cable_routing.CableRouting`, one entry per section) makes the arm cable-driven.
    ``camera`` (a :class:`~snakeplan.mapping.models.CameraModel`, default ``TIP_CAMERA``) rides the tip, looking
    along its direction: what an inspect task's views see.
    Chains are immutable; :meth:`with_base` returns a moved copy.
    """

    def __init__(
        self,
        sections: Sequence[Section],
        *,
        name: str = "chain",
        feed_range: Sequence[float] | None = None,
        base: ArrayLike | None = None,
        k_ul: float | None = None,
        kinematics: Kinematics | None = None,
        limits: MotionLimits | None = None,
        cables: CableRouting | None = None,
        camera: CameraModel | None = None,
    ) -> None:
        self._sections = tuple(sections)
        if not self._sections:
            raise ValueError("sections: need at least one section")
        for i, s in enumerate(self._sections):
            if not isinstance(s, Section):
                raise TypeError(f"section {i}: expected a Section, got {type(s).__name__}")
        self._name = str(name)
        feed = None if feed_range is None else _feed_range(feed_range)
        self._kin = default_kinematics(self._sections, feed) if kinematics is None else kinematics
        self._base = _readonly(_check_base(base))
        n = len(self._sections)
        massed = [s.mass_kg is not None for s in self._sections]
        if any(massed) and not all(massed):
            raise ValueError(f"sections: section {massed.index(False)} has no mass_kg while section "
                             f"{massed.index(True)} has one (give every section a mass, or none)")
        self._masses = _readonly([s.mass_kg for s in self._sections]) if all(massed) else None
        self._coms = _readonly([s.com_mm for s in self._sections]) if all(massed) else None
        self._lengths = _readonly([s.length for s in self._sections])
        self._radii = _readonly([s.radius for s in self._sections])
        self._max_bends = _readonly([s.max_bend for s in self._sections])
        if k_ul is None:
            self._k_ul = float(np.max(2.0 * np.sin(self._max_bends / 2.0) / self._lengths))
        else:
            self._k_ul = _number("k_ul", "", k_ul)
            if self._k_ul <= 0:
                raise ValueError(f"k_ul: must be > 0 (1/mm), got {self._k_ul}")
        if len(self._kin.frames) != n + 1:
            raise ValueError(f"kinematics: {len(self._kin.frames)} frames for {n} sections (need n + 1)")
        self._enc = _Encoded(self._kin)
        prefix = [e for e in self._kin.ets[: self._kin.frames[0]] if e.joint is not None]
        self._has_feed = bool(prefix)
        if prefix and (len(prefix) != 1 or prefix[0].joint != 0 or prefix[0].is_rotation):
            raise ValueError("kinematics: the only joint before frame 0 must be the feed, a translation, as q[0]")
        if self._has_feed:
            self._feed = (self._kin.lower[0], self._kin.upper[0])
            if feed is not None and feed != self._feed:
                raise ValueError(f"feed_range: {feed} differs from the kinematics' feed limits {self._feed}")
        elif feed is not None:
            raise ValueError("feed_range: given, but the kinematics have no feed joint")
        else:
            self._feed = None
        self._corr = self._check_zero_configuration()
        self._limits = DEFAULT_LIMITS if limits is None else limits
        self._camera = TIP_CAMERA if camera is None else camera
        if not isinstance(self._camera, CameraModel):
            raise TypeError(f"camera: expected CameraModel, got {type(camera).__name__}")
        if not isinstance(self._limits, MotionLimits):
            raise TypeError(f"limits: expected MotionLimits, got {type(limits).__name__}")
        if cables is not None and len(cables.sections) != n:
            raise ValueError(f"cables: {len(cables.sections)} sections of cables for {n} sections")
        self._cables = cables
        self._universal: list[_UniversalSection | None] | None = None
        self._cone: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def _check_zero_configuration(self) -> np.ndarray:
        """Verify the straight zero configuration; return the per-frame constant corrections (n+1, 3, 3)."""
        n = self.n_sections
        ident = np.broadcast_to(np.eye(3), (n + 1, 3, 3)).copy()
        Q = np.zeros((2, self.dof))
        if self._has_feed:
            Q[1, 0] = 1.0
        F = self._enc.frames(Q, np.eye(4), ident)
        expected = np.zeros((n + 1, 3))
        expected[1:, 2] = np.cumsum(self._lengths)
        tol = _LENGTH_TOL * (1.0 + float(self._lengths.sum()))
        for k in range(n + 1):
            if not np.allclose(F[0, k, :3, 3], expected[k], atol=tol):
                raise ValueError(
                    f"kinematics: at zero joint values frame {k} is at {np.round(F[0, k, :3, 3], 6).tolist()}, "
                    f"expected {expected[k].tolist()} (the arm must lie straight along the base +z axis with "
                    "the sections' lengths)"
                )
        if self._has_feed and not np.allclose(F[1, 0, :3, 3], [0, 0, 1], atol=1e-9):
            raise ValueError("kinematics: the feed must move the arm base along the base +z axis")
        return np.ascontiguousarray(np.transpose(F[0, :, :3, :3], (0, 2, 1)))

    # ------------------------------------------------------------------ properties
    @property
    def name(self) -> str:
        """Preset or user name."""
        return self._name

    @property
    def sections(self) -> tuple[Section, ...]:
        """The sections, base to tip."""
        return self._sections

    @property
    def n_sections(self) -> int:
        """Number of sections ``n``."""
        return len(self._sections)

    @property
    def dof(self) -> int:
        """Length of the joint vector (feed included)."""
        return self._kin.dof

    @property
    def kinematics(self) -> Kinematics:
        """The ETS structure, frame marks, joint limits and names."""
        return self._kin

    @property
    def joint_names(self) -> tuple[str, ...]:
        """One name per joint."""
        return self._kin.joint_names

    @property
    def lengths(self) -> np.ndarray:
        """Section lengths (n,) in mm."""
        return self._lengths

    @property
    def masses(self) -> np.ndarray | None:
        """Section masses (kg), or None when the robot states none."""
        return self._masses

    @property
    def coms(self) -> np.ndarray | None:
        """Section centres of mass ``(n, 3)`` (mm, each in its section's frame from its start), or None."""
        return self._coms

    @property
    def radii(self) -> np.ndarray:
        """Section body radii (n,) in mm."""
        return self._radii

    @property
    def max_bends(self) -> np.ndarray:
        """Bend limits (n,) in rad between each section and the previous one (section 0: the feed axis)."""
        return self._max_bends

    @property
    def total_length(self) -> float:
        """Sum of section lengths (mm)."""
        return float(self._lengths.sum())

    @property
    def k_ul(self) -> float:
        """Curvature upper limit (1/mm) used by the smoothness index."""
        return self._k_ul

    @property
    def has_feed(self) -> bool:
        """True when ``q[0]`` is a prismatic feed along the base +z axis."""
        return self._has_feed

    @property
    def feed_range(self) -> tuple[float, float] | None:
        """(min, max) feed stroke in mm, or None without a feed."""
        return self._feed

    @property
    def base(self) -> np.ndarray:
        """Base pose (4x4, read-only): the arm starts at its origin pointing along its local +z."""
        return self._base

    @property
    def limits(self) -> MotionLimits:
        """Feed speed and acceleration, joint rate and acceleration limits of a trajectory."""
        return self._limits

    @property
    def camera(self) -> CameraModel:
        """The tip camera: field of view, range, incidence limit (rad, mm)."""
        return self._camera

    @property
    def cables(self) -> CableRouting | None:
        """The driving cables' routing, or None for an arm that is not cable-driven."""
        return self._cables

    def with_masses(self, masses_kg: ArrayLike, coms_mm: ArrayLike | None = None) -> Chain:
        """A copy whose sections weigh ``masses_kg`` (kg, one per section) with centres of mass ``coms_mm``
        (``(n, 3)`` mm, each in its section's frame from its start; default the middle of each axis)."""
        m = np.asarray(masses_kg, dtype=float).reshape(-1)
        if m.size != self.n_sections:
            raise ValueError(f"masses_kg: {m.size} masses for {self.n_sections} sections")
        c = [None] * m.size if coms_mm is None else [tuple(row) for row in np.asarray(coms_mm, dtype=float)]
        sections = [Section(s.length, s.radius, s.max_bend, float(mi), ci)
                    for s, mi, ci in zip(self._sections, m, c)]
        return Chain(sections, name=self._name, feed_range=self._feed, base=self._base, k_ul=self._k_ul,
                     kinematics=self._kin, limits=self._limits, cables=self._cables, camera=self._camera)

    def with_base(self, base: ArrayLike) -> Chain:
        """A copy of this chain standing at ``base`` (4x4)."""
        return Chain(self._sections, name=self._name, base=base, k_ul=self._k_ul, kinematics=self._kin,
                     limits=self._limits, cables=self._cables, camera=self._camera)

    def joint_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) joint limits, each (dof,): ±max_bend per universal-joint angle, the feed range."""
        return np.array(self._kin.lower), np.array(self._kin.upper)

    def random_q(self, seed: int | np.random.Generator | None = None, size: int | tuple[int, ...] = ()) -> np.ndarray:
        """Joint vectors ``size + (dof,)`` drawn uniformly within the joint limits."""
        rng = np.random.default_rng(seed)
        lo, hi = self.joint_limits()
        shape = (size,) if isinstance(size, int) else tuple(size)
        return lo + (hi - lo) * rng.random(shape + (self.dof,))

    def __repr__(self) -> str:
        feed = f", feed={self._feed}" if self._has_feed else ""
        return f"Chain({self._name!r}, n={self.n_sections}, dof={self.dof}, length={self.total_length:g} mm{feed})"

    # ------------------------------------------------------------------ kinematics
    def _batch(self, q: ArrayLike) -> tuple[np.ndarray, tuple[int, ...]]:
        Q = np.asarray(q, dtype=np.float64)
        if Q.ndim == 0 or Q.shape[-1] != self.dof:
            raise ValueError(f"q must have shape (..., {self.dof}), got {Q.shape}")
        return np.ascontiguousarray(Q.reshape(-1, self.dof)), Q.shape[:-1]

    def fk(self, q: ArrayLike) -> np.ndarray:
        """Frames ``(..., n+1, 4, 4)`` in world coordinates: frame 0 the arm base after the feed, frame ``i``
        the end of section ``i-1``; each frame's local +z points along the section ending there."""
        Q, batch = self._batch(q)
        out = self._enc.frames(Q, np.ascontiguousarray(self._base), self._corr)
        return out.reshape(batch + out.shape[1:])

    def joint_positions(self, q: ArrayLike) -> np.ndarray:
        """Joint (section end) positions ``(..., n+1, 3)`` in mm, base first."""
        return self.fk(q)[..., :3, 3]

    def _tip_and_jacobian(self, q: ArrayLike) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
        Q, batch = self._batch(q)
        J = np.empty((Q.shape[0], 6, self.dof))
        tip = np.empty((Q.shape[0], 3))
        e = self._enc
        _jac_kernel(e.kinds, e.values, e.qidx, int(e.marks[-1]), np.ascontiguousarray(self._base), Q, J, tip)
        return tip, J, batch

    def tip_jacobian(self, q: ArrayLike, orientation: bool = False) -> np.ndarray:
        """Geometric Jacobian of the tip: ``(..., 3, dof)`` linear velocity (mm per rad or mm per mm), or
        ``(..., 6, dof)`` with the angular velocity rows (rad per joint unit) below when ``orientation``."""
        _, J, batch = self._tip_and_jacobian(q)
        J = J if orientation else J[:, :3]
        return J.reshape(batch + J.shape[1:])

    def null_space_projector(self, q: ArrayLike, rcond: float = 1e-10) -> np.ndarray:
        """``I - J⁺J`` ``(..., dof, dof)`` for the 3 x dof tip position Jacobian: joint motions along its
        range leave the tip still to first order. Singular values below ``rcond`` times the largest count
        as zero."""
        J = self.tip_jacobian(q)
        return np.eye(self.dof) - np.linalg.pinv(J, rcond=rcond) @ J

    def bend_angles(self, q: ArrayLike) -> np.ndarray:
        """Angles (rad) ``(..., n)`` between consecutive section axes, from joint positions; section 0 is
        measured against the base +z (feed) axis."""
        p = self.joint_positions(q)
        d = normalize(np.diff(p, axis=-2))
        prev = np.concatenate([np.broadcast_to(self._base[:3, 2], d[..., :1, :].shape), d[..., :-1, :]], axis=-2)
        return np.arctan2(np.linalg.norm(np.cross(prev, d), axis=-1), np.sum(prev * d, axis=-1))

    def within_bend_limits(self, q: ArrayLike, tol: float = 1e-9) -> np.ndarray:
        """Boolean ``(...)``: every bend angle within its section's ``max_bend`` (+ ``tol`` rad)."""
        return np.all(self.bend_angles(q) <= self._max_bends + tol, axis=-1)

    # ------------------------------------------------------------------ directions -> joint angles
    def _universal_sections(self) -> list[_UniversalSection | None]:
        """Per section, its two-angle structure, or None where the section is not such a joint."""
        if self._universal is None:
            self._universal = [self._analyse_section(k) for k in range(self.n_sections)]
        return self._universal

    def _analyse_section(self, k: int) -> _UniversalSection | None:
        ets = self._kin.ets[self._kin.frames[k] : self._kin.frames[k + 1]]
        rot = [np.eye(3), np.eye(3)]
        joints: list[ET] = []
        rest = np.eye(4)
        for e in ets:
            if len(joints) < 2:
                if e.joint is not None:
                    if not e.is_rotation:
                        return None
                    joints.append(e)
                elif not e.is_rotation:
                    if e.value != 0.0:
                        return None
                else:
                    rot[len(joints)] = rot[len(joints)] @ _ROT[e.axis](e.value)
            else:
                if e.joint is not None:
                    return None
                rest = rest @ e.matrix()
        if len(joints) < 2:
            return None
        j1, j2 = joints
        C1 = _ROT[j1.axis](j1.value) @ rot[1]
        off2 = _ROT[j2.axis](j2.value)
        v = off2 @ rest[:3, 3]
        if np.linalg.norm(v) == 0.0:
            return None
        v = v / np.linalg.norm(v)
        u1 = np.eye(3)[j1.axis]
        u2 = C1 @ np.eye(3)[j2.axis]
        vw = C1 @ v
        ortho = max(abs(u1 @ u2), abs(u1 @ vw), abs(u2 @ vw)) < _ORTHO_TOL
        return _UniversalSection(rot[0], j1.axis, j1.joint, C1, j2.axis, j2.joint, v, off2 @ rest[:3, :3], ortho)

    def universal_joints(self) -> list[tuple[int, int]]:
        """Per section, the indices in ``q`` of its two angles (first, second); ValueError when a section is
        not a two-angle joint pivoting at its start."""
        secs = self._universal_sections()
        bad = [k for k, s in enumerate(secs) if s is None]
        if bad:
            raise ValueError(f"section {bad[0]} is not a two-angle joint pivoting at its start")
        return [(s.j1, s.j2) for s in secs]

    def joint_angles_from_directions(
        self,
        directions: ArrayLike,
        base_rotation: ArrayLike | None = None,
        feed: float | ArrayLike | None = None,
    ) -> np.ndarray:
        """Joint vector ``(..., dof)`` that points section ``i`` along world unit direction ``directions[..., i,
        :]`` (shape ``(..., n, 3)``), frame by frame from the base. ``base_rotation`` (3x3) replaces the base
        pose's rotation; ``feed`` (mm, default: the feed value nearest 0) fills ``q[0]``. For the default
        structure, with local direction ``d = (x, y, z)``: ``b = asin(x)``, ``a = atan2(-y, z)``; other
        universal joints are solved the same way in their own axes (the smaller-magnitude root is taken)."""
        secs = self._universal_sections()
        bad = [k for k, s in enumerate(secs) if s is None]
        if bad:
            raise ValueError(f"section {bad[0]} is not a two-angle joint pivoting at its start")
        d = normalize(np.asarray(directions, dtype=np.float64))
        if d.ndim < 2 or d.shape[-2:] != (self.n_sections, 3):
            raise ValueError(f"directions must have shape (..., {self.n_sections}, 3), got {d.shape}")
        batch = d.shape[:-2]
        R0 = self._base[:3, :3] if base_rotation is None else np.asarray(base_rotation, dtype=np.float64)
        if R0.shape != (3, 3):
            raise ValueError(f"base_rotation must be 3x3, got {R0.shape}")
        for e in self._kin.ets[: self._kin.frames[0]]:
            R0 = R0 @ e.matrix()[:3, :3]
        R = np.broadcast_to(R0, batch + (3, 3))
        q = np.zeros(batch + (self.dof,))
        if self._has_feed:
            lo, hi = self._feed
            q[..., 0] = np.clip(0.0, lo, hi) if feed is None else feed
        for k, s in enumerate(secs):
            A = R @ s.C0
            t = np.einsum("...ji,...j->...i", A, d[..., k, :])
            u2 = np.eye(3)[s.ax2]
            v_par = (s.v @ u2) * u2
            v_perp = s.v - v_par
            u2xv = np.cross(u2, v_perp)
            K, Ac, Bs = (s.C1 @ v_par)[s.ax1], (s.C1 @ v_perp)[s.ax1], (s.C1 @ u2xv)[s.ax1]
            amp = math.hypot(Ac, Bs)
            phi = math.atan2(Bs, Ac)
            delta = np.arccos(np.clip((t[..., s.ax1] - K) / amp, -1.0, 1.0)) if amp > 0 else np.zeros(batch)
            b1 = _wrap(phi + delta)
            b2 = _wrap(phi - delta)
            b = np.where(np.abs(b1) <= np.abs(b2), b1, b2)
            cb, sb = np.cos(b)[..., None], np.sin(b)[..., None]
            w = (v_par + cb * v_perp + sb * u2xv) @ s.C1.T
            u1 = np.eye(3)[s.ax1]
            wp = w - w[..., s.ax1, None] * u1
            tp = t - t[..., s.ax1, None] * u1
            a = np.arctan2(np.sum(np.cross(wp, tp) * u1, axis=-1), np.sum(wp * tp, axis=-1))
            q[..., s.j1] = a
            q[..., s.j2] = b
            R = A @ _ROT[s.ax1](a) @ s.C1 @ _ROT[s.ax2](b) @ s.RC2
        return q

    # ------------------------------------------------------------------ inverse kinematics
    def _cone_joints(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(a indices, b indices, cos max_bend) of the perpendicular universal joints."""
        if self._cone is None:
            secs = [(s.j1, s.j2, math.cos(m)) for s, m in zip(self._universal_sections(), self._max_bends)
                    if s is not None and s.orthogonal]
            j1, j2, cos_m = zip(*secs) if secs else ((), (), ())
            self._cone = (np.array(j1, dtype=np.int64), np.array(j2, dtype=np.int64), np.array(cos_m))
        return self._cone

    def clip_to_limits(self, q: ArrayLike, respect_bend: bool = True) -> np.ndarray:
        """``q (..., dof)`` clipped to the joint limits and, with ``respect_bend``, each perpendicular
        universal joint's angle pair (a, b) shrunk by a common factor until ``arccos(cos a cos b) <=
        max_bend`` (the bend cone inside the ±max_bend box)."""
        lo, hi = self.joint_limits()
        q = np.clip(np.asarray(q, dtype=np.float64), lo, hi)
        if not respect_bend:
            return q
        j1, j2, cos_m = self._cone_joints()
        a, b = q[..., j1], q[..., j2]
        outside = np.cos(a) * np.cos(b) < cos_m
        if not np.any(outside):
            return q
        t = np.ones(a.shape)
        for _ in range(8):  # Newton on cos(ta) cos(tb) = cos(max_bend), decreasing in t on [0, 1]
            f = np.cos(t * a) * np.cos(t * b) - cos_m
            df = -a * np.sin(t * a) * np.cos(t * b) - b * np.cos(t * a) * np.sin(t * b)
            t = np.clip(t - f / np.where(df < 0, df, -1.0), 0.0, 1.0)
        scale = np.where(outside, t * (1.0 - 1e-12), 1.0)
        q[..., j1] = a * scale
        q[..., j2] = b * scale
        return q

    def ik(
        self,
        target: ArrayLike,
        q0: ArrayLike | None = None,
        *,
        iterations: int = 200,
        damping: float = 1.0,
        tol: float = 1e-3,
        restarts: int = 20,
        max_step: float = 0.2,
        respect_bend: bool = True,
        seed: int | None = None,
    ) -> IKResult:
        """Damped-least-squares position IK for the tip to reach ``target`` (3,) mm.

        Each step ``dq = Jᵀ (J Jᵀ + damping² I)⁻¹ e`` (damping in mm) is scaled so no angle changes by more
        than ``max_step`` rad, then clipped to the joint limits (joints pushing against a limit are frozen
        for that step) and, with ``respect_bend``, pulled inside each universal joint's bend cone. Starts at
        ``q0`` (default: zero, clipped), then up to ``restarts`` random starts from
        ``np.random.default_rng(seed)``; returns the first within ``tol`` mm or the best found.
        """
        p_target = np.asarray(target, dtype=np.float64).reshape(-1)
        if p_target.shape != (3,) or not np.all(np.isfinite(p_target)):
            raise ValueError(f"target must be a finite 3-vector in mm, got {np.asarray(target).shape}")
        lo, hi = self.joint_limits()
        rng = np.random.default_rng(seed)
        angle = np.ones(self.dof, dtype=bool)
        if self._has_feed:
            angle[0] = False
        start = np.zeros(self.dof) if q0 is None else np.array(q0, dtype=np.float64).reshape(-1)
        if start.shape != (self.dof,):
            raise ValueError(f"q0 must have shape ({self.dof},), got {start.shape}")
        lam2 = float(damping) ** 2
        best_q, best_err, total = start, math.inf, 0
        for attempt in range(restarts + 1):
            q = self.clip_to_limits(start if attempt == 0 else self.random_q(rng), respect_bend)
            checkpoint = math.inf
            for it in range(iterations):
                tip, J, _ = self._tip_and_jacobian(q)
                err_vec = p_target - tip[0]
                err = float(np.linalg.norm(err_vec))
                if err < best_err:
                    best_q, best_err = q.copy(), err
                if err <= tol:
                    return IKResult(best_q, True, best_err, total)
                if it % 25 == 24:
                    if err > 0.95 * checkpoint:
                        break
                    checkpoint = err
                total += 1
                Jp = J[0, :3]
                dq = Jp.T @ np.linalg.solve(Jp @ Jp.T + lam2 * np.eye(3), err_vec)
                blocked = ((q <= lo) & (dq < 0)) | ((q >= hi) & (dq > 0))
                if blocked.any():
                    Jf = Jp * ~blocked
                    dq = Jf.T @ np.linalg.solve(Jf @ Jf.T + lam2 * np.eye(3), err_vec)
                biggest = float(np.max(np.abs(dq[angle]), initial=0.0))
                if biggest > max_step:
                    dq *= max_step / biggest
                q = self.clip_to_limits(q + dq, respect_bend)
        return IKResult(best_q, False, best_err, total)

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict[str, Any]:
        """``snakeplan.robot/1`` dict (mm, rad, 1/mm) plus ``dof``, ``feed_range``, ``base``, the exact
        ``kinematics``, the motion ``limits`` and the ``cables`` (null when not cable-driven) so :meth:`from_dict`
        rebuilds this chain."""
        return {
            "schema": SCHEMA,
            "name": self._name,
            "sections": [s.to_dict() for s in self._sections],
            "k_ul": self._k_ul,
            "total_length": self.total_length,
            "dof": self.dof,
            "feed_range": None if self._feed is None else list(self._feed),
            "base": self._base.tolist(),
            "kinematics": self._kin.to_dict(),
            "limits": self._limits.to_dict(),
            "cables": None if self._cables is None else self._cables.to_dict(),
            "camera": self._camera.to_dict(),
        }

    @classmethod
    def from_dict(cls, d: Any) -> Chain:
        """Chain from a ``snakeplan.robot/1`` dict. Only ``name`` and ``sections`` are required; without
        ``kinematics`` the default structure is built; without ``limits``, ``DEFAULT_LIMITS`` (a partial
        ``limits`` object takes the rest from them). ValueError with a one-line message naming the field."""
        if not isinstance(d, Mapping):
            raise ValueError("robot: must be a JSON object")
        _known_keys("", d, ROBOT_KEYS)
        if "schema" in d and d["schema"] != SCHEMA:
            raise ValueError(f"schema: expected {SCHEMA!r}, got {d['schema']!r}")
        if "name" not in d:
            raise ValueError("name: missing")
        if not isinstance(d["name"], str) or not d["name"]:
            raise ValueError(f"name: must be a non-empty string, got {d['name']!r}")
        raw = d.get("sections")
        if raw is None:
            raise ValueError("sections: missing")
        if not isinstance(raw, Sequence) or isinstance(raw, str) or not raw:
            raise ValueError("sections: must be a non-empty list")
        sections = []
        for i, s in enumerate(raw):
            where = f"section {i}"
            if not isinstance(s, Mapping):
                raise ValueError(f"{where}: must be an object with length, radius, max_bend")
            _known_keys(f"{where}: ", s, SECTION_KEYS)
            for key in ("length", "radius", "max_bend"):
                if key not in s:
                    raise ValueError(f"{where}: {key} missing")
            fields = _check_section_fields(where, s["length"], s["radius"], s["max_bend"])
            if fields[2] < MIN_PLAUSIBLE_BEND_RAD:
                raise ValueError(f"{where}: max_bend {fields[2]:.4g} rad ({math.degrees(fields[2]):.3g} deg) is "
                                 f"implausibly small for a snake arm's section (under 1 deg); robot files state "
                                 f"angles in rad")
            mass = _check_mass(where, fields[0], fields[1], s.get("mass_kg"), s.get("com_mm"))
            sections.append(Section(*fields, *mass))
        k_ul = d.get("k_ul")
        if k_ul is not None:
            k_ul = _number("k_ul", "", k_ul)
        feed = d.get("feed_range")
        feed = None if feed is None else _feed_range(feed)
        base = _check_base(d.get("base"))
        kin = None if d.get("kinematics") is None else Kinematics.from_dict(d["kinematics"])
        limits = None if d.get("limits") is None else MotionLimits.from_dict(d["limits"], DEFAULT_LIMITS)
        cables = None if d.get("cables") is None else CableRouting.from_dict(d["cables"])
        camera = None if d.get("camera") is None else CameraModel.from_dict(d["camera"], TIP_CAMERA)
        chain = cls(sections, name=d["name"], feed_range=feed, base=base, k_ul=k_ul, kinematics=kin,
                    limits=limits, cables=cables, camera=camera)
        if "total_length" in d:
            total = _number("total_length", "", d["total_length"])
            if abs(total - chain.total_length) > _LENGTH_TOL * (1.0 + total):
                raise ValueError(f"total_length: {total} differs from the sum of section lengths {chain.total_length}")
        return chain


def _wrap(a: np.ndarray | float) -> np.ndarray:
    """Angles wrapped to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi
