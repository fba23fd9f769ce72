"""The pictures of an episode, whatever its task, in one place: a reach plan's figure, crawl video and page; an
inspect plan's maps, mission video and page, from the judge's measuring of its views again."""

from __future__ import annotations

from pathlib import Path

from snakeplan.viz.mission import JudgedMission, MissionRecord, mission_title


def _mission(episode) -> tuple[JudgedMission, str]:
    judged = JudgedMission.of(episode)
    return judged, mission_title(episode.problem.scene, episode.problem.robot.name, judged)


def save_episode_plot(filename: str | Path, episode) -> None:
    """The PNG of an episode: the plan's figure (scene, path, body, curvature), or a mission's maps."""
    problem, plan = episode.problem, episode.plan
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
    if plan.mission is not None:
        from snakeplan.viz.mission import save_mission_page

        judged, title = _mission(episode)
        save_mission_page(filename, problem.scene, judged, MissionRecord.of(problem.scene, plan.mission), title)
        return
    from snakeplan.viz.crawl import crawl_frames
    from snakeplan.viz.page import save_crawl_page

    save_crawl_page(filename, crawl_frames(problem.scene, problem.robot, plan.path, crawl_frames_count,
                                           episode.report), plan.planner)
