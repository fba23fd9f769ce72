"""The pictures of an episode, whatever its task, in one place: a reach plan's figure, crawl video and page; an
inspect plan's maps, mission video and page, from the judge's measuring of its views again."""

from __future__ import annotations

from pathlib import Path

from snakeplan.scenes import Task
from snakeplan.viz.mission import JudgedMission, MissionRecord, mission_title


def _fed(episode) -> bool:
    """Whether the episode is a fed arm's inspection by its tip camera (points of interest, not a field)."""
    return episode.plan.mission is not None and episode.plan.mission.settings.tip_camera


def _timeline(episode, frames: int):
    from snakeplan.viz.coverage import Timeline, coverage_title

    p = episode.problem
    found = episode.report.found_s if p.task is Task.SEARCH else None
    return (Timeline.of(p.scene, p.robot, episode.plan.mission, frames, found),
            coverage_title(p.scene, p.robot.name, episode.plan.planner, episode.report))


def _mission(episode) -> tuple[JudgedMission, str]:
    judged = JudgedMission.of(episode)
    return judged, mission_title(episode.problem.scene, episode.problem.robot.name, judged)


def save_episode_plot(filename: str | Path, episode) -> None:
    """The PNG of an episode: the plan's figure (scene, path, body, curvature), or a mission's maps."""
    problem, plan = episode.problem, episode.plan
    if _fed(episode):
        from snakeplan.viz.coverage import save_coverage_figure

        save_coverage_figure(filename, problem.scene, *_timeline(episode, 200), report=episode.report)
        return
    if plan.mission is not None:
        from snakeplan.viz.mission import save_mission_maps

        judged, title = _mission(episode)
        save_mission_maps(filename, problem.scene, judged, title)
        return
    from snakeplan.viz.figures import save_plan_figure

    save_plan_figure(filename, problem.scene, problem.robot, plan.path, episode.report, plan.planner)


def save_episode_video(filename: str | Path, episode, frames: int, fps: float, size: tuple[int, int],
                       progress: bool) -> int:
    """The video of an episode (the crawl, or the mission with the map filling in); returns its frame count."""
    problem, plan = episode.problem, episode.plan
    if _fed(episode):
        from snakeplan.viz.coverage import save_coverage_video

        save_coverage_video(filename, problem.scene, *_timeline(episode, frames)[:1], fps, size,
                            _timeline(episode, 2)[1], progress=progress)
        return frames
    if plan.mission is not None:
        from snakeplan.viz.mission import save_mission_video

        judged, title = _mission(episode)
        save_mission_video(filename, problem.scene, judged, MissionRecord.of(problem.scene, plan.mission), frames,
                           fps, size, title, progress=progress)
        return frames
    from snakeplan.viz.animation import save_crawl_video
    from snakeplan.viz.crawl import crawl_frames

    crawl = crawl_frames(problem.scene, problem.robot, plan.path, frames, episode.report)
    save_crawl_video(filename, crawl, fps, size, plan.planner, progress=progress)
    return len(crawl.depths)


def save_episode_page(filename: str | Path, episode, crawl_frames_count: int) -> None:
    """The interactive page of an episode (a crawl with ``crawl_frames_count`` frames, or the mission)."""
    problem, plan = episode.problem, episode.plan
    if _fed(episode):
        from snakeplan.viz.coverage import save_coverage_page

        line, title = _timeline(episode, 4 * crawl_frames_count)
        r = episode.report
        verdict = "inspected" if r.success else f"refused ({r.reason})"
        if problem.task is Task.SEARCH and r.failure is None:
            verdict = f"{r.reason}: found {r.found:.0%}, reached {r.reached:.0%}"
        metrics = {"verdict": verdict, "views": r.views,
                   "mission (s)": round(r.mission_time_s), "feed travel (m)": round(r.motion_mm / 1000, 1),
                   "retractions": r.retractions}
        save_coverage_page(filename, problem.scene, problem.robot, line, title, metrics, plan.mission)
        return
    if plan.mission is not None:
        from snakeplan.viz.mission import save_mission_page

        judged, title = _mission(episode)
        save_mission_page(filename, problem.scene, judged, MissionRecord.of(problem.scene, plan.mission), title)
        return
    from snakeplan.viz.crawl import crawl_frames
    from snakeplan.viz.page import save_crawl_page

    save_crawl_page(filename, crawl_frames(problem.scene, problem.robot, plan.path, crawl_frames_count,
                                           episode.report), plan.planner)
