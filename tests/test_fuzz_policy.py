"""Policy files from anyone: a malformed one is refused with one `--policy:` line (exit 2), never a crash.

Hypothesis mutates the shipped policies (fuel-tank sac-her, oil-tank sac-per) and SSCC agents (sscc-16, sscc-24):
truncation, random bytes, flipped bytes, missing and extra arrays, wrong shapes and dtypes, NaN/inf weights,
route-table indices out of range, bad meta JSON and types. `snakeplan plan ... --policy FILE` (sac-her in the fuel
tank, sac-per in the oil tank, sscc in the pipe) runs in a subprocess with a timeout (an out-of-range route index
used to segfault the process); the loaders (``NumpyPolicy.from_bytes`` with ``check_policy_fits``,
``SwingAgent.load``) also run in-process, many more times. Each fuzz test counts inputs tried, clean rejections,
tracebacks, hangs, crashes (exit by a signal) and wrong acceptances, and prints them (``-s``); a bounded slice runs
by default, the long run with ``-m slow``.
"""

from __future__ import annotations

import io
import itertools
import json
import os
import subprocess
import sys
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from snakeplan.cli import main
from snakeplan.planners import Problem, get_planner
from snakeplan.planners.sac import NumpyPolicy, PolicyTransferWarning, check_policy_fits, policy_path
from snakeplan.planners.sscc.agent import SwingAgent, shipped_agent_path
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene

SRC = Path(__file__).resolve().parents[1] / "src"
#: The shipped policies: scene family -> (planner, file).
POLICIES = {family: (planner, policy_path(family, planner)) for family, planner in
            (("fuel-tank", "sac-her"), ("oil-tank", "sac-per"))}
AGENTS = {robot: shipped_agent_path(robot) for robot in ("sscc-16", "sscc-24")}
#: A subprocess that runs longer than this hangs (planning itself is given PLAN_BUDGET_S).
CLI_TIMEOUT_S = 120
PLAN_BUDGET_S = "5"
REJECT, ACCEPT, EITHER = "reject", "accept", "either"
FLOAT_POLICY_KEYS = ("w0", "b0", "w1", "b1", "mu_w", "mu_b", "graph_lo", "graph_hi", "graph_centre", "graph_normal")
INDEX_KEYS = ("graph_next_portal", "graph_after")


def _arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


SHIPPED = {family: _arrays(path) for family, (_, path) in POLICIES.items()}
SHIPPED_AGENTS = {robot: _arrays(path) for robot, path in AGENTS.items()}


def _npz(arrays: dict, compressed: bool = False) -> bytes:
    """An .npz of ``arrays`` (object arrays are pickled into it, as np.savez does by default)."""
    buf = io.BytesIO()
    (np.savez_compressed if compressed else np.savez)(buf, **arrays)
    return buf.getvalue()


def _meta(family: str) -> dict:
    return json.loads(str(SHIPPED[family]["meta"]))


def _with_meta(family: str, meta) -> dict:
    return {**SHIPPED[family], "meta": np.array(meta if isinstance(meta, str) else json.dumps(meta))}


# --- mutations: each draws (label, file bytes, expectation) from a shipped file's arrays ---------------------
def _truncated(draw, arrays, raw):
    k = draw(st.integers(0, len(raw) - 1))
    return f"truncated to {k} of {len(raw)} bytes", raw[:k], REJECT


def _random_bytes(draw, arrays, raw):
    head = draw(st.sampled_from([b"", b"PK\x03\x04", b"PK\x05\x06", b"\x93NUMPY\x01\x00", b"\x80\x04\x95"]))
    return f"random bytes after {head!r}", head + draw(st.binary(max_size=2048)), REJECT


def _flipped(draw, arrays, raw):
    spots = draw(st.lists(st.integers(0, len(raw) - 1), min_size=1, max_size=6, unique=True))
    data = bytearray(raw)
    for i in spots:
        data[i] ^= draw(st.integers(1, 255))
    return f"bytes flipped at {spots}", bytes(data), EITHER  # a flipped timestamp leaves a valid file


