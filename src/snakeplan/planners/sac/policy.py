"""Policy files (mm): :class:`NumpyPolicy`, the actor from a plain ``.npz`` weights file (no pickle, no torch), ~5 us
a call, checked before use (one ``policy: ...`` error names what is wrong); :func:`check_policy_fits`, whether a
policy fits a problem (another robot: refused; another scene family: a :class:`PolicyTransferWarning`); which
policy ships for a scene family (the scene spec's ``policies``, else the generalist; the files live in
``snakeplan/rl/data`` with the learning curve that made them, ``.curve.json``); and :func:`load_policy`, files
parsed once per content.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import warnings
from importlib.resources import files
from pathlib import Path

import numpy as np

from snakeplan import inputs
from snakeplan.files import atomic_path
from snakeplan.planners.sac.crawler import STEP_MM, TURN_RADIUS_MM, Crawler
from snakeplan.planners.sac.kernels import _actor_rows
from snakeplan.planners.sac.observation import (
    OBSERVATIONS,
    RoomGraph,
    action_dim,
    input_dim,
    observation_dim,
    policy_input,
)
from snakeplan.planners.weights import read_npz, read_weights_file
from snakeplan.robots import Chain, get_robot
from snakeplan.robots.arm_range import ARM_RANGE, ArmRange, outside
from snakeplan.scenes import Scene, SceneSpec, scene_spec

_GRAPH_KEYS = ("lo", "hi", "centre", "normal", "next_portal", "after")
#: What a policy file is held to besides its shapes: hidden layers, goal-capture steps, and the magnitude of weights
#: and of route-table coordinates (mm). A trained actor's weights are O(1) and a tank is metres across; past these
#: a roll-out's float arithmetic could overflow into NaN actions. Portal normals are unit vectors within UNIT_TOL.
MAX_HIDDEN_LAYERS = 16
MAX_CAPTURE_STEPS = 100
MAX_WEIGHT = 1e6
MAX_COORD_MM = 1e7
UNIT_TOL = 1e-6


class ArmRangeWarning(UserWarning):
    """An arm-conditioned policy plans for an arm outside the distribution it was trained over."""


class PolicyTransferWarning(UserWarning):
    """A policy planned in a scene family other than the one it was trained in: accepted, since it may transfer."""


def _bad(message: str) -> ValueError:
    return ValueError(f"policy: {message}")


def _at(name: str, index) -> str:
    return f"{name}[{', '.join(str(int(i)) for i in index)}]"


def _check_meta(meta) -> dict:
    """``meta`` after checking it is plain JSON data and the types and ranges of the keys a roll-out reads
    (:mod:`snakeplan.inputs`' checks; other keys are free-form)."""
    try:
        inputs.mapping(meta, "meta", required=("observation", "hidden_layers"), what="a JSON object")
        inputs.plain_json(meta, "meta")
        mode = inputs.text(meta["observation"], "meta.observation")
        if mode not in OBSERVATIONS:
            raise ValueError(f"meta.observation: must be one of {', '.join(OBSERVATIONS)}, got {inputs.show(mode)}")
        inputs.integer(meta["hidden_layers"], "meta.hidden_layers", 0, MAX_HIDDEN_LAYERS)
        step = inputs.length(meta.get("step_mm", STEP_MM), "meta.step_mm")
        radius = inputs.length(meta.get("turn_radius_mm", TURN_RADIUS_MM), "meta.turn_radius_mm")
        if step > math.pi * radius:
            raise ValueError(f"meta.turn_radius_mm: {radius:g} mm would turn a {step:g} mm step by more than half "
                             f"a turn")
        inputs.integer(meta.get("capture_steps", 0), "meta.capture_steps", 0, MAX_CAPTURE_STEPS)
        for key in ("lookahead", "residual", "arm_conditioned"):
            if type(meta.get(key, False)) is not bool:
                raise ValueError(f"meta.{key}: expected true or false, got {inputs.show(meta[key])}")
        for key in ("name", "scene", "algorithm", "robot"):
            if key in meta:
                inputs.text(meta[key], f"meta.{key}")
        if "arm" in meta:
            _check_arm(meta["arm"])
        if meta.get("arm_conditioned", False) and mode == "paper":
            raise ValueError("meta.arm_conditioned: the paper observation carries no arm features")
        if "arm_range" in meta:
            _check_arm_range(meta["arm_range"])
    except ValueError as exc:
        raise _bad(str(exc)) from None
    return meta


#: Most sections a policy file's ``meta.arm`` may list.
MAX_ARM_SECTIONS = 1000


def _check_arm(record) -> None:
    """``meta.arm`` (:func:`arm_record`): a name and, per section, a length and radius (mm) and a bend limit (rad)
    in lists of one size; ValueError naming the field."""
    inputs.mapping(record, "meta.arm", required=("name", "lengths", "radii", "max_bends"), what="a JSON object")
    inputs.text(record["name"], "meta.arm.name")
    sizes = set()
    for key in ("lengths", "radii", "max_bends"):
        values = record[key]
        if not isinstance(values, list) or not 0 < len(values) <= MAX_ARM_SECTIONS:
            raise ValueError(f"meta.arm.{key}: expected a list of 1 to {MAX_ARM_SECTIONS} numbers")
        for i, v in enumerate(values):
            if key == "max_bends" and not 0.0 < inputs.real(v, f"meta.arm.{key}[{i}]") <= math.pi:
                raise ValueError(f"meta.arm.{key}[{i}]: a bend limit must lie in (0, pi] rad, got {v!r}")
            if key != "max_bends":
                inputs.length(v, f"meta.arm.{key}[{i}]")
        sizes.add(len(values))
    if len(sizes) > 1:
        raise ValueError("meta.arm: lengths, radii and max_bends must list the same sections")


def _check_arm_range(ranges) -> None:
    """``meta.arm_range`` (:meth:`snakeplan.robots.arm_range.ArmRange.to_dict`): names of arm parameters, each
    with a [low, high] pair; ValueError naming the field."""
    inputs.mapping(ranges, "meta.arm_range", what="a JSON object")
    for key, pair in ranges.items():
        where = f"meta.arm_range.{key}"
        if key not in ArmRange.__dataclass_fields__:
            raise ValueError(f"{where}: unknown arm parameter (known: {', '.join(ArmRange.__dataclass_fields__)})")
        if not isinstance(pair, list) or len(pair) != 2 or inputs.real(pair[0], where) > inputs.real(pair[1], where):
            raise ValueError(f"{where}: expected [low, high], got {inputs.show(pair)}")


def _parse_meta(raw: np.ndarray | None) -> dict:
    """The ``meta`` array (a 0-d string of JSON) as a checked dict."""
    if raw is None:
        raise _bad("meta: missing (a JSON object naming the observation design and hidden_layers)")
    if raw.dtype.kind != "U" or raw.shape != ():
        raise _bad(f"meta: must be a JSON string (a 0-d unicode array), got a {raw.dtype} array of shape {raw.shape}")
    try:
        meta = inputs.load_json(str(raw), "meta")
    except ValueError as exc:
        raise _bad(str(exc)) from None
    return _check_meta(meta)


def _real_array(value, name: str, bound: float, shape: tuple | None = None, what: str = "") -> np.ndarray:
    """``value`` as float64 after checking it is a real (not boolean) numeric array of ``shape`` (None entries:
    any length) whose values are finite and within +-``bound``."""
    a = np.asarray(value)
    if a.dtype.kind not in "fiu":
        raise _bad(f"{name}: must hold real numbers, got dtype {a.dtype}")
    if shape is not None and (a.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, a.shape))):
        expected = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise _bad(f"{name}: shape {a.shape}, expected {expected}{what}")
    a = np.ascontiguousarray(a, dtype=float)
    finite = np.isfinite(a)
    if not finite.all():
        index = np.argwhere(~finite)[0]
        raise _bad(f"{_at(name, index)}: {a[tuple(index)]} is not a finite number")
    if np.any(np.abs(a) > bound):
        index = np.argwhere(np.abs(a) > bound)[0]
        raise _bad(f"{_at(name, index)}: {a[tuple(index)]:g} is beyond +-{bound:g}")
    return a


