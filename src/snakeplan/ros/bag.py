"""A recording as a ROS 2 bag (``rosbags``: no ROS installation needed), MCAP storage by default, sqlite3 on
request, with ROS 2 Jazzy's message definitions. ``ros2 bag play DIR`` replays it (docs/ROS.md).

The bag is written into a temporary folder beside ``DIR`` and renamed onto it when whole, so an interrupted
export leaves nothing half-written; an existing ``DIR`` is refused before any work (:func:`check_bag`).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from snakeplan.checkpoints import fsync_dir
from snakeplan.extras import require_ros
from snakeplan.ros.messages import LATCHED, messages
from snakeplan.ros.recording import Recording

#: Storage formats by name: what ``--storage`` takes.
STORAGES = ("mcap", "sqlite3")
#: The message definitions written (rosbags' store of a ROS 2 distribution).
DISTRO = "ros2_jazzy"


def check_bag(directory: str, field: str = "--rosbag") -> Path:
    """The bag folder to write, refused in one line naming ``field`` when it exists already, or its parent folder
    does not or cannot be written."""
    path = Path(directory)
    if not str(directory):
        raise ValueError(f"{field}: empty; name the new folder to write the bag in")
    if path.exists():
        raise ValueError(f"{field}: {directory} exists; a bag is a new folder (rosbag2 does not write into one)")
    if not path.parent.is_dir():
        raise ValueError(f"{field}: folder {str(path.parent)!r} does not exist (create it first)")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise ValueError(f"{field}: folder {path.parent} is not writable")
    return path


_NUMPY = {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
          "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32, "int64": np.int64,
          "uint64": np.uint64, "float32": np.float32, "float64": np.float64}


class MessageFactory:
    """rosbags messages from plain data (ROS field names; every field not given takes ROS's default), one
    converter per field made once per message type."""

    def __init__(self, typestore) -> None:
        self.typestore = typestore
        self._types: dict[str, tuple[type, list]] = {}

    def build(self, msgtype: str, data: dict[str, Any]):
        cls, fields = self._types.get(msgtype) or self._compile(msgtype)
        return cls(**{name: convert(data.get(name)) for name, convert in fields})

    def _compile(self, msgtype: str) -> tuple[type, list]:
        _, fields = self.typestore.fielddefs[msgtype]
        self._types[msgtype] = entry = (self.typestore.types[msgtype],
                                        [(name, self._converter(kind, spec)) for name, (kind, spec) in fields])
        return entry

    def _converter(self, kind, spec):
        from rosbags.interfaces import Nodetype

        if kind == Nodetype.BASE:
            name = spec[0]
            cast, default = (str, "") if name == "string" else (bool, False) if name == "bool" else (
                (float, 0.0) if name.startswith("float") else (int, 0))
            return lambda v: default if v is None else cast(v)
        if kind == Nodetype.NAME:
            return lambda v: self.build(spec, v or {})
        (inner_kind, inner_spec), size = spec
        if inner_kind == Nodetype.BASE and inner_spec[0] != "string":
            dtype, n = _NUMPY[inner_spec[0]], size if kind == Nodetype.ARRAY else 0
            return lambda v: np.zeros(n, dtype=dtype) if v is None else np.asarray(v, dtype=dtype)
        item = self._converter(inner_kind, inner_spec)
        if kind == Nodetype.ARRAY:
            return lambda v: [item(x) for x in (v if v is not None else [None] * size)]
        return lambda v: [] if v is None else [item(x) for x in v]


def write_bag(rec: Recording, directory: str, storage: str = "mcap") -> dict[str, int]:
    """Write ``rec`` as a ROS 2 bag in the new folder ``directory`` (``storage`` mcap or sqlite3), every message
    stamped with its recording time. Returns the message count per topic."""
    require_ros("--rosbag")
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    target = check_bag(directory)
    if storage not in STORAGES:
        raise ValueError(f"--storage: {storage!r} is not one of {', '.join(STORAGES)}")
    typestore = get_typestore(Stores(DISTRO))
    factory = MessageFactory(typestore)
    zero = QosTime(0, 0)

    def qos(latched: bool) -> Qos:
        return Qos(QosHistory.KEEP_LAST, 1 if latched else 10, QosReliability.RELIABLE,
                   QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE, zero, zero,
                   QosLiveliness.AUTOMATIC, zero, False)

    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    counts: dict[str, int] = {}
    work = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    try:
        inside = work / target.name
        with Writer(inside, version=8, storage_plugin=plugin) as writer:
            connections = {}
            for m in messages(rec):
                if m.topic not in connections:
                    connections[m.topic] = writer.add_connection(m.topic, m.msgtype, typestore=typestore,
                                                                 offered_qos_profiles=[qos(m.topic in LATCHED)])
                writer.write(connections[m.topic], int(round(m.t * 1e9)),
                             typestore.serialize_cdr(factory.build(m.msgtype, m.data), m.msgtype))
                counts[m.topic] = counts.get(m.topic, 0) + 1
        for file in inside.iterdir():
            with open(file, "rb+") as fh:
                os.fsync(fh.fileno())
        fsync_dir(inside)
        inside.rename(target)
        fsync_dir(target.parent)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return counts