def _missing(draw, arrays, raw):
    key = draw(st.sampled_from(sorted(arrays)))
    return f"without {key}", _npz({k: v for k, v in arrays.items() if k != key}), REJECT


def _extra(draw, arrays, raw):
    name = draw(st.from_regex(r"\A[a-z_][a-z0-9_.]{0,10}\Z").filter(lambda n: n not in arrays))
    value = draw(st.sampled_from([np.zeros(3), np.array(1.0), np.ones((2, 2), np.float32), np.arange(4)]))
    return f"extra array {name!r}", _npz({**arrays, name: value}), REJECT


def _reshape(a: np.ndarray, how: str) -> np.ndarray | None:
    if how == "add axis":
        return a[None]
    if a.ndim == 0 or (how in ("drop column", "add column", "flatten") and a.ndim != 2):
        return None
    return {"drop row": lambda: a[:-1], "add row": lambda: np.concatenate([a, a[-1:]]),
            "drop column": lambda: a[:, :-1], "add column": lambda: np.concatenate([a, a[:, -1:]], axis=1),
            "flatten": lambda: a.reshape(-1)}[how]()


def _wrong_shape(draw, arrays, raw):
    key = draw(st.sampled_from(sorted(arrays)))
    how = draw(st.sampled_from(["drop row", "add row", "drop column", "add column", "flatten", "add axis"]))
    changed = _reshape(arrays[key], how)
    if changed is None:
        how, changed = "add axis", arrays[key][None]
    return f"{key} {how} {arrays[key].shape} -> {changed.shape}", _npz({**arrays, key: changed}), REJECT


def _wrong_dtype(draw, arrays, raw):
    key = draw(st.sampled_from(sorted(arrays)))
    a = arrays[key]
    if a.dtype.kind == "U":  # the meta string
        options = {"bytes": lambda: np.char.encode(a, "utf-8"), "object": lambda: np.array(str(a), dtype=object),
                   "number": lambda: np.array(5.0), "list of strings": lambda: a[None]}
    else:
        options = {"complex": lambda: a.astype(complex), "bool": lambda: a.astype(bool),
                   "str": lambda: a.astype("U12"), "bytes": lambda: a.astype("S12"),
                   "object": lambda: a.astype(object)}
        if a.dtype.kind in "iu":
            options["float"] = lambda: a.astype(float)  # a route index must be an integer
    name = draw(st.sampled_from(sorted(options)))
    return f"{key} as {name}", _npz({**arrays, key: options[name]()}), REJECT


def _set_one(draw, a: np.ndarray, value) -> tuple[np.ndarray, tuple]:
    index = np.unravel_index(draw(st.integers(0, a.size - 1)), a.shape)
    out = a.copy()
    out[index] = value
    return out, tuple(int(i) for i in index)


def _nonfinite(draw, arrays, raw):
    key = draw(st.sampled_from([k for k in arrays if k.endswith(("weight", "bias")) or k in FLOAT_POLICY_KEYS]))
    value = draw(st.sampled_from([np.nan, np.inf, -np.inf, 1e300, -1e300]))
    changed, index = _set_one(draw, arrays[key].astype(float), value)
    return f"{key}{list(index)} = {value}", _npz({**arrays, key: changed}), REJECT


def _bad_index(draw, arrays, raw):
    """A route-table entry that is no portal (next_portal: -1 or 0..P-1) or no room (after: 0..R-1)."""
    rooms, portals = arrays["graph_lo"].shape[0], arrays["graph_centre"].shape[0]
    key = draw(st.sampled_from(INDEX_KEYS))
    low, high = (-1, portals - 1) if key == "graph_next_portal" else (0, rooms - 1)
    value = draw(st.one_of(st.sampled_from([10**9, -10**9, 99, high + 1, low - 1, 2**62, -2**62]),
                           st.integers(high + 1, 2**62), st.integers(-2**62, low - 1)))
    changed, index = _set_one(draw, arrays[key], value)
    return f"{key}{list(index)} = {value}", _npz({**arrays, key: changed}), REJECT