def _index_table(value, name: str, shape: tuple, low: int, high: int, what: str) -> np.ndarray:
    """``value`` as int64 after checking it is an integer array of ``shape`` with entries in ``low..high``."""
    a = np.asarray(value)
    if a.dtype.kind not in "iu":
        raise _bad(f"{name}: must be an integer array, got dtype {a.dtype}")
    if a.shape != shape:
        raise _bad(f"{name}: shape {a.shape}, expected {shape} (rooms x rooms)")
    wrong = (a < low) | (a > high)
    if wrong.any():
        index = np.argwhere(wrong)[0]
        raise _bad(f"{_at(name, index)}: {int(a[tuple(index)])} is not {what} ({low}..{high})")
    return np.ascontiguousarray(a, dtype=np.int64)


def _check_graph(graph: RoomGraph) -> RoomGraph:
    """``graph`` with float64 / int64 arrays, after checking that every route-table index is in range (the roll-out
    reads them unchecked), rooms are boxes with min <= max, and portal normals are unit vectors."""
    lo = _real_array(graph.lo, "graph_lo", MAX_COORD_MM, (None, 3))
    rooms = lo.shape[0]
    if rooms == 0:
        raise _bad("graph_lo: no rooms (route tables need at least one)")
    hi = _real_array(graph.hi, "graph_hi", MAX_COORD_MM, (rooms, 3), " (one row per room of graph_lo)")
    if np.any(lo > hi):
        index = np.argwhere(lo > hi)[0]
        raise _bad(f"{_at('graph_lo', index)}: {lo[tuple(index)]:g} is above graph_hi's {hi[tuple(index)]:g}")
    centre = _real_array(graph.centre, "graph_centre", MAX_COORD_MM, (None, 3))
    portals = centre.shape[0]
    normal = _real_array(graph.normal, "graph_normal", 1.0 + UNIT_TOL, (portals, 3),
                         " (one row per portal of graph_centre)")
    off = np.abs(np.linalg.norm(normal, axis=1) - 1.0) > UNIT_TOL
    if off.any():
        raise _bad(f"graph_normal[{int(np.argmax(off))}]: must be a unit vector")
    nxt = _index_table(graph.next_portal, "graph_next_portal", (rooms, rooms), -1, portals - 1,
                       "a portal index or -1")
    if np.any(np.diagonal(nxt) != -1):
        room = int(np.argmax(np.diagonal(nxt) != -1))
        raise _bad(f"graph_next_portal[{room}, {room}]: the route from a room to itself has no portal (-1)")
    after = _index_table(graph.after, "graph_after", (rooms, rooms), 0, rooms - 1, "a room index")
    return RoomGraph(lo, hi, centre, normal, nxt, after)


