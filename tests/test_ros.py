"""ROS 2 bags, Foxglove MCAP files and the live view (snakeplan.ros), each read back by libraries that did not write
it: rosbags and, independently, mcap with its ROS 2 decoder for the bag; mcap with its protobuf decoder for the
Foxglove file; yourdfpy for the URDF on /robot_description; a WebSocket client and /proc/net for the live view.
"""

import asyncio
import io
import json
import socket
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from snakeplan.cli import main
from snakeplan.geometry.polyline import cumulative_length
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene

pytest.importorskip("rosbags")
pytest.importorskip("foxglove")


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def point_to_polyline_mm(p: np.ndarray, path: np.ndarray) -> float:
    """Distance from ``p`` to the polyline ``path`` (mm), by projecting onto every segment."""
    a, b = path[:-1], path[1:]
    d = b - a
    f = np.clip(np.einsum("ij,ij->i", p - a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + f[:, None] * d - p, axis=1)))


@pytest.fixture(scope="module")
def reach(tmp_path_factory):
    """A judged fuel-tank plan written at once as trajectory/1, a ROS 2 bag (MCAP and sqlite3) and a Foxglove file."""
    folder = tmp_path_factory.mktemp("reach")
    argv = ["plan", "--scene", "fuel-tank", "--seed", "3", "--planner", "as-rrt", "--json",
            "--trajectory", folder / "t.json", "--rosbag", folder / "bag", "--mcap", folder / "plan.mcap"]
    assert main([str(a) for a in argv]) == 0
    return folder


def _plan_json(folder: Path, capsys) -> Path:
    code, out, _ = run(capsys, "plan", "--scene", "fuel-tank", "--seed", "3", "--planner", "as-rrt", "--json")
    assert code == 0
    (folder / "plan.json").write_text(out)
    return folder / "plan.json"


def rosbags_messages(bag: Path) -> dict[str, list]:
    """Every message of a bag by topic, read and deserialised by rosbags."""
    from rosbags.highlevel import AnyReader

    out: dict[str, list] = {}
    with AnyReader([bag]) as reader:
        for conn, stamp, raw in reader.messages():
            out.setdefault(conn.topic, []).append((stamp, reader.deserialize(raw, conn.msgtype)))
    return out


def mcap_messages(file: Path, decoder: str, topics: list[str] | None = None) -> tuple[dict[str, list], dict]:
    """Every message of an MCAP file by topic, read by mcap and decoded by ``decoder`` (``ros2``: mcap-ros2-support,
    ``protobuf``: mcap-protobuf-support, from the schemas the file carries; neither is what wrote it), and the file's
    channels with their schemas; only ``topics`` when given."""
    from importlib import import_module

    from mcap.reader import make_reader

    factory = import_module(f"mcap_{decoder}.decoder").DecoderFactory()
    out: dict[str, list] = {}
    with open(file, "rb") as f:
        reader = make_reader(f, decoder_factories=[factory])
        summary = reader.get_summary()
        for _, channel, message, decoded in reader.iter_decoded_messages(topics=topics):
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out, {c.topic: summary.schemas.get(c.schema_id) for c in summary.channels.values()}


def mcap_ros2_messages(bag: Path, topics: list[str] | None = None) -> tuple[dict[str, list], dict]:
    """A bag's messages and schemas, read from its MCAP file by mcap and mcap-ros2-support (not rosbags)."""
    (file,) = bag.glob("*.mcap")
    return mcap_messages(file, "ros2", topics)


def _seconds(d) -> float:
    return d.sec + d.nanosec * 1e-9