def _bad_tables(draw, arrays, raw):
    """Tables that index fine but contradict themselves: a room's route to itself through a portal, a room whose
    min exceeds its max."""
    room = draw(st.integers(0, arrays["graph_lo"].shape[0] - 1))
    if draw(st.booleans()):
        table = arrays["graph_next_portal"].copy()
        table[room, room] = draw(st.integers(0, arrays["graph_centre"].shape[0] - 1))
        return f"graph_next_portal[{room}, {room}] a portal", _npz({**arrays, "graph_next_portal": table}), REJECT
    lo, hi = arrays["graph_lo"].copy(), arrays["graph_hi"].copy()
    lo[room], hi[room] = arrays["graph_hi"][room], arrays["graph_lo"][room]
    return f"room {room} min and max swapped", _npz({**arrays, "graph_lo": lo, "graph_hi": hi}), REJECT


#: Meta values that are wrong by type or meaning, by key.
BAD_META_VALUES = {
    "observation": ["global", "", 5, None, ["local"], True],
    "hidden_layers": [-1, 1, 3, 2.0, True, "2", None, 10**400],
    "step_mm": [0, -35, "35", True, None, [35.0], float("inf"), float("nan"), 10**400, 1e9],
    "turn_radius_mm": [0, -240.0, "240", False, None, float("inf"), 1e-6],
    "capture_steps": [-1, 1.5, True, "4", None, 10**400],
    "lookahead": [1, "yes", None],
    "scene": ["", 5, None, [], {}],
    "robot": ["", 5, None, "sscc-24", "hsr-10", "no-such-robot"],
    "name": ["", 7, None],
}
BAD_META_TEXTS = ["5", "[]", '"local"', "null", "", "{", '{"observation": NaN}', "[" * 1000 + "]" * 1000,
                  '{"observation": "local", "hidden_layers": ' + "9" * 5000 + "}", "1e400"]


def _bad_meta(draw, arrays, raw):
    family = "fuel-tank" if arrays["w0"].shape[1] == SHIPPED["fuel-tank"]["w0"].shape[1] else "oil-tank"
    if draw(st.booleans()):
        text = draw(st.sampled_from(BAD_META_TEXTS))
        return f"meta {text[:20]!r}", _npz({**arrays, "meta": np.array(text)}), REJECT
    key = draw(st.sampled_from(sorted(BAD_META_VALUES)))
    values = BAD_META_VALUES[key] + ([not _meta(family).get("lookahead", False)] if key == "lookahead" else [])
    values += ["paper"] if key == "observation" else []  # a real design the file's network does not fit
    value = draw(st.sampled_from(values))
    return f"meta.{key} = {str(value)[:20]}", _npz(_with_meta(family, {**_meta(family), key: value})), REJECT


def _benign(draw, arrays, raw):
    """Valid variations: they must plan (exit 0 or 1)."""
    family = "fuel-tank" if arrays["w0"].shape[1] == SHIPPED["fuel-tank"]["w0"].shape[1] else "oil-tank"
    how = draw(st.sampled_from(["float64 and uncompressed", "int32 route tables", "an unknown meta key"]))
    if how == "float64 and uncompressed":
        changed = {k: v.astype(float) if v.dtype.kind == "f" else v for k, v in arrays.items()}
    elif how == "int32 route tables":
        changed = {**arrays, **{k: arrays[k].astype(np.int32) for k in INDEX_KEYS}}
    else:
        changed = _with_meta(family, {**_meta(family), "comment": "from a colleague"})
    return how, _npz(changed, compressed=how != "float64 and uncompressed"), ACCEPT


def _benign_agent(draw, arrays, raw):
    """An agent saved as float64, compressed or not: it must plan (exit 0 or 1)."""
    compressed = draw(st.booleans())
    data = _npz({k: v.astype(float) for k, v in arrays.items()}, compressed=compressed)
    return f"float64{' compressed' if compressed else ''}", data, ACCEPT