class NumpyPolicy:
    """Deterministic actor from plain weights: hidden ReLU layers ``(w_i, b_i)``, mean head, tanh.

    A policy file is an ``.npz`` of ``w0, b0, ..., mu_w, mu_b``, optional route tables ``graph_*``, and ``meta``
    (a JSON string: scene, robot, algorithm, observation design, crawl settings, training command); read without
    pickle. Every policy is checked when made (:meth:`load` adds the file's arrays): ValueError ``policy: ...``
    names what is wrong. ``meta`` is plain JSON (finite numbers, valid text) holding ``observation`` (one of
    :data:`OBSERVATIONS`) and ``hidden_layers`` (0 to ``MAX_HIDDEN_LAYERS``); optionally ``step_mm`` and
    ``turn_radius_mm`` (lengths as :func:`snakeplan.inputs.length` takes them; a step turns by at most half a
    turn), ``capture_steps`` (0 to ``MAX_CAPTURE_STEPS``), boolean ``lookahead``, and names ``name``, ``scene``,
    ``algorithm``, ``robot``, and the trained ``arm`` (:func:`_check_arm`); other keys are free-form. The layers
    chain from the input :func:`policy_input` makes for the design (and look-ahead) to :func:`action_dim`
    outputs, with real, finite weights within ``MAX_WEIGHT``; route tables: see :func:`_check_graph`.
    """

    def __init__(self, layers: list[tuple[np.ndarray, np.ndarray]], mu: tuple[np.ndarray, np.ndarray], meta: dict,
                 graph: RoomGraph | None = None):
        meta = _check_meta(meta)
        mode = meta["observation"]
        lookahead = bool(meta.get("lookahead", False)) and mode != "paper"
        if len(layers) != meta["hidden_layers"]:
            raise _bad(f"meta.hidden_layers: {meta['hidden_layers']}, but the network has {len(layers)}")
        conditioned = bool(meta.get("arm_conditioned", False))
        width = input_dim(mode, observation_dim(mode, lookahead, conditioned))
        feeds = (f" (the input of the {mode} observation{' with look-ahead' if lookahead else ''}"
                 f"{' and the arm' if conditioned else ''})")
        checked = []
        for i, (w, b) in enumerate([*layers, mu]):
            name = f"w{i}" if i < len(layers) else "mu_w"
            rows = None if i < len(layers) else action_dim(mode)
            w = _real_array(w, name, MAX_WEIGHT, (rows, width), feeds)
            bias = "b" + name[1:] if i < len(layers) else "mu_b"
            checked.append((w, _real_array(b, bias, MAX_WEIGHT, (w.shape[0],), f" (one per row of {name})")))
            if w.shape[0] == 0:
                raise _bad(f"{name}: a layer needs at least one unit")
            width, feeds = w.shape[0], f" (to follow {name})"
        self.layers = checked[:-1]
        self.mu = checked[-1]
        self.shapes = np.array([w.shape for w, _ in checked], dtype=np.int64)
        widest = int(max(self.shapes.max(), 1))
        self.weights = np.zeros((len(checked), widest, widest))  # the compiled actor's form (:func:`_actor`)
        self.biases = np.zeros((len(checked), widest))
        for i, (w, b) in enumerate(checked):
            self.weights[i, :w.shape[1], :w.shape[0]] = w.T
            self.biases[i, :b.shape[0]] = b
        self.meta = meta
        self.graph = None if graph is None else _check_graph(graph)
        self.mode = mode

    @classmethod
    def load(cls, path: str | Path | io.BytesIO) -> NumpyPolicy:
        """The policy in a file (or its bytes in a BytesIO), checked; ValueError ``policy: ...`` when it is not one."""
        data = path.getvalue() if isinstance(path, io.BytesIO) else read_weights_file(path, "policy")
        return cls.from_bytes(data)

    @classmethod
    def from_bytes(cls, data: bytes) -> NumpyPolicy:
        """The policy in a file's bytes: the arrays the meta's ``hidden_layers`` names, all six route tables or none,
        nothing else."""
        arrays = read_npz(data, "policy")
        meta = _parse_meta(arrays.pop("meta", None))
        names = [f"{p}{i}" for i in range(meta["hidden_layers"]) for p in "wb"] + ["mu_w", "mu_b"]
        missing = [k for k in names if k not in arrays]
        if missing:
            raise _bad(f"{missing[0]}: missing (meta.hidden_layers = {meta['hidden_layers']} needs "
                       f"{', '.join(names)})")
        tables = [f"graph_{k}" for k in _GRAPH_KEYS]
        given = [k for k in tables if k in arrays]
        if given and len(given) < len(tables):
            absent = next(k for k in tables if k not in arrays)
            raise _bad(f"{absent}: missing (route tables come all together: {', '.join(tables)})")
        extra = sorted(set(arrays) - set(names) - set(tables))
        if extra:
            name = extra[0] if extra[0].isidentifier() else inputs.show(extra[0])
            raise _bad(f"{name}: unexpected array (a policy file holds meta, {', '.join(names)} and "
                       f"optionally the graph_* route tables)")
        layers = [(arrays[f"w{i}"], arrays[f"b{i}"]) for i in range(meta["hidden_layers"])]
        graph = RoomGraph.from_arrays({k: arrays[f"graph_{k}"] for k in _GRAPH_KEYS}) if given else None
        return cls(layers, (arrays["mu_w"], arrays["mu_b"]), meta, graph)

    def save(self, path: str | Path) -> None:
        arrays = {"meta": np.array(json.dumps({**self.meta, "hidden_layers": len(self.layers)}))}
        for i, (w, b) in enumerate(self.layers):
            arrays[f"w{i}"], arrays[f"b{i}"] = w.astype(np.float32), b.astype(np.float32)
        arrays["mu_w"], arrays["mu_b"] = self.mu[0].astype(np.float32), self.mu[1].astype(np.float32)
        if self.graph is not None:
            arrays.update({f"graph_{k}": v for k, v in self.graph.arrays().items()})
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)

    def act(self, obs: dict) -> np.ndarray:
        """tanh(mu(features)) for one observation dict (or a batch), by the compiled actor the roll-outs use."""
        h = policy_input(obs["observation"], obs["achieved_goal"], obs["desired_goal"], self.mode, self.graph)
        rows = np.ascontiguousarray(h.reshape(-1, h.shape[-1]))
        out = np.empty((rows.shape[0], self.shapes[-1, 0]))
        _actor_rows(rows, self.weights, self.biases, self.shapes, out)
        return out.reshape(*h.shape[:-1], out.shape[1])

    def crawler(self, robot: Chain, check_body: bool = True) -> Crawler:
        """A crawler with the settings this policy was trained with (no goal capture or look-ahead when the file
        predates them)."""
        return Crawler(robot, self.mode, self.step_mm,
                       self.meta.get("turn_radius_mm", TURN_RADIUS_MM), check_body, self.meta.get("capture_steps", 0),
                       self.meta.get("lookahead", False), self.meta.get("residual", False), self.arm_conditioned)

    @property
    def step_mm(self) -> float:
        """The tip's advance (mm) per action of the crawl this policy was trained on."""
        return float(self.meta.get("step_mm", STEP_MM))

    @property
    def arm_conditioned(self) -> bool:
        """Whether the policy observes the arm it plans for (trained over a distribution of arms)."""
        return bool(self.meta.get("arm_conditioned", False))

    def pursuit_only(self) -> NumpyPolicy:
        """This residual guide policy with its mean head zeroed: its crawl follows the pursuit of the guide alone
        (plus any action noise). ValueError for a policy whose crawl does not pursue its guide."""
        if not (self.mode == "guide" and self.meta.get("residual", False)):
            raise ValueError("policy: only a residual guide policy's crawl pursues its guide")
        w, b = self.mu
        return NumpyPolicy(self.layers, (np.zeros_like(w), np.zeros_like(b)), self.meta, self.graph)