def test_the_bag_round_trips_through_rosbags_and_independently_through_mcap(reach):
    doc = json.loads((reach / "t.json").read_text())
    q = np.array([p["positions"] for p in doc["points"]])
    t = np.array([p["t"] for p in doc["points"]])
    feed = np.array([1e-3] + [1.0] * (q.shape[1] - 1))  # ROS's feed is in m
    scene = make_scene("fuel-tank", 3)
    ours, schemas = mcap_ros2_messages(reach / "bag")
    for name, messages in (("rosbags", rosbags_messages(reach / "bag")), ("mcap", ours)):
        (_, jt), = messages["/joint_trajectory"]
        assert list(jt.joint_names) == doc["joint_names"], name
        got_q = np.array([p.positions for p in jt.points])
        got_t = np.array([_seconds(p.time_from_start) for p in jt.points])
        assert np.max(np.abs(got_q / feed - q)) <= 1e-9 and np.max(np.abs(got_t - t)) <= 1e-9, name
        for field in ("velocities", "accelerations"):
            got = np.array([getattr(p, field) for p in jt.points]) / feed
            assert np.max(np.abs(got - [p[field] for p in doc["points"]])) <= 1e-9, (name, field)
        (_, markers), = messages["/scene"]
        assert len(markers.markers) == len(scene.obstacles), name
        assert len(messages["/joint_states"]) == len(messages["/tf"]) == len(t), name
    assert all(s is not None and s.encoding == "ros2msg" and s.data for s in schemas.values())


def sqlite_messages(bag: Path) -> dict[str, list]:
    """Every message of a sqlite3 bag by topic, read with Python's sqlite3 from rosbag2's tables and decoded by
    mcap-ros2-support from the message definitions the bag carries (neither is rosbags)."""
    import sqlite3

    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    (file,) = bag.glob("*.db3")
    with sqlite3.connect(file) as db:
        definitions = dict(db.execute("select topic_type, encoded_message_definition from message_definitions"))
        topics = {i: (name, kind) for i, name, kind in db.execute("select id, name, type from topics")}
        decoders = {i: DecoderFactory().decoder_for("cdr", Schema(id=i, name=kind, encoding="ros2msg",
                                                                  data=definitions[kind].encode()))
                    for i, (_, kind) in topics.items()}
        out: dict[str, list] = {}
        for topic, stamp, data in db.execute("select topic_id, timestamp, data from messages order by timestamp"):
            out.setdefault(topics[topic][0], []).append((stamp, decoders[topic](data)))
    return out


def test_the_sqlite3_bag_holds_the_same_messages(reach, tmp_path, capsys):
    plan = _plan_json(tmp_path, capsys)
    code, _, err = run(capsys, "export", plan, "--rosbag", tmp_path / "db", "--storage", "sqlite3")
    assert code == 0 and "sqlite3" in err
    b, _ = mcap_ros2_messages(reach / "bag")
    for a in (rosbags_messages(tmp_path / "db"), sqlite_messages(tmp_path / "db")):
        assert {k: len(v) for k, v in a.items()} == {k: len(v) for k, v in b.items()}
        qa = np.array([p.positions for p in a["/joint_trajectory"][0][1].points])
        qb = np.array([p.positions for p in b["/joint_trajectory"][0][1].points])
        assert np.array_equal(qa, qb)
        assert [stamp for stamp, _ in a["/tf"]] == [stamp for stamp, _ in b["/tf"]]


def as_matrix(transform) -> np.ndarray:
    """A ``geometry_msgs/Transform`` as a 4x4 pose (m)."""
    T = np.eye(4)
    r, t = transform.rotation, transform.translation
    T[:3, :3] = Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix()
    T[:3, 3] = [t.x, t.y, t.z]
    return T


def test_the_robot_description_puts_the_tip_on_the_planned_path_as_yourdfpy_computes_it(reach):
    import yourdfpy

    messages, _ = mcap_ros2_messages(reach / "bag")
    (_, description), = messages["/robot_description"]
    model = yourdfpy.URDF.load(io.StringIO(description.data), build_scene_graph=True, load_meshes=False)
    (_, static), = messages["/tf_static"]
    base = next(tf.transform for tf in static.transforms if tf.child_frame_id == "world")
    scene_from_world = as_matrix(base)
    doc = json.loads((reach / "t.json").read_text())
    path = np.array(doc["provenance"]["path"])
    tip_link = doc["tip_link"]
    worst = 0.0
    (_, jt), = messages["/joint_trajectory"]
    for point in jt.points[::5]:
        model.update_cfg(dict(zip(jt.joint_names, point.positions)))
        tip = (scene_from_world @ model.get_transform(tip_link, "world"))[:3, 3] * 1e3
        worst = max(worst, point_to_polyline_mm(tip, path))
    assert worst <= 1.0
    # /tf, chained from the fixed frame through every link, puts the tip where yourdfpy does
    model.update_cfg(dict(zip(jt.joint_names, jt.points[-1].positions)))
    expected = (scene_from_world @ model.get_transform(tip_link, "world"))[:3, 3]
    assert np.linalg.norm(tip_in_scene(static, messages["/tf"][-1][1], tip_link) - expected) <= 1e-9