POLICY_MUTATIONS = (_truncated, _random_bytes, _flipped, _missing, _extra, _wrong_shape, _wrong_dtype, _nonfinite,
                    _bad_index, _bad_tables, _bad_meta)
AGENT_MUTATIONS = (_truncated, _random_bytes, _flipped, _missing, _extra, _wrong_shape, _wrong_dtype, _nonfinite)


# --- running and counting ----------------------------------------------------------------------------------
class Tally:
    """Outcomes of fuzzed inputs, and what went wrong with which."""

    KEYS = ("tried", "clean rejections", "accepted as expected", "tracebacks", "hangs", "crashes",
            "wrong acceptances", "wrong rejections", "unclear messages")

    def __init__(self, what: str):
        self.what, self.counts, self.failures = what, Counter(), []

    def add(self, outcome: str, label: str, detail: str = "") -> None:
        self.counts["tried"] += 1
        self.counts[outcome] += 1
        if outcome not in ("clean rejections", "accepted as expected"):
            self.failures.append(f"{outcome}: {label}: {detail[-400:]}")

    def report(self) -> str:
        return f"{self.what}: " + ", ".join(f"{k} {self.counts[k]}" for k in self.KEYS)

    def check(self) -> None:
        print(self.report())
        assert not self.failures, "\n".join(self.failures[:20])


def plan_cli(target: str, policy: Path) -> tuple[int | None, str, str]:
    """``snakeplan plan`` in a subprocess with ``--policy``: a learned planner's policy in its scene family
    (``target`` a family), or an SSCC agent in the pipe (``target`` its robot): (exit status, or None when it hung;
    stdout; stderr)."""
    if target in AGENTS:
        where = ["--scene", "pipe", "--planner", "sscc", "--robot", target]
    else:
        where = ["--scene", target, "--planner", POLICIES[target][0]]
    cmd = [sys.executable, "-m", "snakeplan.cli", "plan", *where, "--policy", str(policy), "--time-limit",
           PLAN_BUDGET_S]
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    try:
        done = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=CLI_TIMEOUT_S, env=env)
    except subprocess.TimeoutExpired:
        return None, "", ""
    return done.returncode, done.stdout, done.stderr


def classify_cli(rc: int | None, stderr: str, expect: str) -> str:
    lines = stderr.splitlines()
    errors = [line for line in lines if line.startswith("snakeplan: error:")]
    if rc is None:
        return "hangs"
    if rc < 0:
        return "crashes"
    if "Traceback" in stderr:
        return "tracebacks"
    if rc == 2:
        clean = (len(lines) == 1 and lines[0].startswith("snakeplan: error: --policy: ")
                 and "pickle" not in stderr.lower())
        if not clean:
            return "unclear messages"
        return "wrong rejections" if expect == ACCEPT else "clean rejections"
    if expect == REJECT:
        return "wrong acceptances"
    ok = rc in (0, 1) and not errors and all(line.startswith("snakeplan: warning: ") for line in lines)
    return "accepted as expected" if ok else "unclear messages"


def load_in_process(data: bytes, family: str) -> str:
    """Whether the policy in ``data`` is accepted for planning its family's scene (checked, not rolled out)."""
    try:
        policy = NumpyPolicy.from_bytes(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PolicyTransferWarning)
            check_policy_fits(policy, make_scene(family, 0), get_robot("sjtu-snake-iii"))
    except ValueError as exc:
        message = str(exc)
        clean = message.startswith("policy: ") and "\n" not in message and "pickle" not in message.lower()
        return "clean rejections" if clean else "unclear messages"
    except Exception as exc:  # noqa: BLE001 - any other exception is what this test counts
        return f"tracebacks ({type(exc).__name__}: {exc})"
    return "accepted"