def trained_robot(policy: NumpyPolicy) -> str | None:
    """The robot a policy was trained for: its meta's ``robot``, else (files from before it was recorded) the robot
    of its meta's scene family's spec; None when neither is known."""
    if "robot" in policy.meta:
        return policy.meta["robot"]
    family = policy.meta.get("scene")
    try:
        return scene_spec(family).robot if family is not None else None
    except KeyError:
        return None


def arm_record(robot: Chain) -> dict:
    """What a policy file records of the arm it was trained for (its ``meta.arm``): name, and each section's length
    (mm), radius (mm) and bend limit (rad)."""
    return {"name": robot.name, "lengths": robot.lengths.tolist(), "radii": robot.radii.tolist(),
            "max_bends": robot.max_bends.tolist()}


def fits_arm(record: dict, robot: Chain) -> bool:
    """Whether ``robot`` is the arm of ``record`` (:func:`arm_record`): the same sections, lengths, radii and bend
    limits (to 1e-6); the record is checked when its policy is made (:func:`_check_arm`)."""
    mine = {k: np.asarray(record[k], dtype=float) for k in ("lengths", "radii", "max_bends")}
    theirs = {"lengths": robot.lengths, "radii": robot.radii, "max_bends": robot.max_bends}
    return all(mine[k].shape == theirs[k].shape and np.allclose(mine[k], theirs[k], rtol=0.0, atol=1e-6)
               for k in mine)