def foxglove_messages(file: Path) -> tuple[dict[str, list], dict]:
    """A Foxglove file's messages and schemas, decoded by mcap-protobuf-support."""
    return mcap_messages(file, "protobuf")


def test_the_foxglove_file_has_a_schema_on_every_channel_and_shows_the_plan(reach):
    messages, schemas = foxglove_messages(reach / "plan.mcap")
    assert set(schemas) >= {"/scene", "/arm", "/tf", "/tip_path", "/judge", "/log", "/joint_states"}
    assert all(s is not None and s.encoding == "protobuf" and s.name.startswith("foxglove.") and s.data
               for s in schemas.values())
    scene = make_scene("fuel-tank", 3)
    (_, update), = messages["/scene"]
    assert len(update.entities) == len(scene.obstacles)
    doc = json.loads((reach / "t.json").read_text())
    assert len(messages["/arm"]) == len(doc["points"])
    _, last = messages["/arm"][-1]
    cylinders = last.entities[0].cylinders
    assert len(cylinders) == len(doc["body_links"]) - 1  # one per section
    ends = []  # each cylinder's two end centres: its centre -/+ half its height along its z axis
    for c in cylinders:
        q, p = c.pose.orientation, c.pose.position
        z = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()[:, 2]
        ends.append([np.array([p.x, p.y, p.z]) + sign * c.size.z / 2 * z for sign in (-1, 1)])
    ends = np.array(ends) * 1e3
    assert np.max(np.linalg.norm(ends[1:, 0] - ends[:-1, 1], axis=1)) <= 1e-6  # section to section, end to end
    assert np.linalg.norm(ends[-1, 1] - doc["points"][-1]["tip"]) <= 1e-6  # the last ends at the tip
    assert np.allclose([c.size.x * 1e3 / 2 for c in cylinders], get_robot("sjtu-snake-iii").radii)
    tip = np.array([[m.translation.x, m.translation.y, m.translation.z] for _, tf in messages["/tf"]
                    for m in tf.transforms])[-1] * 1e3
    assert np.linalg.norm(tip - doc["points"][-1]["tip"]) <= 1e-3  # float64 m to mm
    (_, log), = messages["/log"]
    assert log.message == "verdict: feasible (reached)" and log.level == 2  # INFO


def test_a_refused_plan_gets_no_bag_but_a_foxglove_file_with_its_first_failure_marked(tmp_path, capsys):
    scene = make_scene("fuel-tank", 0)
    e, u = scene.entrance.position, scene.entrance.direction
    path = np.array([e, e + 1500.0 * u])  # straight through the tank into its far wall
    (tmp_path / "p.json").write_text(json.dumps({"path": path.tolist()}))
    code, out, err = run(capsys, "check", tmp_path / "p.json", "--rosbag", tmp_path / "bag", "--mcap",
                         tmp_path / "f.mcap")
    assert code == 1 and "no bag: the judge rejects it (collision)" in err
    assert not (tmp_path / "bag").exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    depth = float(next(line.split()[-1] for line in out.splitlines() if "first_failure_depth_mm" in line))
    messages, _ = foxglove_messages(tmp_path / "f.mcap")
    marks = [(t, s) for t, update in messages["/judge"] for e in update.entities if e.id == "failure"
             for s in e.spheres]
    assert len(marks) == 1
    t, sphere = marks[0]
    where = np.array([sphere.pose.position.x, sphere.pose.position.y, sphere.pose.position.z]) * 1e3
    s = cumulative_length(path)
    expected = path[0] + (path[1] - path[0]) * depth / s[-1]  # the tip lies on the path at its depth
    assert np.linalg.norm(where - expected) <= 1e-6
    speed = get_robot("sjtu-snake-iii").limits.feed_speed_mm_s  # shown at the feed speed, untimed
    assert t == pytest.approx(depth / speed * 1e9, abs=1.0)