def load_agent_in_process(data: bytes, robot: str, tmp: Path) -> str:
    path = tmp / f"{robot}.npz"
    path.write_bytes(data)
    try:
        SwingAgent.load(robot, path)
    except ValueError as exc:
        message = str(exc)
        clean = message.startswith("agent_path: ") and "\n" not in message and "pickle" not in message.lower()
        return "clean rejections" if clean else "unclear messages"
    except Exception as exc:  # noqa: BLE001
        return f"tracebacks ({type(exc).__name__}: {exc})"
    return "accepted"


def _settings(examples: int, derandomize: bool):
    return settings(max_examples=examples, deadline=None, derandomize=derandomize, database=None,
                    phases=[Phase.explicit, Phase.generate], suppress_health_check=list(HealthCheck))


#: The CLI fuzz's kinds of mutation: a policy's, an agent's, ... (valid variations included; the default slice
#: runs the first 15).
_CLI_POLICY = (_bad_index, _random_bytes, _truncated, _bad_meta, _nonfinite, _missing, _wrong_dtype, _benign,
               _bad_tables, _extra, _wrong_shape, _flipped)
_CLI_AGENT = (_truncated, _random_bytes, _nonfinite, _wrong_shape, _benign_agent, _missing, _wrong_dtype, _extra,
              _flipped)
CLI_KINDS = [kind for pair in itertools.zip_longest([("policy", m) for m in _CLI_POLICY],
                                                    [("agent", m) for m in _CLI_AGENT])
             for kind in pair if kind is not None]


def fuzz_cli(examples: int, kinds: list, derandomize: bool, tmp: Path) -> Tally:
    """Each example runs one command per kind of mutation in ``kinds`` (from :data:`CLI_KINDS`), each with its
    mutated file through the CLI in a subprocess."""
    tally = Tally("plan --policy in a subprocess")

    @_settings(examples, derandomize)
    @given(st.data())
    def run(data):
        for i, (what, mutate) in enumerate(kinds):
            if what == "policy":
                target = data.draw(st.sampled_from(sorted(POLICIES)))
                arrays, raw = SHIPPED[target], POLICIES[target][1].read_bytes()
            else:
                target = data.draw(st.sampled_from(sorted(AGENTS)))
                arrays, raw = SHIPPED_AGENTS[target], AGENTS[target].read_bytes()
            label, content, expect = mutate(data.draw, arrays, raw)
            path = tmp / f"{what}-{i}.npz"
            path.write_bytes(content)
            rc, _, stderr = plan_cli(target, path)
            tally.add(classify_cli(rc, stderr, expect), f"{target}: {label}", stderr)
            path.unlink()

    run()
    return tally


def fuzz_in_process(examples: int, derandomize: bool, tmp: Path) -> tuple[Tally, Tally]:
    """Policy and SSCC agent mutations through their loaders, in this process (no roll-out)."""
    policies, agents = Tally("policy files, loaded in-process"), Tally("SSCC agent files, loaded in-process")

    def count(tally: Tally, outcome: str, expect: str, label: str) -> None:
        if outcome == "accepted":
            outcome = "wrong acceptances" if expect == REJECT else "accepted as expected"
        elif outcome == "clean rejections" and expect == ACCEPT:
            outcome = "wrong rejections"
        elif outcome.startswith("tracebacks"):
            tally.add("tracebacks", label, outcome)
            return
        tally.add(outcome, label)

    @_settings(examples, derandomize)
    @given(st.data())
    def run(data):
        for mutate in POLICY_MUTATIONS:
            family = data.draw(st.sampled_from(sorted(POLICIES)))
            label, content, expect = mutate(data.draw, SHIPPED[family], POLICIES[family][1].read_bytes())
            count(policies, load_in_process(content, family), expect, f"{family}: {label}")
        for mutate in AGENT_MUTATIONS:
            robot = data.draw(st.sampled_from(sorted(AGENTS)))
            label, content, expect = mutate(data.draw, SHIPPED_AGENTS[robot], AGENTS[robot].read_bytes())
            count(agents, load_agent_in_process(content, robot, tmp), expect, f"{robot}: {label}")

    run()
    return policies, agents


def test_fuzz_policy_files_through_the_cli(tmp_path):
    fuzz_cli(1, CLI_KINDS[:15], True, tmp_path).check()