def _describe(record: dict) -> str:
    """An arm in a line: its name, sections, length, thickest radius and tightest bend limit."""
    lengths = np.asarray(record["lengths"], dtype=float)
    return (f"{record['name']} ({lengths.size} sections, {lengths.sum():g} mm, radius {max(record['radii']):g} mm, "
            f"bend limit {math.degrees(min(record['max_bends'])):.3g} deg)")


def arm_refusal(policy: NumpyPolicy, robot: Chain) -> str | None:
    """Why ``policy`` cannot plan for ``robot`` (see :func:`check_policy_fits`), or None."""
    if policy.arm_conditioned:
        return None
    if "arm" in policy.meta:
        record = policy.meta["arm"]
        if fits_arm(record, robot):
            return None
        return (f"trained for {_describe(record)}, planning with {_describe(arm_record(robot))}: a policy plans for "
                f"the arm it was trained on (train one for this arm: snakeplan train rl ... --robot FILE)")
    trained = trained_robot(policy)
    if trained is None:
        return None
    try:
        theirs = get_robot(trained)
    except KeyError:
        theirs = None
    if theirs is None and trained != robot.name:
        return f"trained for robot {trained}, which is not registered here; planning with {robot.name}"
    if theirs is not None and (theirs.n_sections != robot.n_sections or not np.allclose(theirs.lengths, robot.lengths)):
        return (f"trained for {trained} ({theirs.n_sections} sections, {theirs.total_length:g} mm), planning with "
                f"{robot.name} ({robot.n_sections} sections, {robot.total_length:g} mm): a policy plans for the arm "
                f"it was trained on")
    return None


