"""Inspection-mission pictures: the record sees the map the mission ends with; the video decodes as asked."""

from __future__ import annotations

import numpy as np
import pytest

from snakeplan.episode import run_mission
from snakeplan.planners.inspection import InspectionProblem
from snakeplan.robots import load_robot
from snakeplan.scenes import make_scene
from snakeplan.viz.mission import MissionRecord, save_mission_video

imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="the video extra (imageio-ffmpeg) is not installed")


def test_record_and_video(tmp_path):
    scene = make_scene("station", 0)
    record = MissionRecord()
    result = run_mission(InspectionProblem(scene, load_robot("hsr-10"), budget_s=12.0), "random", 0,
                         on_measure=record).result
    assert record.times == pytest.approx(result.times.tolist())
    np.testing.assert_array_equal(record.means[-1], result.final_map.mean)
    np.testing.assert_array_equal(record.variances[-1], np.diag(result.final_map.cov))
    assert np.sum(record.variances[-1]) == pytest.approx(result.trace[-1])  # the trace is the variances' sum
    out = save_mission_video(tmp_path / "m.mp4", scene, result, record, 8, 4.0, (480, 272), "t", progress=False)
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = reader.__next__()
    frames = [np.frombuffer(f, dtype=np.uint8).reshape(272, 480, 3) for f in reader]
    assert len(frames) == 8 and tuple(meta["size"]) == (480, 272)
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).max(axis=2).astype(bool).sum() > 500