def test_fuzz_policy_and_agent_files_in_process(tmp_path):
    for tally in fuzz_in_process(25, True, tmp_path):
        tally.check()


@pytest.mark.slow
def test_fuzz_policy_files_long_run(tmp_path, request):
    if "slow" not in (request.config.getoption("markexpr") or ""):
        pytest.skip("the long fuzz run is opt-in: -m slow")
    tallies = [fuzz_cli(6, CLI_KINDS, False, tmp_path), *fuzz_in_process(300, False, tmp_path)]
    for tally in tallies:
        tally.check()


# --- regression tests: the inputs issue 17 lists ---------------------------------------------------------------
def _mutated(tmp_path: Path, family: str, name: str = "policy.npz", **changes) -> Path:
    path = tmp_path / name
    path.write_bytes(_npz({**SHIPPED[family], **changes}))
    return path


def _next_portal_set(value: int) -> np.ndarray:
    """The fuel-tank route table with every portal entry set to ``value`` (so the roll-out meets it at once)."""
    table = SHIPPED["fuel-tank"]["graph_next_portal"].copy()
    table[table >= 0] = value
    return table


def _plan(capsys, family: str, policy: Path, *extra: str) -> tuple[int, str, str]:
    code = main(["plan", "--scene", family, "--planner", POLICIES[family][0], "--policy", str(policy),
                 "--time-limit", PLAN_BUDGET_S, *extra])
    out, err = capsys.readouterr()
    return code, out, err