def test_a_mission_bag_carries_its_views_and_the_coverage_the_judge_counts(tmp_path, capsys):
    code, out, _ = run(capsys, "plan", "--scene", "fuel-tank", "--task", "inspect", "--time-limit", "1", "--json",
                       "--rosbag", tmp_path / "bag")
    assert code == 0
    doc = json.loads(out)
    views = len(doc["mission"]["views"]["times_s"])
    messages, _ = mcap_ros2_messages(tmp_path / "bag", ["/views", "/coverage", "/tip_path", "/joint_trajectory"])
    assert len(messages["/views"]) == views
    _, cloud = messages["/coverage"][-1]
    rec = np.frombuffer(bytes(cloud.data), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
    green = (rec["rgb"] >> 8) & 0xFF > (rec["rgb"] >> 16) & 0xFF  # seen: green over red
    assert cloud.width == doc["metrics"]["points"] and int(green.sum()) == doc["metrics"]["points_seen"]
    starts = [m["times_s"][0] for m in doc["mission"]["motions"]]
    assert len(messages["/tip_path"]) == len(starts)
    jt = messages["/joint_trajectory"][0][1]
    times = np.array([_seconds(p.time_from_start) for p in jt.points])
    assert np.all(np.diff(times) > 0) and times[-1] == pytest.approx(doc["metrics"]["mission_time_s"], abs=1e-6)


def tip_in_scene(static, moving, tip_link: str) -> np.ndarray:
    """The tip link's position (m) in the fixed frame, chained through the bag's transforms: ``static`` and
    ``moving`` TF messages, each transform from its parent frame to its child."""
    chain = {tf.child_frame_id: (tf.header.frame_id, tf.transform) for tf in static.transforms}
    chain.update({tf.child_frame_id: (tf.header.frame_id, tf.transform) for tf in moving.transforms})
    T, frame = np.eye(4), tip_link
    while frame in chain:
        parent, transform = chain[frame]
        T = as_matrix(transform) @ T
        frame = parent
    assert frame == "scene"
    return T[:3, 3]


def test_the_station_bag_moves_the_base_and_holds_every_view_on_the_tip(tmp_path, capsys):
    code, out, _ = run(capsys, "plan", "--scene", "station", "--time-limit", "3", "--json", "--rosbag",
                       tmp_path / "bag")
    assert code == 0
    doc = json.loads(out)
    messages, _ = mcap_ros2_messages(tmp_path / "bag")
    (_, static), = messages["/tf_static"]
    assert "world" not in {tf.child_frame_id for tf in static.transforms}  # the carriage moves the arm's base
    bases = {tuple(np.round(as_matrix(tf.transform)[:3, 3], 9)) for _, m in messages["/tf"] for tf in m.transforms
             if tf.child_frame_id == "world"}
    assert len(bases) > 1
    tf_at = {stamp: m for stamp, m in messages["/tf"]}
    n = len(doc["arm"]["sections"])
    views = messages["/views"]
    assert len(views) == len(doc["mission"]["views"]["times_s"]) > 0
    worst = 0.0
    for stamp, view in views:
        p = view.pose.position
        tip = tip_in_scene(static, tf_at[stamp], f"s{n - 1}_end")
        worst = max(worst, float(np.linalg.norm(tip - [p.x, p.y, p.z])) * 1e3)
    assert worst <= 10.0  # the judge holds each view on the tip within 10 mm


def _listeners(port: int) -> set[str]:
    """The local addresses listening on ``port`` (TCP, IPv4 and IPv6), from /proc/net."""
    found = set()
    for table, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except FileNotFoundError:
            continue
        for line in lines:
            local, state = line.split()[1], line.split()[3]
            address, hex_port = local.split(":")
            if state == "0A" and int(hex_port, 16) == port:  # LISTEN
                found.add(address)
    return found


def test_the_live_view_listens_on_loopback_only_and_serves_schemas(tmp_path):
    import websockets

    from snakeplan.evaluation import evaluate
    from snakeplan.ros import of_plan
    from snakeplan.ros.foxglove import LiveView

    view = LiveView("127.0.0.1", 0)
    try:
        assert _listeners(view.port) == {"0100007F"}  # 127.0.0.1, and nothing on IPv6
        others = {a[4][0] for a in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET)} - {"127.0.0.1"}
        for address in others:  # this machine's other addresses do not answer
            with pytest.raises(OSError):
                socket.create_connection((address, view.port), timeout=2).close()
        scene, robot = make_scene("fuel-tank", 0), get_robot("sjtu-snake-iii")
        e, u = scene.entrance.position, scene.entrance.direction
        path = np.array([e, e + 600.0 * u])
        view.show(of_plan(scene, robot, path, evaluate(scene, robot, path)))

        async def client():
            async with websockets.connect(f"ws://127.0.0.1:{view.port}", subprotocols=["foxglove.sdk.v1"],
                                          max_size=None) as ws:
                channels = {}
                while "/arm" not in channels.values():
                    message = json.loads(await asyncio.wait_for(ws.recv(), 10))
                    if message["op"] == "advertise":
                        channels.update({c["id"]: c["topic"] for c in message["channels"]})
                        schemas = {c["topic"]: (c["schemaName"], c["encoding"], c["schema"]) for c in
                                   message["channels"]}
                        assert all(name.startswith("foxglove.") and enc == "protobuf" and data
                                   for name, enc, data in schemas.values())
                return set(channels.values())

        assert {"/scene", "/arm", "/judge"} <= asyncio.run(client())
    finally:
        view.stop()