def check_policy_fits(policy: NumpyPolicy, scene: Scene, robot: Chain) -> None:
    """The rule for planning with a policy outside what it was trained for.

    Another arm is refused (ValueError ``policy: ...`` naming both): the observation (inserted fraction), the
    step and the crawl depend on the arm, so the planning robot must be the arm the file records (``meta.arm``,
    :func:`fits_arm`), or, in files from before it was recorded, have the section count and lengths of the
    trained robot (see :func:`trained_robot`; when that is no registered preset, its name), and be longer than
    one step. A policy that names no robot or family is not checked for it. An arm-conditioned policy plans any
    arm, with an :class:`ArmRangeWarning` per parameter outside the distribution it was trained over
    (``meta.arm_range``, :func:`snakeplan.robots.arm_range.outside`). Another scene family is accepted with a
    :class:`PolicyTransferWarning` (a policy may transfer; its route tables stay those of its own family).
    """
    if policy.arm_conditioned:
        for line in outside(robot, policy.meta.get("arm_range", ARM_RANGE.to_dict())):
            warnings.warn(f"policy: {robot.name}: {line} of the arm-conditioned policy", ArmRangeWarning,
                          stacklevel=3)
    refusal = arm_refusal(policy, robot)
    if refusal is not None:
        raise _bad(refusal)
    step = policy.step_mm
    if step > robot.total_length:
        raise _bad(f"meta.step_mm: a {step:g} mm step is longer than {robot.name} ({robot.total_length:g} mm)")
    if robot.total_length / step > MAX_ROLLOUT_STEPS:
        raise _bad(f"meta.step_mm: a {step:g} mm step makes {robot.total_length / step:.3g} steps of {robot.name} "
                   f"({robot.total_length:g} mm) per roll-out, more than the limit of {MAX_ROLLOUT_STEPS:,}")
    family = policy.meta.get("scene")
    if family is not None and scene.name not in family.split("+"):
        warnings.warn(f"policy: trained in {family}, planning in {scene.name}", PolicyTransferWarning, stacklevel=3)