def _one_policy_line(err: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("snakeplan: error: --policy: "), err
    assert "Traceback" not in err and "pickle" not in err.lower()
    return lines[0]


@pytest.mark.parametrize("value", [10**9, -10**9])
def test_policy_graph_next_portal_1e9_is_refused_not_a_segfault(tmp_path, value):
    path = _mutated(tmp_path, "fuel-tank", graph_next_portal=_next_portal_set(value))
    rc, _, err = plan_cli("fuel-tank", path)
    assert rc == 2
    assert "graph_next_portal[0, 1]" in _one_policy_line(err)


def test_policy_graph_next_portal_99_is_refused_not_read_out_of_bounds(tmp_path):
    # the fuel-tank tables have 7 portals: 99 is past the end of graph_centre
    assert SHIPPED["fuel-tank"]["graph_centre"].shape[0] < 99
    rc, _, err = plan_cli("fuel-tank", _mutated(tmp_path, "fuel-tank", graph_next_portal=_next_portal_set(99)))
    assert rc == 2 and "graph_next_portal[0, 1]: 99" in _one_policy_line(err)


def test_policy_graph_after_past_the_rooms_is_refused(capsys, tmp_path):
    after = SHIPPED["oil-tank"]["graph_after"].copy()
    after[2, 5] = after.shape[0]
    code, _, err = _plan(capsys, "oil-tank", _mutated(tmp_path, "oil-tank", graph_after=after))
    assert code == 2 and "graph_after[2, 5]" in _one_policy_line(err)


def test_policy_step_mm_0(capsys, tmp_path):
    path = _mutated(tmp_path, "fuel-tank", meta=np.array(json.dumps({**_meta("fuel-tank"), "step_mm": 0})))
    code, _, err = _plan(capsys, "fuel-tank", path)
    assert code == 2 and "meta.step_mm" in _one_policy_line(err)


def test_policy_truncated(capsys, tmp_path):
    raw = POLICIES["fuel-tank"][1].read_bytes()
    (tmp_path / "half.npz").write_bytes(raw[: len(raw) // 2])
    code, _, err = _plan(capsys, "fuel-tank", tmp_path / "half.npz")
    assert code == 2 and "damaged .npz archive" in _one_policy_line(err)


def test_policy_empty(capsys, tmp_path):
    (tmp_path / "empty.npz").write_bytes(b"")
    code, _, err = _plan(capsys, "fuel-tank", tmp_path / "empty.npz")
    assert code == 2 and "not an .npz archive" in _one_policy_line(err)


def test_policy_random_bytes_gets_no_unpickle_advice(capsys, tmp_path):
    (tmp_path / "noise.npz").write_bytes(np.random.default_rng(17).bytes(4096))
    code, _, err = _plan(capsys, "fuel-tank", tmp_path / "noise.npz")
    assert code == 2
    line = _one_policy_line(err)
    assert "unsafe" not in line and "allow_pickle" not in line


def test_policy_with_a_pickled_object_array_is_refused_unread(capsys, tmp_path):
    path = _mutated(tmp_path, "fuel-tank", w0=SHIPPED["fuel-tank"]["w0"].astype(object))
    code, _, err = _plan(capsys, "fuel-tank", path)
    assert code == 2 and "w0" in _one_policy_line(err)


def test_policy_nan_weight_is_refused(capsys, tmp_path):
    w1 = SHIPPED["oil-tank"]["w1"].copy()
    w1[4, 2] = np.nan
    code, _, err = _plan(capsys, "oil-tank", _mutated(tmp_path, "oil-tank", w1=w1))
    assert code == 2 and "w1[4, 2]" in _one_policy_line(err)


def test_policy_missing_a_file_is_one_line(capsys, tmp_path):
    code, _, err = _plan(capsys, "fuel-tank", tmp_path / "nowhere.npz")
    assert code == 2 and "no such file" in _one_policy_line(err)


def test_declared_input_width_is_what_policy_input_makes():
    """The width the check demands of w0 is the width of the actor's input in a real roll-out of each design."""
    from snakeplan.planners.sac import Crawler, policy_input

    robot, scene = get_robot("sjtu-snake-iii"), make_scene("oil-tank", 0)
    for family, arrays in SHIPPED.items():
        policy = NumpyPolicy.load(POLICIES[family][1])
        crawler = policy.crawler(robot)
        crawler.reset(scene)
        obs = crawler.observation()
        made = policy_input(obs["observation"], obs["achieved_goal"], obs["desired_goal"], policy.mode, policy.graph)
        assert made.shape == (arrays["w0"].shape[1],)
    paper = Crawler(robot, "paper")
    paper.reset(scene)
    obs = paper.observation()
    width = policy_input(obs["observation"], obs["achieved_goal"], obs["desired_goal"], "paper").shape[-1]
    hidden = np.zeros((4, width))
    assert NumpyPolicy([(hidden, np.zeros(4))], (np.zeros((3, 4)), np.zeros(3)),
                       {"observation": "paper", "hidden_layers": 1}).mode == "paper"
    with pytest.raises(ValueError, match=rf"^policy: w0: shape \(4, {width + 1}\), expected \(n, {width}\)"):
        NumpyPolicy([(np.zeros((4, width + 1)), np.zeros(4))], (np.zeros((3, 4)), np.zeros(3)),
                    {"observation": "paper", "hidden_layers": 1})


def test_a_step_that_turns_more_than_half_a_turn_is_refused():
    meta = {**_meta("fuel-tank"), "step_mm": 35.0, "turn_radius_mm": 35.0 / np.pi * 0.99}
    with pytest.raises(ValueError, match=r"^policy: meta\.turn_radius_mm"):
        NumpyPolicy.from_bytes(_npz(_with_meta("fuel-tank", meta)))
    meta["turn_radius_mm"] = 35.0 / np.pi * 1.01
    assert NumpyPolicy.from_bytes(_npz(_with_meta("fuel-tank", meta))).meta["turn_radius_mm"] == meta["turn_radius_mm"]


# --- another scene family or robot --------------------------------------------------------------------------
def test_fuel_tank_policy_in_oil_tank_warns(capsys):
    code, out, err = _plan(capsys, "oil-tank", POLICIES["fuel-tank"][1])
    assert code in (0, 1) and out.startswith("sac-per on oil-tank")
    assert err == "snakeplan: warning: --policy: trained in fuel-tank, planning in oil-tank\n"
    problem = Problem(make_scene("oil-tank", 1), get_robot("sjtu-snake-iii"), time_limit_s=5.0)
    with pytest.warns(PolicyTransferWarning, match="^policy: trained in fuel-tank, planning in oil-tank$"):
        get_planner("sac-per", policy=POLICIES["fuel-tank"][1]).plan(problem)


def test_a_policy_in_its_own_family_plans_without_a_word(capsys):
    for family, (_, path) in POLICIES.items():
        code, _, err = _plan(capsys, family, path)
        assert code == 0 and err == ""


@pytest.mark.parametrize("robot", ["hsr-10", "sscc-24"])
def test_policy_planned_with_another_arm_is_refused(capsys, robot):
    ours, theirs = get_robot("sjtu-snake-iii"), get_robot(robot)
    assert theirs.n_sections != ours.n_sections or not np.allclose(theirs.lengths, ours.lengths)
    for family, (_, path) in POLICIES.items():  # fuel-tank's file names no robot: its family's spec robot
        code, _, err = _plan(capsys, family, path, "--robot", robot)
        assert code == 2 and f"planning with {robot}" in _one_policy_line(err)


def test_policy_trained_for_another_arm_is_refused(capsys, tmp_path):
    path = _mutated(tmp_path, "oil-tank", meta=np.array(json.dumps({**_meta("oil-tank"), "robot": "sscc-24"})))
    code, _, err = _plan(capsys, "oil-tank", path)
    assert code == 2 and "trained for sscc-24" in _one_policy_line(err)


# --- SSCC agents ---------------------------------------------------------------------------------------------
def test_sscc_agent_truncated_through_the_cli_is_one_policy_line(capsys, tmp_path):
    raw = AGENTS["sscc-24"].read_bytes()
    (tmp_path / "half.npz").write_bytes(raw[: len(raw) // 2])
    code = main(["plan", "--scene", "pipe", "--planner", "sscc", "--policy", str(tmp_path / "half.npz")])
    _, err = capsys.readouterr()
    assert code == 2 and "damaged .npz archive" in _one_policy_line(err)


def test_sscc_agent_truncated_empty_or_random_is_one_error(tmp_path):
    raw = AGENTS["sscc-16"].read_bytes()
    for name, data in (("truncated", raw[:1000]), ("empty", b""), ("random", np.random.default_rng(3).bytes(999))):
        (tmp_path / name).write_bytes(data)
        with pytest.raises(ValueError, match="^agent_path: ") as caught:
            SwingAgent.load("sscc-16", tmp_path / name)
        assert "pickle" not in str(caught.value).lower()


def test_sscc_agent_of_the_other_arm_is_refused():
    with pytest.raises(ValueError, match=r"^agent_path: actor\.mu\.0\.weight: shape"):
        SwingAgent.load("sscc-16", AGENTS["sscc-24"])


def test_sscc_agent_with_an_inf_weight_is_refused(tmp_path):
    weights = dict(SHIPPED_AGENTS["sscc-24"])
    weights["actor.mu.2.bias"] = weights["actor.mu.2.bias"].copy()
    weights["actor.mu.2.bias"][7] = np.inf
    (tmp_path / "a.npz").write_bytes(_npz(weights))
    with pytest.raises(ValueError, match=r"^agent_path: actor\.mu\.2\.bias"):
        SwingAgent.load("sscc-24", tmp_path / "a.npz")


def test_a_tiny_step_read_from_a_file_is_refused_before_anything_is_allocated(capsys, tmp_path):
    """meta.step_mm = 1e-6 mm asked a roll-out for 1.8 billion steps (31.7 GiB of noise, a MemoryError traceback):
    a size derived from a file is bounded first, one line naming the field."""
    path = _mutated(tmp_path, "fuel-tank", meta=np.array(json.dumps({**_meta("fuel-tank"), "step_mm": 1e-6})))
    code, out, err = _plan(capsys, "fuel-tank", path)
    assert code == 2 and out == "" and "meta.step_mm: a 1e-06 mm step makes" in _one_policy_line(err)