def test_live_host_needs_live_and_a_taken_port_is_one_line(capsys, tmp_path):
    code, _, err = run(capsys, "plan", "--live-host", "0.0.0.0")
    assert code == 2 and err == "snakeplan: error: --live-host: only with --live\n"
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        code, _, err = run(capsys, "plan", "--live", "--live-port", s.getsockname()[1])
    assert code == 2 and err.startswith("snakeplan: error: --live: cannot serve on 127.0.0.1:") and err.count("\n") == 1


def test_a_live_view_off_loopback_is_asked_for_and_said(capsys, monkeypatch):
    from snakeplan.commands import ros

    bound = []

    class Recorded:  # stands in for the server: nothing is bound off loopback in a test
        def __init__(self, host, port):
            bound.append((host, port))
            self.url = f"ws://{host}:{port}"

    monkeypatch.setattr("snakeplan.ros.foxglove.LiveView", Recorded)
    args = __import__("argparse").Namespace(live=True, live_host="0.0.0.0", live_port=None)
    ros.live_view(args)
    err = capsys.readouterr().err
    assert bound == [("0.0.0.0", 8765)]
    assert "warning: the live view listens on 0.0.0.0, not loopback: other machines can connect" in err
    for host in ("127.0.0.2", "::1", "localhost"):
        ros.live_view(__import__("argparse").Namespace(live=True, live_host=host, live_port=0))
        assert "warning" not in capsys.readouterr().err


def test_a_search_bag_turns_each_target_green_when_the_judge_found_it(tmp_path, capsys):
    code, out, _ = run(capsys, "plan", "--scene", "fuel-tank", "--seed", "1", "--task", "search", "--json",
                       "--rosbag", tmp_path / "bag")
    doc = json.loads(out)
    found = doc["metrics"]["found_s"]
    assert code == 0 and all(f is not None for f in found)
    messages, _ = mcap_ros2_messages(tmp_path / "bag")
    first, *later = messages["/targets"]
    assert [m.color.g > m.color.r for m in first[1].markers] == [False] * len(found)
    assert len(later) == len(found)
    for stamp, update in later:
        (marker,) = update.markers
        assert marker.color.g > marker.color.r and stamp == round(found[marker.id] * 1e9)