#: The most steps a roll-out may take (the arm's length over the policy's step): a roll-out allocates its noise and
#: path per step, so a size read from a file is bounded before anything is allocated.
MAX_ROLLOUT_STEPS = 100_000


#: The generalist policy (the residual ``guide`` design, trained with sensed knowledge on the ``confined`` family
#: and both tanks): the planners in ``GENERALIST_PLANNERS`` plan with it wherever a scene's family ships no policy
#: of its own for them.
GENERALIST = ("snakeplan", "rl/data/generalist.npz")
GENERALIST_PLANNERS = ("sac", "sac-her", "sac-per")
#: The arm-conditioned generalist (the same design, trained over the distribution of arms of
#: :mod:`snakeplan.robots.arm_range`): what those planners plan with for an arm no other policy they would use was
#: trained for.
ARM_GENERALIST = ("snakeplan", "rl/data/generalist-arms.npz")


def generalist_path(which: tuple[str, str] = GENERALIST) -> Path | None:
    """The generalist policy's file (``which``: :data:`GENERALIST` or :data:`ARM_GENERALIST`), or None when this
    installation has none."""
    path = Path(str(files(which[0]).joinpath(*which[1].split("/"))))
    return path if path.is_file() else None


#: The shipped generalists by the names ``policy=`` takes.
GENERALISTS = {"generalist": GENERALIST, "generalist-arms": ARM_GENERALIST}


def shipped_policy(spec: SceneSpec, planner: str) -> Path | None:
    """The policy ``planner`` plans with by default in ``spec``'s family: the family's own, else the generalist
    (for :data:`GENERALIST_PLANNERS`, when it is installed), else None."""
    own = spec.policy_path(planner)
    return own if own is not None or planner not in GENERALIST_PLANNERS else generalist_path()


def policy_path(scene_name: str, planner: str) -> Path | None:
    """The policy ``planner`` plans with by default in a registered scene family (:func:`shipped_policy`)."""
    return shipped_policy(scene_spec(scene_name), planner)


_POLICIES: dict[str, NumpyPolicy] = {}
_SEEN: dict[tuple, NumpyPolicy] = {}


def load_policy(path: str | Path) -> NumpyPolicy:
    """A policy file, parsed and checked once per content: keyed by the hash of its bytes, not its path, so a file
    that training rewrites in place (``--out DIR/policy.npz``) is read again; ValueError ``policy: ...`` when the
    file is missing or not a valid policy. A file whose path, inode, size and modification time were seen before
    is not read again (a plan in milliseconds should not hash its policy file)."""
    try:
        info = os.stat(path)
        seen = (os.fspath(path), info.st_ino, info.st_size, info.st_mtime_ns)
    except OSError:
        seen = None
    if seen in _SEEN:
        return _SEEN[seen]
    data = read_weights_file(path, "policy")
    key = hashlib.sha256(data).hexdigest()
    if key not in _POLICIES:
        _POLICIES[key] = NumpyPolicy.from_bytes(data)
    if seen is not None:
        _SEEN[seen] = _POLICIES[key]
    return _POLICIES[key]