def test_bad_outputs_are_one_line_and_write_nothing(tmp_path, capsys, monkeypatch):
    (tmp_path / "bag").mkdir()
    plan = _plan_json(tmp_path, capsys)
    from snakeplan.robots import Chain

    no_feed = tmp_path / "no-feed.json"
    no_feed.write_text(json.dumps(Chain(get_robot("sjtu-snake-iii").sections, name="no-feed").to_dict()))
    (tmp_path / "p.json").write_text(json.dumps({"path": json.loads(plan.read_text())["path"]}))
    plan = tmp_path / "p.json"  # a bare path: --robot may name another arm
    cases = [(("export", plan, "--rosbag", tmp_path / "bag"), "--rosbag: "),
             (("export", plan, "--mcap", tmp_path / "f.txt"), "--mcap: "),
             (("export", plan), "--rosbag: give --rosbag DIR, --mcap FILE or both"),
             (("plan", "--mcap", tmp_path / "no" / "f.mcap"), "--mcap: folder"),
             (("trajectory", plan), "-o: give at least one output"),
             (("export", plan, "--mcap", tmp_path / "f.mcap", "--storage", "sqlite3"), "--storage: only with --rosbag"),
             (("plan", "--live-port", "9000"), "--live-port: only with --live"),
             (("export", plan, "--rosbag", ""), "--rosbag: empty"),
             (("export", plan, "--scene", "fuel-tank", "--seed", "3", "--robot", no_feed, "--mcap",
               tmp_path / "f.mcap"),
              "--mcap: robot no-feed has no feed joint")]
    for argv, expected in cases:
        before = sorted(p.name for p in tmp_path.iterdir())
        code, _, err = run(capsys, *argv)
        assert code == 2 and err.count("\n") == 1 and expected in err, (argv, err)
        assert sorted(p.name for p in tmp_path.iterdir()) == before
    monkeypatch.setitem(sys.modules, "rosbags", None)  # the ros extra not installed
    code, _, err = run(capsys, "plan", "--rosbag", tmp_path / "new")
    assert code == 2 and err == 'snakeplan: error: --rosbag: needs the ros extra: pip install "snakeplan[ros]"\n'


def test_an_interrupted_bag_leaves_nothing(tmp_path, monkeypatch):
    from snakeplan.evaluation import evaluate
    from snakeplan.ros import bag, of_plan

    scene, robot = make_scene("fuel-tank", 0), get_robot("sjtu-snake-iii")
    e, u = scene.entrance.position, scene.entrance.direction
    path = np.array([e, e + 300.0 * u])
    rec = of_plan(scene, robot, path, evaluate(scene, robot, path))

    build, calls = bag.MessageFactory.build, []

    def interrupted(self, msgtype, data):  # Ctrl-C once the bag is half written
        calls.append(msgtype)
        if len(calls) == 40:
            raise KeyboardInterrupt
        return build(self, msgtype, data)

    monkeypatch.setattr(bag.MessageFactory, "build", interrupted)
    with pytest.raises(KeyboardInterrupt):
        bag.write_bag(rec, str(tmp_path / "bag"))
    assert len(calls) == 40
    assert list(tmp_path.iterdir()) == []


def test_a_benchmark_shows_each_plan_live_as_its_row_is_logged(tmp_path, capsys, monkeypatch):
    from snakeplan.ros.foxglove import LiveView

    shown, notes = [], []
    show, note = LiveView.show, LiveView.note
    monkeypatch.setattr(LiveView, "show", lambda self, rec, *a, **k: (shown.append(rec), show(self, rec, *a, **k)))
    monkeypatch.setattr(LiveView, "note", lambda self, text: (notes.append(text), note(self, text)))
    code, _, err = run(capsys, "bench", "run", "--scenes", "fuel-tank", "--planners", "as-rrt,rrt-star", "--seeds",
                       "0", "--time-limit", "2", "--workers", "1", "--out", tmp_path / "runs", "--live",
                       "--live-port", "0")
    assert code == 0 and "live view: ws://127.0.0.1:" in err
    rows = [json.loads(line) for line in (tmp_path / "runs" / "runs.jsonl").read_text().splitlines()]
    assert len(shown) == len(notes) == len(rows) == 2
    assert [r.success for r in shown] == [row["success"] for row in rows]
    assert all(np.array_equal(r.paths[0], row["path"]) for r, row in zip(shown, rows))
